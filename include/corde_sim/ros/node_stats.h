// What corde_sim_node measures and reports about itself: step statistics, the guard's events, the
// strain and stability notes. Written by the loop (SimNode, NodeOutputs), read by the outputs and
// the service replies; loop thread only. No ROS here.
#pragma once

#include <string>

namespace corde_sim {

struct NodeStats {
  // Steps, and what the state rate renews (NodeOutputs::update_stats).
  unsigned long steps_total = 0;
  long steps_since_stats = 0, substeps_per_publish = 0, steps_last_iteration = 0;
  double step_wall_since_stats = 0.0;
  double step_cpu_total = 0.0;  // thread CPU time spent in SimNode::run_steps (s)
  double sim_at_stats = 0.0, wall_at_stats = 0.0;
  double step_time_us = 0.0, measured_rtf = 0.0;
  bool lagging = false, rtf_initialised = false;
  // The time model: backlogs dropped (stamps re-anchored), the last /clock jump (for one report).
  long backlog_drops = 0, backlog_drops_reported = 0;
  std::string clock_note;
  // The stability guard: detections (all recovered or not), and its last event.
  int recoveries = 0, recoveries_reported = 0;
  std::string last_problem;
  std::string strain_warning;     // rod strained beyond its max_strain (for diagnostics)
  double stability_margin = 0.0;  // h / h_crit, largest over rods
  std::string limiting_rod;
};

}  // namespace corde_sim
