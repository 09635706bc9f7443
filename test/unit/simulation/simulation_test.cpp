// The simulation driver without ROS: commands applied in time order at the step nearest their
// time, replayed after a guard's rollback, configuration that a rollback does not revert, events
// and pause.
#include "corde_sim/simulation/simulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "dynamics_util.h"
#include "grasp_test_util.h"

namespace corde {
namespace {

constexpr double kH = 1e-5;

// The example rod of dynamics_util.h (1 m along x, 10 elements) at z = 1, named "rod", stepped by
// an explicit method.
World example_world() {
  Rod rod = dyn::straight_rod(dyn::example_material(), 0.01, 1.0, 10);
  for (Vec3& x : rod.positions()) x.z() += 1.0;
  World w;
  w.time_step = kH;
  w.integrator = Integrator::kSplitRotation;
  w.add_rod(std::move(rod));
  return w;
}

using corde::test::at_node;

// A guard that checks (and snapshots) every 8 steps.
GuardSettings every_8() {
  GuardSettings g;
  g.check_every = 8;
  return g;
}

// Installs the example world with grasp "g" at its last node, holder where the segment is.
void install_with_grasp(Simulation* sim) {
  sim->install(example_world());
  const Rod& rod = sim->world().rods()[0];
  const Eigen::Isometry3d pose = segment_pose(rod, rod.num_segments() - 1);
  ASSERT_EQ(sim->grasps().add(sim->world(), at_node("g", 10), pose, nullptr, 0.0), "");
  sim->mark_good();
}

// Throws once, from the step that ends at or after world time t: the guard rolls back.
Simulation::StepObserver throw_once_at(double t, bool* thrown) {
  return [t, thrown](const World& w) {
    if (*thrown || w.time() < t - 0.5 * kH) return;
    *thrown = true;
    throw std::runtime_error("injected failure");
  };
}

long count(const std::vector<SimulationEvent>& events, SimulationEvent::Kind kind) {
  long n = 0;
  for (const SimulationEvent& e : events) n += e.kind == kind;
  return n;
}

TEST(Simulation, HolderLimitsChangedAfterTheSnapshotSurviveARollback) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  ASSERT_TRUE(sim.advance(20));  // snapshots at steps 8 and 16
  // A slower holder (as a dynamic_reconfigure change would set), then a goal 1 m away.
  HolderLimits slow = sim.holder_limits();
  slow.max_speed = 0.05;
  sim.set_holder_limits(slow);
  Eigen::Isometry3d goal = sim.grasps().find("g")->holder.pose();
  goal.translation().y() += 1.0;
  sim.submit(Command::goal(sim.world().time(), "g", goal, 0.0));
  // A failure at step 22 sends the world back to step 16, before the change.
  bool thrown = false;
  double fastest = 0.0;
  auto fail = throw_once_at(22 * kH, &thrown);
  sim.set_step_observer([&](const World& w) {
    fail(w);
    fastest = std::max(fastest, sim.grasps().find("g")->holder.velocity().norm());
  });
  ASSERT_TRUE(sim.advance(400));  // at 50 m/s^2 the old 2 m/s limit allows 0.2 m/s by then
  ASSERT_TRUE(thrown);
  EXPECT_GE(sim.guard().rollbacks(), 1);
  EXPECT_EQ(sim.holder_limits().max_speed, 0.05);
  EXPECT_LE(fastest, 0.05 * (1.0 + 1e-9));
  EXPECT_GT(fastest, 0.049);  // it did move, at the new limit
}

TEST(Simulation, CommandsApplyInTimeOrderAtTheNearestStep) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  const Vec3 f0(0.0, 0.0, 1.0), f1(0.0, 2.0, 0.0);
  // Submitted out of order: f1 at 3.2 steps (the step from 3 h), f0 at 1.4 steps (from h).
  sim.submit(Command::wrench(3.2 * kH, "g", f1, Vec3::Zero()));
  sim.submit(Command::wrench(1.4 * kH, "g", f0, Vec3::Zero()));
  EXPECT_EQ(sim.pending_commands(), 2u);
  std::vector<Vec3> force_in_step;  // on the grasped segment's first node, in each step
  sim.set_step_observer([&](const World& w) {
    const Rod& rod = w.rods()[0];
    force_in_step.push_back(rod.has_external() ? rod.external_forces()[10] : Vec3::Zero());
  });
  ASSERT_TRUE(sim.advance(6));
  ASSERT_EQ(force_in_step.size(), 6u);
  for (int k = 0; k < 6; ++k) {
    const Vec3 expected = k < 1 ? Vec3::Zero() : k < 3 ? Vec3(0.5 * f0) : Vec3(0.5 * f1);
    EXPECT_TRUE(force_in_step[k].isApprox(expected) ||
                (expected.isZero() && force_in_step[k].isZero()))
        << "step " << k << ": " << force_in_step[k].transpose();
  }
  EXPECT_EQ(sim.pending_commands(), 0u);
  // A time already past applies before the next step.
  sim.submit(Command::wrench(0.0, "g", Vec3::Zero(), Vec3::Zero()));
  ASSERT_TRUE(sim.advance(1));
  EXPECT_TRUE(force_in_step.back().isZero());
}

