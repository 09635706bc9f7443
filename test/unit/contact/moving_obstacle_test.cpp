// Moving obstacles: a link sweeping through a hanging rod at 1 and 3 m/s never lets it through,
// a rope on an accelerating plate is carried by static friction or slides at mu g, a rod on a
// turntable turns with it, the gripper_sweep scene, URDF groups and the scene keys' errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/grasp/grasp.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"
#include "dynamics_util.h"

namespace corde {
namespace {

using dyn::mean_velocity;

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;

// A capsule lying along y (axis half length `half`, radius R) whose centre is at (x, 0, z).
struct Link {
  double x, z, half, R;
};

// Smallest distance from the rod's surface to the link's surface (negative: penetration).
double clearance(const Rod& rod, const Link& l) {
  const Vec3 q0(l.x, -l.half, l.z), q1(l.x, l.half, l.z);
  const auto& x = rod.positions();
  double best = INFINITY;
  for (int s = 0; s < rod.num_segments(); ++s) {
    const SegmentPair p = closest_points(x[s], x[s + 1], q0, q1);
    best = std::min(best, (x[s] + p.s * (x[s + 1] - x[s]) - q0 - p.t * (q1 - q0)).norm());
  }
  return best - l.R - rod.section().radius;
}

// The angle the rod (from its held end to its free end) winds about the link's axis, seen along
// y (the x-z plane; counter-clockwise positive), each segment adding the angle it subtends there,
// in (-pi, pi). A segment crossing the axis flips its angle from near pi to near -pi: the winding
// jumps by about 2 pi. While nothing crosses the axis it changes continuously (a free end going
// round the link over its top changes it smoothly). So a rod that passed through the link's axis,
// however fast, shows a jump of the winding between two steps; one pushed aside never does.
double winding(const Rod& rod, const Link& l) {
  double total = 0.0;
  const auto& x = rod.positions();
  for (int s = 0; s < rod.num_segments(); ++s) {
    const double ax = x[s].x() - l.x, az = x[s].z() - l.z;
    const double bx = x[s + 1].x() - l.x, bz = x[s + 1].z() - l.z;
    total += std::atan2(ax * bz - az * bx, ax * bx + az * bz);
  }
  return total;
}

// Checks of a sweep, every step, against the link's exact trajectory: the deepest overlap of the
// surfaces, the largest jump of the winding between two steps, the most clockwise winding.
struct SweepCheck {
  double least = INFINITY, jump = 0.0, most_wound = 0.0, last = NAN;
  int touching = 0;
  void sample(const Rod& rod, const Link& link) {
    const double c = clearance(rod, link);
    least = std::min(least, c);
    touching += c < 0.05 * rod.section().radius;
    const double w = winding(rod, link);
    if (!std::isnan(last)) jump = std::max(jump, std::abs(w - last));
    last = w;
    most_wound = std::min(most_wound, w);
  }
};

// (a) A rod of 0.5 m hangs from a clamp at (0, 0, 1); a capsule link (radius 3 cm, 0.3 m long,
// across the sweep) 0.3 m below the clamp sweeps along x from x = -0.1 by 0.5 m at `speed`
// (keyframed, linear), pushing the rod aside. Checked every step against the link's exact
// trajectory: the surfaces never overlap by more than 1% of the rod's radius (a rod sinking into
// the link fails here), and the winding of the rod about the link never jumps (no segment crossed
// the link's axis: the rod stayed on the side the link pushed it to, going round the link only
// over its surface).
void sweep_through_hanging_rod(double speed) {
  const double R = 0.03, z = 0.7, x0 = -0.1, t0 = 0.05, travel = 0.5;
  const double t1 = t0 + travel / speed;
  char yaml[2000];
  std::snprintf(yaml, sizeof yaml,
                "gravity: [0, 0, -9.81]\ntime_step: auto\n"
                "obstacles:\n"
                "  - {name: link, type: capsule, radius: %g, length: 0.3, position: [%g, 0, %g],"
                " rpy: [1.5707963267948966, 0, 0], friction: 0.3, interpolation: linear,"
                " keyframes: [{time: %.17g, displacement: [0, 0, 0]},"
                " {time: %.17g, displacement: [%g, 0, 0]}]}\n"
                "rods:\n"
                "  - {name: rod, elements: 25, radius: 0.003,"
                " material: {preset: soft_cable, E_s: 5.0e7, kappa: 60},"
                " shape: {type: straight, start: [0, 0, 1], direction: [0, 0, -1], length: 0.5},"
                " boundary: [{clamp: start}]}\n",
                R, x0, z, t0, t1, travel);
  Scene s = parse_scene(yaml);
  World& w = s.world;
  const Rod& rod = w.rods()[0];
  const double r = rod.section().radius;
  const int steps = static_cast<int>((t1 + 0.1) / w.time_step);
  SweepCheck check;
  double furthest = 0.0;
  for (int k = 0; k < steps; ++k) {
    w.step();
    ASSERT_TRUE(w.finite()) << "step " << k;
    const double t = w.time();
    check.sample(rod, {x0 + speed * std::clamp(t - t0, 0.0, t1 - t0), z, 0.15, R});
    for (const Vec3& p : rod.positions()) {
      furthest = std::max(furthest, p.x());
      ASSERT_LT(std::abs(p.y()), 0.1) << "the rod left the link's span";
    }
  }
  std::printf(
      "sweep at %g m/s: deepest overlap %.3g of the radius, largest winding jump %.3g rad, most "
      "wound %.3g rad, %d steps touching\n",
      speed, -check.least / r, check.jump, check.most_wound, check.touching);
  EXPECT_GT(check.least, -0.01 * r) << "deepest penetration " << -check.least << " m";
  EXPECT_LT(check.jump, 1.0) << "the rod went through the link";
  // It was pushed: in contact for many steps, carried far along, wound round the link's far side.
  EXPECT_GT(check.touching, 100);
  EXPECT_GT(furthest, 0.2);
  EXPECT_LT(check.most_wound, -kPi);  // more than half a turn: over the link's top
}

TEST(MovingObstacles, LinkSweepsThroughHangingRodAt1MetrePerSecond) {
  sweep_through_hanging_rod(1.0);
}

TEST(MovingObstacles, LinkSweepsThroughHangingRodAt3MetresPerSecond) {
  sweep_through_hanging_rod(3.0);
}

// The margin: a link at 10 m/s strikes a free rod lying parallel to it (no gravity) broadside.
// The link travels 0.5 mm (a sixth of the radius, over three times the skin) per 50 us step and
// starts 0.3 mm off the step grid, so that one step before the strike the gap is 0.3 mm: only the
// margin grown by the link's own speed finds the rod then (without it, the rod is struck 0.2 mm
// deep). The rod is pushed ahead at the link's speed without overlapping it.
TEST(MovingObstacles, FastLinkFoundOneStepEarly) {
  Scene s = parse_scene(
      "gravity: [0, 0, 0]\ntime_step: 5.0e-5\n"
      "obstacles:\n"
      "  - {name: link, type: capsule, radius: 0.03, length: 0.3, position: [-0.1003, 0, 0.7],"
      " rpy: [1.5707963267948966, 0, 0], friction: 0.3, interpolation: linear,"
      " keyframes: [{time: 0.03, displacement: [0.3, 0, 0]}]}\n"
      "rods:\n"
      "  - {name: rod, elements: 10, radius: 0.003,"
      " material: {preset: soft_cable, E_s: 5.0e7, kappa: 60},"
      " shape: {type: straight, start: [0, -0.1, 0.7], direction: [0, 1, 0], length: 0.2}}\n");
  ASSERT_TRUE(s.warnings.empty());
  World& w = s.world;
  const Rod& rod = w.rods()[0];
  const double r = rod.section().radius;
  double least = INFINITY;
  for (int k = 0; k < 400; ++k) {  // 20 ms: strikes at 6.7 ms
    w.step();
    least = std::min(least, clearance(rod, {-0.1003 + 10.0 * w.time(), 0.7, 0.15, 0.03}));
  }
  std::printf("fast link: deepest overlap %.3g of the radius\n", -least / r);
  EXPECT_GT(least, -0.01 * r);
  EXPECT_NEAR(mean_velocity(rod).x(), 10.0, 1e-6);
}

// A 0.3 m rope (radius 5 mm) resting on a plate (a box, top at z = 0) that accelerates along x at
// `accel` from rest: keyframes of x = a t^2 / 2 every 0.1 s, interpolated smoothly (cubic Hermite
// with the neighbouring chords' slopes, exact for a parabola between interior keyframes).
Scene rope_on_plate(double accel, double mu) {
  std::string frames;
  for (int k = 1; k <= 10; ++k) {
    const double t = 0.1 * k;
    char f[128];
    std::snprintf(f, sizeof f, "%s{time: %.17g, displacement: [%.17g, 0, 0]}", k > 1 ? ", " : "", t,
                  0.5 * accel * t * t);
    frames += f;
  }
  char yaml[3000];
  std::snprintf(yaml, sizeof yaml,
                "gravity: [0, 0, -9.81]\ntime_step: auto\n"
                "obstacles:\n"
                "  - {name: plate, type: box, size: [2, 0.4, 0.02], position: [0, 0, -0.01],"
                " friction: %.17g, interpolation: smooth, keyframes: [%s]}\n"
                "rods:\n"
                "  - {name: rope, elements: 15, radius: 0.005,"
                " material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3},"
                " shape: {type: straight, start: [0.2, 0, 0.005], direction: [1, 0, 0],"
                " length: 0.3}}\n",
                mu, frames.c_str());
  return parse_scene(yaml);
}

// (b) Below mu g the plate carries the rope along by static friction: its velocity is the
// plate's (a t) to 1e-6 of it from 0.1 s on; above mu g it slides, accelerating at mu g (2%).
TEST(MovingObstacles, RopeOnAcceleratingPlateIsCarriedOrSlides) {
  const double mu = 0.3;
  {
    const double a = 0.5 * mu * kG;
    Scene s = rope_on_plate(a, mu);
    World& w = s.world;
    double worst = 0.0;
    const int steps = static_cast<int>(0.8 / w.time_step);
    for (int k = 0; k < steps; ++k) {
      w.step();
      if (w.time() < 0.1) continue;
      const Vec3 v = mean_velocity(w.rods()[0]);
      // The plate's velocity over the last step (its mean: the rope moved with it through it).
      const double plate = a * (w.time() - 0.5 * w.time_step);
      worst = std::max(worst, (v - Vec3(plate, 0, 0)).norm() / plate);
    }
    std::printf("carried: largest velocity error %.3g of the plate's velocity\n", worst);
    EXPECT_LT(worst, 1e-6);
    EXPECT_LT(w.contacts()->stats().max_penetration, 0.01 * 0.005);
  }
  {
    const double a = 2.0 * mu * kG;
    Scene s = rope_on_plate(a, mu);
    World& w = s.world;
    w.step(static_cast<int>(0.1 / w.time_step));
    const double ta = w.time();
    const Vec3 v0 = mean_velocity(w.rods()[0]);
    w.step(static_cast<int>(0.3 / w.time_step));
    const Vec3 v1 = mean_velocity(w.rods()[0]);
    const double accel = (v1.x() - v0.x()) / (w.time() - ta);
    std::printf("sliding: acceleration %.6g m/s^2 against mu g = %.6g (%+.3g)\n", accel, mu * kG,
                accel / (mu * kG) - 1.0);
    EXPECT_NEAR(accel, mu * kG, 0.02 * mu * kG);
    EXPECT_LT(v1.x(), a * w.time() - 0.1);  // it slid: far slower than the plate
  }
}

// (c) A 10 cm rod lying radially on a turntable (a cylinder, radius 0.5 m, top at z = 0) that
// starts turning at pi/2 rad/s about its axis (keyframed turns, linear): friction brings the rod
// up to the surface's speed within about 0.1 s, then it turns with it, each node's velocity
// omega x p to 1% of the slowest node's speed, the centrifugal pull (0.7 m/s^2) far below mu g.
TEST(MovingObstacles, RodOnTurntableTurnsWithIt) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: auto\n"
      "obstacles:\n"
      "  - {name: turntable, type: cylinder, radius: 0.5, length: 0.02, position: [0, 0, -0.01],"
      " friction: 0.5, interpolation: linear, keyframes: [{time: 4, turns: 1}]}\n"
      "rods:\n"
      "  - {name: rod, elements: 10, radius: 0.005,"
      " material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3},"
      " shape: {type: straight, start: [0.25, 0, 0.005], direction: [1, 0, 0], length: 0.1}}\n");
  World& w = s.world;
  const Rod& rod = w.rods()[0];
  const Vec3 omega(0, 0, 2.0 * kPi / 4.0);
  w.step(static_cast<int>(0.4 / w.time_step));
  const Vec3 c0 = rod.center_of_mass();
  const double ta = w.time();
  double worst = 0.0;
  for (int k = 0; k < static_cast<int>(0.6 / w.time_step); ++k) {
    w.step();
    for (int i = 0; i < rod.num_nodes(); ++i) {
      const Vec3 want = omega.cross(rod.positions()[i]);
      worst = std::max(worst, (rod.velocities()[i] - want).norm() / (omega.norm() * 0.25));
    }
  }
  std::printf("turntable: largest node velocity error %.3g of omega r\n", worst);
  EXPECT_LT(worst, 0.01);
  // Turned about the axis by omega dt, at its radius.
  const Vec3 c1 = rod.center_of_mass();
  const double turned =
      std::atan2(c0.x() * c1.y() - c0.y() * c1.x(), c0.x() * c1.x() + c0.y() * c1.y());
  EXPECT_NEAR(turned, omega.z() * (w.time() - ta), 0.01 * omega.z() * (w.time() - ta));
  EXPECT_NEAR(std::hypot(c1.x(), c1.y()), std::hypot(c0.x(), c0.y()), 1e-3);
}

