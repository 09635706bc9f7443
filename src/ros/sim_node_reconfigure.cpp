// SimNode: parameters changed while the node runs (dynamic_reconfigure, cfg/Node.cfg).
#include <cmath>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {
namespace {

// dynamic_reconfigure clamps values to the ranges of cfg/Node.cfg, but a NaN passes its clamp:
// a value that is not finite or outside [lo, hi] is put back to `previous` (the server's reply
// then shows the kept value) and the warning returned ("" when the value is used).
std::string keep_if_bad(const char* name, double* value, double previous, double lo, double hi) {
  if (std::isfinite(*value) && *value >= lo && *value <= hi) return "";
  const std::string w = std::string(name) + " " + num(*value) + " refused (must be finite, in [" +
                        num(lo) + ", " + num(hi) + "]); kept " + num(previous);
  *value = previous;
  return w;
}

}  // namespace

void SimNode::on_reconfigure(NodeConfig& c, uint32_t /*level*/) {
  const NodeConfig& lo = NodeConfig::__getMin__();
  const NodeConfig& hi = NodeConfig::__getMax__();
  std::lock_guard<std::mutex> lock(reconfigure_mutex_);
  const NodeConfig& last = reconfigure_accepted_;
  std::vector<std::string> refused = {
      keep_if_bad("real_time_factor", &c.real_time_factor, last.real_time_factor,
                  lo.real_time_factor, hi.real_time_factor),
      keep_if_bad("tf_rate", &c.tf_rate, last.tf_rate, lo.tf_rate, hi.tf_rate),
      keep_if_bad("marker_rate", &c.marker_rate, last.marker_rate, lo.marker_rate, hi.marker_rate),
      keep_if_bad("state_rate", &c.state_rate, last.state_rate, lo.state_rate, hi.state_rate),
      keep_if_bad("marker_min_diameter", &c.marker_min_diameter, last.marker_min_diameter,
                  lo.marker_min_diameter, hi.marker_min_diameter),
      keep_if_bad("holder_max_speed", &c.holder_max_speed, last.holder_max_speed,
                  lo.holder_max_speed, hi.holder_max_speed),
      keep_if_bad("holder_max_acceleration", &c.holder_max_acceleration,
                  last.holder_max_acceleration, lo.holder_max_acceleration,
                  hi.holder_max_acceleration)};
  if (c.marker_style != "cylinders" && c.marker_style != "line_strip") {
    refused.push_back("marker_style '" + clip(c.marker_style) +
                      "' refused (cylinders or line_strip); kept " + last.marker_style);
    c.marker_style = last.marker_style;
  }
  for (const std::string& w : refused)
    if (!w.empty()) ROS_WARN("corde_sim: reconfigure: %s", w.c_str());
  reconfigure_accepted_ = c;
  reconfigure_pending_ = true;
}

void SimNode::apply_reconfigure() {
  NodeConfig c;
  {
    std::lock_guard<std::mutex> lock(reconfigure_mutex_);
    if (!reconfigure_pending_) return;
    reconfigure_pending_ = false;
    c = reconfigure_accepted_;
  }
  if (c.real_time_factor != params_.real_time_factor) {
    params_.real_time_factor = c.real_time_factor;
    pacer_.reset(c.real_time_factor, sim_time(), wall_seconds());  // no backlog, no jump
  }
  params_.tf_rate = c.tf_rate;
  params_.marker_rate = c.marker_rate;
  params_.state_rate = c.state_rate;
  schedule_.set_rate(OutputSchedule::kTf, c.tf_rate);
  schedule_.set_rate(OutputSchedule::kMarkers, c.marker_rate);
  schedule_.set_rate(OutputSchedule::kState, c.state_rate > 0.0 ? c.state_rate : 2.0);
  const MarkerStyle style =
      c.marker_style == "line_strip" ? MarkerStyle::kLineStrip : MarkerStyle::kCylinders;
  if (style != params_.marker_style || c.show_frames != params_.show_frames)
    markers_clear_ = true;  // the old style's markers go
  params_.marker_style = style;
  params_.show_frames = c.show_frames;
  params_.color_by_strain = c.color_by_strain;
  params_.marker_min_diameter = c.marker_min_diameter;
  params_.holder_max_speed = c.holder_max_speed;
  params_.holder_max_acceleration = c.holder_max_acceleration;
  corde::HolderLimits limits = sim_.holder_limits();  // configuration: never rolled back
  limits.max_speed = c.holder_max_speed;
  limits.max_acceleration = c.holder_max_acceleration;
  sim_.set_holder_limits(limits);
  ROS_INFO(
      "corde_sim: reconfigured: real_time_factor %g, tf/marker/state rates %g/%g/%g Hz, markers "
      "%s%s, holder limits %g m/s, %g m/s^2",
      c.real_time_factor, c.tf_rate, c.marker_rate, c.state_rate, c.marker_style.c_str(),
      c.show_frames ? " with frames" : "", c.holder_max_speed, c.holder_max_acceleration);
}

}  // namespace corde_sim