TEST(Simulation, AdvanceUntilStopsAtTheNearestStep) {
  Simulation sim(every_8());
  sim.install(example_world());
  ASSERT_TRUE(sim.advance_until(10.4 * kH));
  EXPECT_NEAR(sim.world().time(), 10 * kH, 1e-12);
  ASSERT_TRUE(sim.advance_until(10.6 * kH));
  EXPECT_NEAR(sim.world().time(), 11 * kH, 1e-12);
  ASSERT_TRUE(sim.advance_until(0.0));  // never back
  EXPECT_NEAR(sim.world().time(), 11 * kH, 1e-12);
}

TEST(Simulation, CommandsSinceTheSnapshotAreReplayedAfterARollback) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  ASSERT_TRUE(sim.advance(16));  // snapshot at step 16
  const Vec3 f(0.0, 0.0, 0.5);
  sim.submit(Command::wrench(18 * kH, "g", f, Vec3::Zero()));
  Eigen::Isometry3d goal = sim.grasps().find("g")->holder.pose();
  goal.translation().y() += 0.01;
  sim.submit(Command::goal(19 * kH, "g", goal, 1e-3));
  bool thrown = false;
  sim.set_step_observer(throw_once_at(21 * kH, &thrown));
  ASSERT_TRUE(sim.advance(8));
  ASSERT_TRUE(thrown);
  ASSERT_GE(sim.guard().rollbacks(), 1);
  EXPECT_NEAR(sim.world().time(), 24 * kH, 1e-12);
  // The world went back to step 16 (no wrench, holder at rest) and the replay applied both again.
  const Rod& rod = sim.world().rods()[0];
  ASSERT_TRUE(rod.has_external());
  EXPECT_TRUE(rod.external_forces()[10].isApprox(0.5 * f));
  EXPECT_TRUE(sim.grasps().find("g")->holder.goal().isApprox(goal));
  EXPECT_TRUE(sim.grasps().find("g")->holder.moving());
  const std::vector<SimulationEvent> events = sim.take_events();
  ASSERT_GE(count(events, SimulationEvent::Kind::kGuard), 1);
  EXPECT_NE(events.front().text.find("injected failure"), std::string::npos) << events.front().text;
  EXPECT_TRUE(sim.take_events().empty());  // taken
}

// Goals since the snapshot survive a rollback that the state checks ask for: two goals sent to
// the rostests' rope's grasp, then a NaN put into the rope once (as a blow-up would) sends the
// world back to before both. The driver applies them again at their times and the rope ends where
// the last goal put it; the grasps alone, as restored, would have forgotten them (frames_errors
// rostest: the rope stayed where it was).
TEST(Simulation, GoalsSinceTheSnapshotSurviveARollbackFromANonFiniteState) {
  const Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/test/ros/scenes/rope.yaml");
  Simulation sim;
  sim.install(s.world);
  const GraspSpec& spec = s.grasps.at(0);
  int rod = 0, seg = 0;
  ASSERT_EQ(sim.grasps().check(sim.world(), spec, &rod, &seg), "");
  const Eigen::Isometry3d start = segment_pose(sim.world().rods()[rod], seg);
  ASSERT_EQ(sim.grasps().add(sim.world(), spec, start, nullptr, sim.world().time()), "");
  sim.mark_good();
  bool faulted = false;
  sim.set_obstacle_mover([&faulted](World* w, double) {
    if (faulted || w->time() < 0.01) return;
    faulted = true;
    w->rods()[0].velocities()[3].x() = std::nan("");
  });
  Eigen::Isometry3d goal = start;
  ASSERT_TRUE(sim.advance(2));
  goal.translation() = Vec3(0.45, 0.0, 1.0);
  sim.submit(Command::goal(sim.world().time(), spec.name, goal, 0.05));
  ASSERT_TRUE(sim.advance(18));
  goal.translation() = Vec3(0.4, 0.0, 1.02);
  sim.submit(Command::goal(sim.world().time(), spec.name, goal, 0.05));
  ASSERT_TRUE(sim.advance(2000));
  ASSERT_TRUE(faulted);
  ASSERT_FALSE(sim.guard().events().empty());
  EXPECT_EQ(sim.guard().events().front().kind, GuardEvent::Kind::kNonFinite);
  EXPECT_EQ(sim.guard().events().front().rollback_to, 0.0);
  const Vec3 end = segment_pose(sim.world().rods()[rod], seg).translation();
  EXPECT_LT((end - goal.translation()).norm(), 1e-6) << end.transpose();
}