// A keyframed obstacle is posed at the start of each step with the velocity that takes it to its
// pose at the step's end; after the motion it holds its last pose at rest.
TEST(MovingObstacles, KeyframedPoseAndVelocityPerStep) {
  Scene s = parse_scene(
      "time_step: 1.0e-3\n"
      "obstacles:\n"
      "  - {name: ball, type: sphere, radius: 0.1, position: [1, 2, 3], move_by: [0.5, 0, 0],"
      " ramp_time: 0.5, start_time: 0.1, interpolation: linear}\n"
      "  - {name: floor, type: plane}\n"
      "rods:\n  - {elements: 4, material: soft_cable, shape: {type: straight, start: [0, 0, "
      "5]}}\n");
  World& w = s.world;
  const ObstacleSet& obs = *w.obstacles;
  EXPECT_TRUE(obs.obstacle(0).moving);
  EXPECT_FALSE(obs.obstacle(1).moving);
  ASSERT_EQ(w.obstacle_motions.size(), 1u);
  w.step(300);  // the last step started at 0.299 s
  EXPECT_NEAR(obs.obstacle(0).pose.translation().x(), 1.0 + (0.299 - 0.1), 1e-12);
  EXPECT_NEAR(obs.obstacle(0).linear_velocity.x(), 1.0, 1e-9);
  EXPECT_NEAR(obs.obstacle(0).pose.translation().y(), 2.0, 1e-12);
  w.step(400);
  EXPECT_NEAR(obs.obstacle(0).pose.translation().x(), 1.5, 1e-12);
  EXPECT_EQ(obs.obstacle(0).linear_velocity.norm(), 0.0);
  EXPECT_EQ(obs.obstacle(1).linear_velocity.norm(), 0.0);
}

