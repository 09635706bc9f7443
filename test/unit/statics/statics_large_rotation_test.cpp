// Statics far from the straight state, and with sliding supports: pure bending of a cantilever by
// a dead end moment up to more than a full turn of its tip, and sliding clamps under axial load.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "corde_sim/statics/statics.h"
#include "validation_util.h"

namespace corde {
namespace {

using val::Clamp;

// Angle of segment s's tangent d3 in the x-z plane (turning from +x towards -z), unwrapped along
// the rod from segment 0 so that tips turned beyond pi are measured whole.
double unwrapped_angle(const Rod& rod, int s) {
  double angle = val::droop_angle(rod, 0);
  for (int k = 1; k <= s; ++k) {
    const Vec3 a = rod.orientations()[k - 1] * Vec3::UnitZ();
    const Vec3 b = rod.orientations()[k] * Vec3::UnitZ();
    angle += std::atan2(a.cross(b).y(), a.dot(b));
  }
  return angle;
}

// A dead end moment M about +y on the last segment of a cantilever (the example rod, L = 1,
// N = 20) bends it into a circular arc of curvature M/B: no force anywhere, every element carries
// M. Discretely an element of rest length l turns by phi = asin(M l / B) exactly (its moment is
// (B/l) sin(phi)), the ghost element by asin(M l / (2B)); chords keep their rest length along
// d3, so node i sits at l sum_{s<i} (cos a_s, 0, -sin a_s), a_s the angle of segment s: on the
// circle through the clamp of radius l / (2 sin(phi/2)) = B/M (1 + O(l^2)). ML/B = 2.8, 4 and 7
// (the tip turned past pi, and past a full turn) from the straight rod in one load step. Each
// segment's angle to 1e-8 rad, every node to 1e-8 L, and the curvature of the arc through the
// nodes against M/B to the discretisation's O(l^2).
TEST(StaticsLargeRotation, EndMomentBendsAnArcBeyondAHalfTurn) {
  const int n = 20;
  const double l = val::kLength / n;
  for (const double ml_b : {2.8, 4.0, 7.0})
    for (Clamp clamp : {Clamp::kNatural, Clamp::kGhost}) {
      Rod rod = val::straight_rod(val::example_material(), n);
      val::clamp_start(&rod, clamp);
      const double b = rod.section().bend, m = ml_b * b / val::kLength;
      Load load;
      load.kind = Load::Kind::kTorque;
      load.index = n - 1;
      load.value = Vec3(0.0, m, 0.0);
      rod.add_load(load);
      const StaticResult res = solve_statics(rod, Vec3::Zero(), 0.0);
      std::cout << "ML/B = " << ml_b << ", " << val::clamp_name(clamp) << ": converged "
                << res.converged << " in " << res.iterations << " iterations ("
                << res.shifted_iterations << " shifted), tip angle " << unwrapped_angle(rod, n - 1)
                << " rad\n";
      EXPECT_TRUE(res.converged) << "ML/B = " << ml_b << ", " << val::clamp_name(clamp);
      EXPECT_LE(res.iterations, 30);
      const double phi = std::asin(m * l / b);
      const double a0 = clamp == Clamp::kGhost ? std::asin(0.5 * m * l / b) : 0.0;
      Vec3 x = rod.positions()[0];
      double worst_angle = 0.0, worst_node = 0.0;
      for (int s = 0; s < n; ++s) {
        const double a = a0 + s * phi;
        worst_angle = std::max(worst_angle, std::abs(unwrapped_angle(rod, s) - a));
        x += l * Vec3(std::cos(a), 0.0, -std::sin(a));
        worst_node = std::max(worst_node, (rod.positions()[s + 1] - x).norm());
      }
      EXPECT_LT(worst_angle, 1e-8) << "ML/B = " << ml_b << ", " << val::clamp_name(clamp);
      EXPECT_LT(worst_node, 1e-8 * val::kLength)
          << "ML/B = " << ml_b << ", " << val::clamp_name(clamp);
      // The circle through nodes 1, n/2 and n: its curvature is M/B to O(l^2).
      const Vec3 p = rod.positions()[1], q = rod.positions()[n / 2], r = rod.positions()[n];
      const double kappa =
          2.0 * (q - p).cross(r - p).norm() / ((q - p).norm() * (r - q).norm() * (r - p).norm());
      EXPECT_NEAR(kappa / (m / b), 1.0, 0.5 * (m * l / b) * (m * l / b))
          << "ML/B = " << ml_b << ", " << val::clamp_name(clamp);
    }
}

// A clamp at the start that slides along the rod's axis (node 0 on the x axis, its frame held:
// natural, by the segment; ghost, by the ghost frame), the end node pinned, a dead load on node 0
// pulling along -x plus a transverse one that the slide takes: the rod stays straight on the axis
// under the tension F, every chord stretched by F / K_s (the example rod, N = 10, F = 1e-3 K_s,
// 1e-9 relative), in 3D and with the planar option (normal y).
TEST(StaticsSlidingClamp, AxialLoadStretchesByTensionOverStiffness) {
  const int n = 10;
  for (Clamp clamp : {Clamp::kNatural, Clamp::kGhost})
    for (const Vec3& normal : {Vec3(0.0, 0.0, 0.0), Vec3(0.0, 1.0, 0.0)}) {
      Rod rod = val::straight_rod(val::example_material(), n);
      NodeConstraint slide;
      slide.kind = NodeConstraint::Kind::kLine;
      slide.node = 0;
      slide.point = rod.positions()[0];
      slide.direction = Vec3::UnitX();
      rod.add_node_constraint(slide);
      if (clamp == Clamp::kNatural) {
        SegmentDrive sd;
        sd.segment = 0;
        sd.origin = rod.orientations()[0];
        rod.add_segment_drive(sd);
      } else {
        rod.ghost_start().active = true;
        rod.ghost_start().frame = rod.orientations()[0];
      }
      NodeDrive pin;
      pin.node = n;
      pin.origin = rod.positions()[n];
      rod.add_node_drive(pin);
      const double ks = rod.section().stretch, f = 1e-3 * ks;
      Load pull;
      pull.index = 0;
      pull.value = Vec3(-f, 0.0, 0.3 * f);
      rod.add_load(pull);
      StaticOptions opt;
      opt.plane_normal = normal;
      const StaticResult res = solve_statics(rod, Vec3::Zero(), 0.0, opt);
      EXPECT_TRUE(res.converged) << val::clamp_name(clamp) << ", normal " << normal.transpose();
      const double strain = f / ks, l = val::kLength / n;
      for (int i = 0; i <= n; ++i) {
        const Vec3 want(val::kLength - (n - i) * l * (1.0 + strain), 0.0, 0.0);
        EXPECT_LT((rod.positions()[i] - want).norm(), 1e-9 * strain * val::kLength)
            << val::clamp_name(clamp) << ", node " << i << " at " << rod.positions()[i].transpose();
      }
    }
}

// A cantilever whose ghost clamp slides freely along the rod's axis, under a transverse tip load
// (alpha = 1, N = 10): nothing pulls along the axis, so any place along it is an equilibrium; the
// clamped node stays on its line and the rod takes the fixed cantilever's shape, shifted with it
// (1e-9 L).
TEST(StaticsSlidingClamp, FreeSlideUnderTransverseLoadKeepsTheCantileversShape) {
  const int n = 10;
  Rod fixed = val::straight_rod(val::example_material(), n);
  val::clamp_start(&fixed, Clamp::kGhost);
  Rod sliding = val::straight_rod(val::example_material(), n);
  NodeConstraint slide;
  slide.node = 0;
  slide.point = sliding.positions()[0];
  slide.direction = Vec3::UnitX();
  sliding.add_node_constraint(slide);
  sliding.ghost_start().active = true;
  sliding.ghost_start().frame = sliding.orientations()[0];
  Load tip;
  tip.index = n;
  tip.value = Vec3(0.0, 0.0, -sliding.section().bend / (val::kLength * val::kLength));
  fixed.add_load(tip);
  sliding.add_load(tip);
  ASSERT_TRUE(solve_statics(fixed, Vec3::Zero(), 0.0).converged);
  const StaticResult res = solve_statics(sliding, Vec3::Zero(), 0.0);
  EXPECT_TRUE(res.converged);
  EXPECT_GT(-fixed.positions()[n].z(), 0.1);  // it did bend
  const Vec3 shift = sliding.positions()[0] - fixed.positions()[0];
  EXPECT_LT(std::hypot(shift.y(), shift.z()), 1e-12 * val::kLength);
  for (int i = 0; i <= n; ++i)
    EXPECT_LT((sliding.positions()[i] - shift - fixed.positions()[i]).norm(), 1e-9 * val::kLength)
        << "node " << i;
}

}  // namespace
}  // namespace corde
