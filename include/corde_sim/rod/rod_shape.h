// Rod shapes at creation: straight, helix, polyline, and frames that follow them.
#pragma once

#include <string>
#include <vector>

#include "corde_sim/rod/rod.h"

namespace corde {

struct RodShape {
  enum class Kind { kStraight, kHelix, kPolyline };
  Kind kind = Kind::kStraight;
  // Straight: from `start` along `direction` for `length` metres.
  Vec3 start = Vec3::Zero();
  Vec3 direction = Vec3::UnitX();
  double length = 1.0;
  // Helix about an axis through `start` along `direction`: radius, pitch (rise per turn), turns.
  double helix_radius = 0.1, helix_pitch = 0.05, helix_turns = 3.0;
  // Polyline through these points (at least two), resampled at equal arc length.
  std::vector<Vec3> points;
  // First director d1 at the start; projected perpendicular to the first tangent.
  Vec3 reference_d1 = Vec3::UnitZ();
};

struct RodSpec {
  std::string name = "rod";
  RodShape shape;
  int elements = 50;
  Section section;
  bool rest_shape_created = false;  // true: intrinsic strains of the created shape (pre-shaped)
};

// Node positions of the shape at `elements` equal arc-length steps (elements + 1 points).
std::vector<Vec3> sample_shape(const RodShape& shape, int elements);
// Frames with d3 along each segment, d1 carried from reference_d1 by parallel transport
// (no twist); the unit quaternion of each segment.
std::vector<Quat> transport_frames(const std::vector<Vec3>& nodes, const Vec3& reference_d1);
// Builds the rod; throws std::invalid_argument with the reason on a degenerate shape.
Rod build_rod(const RodSpec& spec);

}  // namespace corde