// A URDF's links move together with its root frame: a turn about the root's z carries a link
// away from the axis on a circle.
TEST(MovingObstacles, UrdfGroupFollowsItsRoot) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("corde_moving_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "arm.urdf") << R"(<robot name="arm">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="tip"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="j" type="fixed"><parent link="base"/><child link="tip"/>
    <origin xyz="0.5 0 0"/></joint>
</robot>)";
  Scene s = parse_scene(
      "time_step: 1.0e-3\n"
      "obstacles:\n"
      "  - {name: robot, urdf: " +
      (dir / "arm.urdf").string() +
      ", position: [0, 0, 1], interpolation: linear, keyframes: [{time: 1, turns: 0.25}]}\n"
      "rods:\n  - {elements: 4, material: soft_cable, shape: {type: straight, start: [0, 0, "
      "5]}}\n");
  fs::remove_all(dir);
  World& w = s.world;
  ASSERT_EQ(w.obstacles->size(), 2);
  EXPECT_EQ(w.obstacle_motions.size(), 2u);
  w.step(1001);  // the last step started at t = 1: a quarter turn
  const Obstacle& tip = w.obstacles->obstacle(1);
  EXPECT_EQ(tip.name, "robot/tip");
  EXPECT_TRUE(tip.moving);
  EXPECT_NEAR((tip.pose.translation() - Vec3(0, 0.5, 1)).norm(), 0.0, 1e-9);
  Scene mid = parse_scene(
      "time_step: 1.0e-3\n"
      "obstacles:\n  - {name: bar, type: box, size: [1, 0.1, 0.1], position: [0, 0, 1],"
      " interpolation: linear, keyframes: [{time: 1, turns: 0.25}]}\n"
      "rods:\n  - {elements: 4, material: soft_cable, shape: {type: straight, start: [0, 0, "
      "5]}}\n");
  mid.world.step(500);  // mid-turn: the angular velocity is the turn's rate
  EXPECT_NEAR(mid.world.obstacles->obstacle(0).angular_velocity.z(), kPi / 2.0, 1e-9);
}

