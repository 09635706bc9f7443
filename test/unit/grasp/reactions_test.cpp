// Reactions of supports: in statics they balance the rod's weight and loads; in dynamics they are
// the change of momentum less the applied forces, step by step.
#include "corde_sim/grasp/reactions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "corde_sim/statics/statics.h"
#include "corde_sim/world/world.h"
#include "validation_util.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The example rod of docs/validation_references.md (1 m, r = 1 cm, E = 1e7) along x.
Rod cantilever(int elements) { return val::straight_rod(val::example_material(), elements); }

void clamp_start(Rod* rod, bool ghost) {
  val::clamp_start(rod, ghost ? val::Clamp::kGhost : val::Clamp::kNatural);
}

// Total weight and loads (force) and their moment about p, dead loads at time t.
void applied(const Rod& rod, const Vec3& g, const Vec3& p, Vec3* force, Vec3* moment) {
  *force = Vec3::Zero();
  *moment = Vec3::Zero();
  for (int i = 0; i < rod.num_nodes(); ++i) {
    const Vec3 w = rod.node_masses()[i] * g;
    *force += w;
    *moment += (rod.positions()[i] - p).cross(w);
  }
  for (const Load& l : rod.loads()) {
    if (l.kind == Load::Kind::kForce) {
      *force += l.value;
      *moment += (rod.positions()[l.index] - p).cross(l.value);
    } else {
      *moment += l.value;
    }
  }
}

// A cantilever sagging under its weight, a tip force and a torque: the clamp's reaction balances
// them to the statics tolerance (1e-6 of the weight, and of weight times length for moments).
TEST(Reactions, ClampBalancesWeightAndLoadsInStatics) {
  const Vec3 g(0.0, 0.0, -9.81);
  for (bool ghost : {true, false}) {
    Rod rod = cantilever(30);
    clamp_start(&rod, ghost);
    const int n = rod.num_segments();
    rod.add_load(Load{Load::Kind::kForce, n, Vec3(0.0, 0.5, -1.0)});
    rod.add_load(Load{Load::Kind::kTorque, n / 2, Vec3(0.02, 0.0, 0.01)});
    StaticOptions o;
    o.load_steps = 4;
    const StaticResult res = solve_statics(rod, g, 0.0, o);
    ASSERT_TRUE(res.converged);
    rod.set_static_reactions(0.0, g);
    Support clamp;
    clamp.nodes = {0};
    if (ghost)
      clamp.ghost = 0;
    else
      clamp.segments = {0};
    const Wrench r = support_reaction(rod, clamp);
    Vec3 f, m;
    applied(rod, g, r.point, &f, &m);
    const double weight = f.norm();
    EXPECT_LT((r.force + f).norm(), 1e-6 * weight) << ghost;
    EXPECT_LT((r.moment + m).norm(), 1e-6 * weight * 1.0) << ghost;
    EXPECT_GT(r.moment.norm(), 0.5);  // the clamp carries a moment (about w L^2 / 2 + F L)
  }
}

// Both ends clamped with ghost frames, the end turned by one turn: the clamps hold equal and
// opposite twisting moments C u along the rod, u = 2 pi / L to the discretisation's O(theta^2).
TEST(Reactions, TwistedRodClampMomentsAreEqualAndOpposite) {
  Rod rod = cantilever(20);
  clamp_start(&rod, true);
  const int n = rod.num_segments();
  rod.add_node_drive(NodeDrive{NodeDrive::Kind::kFixed, n, rod.positions()[n]});
  GhostFrame& e = rod.ghost_end();
  e.active = true;
  e.frame = e.origin = rod.orientations()[n - 1];
  e.motion = std::make_shared<Motion>(
      Motion::ramp(0.0, 1.0, Vec3::Zero(), 2.0 * kPi, Vec3::UnitX(), Motion::Interpolation::kStop));
  const Vec3 g = Vec3::Zero();
  StaticOptions o;
  o.load_steps = 8;
  const StaticResult res = solve_statics(rod, g, 2.0, o);
  ASSERT_TRUE(res.converged) << res.load_steps << " " << res.iterations << " " << res.residual;
  rod.set_static_reactions(2.0, g);
  Support a, b;
  a.nodes = {0};
  a.ghost = 0;
  b.nodes = {n};
  b.ghost = 1;
  const Wrench ra = support_reaction(rod, a), rb = support_reaction(rod, b);
  // The discrete twist: N - 1 elements of length l turned by phi each and two ghost elements of
  // l / 2 by phi_g, the angles adding up to one turn. An element's energy (l_e C / 2) u^2 with
  // u = (2 / l_e) sin(angle / 2) gives the torque (C / l_e) sin(angle), equal in all of them.
  // Continuum: C 2 pi / L; here about 1.6% less (the sine).
  const double l = 1.0 / n, c = rod.section().twist;
  auto total = [&](double phi) { return (n - 1) * phi + 2.0 * std::asin(0.5 * std::sin(phi)); };
  double lo = 0.0, hi = 2.0 * kPi / (n - 1);
  for (int i = 0; i < 100; ++i) (total(0.5 * (lo + hi)) < 2.0 * kPi ? lo : hi) = 0.5 * (lo + hi);
  const double moment = c / l * std::sin(0.5 * (lo + hi));
  EXPECT_NEAR(rb.moment.x(), moment, 1e-6 * moment);
  EXPECT_NEAR(moment, c * 2.0 * kPi, 0.02 * c * 2.0 * kPi);
  EXPECT_LT((ra.moment + rb.moment).norm(), 1e-8 * moment);
  EXPECT_LT(ra.force.norm() + rb.force.norm(), 1e-8 * moment);
}

// Over every step the rod's momentum changes by h (weight + loads + reactions): what the supports
// take is exactly what keeps their items on their prescribed paths (a pinned, swinging cable with
// a keyframed hand, a sliding end and a hinge).
TEST(Reactions, MomentumBalanceEveryStep) {
  World w;
  w.time_step = 2e-5;
  Rod& rod = w.add_rod(cantilever(20));
  const int n = rod.num_segments();
  NodeDrive hand;
  hand.kind = NodeDrive::Kind::kMotion;
  hand.node = 0;
  hand.origin = hand.pivot = rod.positions()[0];
  hand.motion =
      std::make_shared<Motion>(Motion::ramp(0.0, 0.02, Vec3(0.0, 0.02, 0.03), 0.0, Vec3::UnitZ()));
  rod.add_node_drive(hand);
  NodeConstraint slide;
  slide.node = n;
  slide.point = rod.positions()[n];
  slide.direction = Vec3(1.0, 0.0, 0.2);
  rod.add_node_constraint(slide);
  rod.add_segment_constraint(SegmentConstraint{n / 2, rod.orientations()[n / 2], Vec3::UnitY()});
  rod.add_load(Load{Load::Kind::kForce, n, Vec3(3.0, 0.0, 0.0)});
  Support all;
  all.nodes = {0, n};
  all.segments = {n / 2};
  double worst = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p0 = rod.linear_momentum();
    Vec3 f, m;
    applied(rod, w.gravity, Vec3::Zero(), &f, &m);
    w.step();
    const Wrench r = support_reaction(rod, all);
    const Vec3 dp = rod.linear_momentum() - p0;
    worst = std::max(worst, (dp / w.time_step - (f + r.force)).norm() / f.norm());
  }
  EXPECT_LT(worst, 1e-9);
}

}  // namespace
}  // namespace corde
