#include "corde_sim/rod/motion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace corde {
namespace {

// Cubic Hermite on [0, 1] in u with end values a, b and end slopes ma, mb (per unit of u): value
// and derivative with respect to u.
template <class T>
void hermite(double u, const T& a, const T& b, const T& ma, const T& mb, T* value, T* deriv) {
  const double u2 = u * u, u3 = u2 * u;
  *value =
      (2 * u3 - 3 * u2 + 1) * a + (u3 - 2 * u2 + u) * ma + (-2 * u3 + 3 * u2) * b + (u3 - u2) * mb;
  *deriv = (6 * u2 - 6 * u) * a + (3 * u2 - 4 * u + 1) * ma + (-6 * u2 + 6 * u) * b +
           (3 * u2 - 2 * u) * mb;
}

// Slope at interior keyframe k from the two neighbouring chords, each weighted by the other
// interval's length (exact for quadratics, no overshoot from uneven spacing dominating).
template <class T>
T interior_slope(const T& p0, const T& p1, const T& p2, double h0, double h1) {
  return ((p1 - p0) * (h1 / h0) + (p2 - p1) * (h0 / h1)) / (h0 + h1);
}

}  // namespace

Motion::Motion(std::vector<Keyframe> keyframes, Interpolation interpolation, const Vec3& turn_axis)
    : frames_(std::move(keyframes)), how_(interpolation) {
  if (!(turn_axis.allFinite() && turn_axis.norm() > 0.0))
    throw std::invalid_argument("the turn axis must be a finite non-zero vector");
  axis_ = turn_axis.normalized();
  for (size_t k = 0; k < frames_.size(); ++k) {
    Keyframe& f = frames_[k];
    if (!std::isfinite(f.time) || f.time < 0.0)
      throw std::invalid_argument("keyframe " + std::to_string(k) +
                                  ": time must be finite and >= 0");
    if (k > 0 && !(f.time > frames_[k - 1].time))
      throw std::invalid_argument("keyframe " + std::to_string(k) +
                                  ": times must increase strictly");
    if (!f.displacement.allFinite() || !f.rotation.coeffs().allFinite() || !std::isfinite(f.angle))
      throw std::invalid_argument("keyframe " + std::to_string(k) + ": values must be finite");
    if (std::abs(f.rotation.norm() - 1.0) > 1e-6)
      throw std::invalid_argument("keyframe " + std::to_string(k) +
                                  ": the rotation must be a unit quaternion");
    f.rotation.normalize();
  }
  if (frames_.empty() || frames_[0].time > 0.0) {
    frames_.insert(frames_.begin(), Keyframe{});
  } else {
    const Keyframe& f = frames_[0];
    if (f.displacement.norm() > 1e-9 || f.angle != 0.0 ||
        Eigen::AngleAxisd(f.rotation).angle() > 1e-9)
      throw std::invalid_argument(
          "keyframe 0: a keyframe at time 0 must be the start pose (the drive starts where the "
          "item is)");
  }
  // Keep consecutive rotations on the same hemisphere so each interval takes the short arc.
  for (size_t k = 1; k < frames_.size(); ++k)
    if (frames_[k].rotation.coeffs().dot(frames_[k - 1].rotation.coeffs()) < 0.0)
      frames_[k].rotation.coeffs() *= -1.0;
  const size_t n = frames_.size();
  slope_d_.assign(n, Vec3::Zero());
  slope_a_.assign(n, 0.0);
  if (how_ == Interpolation::kSmooth)
    for (size_t k = 1; k + 1 < n; ++k) {
      const double h0 = frames_[k].time - frames_[k - 1].time;
      const double h1 = frames_[k + 1].time - frames_[k].time;
      slope_d_[k] = interior_slope(frames_[k - 1].displacement, frames_[k].displacement,
                                   frames_[k + 1].displacement, h0, h1);
      slope_a_[k] =
          interior_slope(frames_[k - 1].angle, frames_[k].angle, frames_[k + 1].angle, h0, h1);
    }
}