// URDF joints keyframed: the links behind a revolute joint are re-posed by forward kinematics each
// step, with the velocity of their motion (omega x r for a link at r from the joint's axis).
TEST(MovingObstacles, UrdfJointMotionMovesLinks) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("corde_joints_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string urdf = (dir / "arm.urdf").string();
  std::ofstream(urdf) << R"(<robot name="arm">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0.25 0 0"/>
    <geometry><box size="0.5 0.05 0.05"/></geometry></collision></link>
  <link name="tip"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="fixed"><parent link="arm"/><child link="tip"/>
    <origin xyz="0.5 0 0"/></joint>
</robot>)";
  const std::string rods =
      "rods:\n  - {elements: 4, material: soft_cable, shape: {type: straight, start: [0, 0, 5]}}\n";
  Scene s = parse_scene("time_step: 1.0e-3\nobstacles:\n  - {name: robot, urdf: " + urdf +
                        ", position: [0, 0, 1], joints: {shoulder: 0.1}, joint_motion: {shoulder:"
                        " {keyframes: [{time: 1, value: 1.6707963267948966}],"
                        " interpolation: linear}}}\n" +
                        rods);
  World& w = s.world;
  ASSERT_EQ(w.obstacles->size(), 3);
  EXPECT_EQ(w.obstacle_motions.size(), 2u);  // arm and tip; the base does not move
  EXPECT_FALSE(w.obstacles->obstacle(0).moving);
  EXPECT_TRUE(w.obstacles->obstacle(2).moving);
  w.step(500);  // the last step started at 0.499 s: the joint at 0.1 + 0.499 * pi / 2
  const Obstacle& tip = w.obstacles->obstacle(2);
  const double q = 0.1 + 0.499 * kPi / 2.0;
  EXPECT_NEAR((tip.pose.translation() - Vec3(0.5 * std::cos(q), 0.5 * std::sin(q), 1)).norm(), 0,
              1e-9);
  const Vec3 want = Vec3(0, 0, kPi / 2.0).cross(tip.pose.translation() - Vec3(0, 0, 1));
  EXPECT_NEAR((tip.linear_velocity - want).norm(), 0.0, 1e-3 * want.norm());  // chord vs arc
  EXPECT_NEAR(w.obstacles->obstacle(1).angular_velocity.z(), kPi / 2.0, 1e-9);
  w.step(600);
  EXPECT_NEAR((tip.pose.translation() - Vec3(0.5 * std::cos(q + 0.501 * kPi / 2.0),
                                             0.5 * std::sin(q + 0.501 * kPi / 2.0), 1))
                  .norm(),
              0, 1e-9);
  EXPECT_EQ(tip.linear_velocity.norm(), 0.0);
  auto error = [&](const std::string& motion) {
    try {
      parse_scene("obstacles:\n  - {name: robot, urdf: " + urdf + ", joint_motion: " + motion +
                  "}\n" + rods);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("{elbow: {move_by: 1, ramp_time: 1}}").find("joint 'elbow'"), std::string::npos);
  EXPECT_NE(error("{wrist: {move_by: 1, ramp_time: 1}}")
                .find("obstacles[0].joint_motion.wrist: joint 'wrist' is not a revolute"),
            std::string::npos);
  EXPECT_NE(error("{shoulder: {move_by: 1}}").find("obstacles[0].joint_motion.shoulder.ramp_time"),
            std::string::npos);
  EXPECT_NE(error("{shoulder: {keyframes: [{time: 1, angle: 2}]}}")
                .find("obstacles[0].joint_motion.shoulder.keyframes[0].angle: unknown key"),
            std::string::npos);
  EXPECT_NE(error("{shoulder: {keyframes: [{time: 2, value: 1}, {time: 1, value: 0}]}}")
                .find("obstacles[0].joint_motion.shoulder.keyframes: keyframe 1"),
            std::string::npos);
  EXPECT_NE(error("[1, 2]").find("obstacles[0].joint_motion: expected a map"), std::string::npos);
  fs::remove_all(dir);
}

