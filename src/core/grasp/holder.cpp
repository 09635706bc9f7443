#include "corde_sim/grasp/holder.h"

#include <algorithm>
#include <cmath>

#include "corde_sim/math/so3.h"

namespace corde {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

// One step of a tracker with a speed and an acceleration limit: e is the error to the reference
// at the start of the step, v_ref the reference's velocity over the step. Far from the reference
// it approaches at the speed from which it can still stop within the acceleration limit
// (sqrt(2 a |e|)); close to it, it closes the error in one step. Returns the new velocity.
Vector3d track(const Vector3d& e, const Vector3d& v_ref, const Vector3d& v, double h, double v_max,
               double a_max, HolderClip* clip) {
  const double dist = e.norm();
  Vector3d v_des = v_ref;
  if (dist > 0.0) v_des += (std::min(dist / h, std::sqrt(2.0 * a_max * dist)) / dist) * e;
  const double speed = v_des.norm();
  if (speed > v_max) {
    v_des *= v_max / speed;
    clip->speed = true;
  }
  Vector3d dv = v_des - v;
  const double dv_norm = dv.norm();
  if (dv_norm > a_max * h) {
    dv *= a_max * h / dv_norm;
    clip->acceleration = true;
  }
  return v + dv;
}

}  // namespace

void HolderMotion::reset(const Eigen::Isometry3d& pose) {
  pose_ = goal_ = pose;
  q_ = q_start_ = q_goal_ = Quaterniond(pose.linear()).normalized();
  p_start_ = p_goal_ = pose.translation();
  v_.setZero();
  w_.setZero();
  t0_ = duration_ = 0.0;
  settled_ = true;
  cached_t_ = -1e300;
  end_stream();
}

void HolderMotion::set_goal(double now, const Eigen::Isometry3d& goal, double duration) {
  reference(now, &p_start_, &q_start_);
  end_stream();
  goal_ = goal;
  p_goal_ = goal.translation();
  q_goal_ = Quaterniond(goal.linear()).normalized();
  if (q_goal_.dot(q_start_) < 0.0) q_goal_.coeffs() *= -1.0;  // slerp the shorter way
  t0_ = now;
  duration_ = std::max(0.0, duration);
  settled_ = false;
  cached_t_ = -1e300;
}

void HolderMotion::stop() {
  goal_ = pose_;
  p_start_ = p_goal_ = pose_.translation();
  q_start_ = q_goal_ = q_;
  duration_ = 0.0;
  settled_ = false;  // it may still move: it decelerates back to here
  cached_t_ = -1e300;
  end_stream();
}

bool HolderMotion::add_sample(double now, double stamp, const Eigen::Isometry3d& pose) {
  Vector3d p_now;
  Quaterniond q_now;
  reference(now, &p_now, &q_now);
  if (!streaming_) stream_.clear();
  const Quaterniond q = Quaterniond(pose.linear()).normalized();
  if (!stream_.add(now, stamp, pose.translation(), q, p_now, q_now)) return false;
  streaming_ = true;
  goal_ = pose;
  p_goal_ = stream_.newest().p;
  q_goal_ = stream_.newest().q;
  settled_ = false;
  cached_t_ = -1e300;
  return true;
}

void HolderMotion::restore(const Kinematics& k) {
  pose_ = k.pose;
  q_ = k.q;
  v_ = k.v;
  w_ = k.w;
  settled_ = k.settled;
  cached_t_ = k.cached_t;
  cached_p_ = k.cached_p;
  cached_q_ = k.cached_q;
}

void HolderMotion::halt() {
  v_.setZero();
  w_.setZero();
}

void HolderMotion::reference(double t, Vector3d* p, Quaterniond* q) const {
  if (streaming_) {
    stream_.at(t, p, q);
    return;
  }
  if (!(duration_ > 0.0) || t >= t0_ + duration_) {
    *p = p_goal_;
    *q = q_goal_;
    return;
  }
  const double a = std::max(0.0, (t - t0_) / duration_);
  *p = (1.0 - a) * p_start_ + a * p_goal_;
  *q = q_start_.slerp(a, q_goal_);
}

Eigen::Isometry3d HolderMotion::reference(double t) const {
  Vector3d p;
  Quaterniond q;
  reference(t, &p, &q);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = q.toRotationMatrix();
  out.translation() = p;
  return out;
}

HolderClip HolderMotion::advance(double t, double h, const HolderLimits& limits) {
  HolderClip clip;
  if (settled_) return clip;
  Vector3d p0, p1;
  Quaterniond q0, q1;
  if (t == cached_t_) {
    p0 = cached_p_;
    q0 = cached_q_;
  } else {
    reference(t, &p0, &q0);
  }
  reference(t + h, &p1, &q1);
  cached_t_ = t + h;
  cached_p_ = p1;
  cached_q_ = q1;
  const Vector3d v_ref = (p1 - p0) / h;
  const Vector3d w_ref = so3::log_exact(q1 * q0.conjugate()) / h;
  v_ = track(p0 - pose_.translation(), v_ref, v_, h, limits.max_speed, limits.max_acceleration,
             &clip);
  w_ = track(so3::log_exact(q0 * q_.conjugate()), w_ref, w_, h, limits.max_angular_speed,
             limits.max_angular_acceleration, &clip);
  pose_.translation() += h * v_;
  q_ = (so3::exp_exact(h * w_) * q_)
           .normalized();  // world-frame increment; no drift off unit length
  const double lag = (p1 - pose_.translation()).norm();
  const double angular_lag = so3::log_exact(q1 * q_.conjugate()).norm();
  // Inputs at tens of hertz give a reference whose velocity jumps at every input, which the
  // acceleration limit rounds off by a fraction of a millimetre: only a clip that leaves the
  // holder visibly behind its reference is reported.
  if (lag < kReportedLag && angular_lag < kReportedAngularLag) clip = HolderClip();
  // At the goal and at rest: snap there exactly and stop computing.
  if (reference_ended(t + h) && lag < 1e-12 && angular_lag < 1e-12 && v_.norm() < 1e-9 &&
      w_.norm() < 1e-9) {
    pose_.translation() = p_goal_;
    q_ = q_goal_;
    v_.setZero();
    w_.setZero();
    settled_ = true;
  }
  pose_.linear() = q_.toRotationMatrix();
  return clip;
}

}  // namespace corde
