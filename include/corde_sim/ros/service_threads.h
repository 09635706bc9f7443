// The node's services on a callback queue of their own, served by threads of their own, so that
// a request waiting for the loop (command_queue.h) or reading a scene never holds the loop.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include <memory>
#include <string>
#include <vector>

namespace corde_sim {

class ServiceThreads {
 public:
  explicit ServiceThreads(const ros::NodeHandle& nh) : nh_(nh) { nh_.setCallbackQueue(&queue_); }
  ~ServiceThreads() { stop(); }

  // Offers service `name` (relative to the node handle) served by obj->*fn.
  template <class T, class Req, class Res>
  void advertise(const std::string& name, bool (T::*fn)(Req&, Res&), T* obj) {
    servers_.push_back(nh_.advertiseService(name, fn, obj));
  }
  // Starts serving; requests that came before wait until then.
  void start(int threads) {
    spinner_ = std::make_unique<ros::AsyncSpinner>(threads, &queue_);
    spinner_->start();
  }
  // Waits for the requests being served (release whatever they wait for first), then ends.
  void stop() {
    if (spinner_) spinner_->stop();
    servers_.clear();
  }

 private:
  ros::CallbackQueue queue_;
  ros::NodeHandle nh_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  std::vector<ros::ServiceServer> servers_;
};

}  // namespace corde_sim
