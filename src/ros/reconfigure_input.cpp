// ReconfigureInput: dynamic_reconfigure requests checked and queued for the loop.
#include "corde_sim/ros/reconfigure_input.h"

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/scene/key_ranges.h"

namespace corde_sim {
namespace {

// dynamic_reconfigure clamps values to the ranges of cfg/Node.cfg (equal to the library's table,
// scene/key_ranges.h), but a NaN passes its clamp: a value that is not finite or outside the
// table's [lo, hi] is put back to `previous` (the server's reply then shows the kept value) and
// the warning returned ("" when the value is used).
std::string keep_if_bad(const char* name, double* value, double previous) {
  const corde::KeyRange& range = *corde::find_key_range(name);
  const double lo = range.min, hi = range.max;
  if (std::isfinite(*value) && *value >= lo && *value <= hi) return "";
  const std::string w = std::string(name) + " " + num(*value) + " refused (must be finite, in [" +
                        num(lo) + ", " + num(hi) + "]); kept " + num(previous);
  *value = previous;
  return w;
}

}  // namespace

ReconfigureInput::ReconfigureInput(const ros::NodeHandle& pnh, const NodeConfig& initial,
                                   CommandQueue* commands, const std::atomic<bool>* loop_running,
                                   ApplyFn apply)
    : accepted_(initial),
      commands_(commands),
      loop_running_(loop_running),
      apply_(std::move(apply)) {
  ros::NodeHandle nh(pnh);
  nh.setCallbackQueue(&queue_);
  server_ = std::make_unique<dynamic_reconfigure::Server<NodeConfig>>(nh);
  server_->setCallback([this](NodeConfig& c, uint32_t /*level*/) { on_request(c); });
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

ReconfigureInput::~ReconfigureInput() {
  spinner_->stop();
  server_.reset();
}

void ReconfigureInput::on_request(NodeConfig& c) {
  std::unique_lock<std::mutex> lock(mutex_);
  const NodeConfig& last = accepted_;
  std::vector<std::string> refused = {
      keep_if_bad("real_time_factor", &c.real_time_factor, last.real_time_factor),
      keep_if_bad("tf_rate", &c.tf_rate, last.tf_rate),
      keep_if_bad("marker_rate", &c.marker_rate, last.marker_rate),
      keep_if_bad("state_rate", &c.state_rate, last.state_rate),
      keep_if_bad("marker_min_diameter", &c.marker_min_diameter, last.marker_min_diameter),
      keep_if_bad("holder_max_speed", &c.holder_max_speed, last.holder_max_speed),
      keep_if_bad("holder_max_acceleration", &c.holder_max_acceleration,
                  last.holder_max_acceleration)};
  if (c.marker_style != "cylinders" && c.marker_style != "line_strip") {
    refused.push_back("marker_style '" + clip(c.marker_style) +
                      "' refused (cylinders or line_strip); kept " + last.marker_style);
    c.marker_style = last.marker_style;
  }
  for (const std::string& w : refused)
    if (!w.empty()) ROS_WARN("corde_sim: reconfigure: %s", w.c_str());
  accepted_ = c;
  lock.unlock();
  // Applied by the loop; the server replies once it is (at start-up, in the constructor's thread,
  // it is applied by the caller's next drain).
  auto apply = [this, accepted = c](const ReplyPtr& reply) {
    apply_(accepted);
    if (reply) reply->set();
  };
  if (*loop_running_)
    commands_->call(apply);
  else
    commands_->post(apply);
}

}  // namespace corde_sim
