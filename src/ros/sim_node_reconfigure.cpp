// SimNode: parameters changed while the node runs (dynamic_reconfigure, cfg/Node.cfg), applied
// in the loop (ReconfigureInput queues them).
#include "corde_sim/ros/sim_node.h"

namespace corde_sim {

void SimNode::apply_reconfigure(const NodeConfig& c) {
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