TEST(Simulation, QueueStaysBoundedWhileTimeStandsStill) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  Eigen::Isometry3d pose = sim.grasps().find("g")->holder.pose();
  for (int i = 0; i < 100; ++i) {
    pose.translation().y() += 1e-4;
    sim.submit(Command::goal(sim.world().time(), "g", pose, 0.01));
    sim.submit(Command::twist_rate(sim.world().time(), "g", 0.1 * i));
  }
  EXPECT_EQ(sim.pending_commands(), 2u);  // the last goal and the last rate
  // A goal of zero duration replaces every goal at its time; one of nonzero duration after it
  // starts from it, so both stay.
  for (int i = 0; i < 10; ++i) {
    sim.submit(Command::goal(sim.world().time(), "g", pose, 0.0));
    sim.submit(Command::goal(sim.world().time(), "g", pose, 0.01));
  }
  EXPECT_EQ(sim.pending_commands(), 3u);
  // At another time they accumulate, as the steps need them.
  sim.submit(Command::goal(sim.world().time() + 5 * kH, "g", pose, 0.01));
  EXPECT_EQ(sim.pending_commands(), 4u);
  ASSERT_TRUE(sim.advance(1));
  EXPECT_EQ(sim.pending_commands(), 1u);
  EXPECT_TRUE(sim.grasps().find("g")->holder.goal().isApprox(pose));
  EXPECT_EQ(sim.grasps().find("g")->twist_rate, 9.9);
}

TEST(Simulation, ExactScriptTakesHoldAndLetsGoAtItsTimes) {
  Simulation sim(every_8());
  sim.install(example_world());
  GraspSpec spec = at_node("script", 10);
  spec.grasp_time = 5 * kH;
  spec.release_time = 9 * kH;
  sim.add_script(spec, ScriptDrive::kExact);
  EXPECT_TRUE(sim.waiting_to_take_hold("script"));
  EXPECT_TRUE(sim.grasps().empty());  // exact scripts hold without a holder
  std::vector<bool> held;
  sim.set_step_observer(
      [&](const World& w) { held.push_back(w.rods()[0].node_drive(10) != nullptr); });
  ASSERT_TRUE(sim.advance(12));
  const std::vector<bool> expected = {false, false, false, false, false, true,
                                      true,  true,  true,  false, false, false};
  EXPECT_EQ(held, expected);
  const std::vector<SimulationEvent> events = sim.take_events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, SimulationEvent::Kind::kTookHold);
  EXPECT_NEAR(events[0].time, 5 * kH, 1e-12);
  EXPECT_EQ(events[1].kind, SimulationEvent::Kind::kLetGo);
  EXPECT_NEAR(events[1].time, 9 * kH, 1e-12);
}

TEST(Simulation, GoalInputEndsAHolderScript) {
  Simulation sim(every_8());
  sim.install(example_world());
  const Rod& rod = sim.world().rods()[0];
  GraspSpec spec = at_node("g", 10);
  spec.release_time = 1.0;
  ASSERT_EQ(sim.grasps().add(sim.world(), spec, segment_pose(rod, 9), nullptr, 0.0), "");
  sim.add_script(spec, ScriptDrive::kHolder);
  EXPECT_TRUE(sim.scripted("g"));
  ASSERT_TRUE(sim.advance(3));
  sim.submit(Command::goal(sim.world().time(), "g", sim.grasps().find("g")->holder.pose(), 0.0));
  ASSERT_TRUE(sim.advance(1));
  EXPECT_FALSE(sim.scripted("g"));
  const std::vector<SimulationEvent> events = sim.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, SimulationEvent::Kind::kScriptEnded);
  EXPECT_EQ(events[0].grasp, "g");
  // A release command lets go.
  sim.submit(Command::release(sim.world().time(), "g"));
  ASSERT_TRUE(sim.advance(1));
  EXPECT_FALSE(sim.grasps().find("g")->held);
  EXPECT_EQ(count(sim.take_events(), SimulationEvent::Kind::kLetGo), 1);
}

