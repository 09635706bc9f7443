// A holder sent out of reach stalls at its material's strain limit (issue 24, item 4): the cable
// is never stretched beyond max_strain (within kStrainTolerance), the driver says why, the
// simulation goes on, and a goal within reach moves the holder again.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/simulation/simulation.h"

namespace corde {
namespace {

// Above max_strain the stall allows what the cable's own weight and the dynamics add: 5 % of the
// limit (measured: the default scene's cable stays at 1.986 %, the two grasps' at 1.991 %, of 2 %).
constexpr double kStrainTolerance = 0.05;

std::string scene_path(const std::string& name) {
  return std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/" + name;
}

// Installs the scene's world and holds each of its grasps where its segment is (as the node
// does with a scene grasp that has no script).
void install_scene(Simulation* sim, Scene scene) {
  sim->install(std::move(scene.world));
  for (const GraspSpec& spec : scene.grasps) {
    int rod = -1, seg = -1;
    ASSERT_EQ(sim->grasps().check(sim->world(), spec, &rod, &seg), "");
    const Eigen::Isometry3d pose = segment_pose(sim->world().rods()[rod], seg);
    ASSERT_EQ(sim->grasps().add(sim->world(), spec, pose, nullptr, sim->world().time()), "");
  }
  sim->mark_good();
}

void send(Simulation* sim, const std::string& grasp, const Eigen::Isometry3d& goal) {
  sim->submit(Command::goal(sim->world().time(), grasp, goal, 0.0));
}

Eigen::Isometry3d moved(const Eigen::Isometry3d& pose, const Vec3& by) {
  Eigen::Isometry3d out = pose;
  out.translation() += by;
  return out;
}

// Advances `seconds` step by step; records the largest strain seen after each step and the
// events. Returns false when the guard gave up.
bool run(Simulation* sim, double seconds, double* max_strain,
         std::vector<SimulationEvent>* events) {
  const long steps = std::lround(seconds / sim->world().time_step);
  for (long i = 0; i < steps; ++i) {
    if (!sim->advance(1)) return false;
    for (const Rod& rod : sim->world().rods())
      *max_strain = std::max(*max_strain, rod.max_stretch_strain());
    for (SimulationEvent& e : sim->take_events()) events->push_back(std::move(e));
  }
  return true;
}

long stalls_of(const std::vector<SimulationEvent>& events, const std::string& grasp) {
  long n = 0;
  for (const SimulationEvent& e : events)
    n += e.kind == SimulationEvent::Kind::kStalled && e.grasp == grasp;
  return n;
}

TEST(StrainStall, DefaultSceneGoalFiveMetresAwayStallsTheHolderAtTheLimit) {
  Simulation sim;
  install_scene(&sim, load_scene(scene_path("default.yaml")));
  const double limit = sim.world().rods()[0].section().max_strain;
  ASSERT_GT(limit, 0.0);
  ASSERT_TRUE(sim.advance(100));  // 0.2 s of sag
  const Eigen::Isometry3d start = sim.grasps().find("gripper")->holder.pose();
  // Away from the clamp at (0, 0, 1): 5 m further along x.
  send(&sim, "gripper", moved(start, Vec3(5.0, 0.0, 0.0)));
  double strain = 0.0;
  std::vector<SimulationEvent> events;
  ASSERT_TRUE(run(&sim, 4.0, &strain, &events)) << "the guard gave up";
  EXPECT_LE(strain, limit * (1.0 + kStrainTolerance));
  const GraspState& g = *sim.grasps().find("gripper");
  EXPECT_TRUE(g.stalled);
  EXPECT_LT(g.holder.velocity().norm(), 1e-9);
  EXPECT_LT(g.holder.pose().translation().x(), 1.1);  // it stopped near 1 + limit from the clamp
  EXPECT_EQ(stalls_of(events, "gripper"), 1);
  for (const SimulationEvent& e : events)
    if (e.kind == SimulationEvent::Kind::kStalled) {
      EXPECT_NE(e.text.find("max_strain"), std::string::npos) << e.text;
      EXPECT_NE(e.text.find("'cable'"), std::string::npos) << e.text;
    }
  // The simulation goes on, and a goal within reach moves the holder again.
  send(&sim, "gripper", start);
  ASSERT_TRUE(run(&sim, 2.0, &strain, &events));
  EXPECT_FALSE(sim.grasps().find("gripper")->stalled);
  EXPECT_LT(
      (sim.grasps().find("gripper")->holder.pose().translation() - start.translation()).norm(),
      1e-9);
  EXPECT_LE(strain, limit * (1.0 + kStrainTolerance));
}

// A free cable held at both ends, the holders sent 5 m apart in opposite directions.
TEST(StrainStall, TwoGraspsPullingApartStallAtTheLimit) {
  const char* yaml = R"(time_step: 2.0e-3
integrator: implicit_euler
gravity: [0, 0, -9.81]
rods:
  - name: cable
    elements: 20
    radius: 0.003
    material: soft_cable
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.8}
grasps:
  - {name: left, rod: cable, place: start}
  - {name: right, rod: cable, place: end}
)";
  Simulation sim;
  install_scene(&sim, parse_scene(yaml));
  const double limit = sim.world().rods()[0].section().max_strain;
  ASSERT_GT(limit, 0.0);
  const Eigen::Isometry3d left = sim.grasps().find("left")->holder.pose();
  const Eigen::Isometry3d right = sim.grasps().find("right")->holder.pose();
  send(&sim, "left", moved(left, Vec3(-5.0, 0.0, 0.5)));
  send(&sim, "right", moved(right, Vec3(5.0, 0.0, -0.5)));
  double strain = 0.0;
  std::vector<SimulationEvent> events;
  ASSERT_TRUE(run(&sim, 4.0, &strain, &events)) << "the guard gave up";
  EXPECT_LE(strain, limit * (1.0 + kStrainTolerance));
  EXPECT_GE(stalls_of(events, "left") + stalls_of(events, "right"), 1);
  // Both back towards each other: they move again.
  send(&sim, "left", left);
  send(&sim, "right", right);
  ASSERT_TRUE(run(&sim, 4.0, &strain, &events));
  EXPECT_LT((sim.grasps().find("left")->holder.pose().translation() - left.translation()).norm(),
            1e-9);
  EXPECT_LT((sim.grasps().find("right")->holder.pose().translation() - right.translation()).norm(),
            1e-9);
}

// A goal within reach is reached, with no stall on the way.
TEST(StrainStall, GoalWithinReachIsReached) {
  Simulation sim;
  install_scene(&sim, load_scene(scene_path("default.yaml")));
  const Eigen::Isometry3d start = sim.grasps().find("gripper")->holder.pose();
  const Eigen::Isometry3d goal = moved(start, Vec3(0.2, 0.0, -0.1));  // 0.72 m from the clamp
  send(&sim, "gripper", goal);
  double strain = 0.0;
  std::vector<SimulationEvent> events;
  ASSERT_TRUE(run(&sim, 1.0, &strain, &events));
  EXPECT_LT((sim.grasps().find("gripper")->holder.pose().translation() - goal.translation()).norm(),
            1e-9);
  EXPECT_EQ(stalls_of(events, "gripper"), 0);
}

}  // namespace
}  // namespace corde
