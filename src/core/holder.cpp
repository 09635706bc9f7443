#include "corde_sim/holder.h"

#include <algorithm>
#include <cmath>

namespace corde {
namespace {

using Eigen::Vector3d;

Vector3d rotation_vector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d exp_map(const Vector3d& v) {
  const double a = v.norm();
  if (a < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

// One step of a tracker with a speed and an acceleration limit: e is the error to the reference
// at the start of the step, v_ref the reference's velocity over the step. Far from the reference it
// approaches at the speed from which it can still stop within the acceleration limit (sqrt(2 a
// |e|)); close to it, it closes the error in one step. Returns the new velocity.
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
  pose_ = start_ = goal_ = pose;
  v_.setZero();
  w_.setZero();
  t0_ = duration_ = 0.0;
}

void HolderMotion::set_goal(double now, const Eigen::Isometry3d& goal, double duration) {
  start_ = reference(now);
  goal_ = goal;
  t0_ = now;
  duration_ = std::max(0.0, duration);
}

void HolderMotion::stop() {
  start_ = goal_ = pose_;
  duration_ = 0.0;
}

Eigen::Isometry3d HolderMotion::reference(double t) const {
  if (!(duration_ > 0.0) || t >= t0_ + duration_) return goal_;
  const double a = std::max(0.0, (t - t0_) / duration_);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond qa(start_.linear()), qb(goal_.linear());
  out.linear() = qa.slerp(a, qb).toRotationMatrix();
  out.translation() = (1.0 - a) * start_.translation() + a * goal_.translation();
  return out;
}

HolderClip HolderMotion::advance(double t, double h, const HolderLimits& limits) {
  HolderClip clip;
  const Eigen::Isometry3d ref0 = reference(t), ref1 = reference(t + h);
  const Vector3d v_ref = (ref1.translation() - ref0.translation()) / h;
  const Vector3d w_ref = rotation_vector(ref1.linear() * ref0.linear().transpose()) / h;
  v_ = track(ref0.translation() - pose_.translation(), v_ref, v_, h, limits.max_speed,
             limits.max_acceleration, &clip);
  w_ = track(rotation_vector(ref0.linear() * pose_.linear().transpose()), w_ref, w_, h,
             limits.max_angular_speed, limits.max_angular_acceleration, &clip);
  pose_.translation() += h * v_;
  Eigen::Matrix3d r = exp_map(h * w_) * pose_.linear();
  pose_.linear() = Eigen::Quaterniond(r).normalized().toRotationMatrix();  // no drift off SO(3)
  // Inputs at tens of hertz give a reference whose velocity jumps at every input, which the
  // acceleration limit rounds off by a fraction of a millimetre: only a clip that leaves the
  // holder visibly behind its reference is reported.
  if ((ref1.translation() - pose_.translation()).norm() < kReportedLag &&
      rotation_vector(ref1.linear() * pose_.linear().transpose()).norm() < kReportedAngularLag)
    clip = HolderClip();
  return clip;
}

bool HolderMotion::moving() const {
  if (v_.norm() > 1e-9 || w_.norm() > 1e-9) return true;
  return (goal_.translation() - pose_.translation()).norm() > 1e-9 ||
         rotation_vector(goal_.linear() * pose_.linear().transpose()).norm() > 1e-9;
}

}  // namespace corde