// (d) The shipped scene: a link sweeping at 1 m/s through a cable held by a gripper. The link's
// surface and the cable's never overlap by more than 1% of the cable's radius and the winding
// never jumps; the cable is pushed aside (its end carried more than 0.3 m along), dragged over the
// link and swings back behind it (at the end, every node behind the link and its end swinging
// back past the gripper's x).
TEST(MovingObstacles, GripperSweepScene) {
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/gripper_sweep.yaml");
  World& w = s.world;
  ASSERT_EQ(s.grasps.size(), 1u);
  Rod& cable = w.rod(s.grasps[0].rod);
  const int held = grasp_segment(cable, s.grasps[0]);
  const Eigen::Isometry3d holder = segment_pose(cable, held);
  hold(cable, make_grasp(cable, s.grasps[0], holder), holder);
  const double r = cable.section().radius;
  const double R = 0.04, z = 0.75, x0 = -0.3, t0 = 0.2, t1 = 1.4;
  SweepCheck check;
  double furthest = 0.0, back = INFINITY;
  const int steps = static_cast<int>(s.duration / w.time_step);
  for (int k = 0; k < steps; ++k) {
    w.step();
    ASSERT_TRUE(w.finite()) << "step " << k;
    check.sample(cable, {x0 + std::clamp(w.time() - t0, 0.0, t1 - t0), z, 0.15, R});
    furthest = std::max(furthest, cable.positions().back().x());
    if (w.time() > t1) back = std::min(back, cable.positions().back().x());
  }
  std::printf("gripper_sweep: deepest overlap %.3g of the radius, largest winding jump %.3g rad\n",
              -check.least / r, check.jump);
  EXPECT_GT(check.least, -0.01 * r) << "deepest penetration " << -check.least << " m";
  EXPECT_LT(check.jump, 1.0) << "the cable went through the link";
  EXPECT_GT(check.touching, 100);
  EXPECT_GT(furthest, 0.3);
  const double link_end = x0 + (t1 - t0);
  for (const Vec3& p : cable.positions()) EXPECT_LT(p.x(), link_end - R);
  EXPECT_LT(back, -0.2) << "the cable did not swing back";
}

