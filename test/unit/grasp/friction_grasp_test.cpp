// Friction grasps (grasp/friction_grasp.h): a hanging cable held with mu N below its weight slides
// out at g - mu N / m and is let go at its end; above its weight it holds and the holder carries
// the weight; a gripper closed lightly and moved along a taut cable traces it. Each under the four
// integrators.
#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/simulation/simulation.h"
#include "dynamics_util.h"

namespace corde {
namespace {

constexpr Integrator kAll[] = {Integrator::kSemiImplicitEuler, Integrator::kSplitRotation,
                               Integrator::kImplicitEuler, Integrator::kBdf2};

// The example rod (r = 1 cm, E = 1e7, rho = 1000) with Kelvin-Voigt friction of retardation time
// 1e-4 s, the step explicit (1e-5 s) or implicit (1e-4 s).
World example_world(Rod rod, Integrator integrator) {
  World w;
  w.integrator = integrator;
  w.time_step = is_implicit(integrator) ? 1e-4 : 1e-5;
  w.add_rod(std::move(rod));
  return w;
}

Material damped_material() {
  Material m = dyn::example_material();
  const double area = dyn::kPi * 0.01 * 0.01, tau = 1e-4;
  m.gamma_t = tau * 1e7 * area;
  m.gamma_r = tau * 1e7 * area * 0.01 * 0.01 / 4.0;
  return m;
}

double rod_mass(const Rod& rod) {
  double m = 0.0;
  for (double mi : rod.node_masses()) m += mi;
  return m;
}

GraspSpec friction_spec(double arc, double force, double mu) {
  GraspSpec s;
  s.name = "g";
  s.rod = "rod";
  s.place = GraspSpec::Place::kArcLength;
  s.value = arc;
  s.grip.friction = true;
  s.grip.force = force;
  s.grip.mu = mu;
  return s;
}

// Holds the spec where its segment is now.
void grasp(World* w, GraspSet* g, const GraspSpec& spec) {
  const Rod& rod = w->rods()[0];
  ASSERT_EQ(g->add(*w, spec, segment_pose(rod, grasp_segment(rod, spec)), nullptr, 0.0), "");
}

// One step; returns how many grasps let go.
int step(World* w, GraspSet* g) {
  g->before_step(*w, w->time(), w->time_step, HolderLimits());
  w->step();
  return g->after_step(*w, w->time_step);
}

// A vertical cable, 1 m from the origin down, 20 elements, held 0.25 m below its top.
World hanging(Integrator integrator) {
  return example_world(
      dyn::straight_rod(damped_material(), 0.01, 1.0, 20, -Vec3::UnitZ(), Vec3::UnitX()),
      integrator);
}

TEST(FrictionGrasp, HangingCableSlidesOutAtThePredictedAcceleration) {
  for (Integrator integrator : kAll) {
    SCOPED_TRACE(integrator_name(integrator));
    World w = hanging(integrator);
    const double m = rod_mass(w.rods()[0]), g0 = 9.81;
    const double mu = 0.5, force = 0.5 * m * g0 / mu;  // mu N = m g / 2: a = g / 2
    GraspSet g;
    grasp(&w, &g, friction_spec(0.25, force, mu));
    const double arc0 = g.find("g")->grip.arc;
    double t_slip = -1.0, t_out = -1.0, v1 = 0.0, t1 = -1.0, v2 = 0.0, t2 = -1.0;
    double slip_mean = 0.0, v_mid = 0.0;
    bool stuck_again = false;
    const long max_steps = static_cast<long>(1.0 / w.time_step);
    for (long k = 0; k < max_steps && t_out < 0.0; ++k) {
      const int out = step(&w, &g);
      const GraspState& s = *g.find("g");
      const double t = w.time(), vz = w.rods()[0].linear_momentum().z() / m;
      if (t_slip < 0.0 && s.grip.slipping) t_slip = t;
      if (t_slip >= 0.0 && !s.grip.slipping && out == 0) stuck_again = true;
      // The centre of mass over a window of the slide, after the start's waves.
      if (t_slip >= 0.0 && t1 < 0.0 && t >= t_slip + 0.05) {
        t1 = t;
        v1 = vz;
        double unused;
        g.take_slip("g", &unused);
      }
      if (t1 >= 0.0 && t2 < 0.0 && t >= t1 + 0.15) {
        t2 = t;
        v2 = vz;
        ASSERT_TRUE(g.take_slip("g", &slip_mean));
        v_mid = 0.5 * (v1 + v2);
      }
      if (out > 0) {
        t_out = t;
        EXPECT_FALSE(s.held);
        EXPECT_EQ(s.grip.slid_out, -1);  // past its start (the top)
        EXPECT_TRUE(w.rods()[0].node_constraints().empty());
      }
    }
    ASSERT_GE(t_slip, 0.0);
    EXPECT_LT(t_slip, 0.02);  // once the weight reaches the grip (stretch waves at 100 m/s)
    EXPECT_FALSE(stuck_again);
    ASSERT_GE(t2, 0.0);
    const double a = -(v2 - v1) / (t2 - t1), expected = g0 - mu * force / m;
    // Momentum balance: weight minus the kinetic friction, to the integrators' round-off.
    EXPECT_NEAR(a, expected, 1e-3 * expected);
    // The slip velocity is the rate of the arc length at the grip point: the cable's speed
    // (towards the start: negative), within its elastic oscillation.
    EXPECT_NEAR(slip_mean, v_mid, 0.02 * std::abs(v_mid));
    // Let go when the top passed the grip: the arc of 0.225 m slid at about a from rest.
    ASSERT_GE(t_out, 0.0);
    const double predicted = t_slip + std::sqrt(2.0 * arc0 / expected);
    EXPECT_NEAR(t_out, predicted, 0.03 * predicted);
    // Free after: it falls at g (BDF2 takes a few steps to forget the friction it had).
    const double v_out = w.rods()[0].linear_momentum().z() / m;
    for (int k = 0; k < 100; ++k) step(&w, &g);
    EXPECT_NEAR((w.rods()[0].linear_momentum().z() / m - v_out) / (100 * w.time_step), -g0,
                0.01 * g0);
  }
}

TEST(FrictionGrasp, HangingCableHoldsAboveItsWeightAndTheHolderCarriesIt) {
  for (Integrator integrator : kAll) {
    SCOPED_TRACE(integrator_name(integrator));
    World w = hanging(integrator);
    const double m = rod_mass(w.rods()[0]), g0 = 9.81;
    const double mu = 0.5, force = 3.0 * m * g0 / mu;  // mu N = 3 m g: above the start's waves
    GraspSet g;
    grasp(&w, &g, friction_spec(0.25, force, mu));
    const double arc0 = g.find("g")->grip.arc;
    const long steps = static_cast<long>(0.6 / w.time_step);
    Vec3 f, t;
    for (long k = 0; k < steps; ++k) {
      if (k == steps / 2) g.take_reaction("g", &f, &t);  // the window: the last 0.3 s
      step(&w, &g);
      ASSERT_FALSE(g.find("g")->grip.slipping) << "at t = " << w.time();
    }
    const GraspState& s = *g.find("g");
    EXPECT_LT(std::abs(s.grip.arc - arc0), 1e-12);
    double slip = 1.0;
    ASSERT_TRUE(g.take_slip("g", &slip));
    EXPECT_LT(std::abs(slip), 1e-10);
    ASSERT_TRUE(g.take_reaction("g", &f, &t));
    // The rod pulls the holder down with its weight (world frame), once its waves have died out.
    const Vec3 world_force = s.holder_pose().linear() * f;
    EXPECT_LT((world_force - Vec3(0, 0, -m * g0)).norm(), 1e-3 * m * g0) << world_force.transpose();
  }
}

// The rest arc length s on a rod: its place, interpolated between the nodes.
Vec3 place_at(const Rod& rod, double s) {
  for (int i = 0; i < rod.num_segments(); ++i) {
    const double l = rod.rest_lengths()[i];
    if (s <= l || i + 1 == rod.num_segments())
      return rod.positions()[i] + (s / l) * (rod.positions()[i + 1] - rod.positions()[i]);
    s -= l;
  }
  return rod.positions().back();
}

TEST(FrictionGrasp, LightGripMovedAlongATautCableTracesIt) {
  for (Integrator integrator : kAll) {
    SCOPED_TRACE(integrator_name(integrator));
    // 1 m along x, 20 elements, stretched by 0.1 % between two clamps (tension 3.1 N), without
    // gravity.
    Rod rod = dyn::straight_rod(damped_material(), 0.01, 1.0, 20);
    for (Vec3& x : rod.positions()) x *= 1.001;
    for (int node : {0, 20}) {
      NodeDrive d;
      d.node = node;
      d.origin = rod.positions()[node];
      rod.add_node_drive(d);
    }
    const std::vector<Vec3> start = rod.positions();
    World w = example_world(std::move(rod), integrator);
    w.gravity = Vec3::Zero();
    const double mu = 0.5, force = 0.1;  // mu N = 0.05 N
    GraspSet g;
    grasp(&w, &g, friction_spec(0.3, force, mu));
    const double arc0 = g.find("g")->grip.arc;
    const Eigen::Isometry3d from = g.find("g")->holder.pose();
    Eigen::Isometry3d to = from;
    to.translation().x() += 0.3;  // at 0.1 m/s
    g.set_goal("g", 0.0, to, 3.0);
    const long steps = static_cast<long>(3.2 / w.time_step);
    double worst_off = 0.0, worst_drag = 0.0;
    for (long k = 0; k < steps; ++k) {
      ASSERT_EQ(step(&w, &g), 0);
      const GraspState& s = *g.find("g");
      const Rod& r = w.rods()[0];
      // The grip point is where the cable is at the grip's arc length.
      const Vec3 c = s.holder.pose() * s.grip.point;
      worst_off = std::max(worst_off, (place_at(r, s.grip.arc) - c).norm());
      for (int i = 0; i < r.num_nodes(); ++i)
        worst_drag = std::max(worst_drag, (r.positions()[i] - start[i]).norm());
    }
    const GraspState& s = *g.find("g");
    // The arc length followed the holder: 0.3 m of cable stretched by 0.1 %.
    EXPECT_NEAR(s.grip.arc - arc0, 0.3 / 1.001, 1e-4);
    EXPECT_LT(worst_off, 1e-5);
    // The cable moves by the friction over its stiffness (0.05 N / (EA/0.3 + EA/0.7) = 3 um), not
    // with the holder.
    EXPECT_LT(worst_drag, 2e-5);
    EXPECT_GT(s.grasp.segment, 10);  // it crossed segment boundaries on the way
  }
}

// The held segment's turn about the unit axis `a` since orientation q0 (rad).
double turn_about(const Quat& q, const Quat& q0, const Vec3& a) {
  const Quat rel = q * q0.conjugate();
  return 2.0 * std::atan2(rel.vec().dot(a), rel.w());
}

// Torsional friction: a free rod (no gravity) held at its middle by a friction grasp and twisted
// there by a torque T about its axis. Below mu N r the fingers hold it; above, it turns in them
// against mu N r: the whole rod spins up at (T - mu N r) / J, J its polar moment of inertia.
TEST(FrictionGrasp, TwistTorqueAboveMuNrTurnsTheCableBelowItHolds) {
  for (Integrator integrator : kAll) {
    SCOPED_TRACE(integrator_name(integrator));
    for (double ratio : {0.5, 2.0}) {
      SCOPED_TRACE(ratio);
      World w = example_world(dyn::straight_rod(damped_material(), 0.01, 1.0, 20), integrator);
      w.gravity = Vec3::Zero();
      const double mu = 0.5, force = 0.01, r = 0.01;
      const double limit = mu * force * r;  // 5e-5 N m
      GraspSet g;
      grasp(&w, &g, friction_spec(0.5, force, mu));
      const int s = g.find("g")->grasp.segment;
      const Vec3 a = w.rods()[0].orientations()[s] * Vec3::UnitZ();
      const Quat q0 = w.rods()[0].orientations()[s];
      g.set_wrench(w, "g", Vec3::Zero(), ratio * limit * a);
      const double t_end = 0.2;
      const long steps = static_cast<long>(std::lround(t_end / w.time_step));
      bool turned = false;
      for (long k = 0; k < steps; ++k) {
        step(&w, &g);
        turned = turned || g.find("g")->grip.turning;
        ASSERT_FALSE(g.find("g")->grip.slipping);
      }
      const double angle = turn_about(w.rods()[0].orientations()[s], q0, a);
      if (ratio < 1.0) {
        EXPECT_FALSE(turned);
        EXPECT_LT(std::abs(angle), 1e-6);
        continue;
      }
      EXPECT_TRUE(turned);
      EXPECT_TRUE(g.find("g")->grip.turning);
      double j = 0.0;
      for (int i = 0; i < w.rods()[0].num_segments(); ++i) j += w.rods()[0].segment_inertia(i).z();
      const double expected = 0.5 * (ratio * limit - limit) / j * t_end * t_end;
      EXPECT_NEAR(angle, expected, 0.05 * expected);
      // The node positions stayed held.
      EXPECT_LT((segment_pose(w.rods()[0], s).translation() -
                 g.find("g")->holder_pose() * g.find("g")->grip.point)
                    .norm(),
                1e-9);
    }
  }
}

TEST(FrictionGrasp, GripForceRaisedMidSlideStopsTheSlide) {
  World w = hanging(Integrator::kSplitRotation);
  const double m = rod_mass(w.rods()[0]), g0 = 9.81;
  GraspSet g;
  grasp(&w, &g, friction_spec(0.25, 0.5 * m * g0, 0.5));  // mu N = m g / 4
  for (int k = 0; k < 5000; ++k) step(&w, &g);
  ASSERT_TRUE(g.find("g")->grip.slipping);
  EXPECT_FALSE(g.set_grip_force(w, "none", 1.0));
  ASSERT_TRUE(g.set_grip_force(w, "g", 20.0 * m * g0));  // mu N = 10 m g: kinetic friction stops it
  bool stuck = false;
  for (int k = 0; k < 20000 && !stuck; ++k) {
    step(&w, &g);
    stuck = !g.find("g")->grip.slipping;
  }
  ASSERT_TRUE(stuck);
  step(&w, &g);  // the first held step puts the segment at its rest length
  const double arc = g.find("g")->grip.arc;
  for (int k = 0; k < 20000; ++k) step(&w, &g);
  EXPECT_FALSE(g.find("g")->grip.slipping);
  EXPECT_LT(std::abs(g.find("g")->grip.arc - arc), 1e-12);
}

// Through the driver: a grip force command loosens the grip at a time; the cable slides out and
// the driver reports the let-go; a bad force is refused naming it.
TEST(FrictionGrasp, GripCommandLoosensAndTheDriverReportsTheLetGo) {
  Simulation sim;
  sim.install(hanging(Integrator::kImplicitEuler));
  World& w = sim.world();
  const double m = rod_mass(w.rods()[0]), g0 = 9.81;
  const GraspSpec spec = friction_spec(0.25, 3.0 * m * g0 / 0.5, 0.5);  // holds
  const Rod& rod = w.rods()[0];
  ASSERT_EQ(sim.grasps().add(w, spec, segment_pose(rod, grasp_segment(rod, spec)), nullptr, 0.0),
            "");
  sim.mark_good();
  sim.submit(Command::grip(0.1, "g", 0.5 * m * g0 / 0.5));  // mu N = m g / 2 from 0.1 s
  ASSERT_TRUE(sim.advance_until(0.1));
  EXPECT_FALSE(sim.grasps().find("g")->grip.slipping);
  ASSERT_TRUE(sim.advance_until(0.5));
  EXPECT_FALSE(sim.grasps().find("g")->held);
  bool reported = false;
  for (const SimulationEvent& e : sim.take_events())
    if (e.kind == SimulationEvent::Kind::kLetGo && e.grasp == "g") {
      reported = true;
      EXPECT_NE(e.text.find("slid out of the grip past its start"), std::string::npos) << e.text;
      EXPECT_GT(e.time, 0.3);  // 0.225 m at g / 2 takes 0.3 s
    }
  EXPECT_TRUE(reported);
  EXPECT_THROW(Command::grip(0.0, "g", -1.0), std::invalid_argument);
  EXPECT_THROW(Command::grip(0.0, "g", NAN), std::invalid_argument);
}

}  // namespace
}  // namespace corde
