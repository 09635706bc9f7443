// Keyframed rigid motion: where a driven node, segment, clamp or grasp is at time t, relative to
// where it started.
//
// A motion is a list of keyframes, each a time with a displacement (world frame), a rotation
// (world frame, applied after the start orientation) and a turn angle about a fixed world axis
// (the tangent at the start, for twisting a rod's end by whole turns). Time 0 is the start pose
// (zero displacement, no rotation); after the last keyframe the motion holds it. Interpolation
// (docs/scene_format.md, "Keyframed drives"):
//  - kSmooth: cubic Hermite through the keyframes, at rest at the first and last, through the
//    interior ones without stopping (tangents from the neighbouring slopes): C1, no velocity jump;
//  - kStop: cubic Hermite at rest at every keyframe (the smoothstep profile between two): C1;
//  - kLinear: piecewise linear, constant velocity between keyframes (velocity jumps at them).
// Rotations between two keyframes follow the shortest arc with the same profile (linear for
// kLinear, smoothstep otherwise), so the angular velocity is zero at every rotation keyframe
// except with kLinear; turn angles are a scalar channel and interpolate like displacements, so
// many turns are fine.
#pragma once

#include <vector>

#include "corde_sim/model/element_energies.h"

namespace corde {

struct Keyframe {
  double time = 0.0;                 // s
  Vec3 displacement = Vec3::Zero();  // m, from the start position
  Quat rotation = Quat::Identity();  // from the start orientation, world frame
  double angle = 0.0;                // rad about Motion::turn_axis (2 pi per turn)
  // Whether the keyframe gave a world position / orientation (scene keys `position`,
  // `orientation`) rather than one relative to the start: rebased() keeps those where they are.
  bool absolute_position = false, absolute_orientation = false;
};

class Motion {
 public:
  enum class Interpolation { kSmooth, kStop, kLinear };

  struct Sample {
    Vec3 displacement = Vec3::Zero(), velocity = Vec3::Zero();  // m, m/s
    Quat rotation = Quat::Identity();  // world frame: orientation = rotation * start orientation
    Vec3 angular_velocity = Vec3::Zero();  // world frame (rad/s)
  };

  Motion() = default;
  // Keyframe times must be finite, >= 0 and strictly increasing; a keyframe at time 0 must be the
  // start pose (zero displacement, rotation and angle), and one is added there otherwise.
  // `turn_axis` is normalised. Throws std::invalid_argument.
  Motion(std::vector<Keyframe> keyframes, Interpolation interpolation,
         const Vec3& turn_axis = Vec3::UnitZ());

  // "Move by `displacement` and turn by `angle` over [start, start + duration], then hold".
  static Motion ramp(double start, double duration, const Vec3& displacement, double angle,
                     const Vec3& turn_axis, Interpolation interpolation = Interpolation::kStop);

  Sample at(double t) const;
  // The same motion for an item that starts at `to` instead of `from` (a grasp that takes hold
  // where the rod is then): keyframes given as world positions or orientations stay there, the
  // relative ones (displacements, turns) now start from `to`; turns about `turn_axis`.
  Motion rebased(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to,
                 const Vec3& turn_axis) const;
  // The pose at t of a frame that was at `start` at time 0, moved about its own origin (a grasp's
  // holder).
  Eigen::Isometry3d pose_at(double t, const Eigen::Isometry3d& start) const;
  const std::vector<Keyframe>& keyframes() const { return frames_; }
  Interpolation interpolation() const { return how_; }
  const Vec3& turn_axis() const { return axis_; }
  double end_time() const { return frames_.empty() ? 0.0 : frames_.back().time; }

 private:
  std::vector<Keyframe> frames_;
  Interpolation how_ = Interpolation::kSmooth;
  Vec3 axis_ = Vec3::UnitZ();
  // Hermite tangents of the displacement and angle channels at each keyframe.
  std::vector<Vec3> slope_d_;
  std::vector<double> slope_a_;
};

}  // namespace corde