// The node's ~release: a wrench and a release submitted at the world's time and applied at once,
// in that order; a rollback to an older snapshot replays both, and the grasp stays released.
TEST(Simulation, CommandsAppliedAtOnceAreReplayedAfterARollback) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  ASSERT_TRUE(sim.advance(20));  // snapshot at step 16
  const Vec3 f(0.0, 0.0, 0.5);
  sim.submit(Command::wrench(sim.world().time(), "g", f, Vec3::Zero()));
  sim.submit(Command::release(sim.world().time(), "g"));
  sim.apply_due();
  EXPECT_EQ(sim.pending_commands(), 0u);
  EXPECT_FALSE(sim.grasps().find("g")->held);
  EXPECT_TRUE(sim.grasps().find("g")->force.isApprox(f));
  EXPECT_EQ(count(sim.take_events(), SimulationEvent::Kind::kLetGo), 1);
  bool thrown = false;
  sim.set_step_observer(throw_once_at(22 * kH, &thrown));
  ASSERT_TRUE(sim.advance(8));
  ASSERT_TRUE(thrown);
  ASSERT_GE(sim.guard().rollbacks(), 1);
  EXPECT_NEAR(sim.world().time(), 28 * kH, 1e-12);
  // Back at step 16 the grasp held again; the replay let go at step 20 and the wrench acts.
  EXPECT_FALSE(sim.grasps().find("g")->held);
  EXPECT_TRUE(sim.grasps().find("g")->force.isApprox(f));
  const Rod& rod = sim.world().rods()[0];
  ASSERT_TRUE(rod.has_external());
  EXPECT_TRUE(rod.external_forces()[10].isApprox(0.5 * f));
  EXPECT_EQ(count(sim.take_events(), SimulationEvent::Kind::kLetGo), 0);  // reported once
}

// A command of a later time waits for its step.
TEST(Simulation, ApplyDueLeavesLaterCommandsWaiting) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  sim.submit(Command::release(3 * kH, "g"));
  sim.apply_due();
  EXPECT_TRUE(sim.grasps().find("g")->held);
  EXPECT_EQ(sim.pending_commands(), 1u);
  ASSERT_TRUE(sim.advance(3));
  EXPECT_TRUE(sim.grasps().find("g")->held);
  ASSERT_TRUE(sim.advance(1));
  EXPECT_FALSE(sim.grasps().find("g")->held);
}

TEST(Simulation, PausedRunsOnlyQueuedSteps) {
  Simulation sim(every_8());
  install_with_grasp(&sim);
  sim.set_paused(true);
  ASSERT_TRUE(sim.advance(100));
  EXPECT_EQ(sim.world().time(), 0.0);
  const Vec3 f(0.0, 0.0, 1.0);
  sim.submit(Command::wrench(0.0, "g", f, Vec3::Zero()));  // waits while paused
  EXPECT_EQ(sim.pending_commands(), 1u);
  sim.queue_steps(3);
  ASSERT_TRUE(sim.advance(100));
  EXPECT_NEAR(sim.world().time(), 3 * kH, 1e-12);
  EXPECT_EQ(sim.queued_steps(), 0);
  EXPECT_TRUE(sim.world().rods()[0].external_forces()[10].isApprox(0.5 * f));
  sim.queue_steps(5);
  ASSERT_TRUE(sim.advance(2));
  EXPECT_EQ(sim.queued_steps(), 3);
  sim.set_paused(false);  // resuming drops the queued steps
  EXPECT_EQ(sim.queued_steps(), 0);
  ASSERT_TRUE(sim.advance(4));
  EXPECT_NEAR(sim.world().time(), 9 * kH, 1e-12);
  sim.set_paused(true);
  sim.queue_steps(4);
  EXPECT_EQ(sim.drop_queued_steps(), 4);
  EXPECT_EQ(sim.queued_steps(), 0);
  ASSERT_TRUE(sim.advance(4));
  EXPECT_NEAR(sim.world().time(), 9 * kH, 1e-12);
}

}  // namespace
}  // namespace corde
