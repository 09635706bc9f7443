// corde_sim_node's private services: ~reset, ~configure, ~pause, ~step, ~grasp, ~release,
// ~list_grasps, ~set_grip. Each callback runs on a service thread (ServiceThreads) and waits until
// the loop has applied its command (command_queue.h); only what needs no simulation state (reading
// a scene, a trial step of a copy) runs on the service thread, so the loop keeps its output rates.
#pragma once

#include <ros/ros.h>
#include <std_srvs/SetBool.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "corde_sim/Configure.h"
#include "corde_sim/Grasp.h"
#include "corde_sim/ListGrasps.h"
#include "corde_sim/Release.h"
#include "corde_sim/Reset.h"
#include "corde_sim/SetGrip.h"
#include "corde_sim/Step.h"
#include "corde_sim/ros/command_queue.h"
#include "corde_sim/ros/configure.h"
#include "corde_sim/ros/service_threads.h"
#include "corde_sim/world/world.h"

namespace corde_sim {

class SimNode;

class NodeServices {
 public:
  explicit NodeServices(SimNode* node) : node_(*node) {}
  // Offers the services on the node's private handle; requests wait until start().
  void advertise(const ros::NodeHandle& pnh);
  void start(int threads) { threads_->start(threads); }
  // Waits for the requests being served (close() their waiting ~step first), then ends.
  void stop() {
    if (threads_) threads_->stop();
  }
  // (loop) The waiting ~step call, if any, returns: the node shuts down.
  void close();
  // (loop) Answers the waiting ~step call once its steps are run, dropped, stopped by the guard,
  // or kStepCallSeconds have passed (the rest then stays queued).
  void answer_step_call(double now);
  bool step_call_waiting() const { return static_cast<bool>(step_call_); }

 private:
  // Runs `fn` in the loop thread and waits (a service thread); false when the node shuts down.
  bool in_loop(const std::function<void()>& fn);
  bool on_reset(Reset::Request& req, Reset::Response& res);
  bool on_configure(Configure::Request& req, Configure::Response& res);
  void reset(Reset::Request& req, Reset::Response& res);
  void configure(Configure::Request& req, Configure::Response& res);
  // (loop) The request applied to a copy of the world: "" or why it cannot be.
  std::string configured_copy(const Configure::Request& req, corde::World* world,
                              SimSettings* settings, std::vector<std::string>* resample,
                              std::string* summary) const;
  // "" or, while the guard has given up, what a refused ~reset or ~configure adds to its reply.
  std::string stopped_note() const;
  bool on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  void pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool on_step(Step::Request& req, Step::Response& res);
  // (loop) Queues the steps of a ~step request; its reply is set by answer_step_call().
  void start_step_call(const Step::Request& req, Step::Response* res, const ReplyPtr& reply);
  bool on_grasp(Grasp::Request& req, Grasp::Response& res);
  bool grasp(Grasp::Request& req, Grasp::Response& res);  // on_grasp before bounding the reply
  bool on_release(Release::Request& req, Release::Response& res);
  void release(Release::Request& req, Release::Response& res);
  bool on_list_grasps(ListGrasps::Request& req, ListGrasps::Response& res);
  void list_grasps(ListGrasps::Response& res) const;
  // ~set_grip (grip_input.cpp).
  bool on_set_grip(SetGrip::Request& req, SetGrip::Response& res);
  void set_grip(SetGrip::Request& req, SetGrip::Response& res);

  SimNode& node_;
  std::unique_ptr<ServiceThreads> threads_;  // stopped in ~SimNode, after close()
  // The ~step call waiting for its steps (loop thread only).
  struct StepCall {
    ReplyPtr reply;
    Step::Response* res = nullptr;
    long requested = 0, steps_before = 0;
    int detections_before = 0;
    double answer_by = 0.0;  // steady-clock s
  };
  std::unique_ptr<StepCall> step_call_;
};

}  // namespace corde_sim
