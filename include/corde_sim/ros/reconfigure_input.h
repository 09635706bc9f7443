// dynamic_reconfigure as an input of corde_sim_node (cfg/Node.cfg): its server runs on a queue
// and thread of its own (it writes every parameter to the master, one round trip each, which
// must not stall the loop). Each request is checked against the last accepted values (a value
// that is not finite or out of range is put back, and the server's reply shows the kept one),
// queued as a command and answered once the loop has applied it (command_queue.h).
#pragma once

#include <dynamic_reconfigure/server.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>

#include "corde_sim/NodeConfig.h"
#include "corde_sim/ros/command_queue.h"

namespace corde_sim {

class ReconfigureInput {
 public:
  // Runs in the loop thread with the accepted values.
  using ApplyFn = std::function<void(const NodeConfig&)>;
  // Starts the server on `pnh` from `initial` (the server's first callback, in this thread,
  // queues those values: the caller's next drain of `commands` applies them), then its thread.
  // Callers wait for the loop only while `loop_running` is true.
  ReconfigureInput(const ros::NodeHandle& pnh, const NodeConfig& initial, CommandQueue* commands,
                   const std::atomic<bool>* loop_running, ApplyFn apply);
  // Stops the thread first (close `commands` before, so that a waiting request returns).
  ~ReconfigureInput();

 private:
  void on_request(NodeConfig& c);

  ros::CallbackQueue queue_;
  std::mutex mutex_;
  NodeConfig accepted_;  // the last accepted values (mutex_)
  CommandQueue* commands_;
  const std::atomic<bool>* loop_running_;
  ApplyFn apply_;
  std::unique_ptr<dynamic_reconfigure::Server<NodeConfig>> server_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
};

}  // namespace corde_sim
