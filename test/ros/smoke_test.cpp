// Smoke test of corde_sim_node on the default scene (see smoke.test).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/SetBool.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>

#include "corde_sim/Configure.h"
#include "corde_sim/Reset.h"
#include "corde_sim/Step.h"
#include "corde_sim/WorldState.h"

namespace {

std::string sim_ns() {
  std::string ns = "/sim";
  ros::param::get("~sim", ns);
  return ns;
}

corde_sim::WorldStateConstPtr wait_state(double timeout) {
  return ros::topic::waitForMessage<corde_sim::WorldState>("/rod_state", ros::Duration(timeout));
}

TEST(Smoke, PublishesFiniteState) {
  auto s = wait_state(20.0);
  ASSERT_TRUE(s) << "no rod_state within 20 s";
  EXPECT_EQ(s->header.frame_id, "world");
  ASSERT_EQ(s->rods.size(), 1u);
  EXPECT_EQ(s->rods[0].name, "cable");
  EXPECT_EQ(s->rods[0].nodes.size(), s->rods[0].orientations.size() + 1);
  for (const auto& p : s->rods[0].nodes)
    EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
  // The first state may be the initial one (t = 0: with the default scene's 2 ms steps the first
  // loop iteration can come before the first step is due); the clock must then move on.
  auto later = s;
  for (int i = 0; i < 50 && later && later->sim_time <= s->sim_time; ++i) later = wait_state(5.0);
  ASSERT_TRUE(later) << "no rod_state after the first";
  EXPECT_GT(later->sim_time, s->sim_time);
}

TEST(Smoke, PublishesSegmentFrames) {
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  EXPECT_TRUE(buffer.canTransform("world", "cable/seg_0", ros::Time(0), ros::Duration(10.0)));
  EXPECT_TRUE(buffer.canTransform("world", "grasp/gripper", ros::Time(0), ros::Duration(5.0)));
}

TEST(Smoke, PauseStepResetConfigure) {
  const std::string ns = sim_ns();
  ASSERT_TRUE(ros::service::waitForService(ns + "/pause", ros::Duration(20.0)));
  std_srvs::SetBool pause;
  pause.request.data = true;
  ASSERT_TRUE(ros::service::call(ns + "/pause", pause));
  EXPECT_TRUE(pause.response.success);

  corde_sim::Step step;
  step.request.steps = 100;
  ASSERT_TRUE(ros::service::call(ns + "/step", step));
  ASSERT_TRUE(step.response.success) << step.response.message;
  const double t1 = step.response.time;
  ASSERT_TRUE(ros::service::call(ns + "/step", step));
  const double t2 = step.response.time;
  auto s = wait_state(5.0);
  ASSERT_TRUE(s);
  EXPECT_NEAR(t2 - t1, 100 * s->time_step, 1e-9);  // paused: exactly the requested steps
  EXPECT_TRUE(s->paused);

  corde_sim::Reset reset;
  ASSERT_TRUE(ros::service::call(ns + "/reset", reset));
  EXPECT_TRUE(reset.response.success) << reset.response.message;
  ASSERT_TRUE(ros::service::call(ns + "/step", step));
  EXPECT_GT(step.response.time, t2);  // the clock did not go back

  corde_sim::Configure bad;
  bad.request.keys = {"E"};
  bad.request.values = {-1.0};
  ASSERT_TRUE(ros::service::call(ns + "/configure", bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("E"), std::string::npos) << bad.response.message;

  pause.request.data = false;
  ASSERT_TRUE(ros::service::call(ns + "/pause", pause));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "smoke_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