Motion Motion::ramp(double start, double duration, const Vec3& displacement, double angle,
                    const Vec3& turn_axis, Interpolation interpolation) {
  if (!(std::isfinite(start) && start >= 0.0))
    throw std::invalid_argument("start_time must be finite and >= 0");
  if (!(std::isfinite(duration) && duration > 0.0))
    throw std::invalid_argument("ramp_time must be finite and > 0");
  std::vector<Keyframe> frames;
  if (start > 0.0)
    frames.push_back(Keyframe{start, Vec3::Zero(), Quat::Identity(), 0.0, false, false});
  frames.push_back(Keyframe{start + duration, displacement, Quat::Identity(), angle, false, false});
  return Motion(std::move(frames), interpolation, turn_axis);
}

Motion::Sample Motion::at(double t) const {
  Sample s;
  if (frames_.empty()) return s;
  const size_t n = frames_.size();
  if (!(t > 0.0) || n == 1) return s;
  if (t >= frames_.back().time) {
    const Keyframe& f = frames_.back();
    s.displacement = f.displacement;
    s.rotation = f.rotation * Quat(Eigen::AngleAxisd(f.angle, axis_));
    return s;
  }
  // The interval [k, k + 1] holding t: the last keyframe at or before t.
  const auto after = std::upper_bound(frames_.begin(), frames_.end(), t,
                                      [](double x, const Keyframe& f) { return x < f.time; });
  const size_t k = std::min(static_cast<size_t>(after - frames_.begin()) - 1, n - 2);
  const Keyframe &a = frames_[k], &b = frames_[k + 1];
  const double h = b.time - a.time, u = (t - a.time) / h;
  double angle = 0.0, angle_rate = 0.0, profile = u, profile_rate = 1.0 / h;
  if (how_ == Interpolation::kLinear) {
    s.displacement = a.displacement + u * (b.displacement - a.displacement);
    s.velocity = (b.displacement - a.displacement) / h;
    angle = a.angle + u * (b.angle - a.angle);
    angle_rate = (b.angle - a.angle) / h;
  } else {
    Vec3 dv;
    hermite<Vec3>(u, a.displacement, b.displacement, h * slope_d_[k], h * slope_d_[k + 1],
                  &s.displacement, &dv);
    s.velocity = dv / h;
    double da = 0.0;
    hermite<double>(u, a.angle, b.angle, h * slope_a_[k], h * slope_a_[k + 1], &angle, &da);
    angle_rate = da / h;
    profile = u * u * (3.0 - 2.0 * u);
    profile_rate = 6.0 * u * (1.0 - u) / h;
  }
  // Rotation: a.rotation then a fraction `profile` of the arc to b.rotation (about the world
  // axis r_a * axis_local), then the turn about the fixed axis.
  const Eigen::AngleAxisd arc(a.rotation.conjugate() * b.rotation);
  const Quat partial = a.rotation * Quat(Eigen::AngleAxisd(profile * arc.angle(), arc.axis()));
  const Quat turn = Quat(Eigen::AngleAxisd(angle, axis_));
  s.rotation = partial * turn;
  s.angular_velocity =
      a.rotation * (arc.axis() * (arc.angle() * profile_rate)) + partial * (axis_ * angle_rate);
  return s;
}

Motion Motion::rebased(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to,
                       const Vec3& turn_axis) const {
  std::vector<Keyframe> frames = frames_;
  const Vec3 shift = from.translation() - to.translation();
  const Quat turn = Quat(from.linear()) * Quat(to.linear()).conjugate();
  for (Keyframe& f : frames) {
    // displacement = position - from, rotation = orientation * from^-1: the same world pose from
    // `to`.
    if (f.absolute_position) f.displacement += shift;
    if (f.absolute_orientation) f.rotation = (f.rotation * turn).normalized();
  }
  return Motion(std::move(frames), how_, turn_axis);
}

Eigen::Isometry3d Motion::pose_at(double t, const Eigen::Isometry3d& start) const {
  const Sample s = at(t);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = s.rotation.toRotationMatrix() * start.linear();
  pose.translation() = start.translation() + s.displacement;
  return pose;
}

}  // namespace corde