// (e) Malformed obstacle motions: errors name the key.
TEST(MovingObstacles, SceneKeyErrors) {
  const std::string rods =
      "rods:\n  - {elements: 4, material: soft_cable, shape: {type: straight, start: [0, 0, 5]}}\n";
  auto error = [&](const std::string& obstacle) {
    try {
      parse_scene("obstacles:\n  - " + obstacle + "\n" + rods);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto expect = [&](const std::string& obstacle, const std::string& want) {
    const std::string got = error(obstacle);
    EXPECT_NE(got.find(want), std::string::npos) << "got: " << got << "\nwant: " << want;
  };
  const std::string ball = "{name: b, type: sphere, radius: 0.1, ";
  expect(ball + "keyframes: [{time: 1, position: [0, 0, 1]}, {time: 0.5}]}",
         "obstacles[0].keyframes[1]: times must increase strictly");
  expect(ball + "move_by: [1, 0, 0]}", "obstacles[0].ramp_time: missing");
  expect(ball + "move_by: [1, 0, 0], ramp_time: 0}", "obstacles[0].ramp_time: ");
  expect(ball + "keyframes: [{time: 1, velocity: [1, 0, 0]}]}",
         "obstacles[0].keyframes[0].velocity: unknown key");
  expect(ball + "keyframes: [{time: 1, orientation: [0, 0, 0, 2]}]}",
         "obstacles[0].keyframes[0].orientation: ");
  expect(ball + "keyframes: [], interpolation: linear}",
         "obstacles[0].keyframes: expected a non-empty");
  expect(ball + "keyframes: [{time: 1}], interpolation: cubic}", "obstacles[0].interpolation: ");
  expect(ball + "keyframes: [{time: 1}], move_by: [1, 0, 0]}",
         "obstacles[0].keyframes: give either keyframes or move_by");
  expect(ball + "keyframes: [{time: 1}], moving: false}",
         "obstacles[0].moving: false, but the obstacle is keyframed");
  expect(ball + "start_time: 1}", "obstacles[0].start_time: unknown key");
  expect(ball + "keyframes: {file: no_such_file.csv}}",
         "obstacles[0].keyframes: no_such_file.csv: cannot open the keyframe file");
  expect("{name: robot, urdf: no_such.urdf, keyframes: [{time: 1, turns: 1}], interpolation: x}",
         "obstacles[0].interpolation: ");
}

}  // namespace
}  // namespace corde
