// corde_sim_node's outputs and their schedule: /tf, markers with the rods' paths and poses,
// rod_state, the grasps' reactions, /clock, /diagnostics and the console status line, each
// published from the checked state when due on its own wall-clock rate (OutputSchedule), stamped
// with its simulation time. Loop thread only; it reads the simulation, never changes it.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <memory>
#include <string>
#include <vector>

#include "corde_sim/ros/output_schedule.h"
#include "corde_sim/ros/outputs.h"
#include "corde_sim/world/world.h"

namespace corde_sim {

class SimNode;

class NodeOutputs {
 public:
  explicit NodeOutputs(SimNode* node) : node_(*node) {}
  // Advertises the topics (before the first layout).
  void advertise();
  // Diagnostics on their own updater (after the first reconfigure request).
  void start_diagnostics();
  OutputSchedule& schedule() { return schedule_; }
  // The loop's outputs after its steps: what is due at `now`, diagnostics, the status line.
  void publish_due(double now);
  void update_diagnostics(double now);
  // The held grasps or the rods changed: frames and markers follow, the stability estimate too.
  void refresh_layout();
  // The markers start over (a new style): the old ones go with the next array.
  void clear_markers() { markers_clear_ = true; }
  // After each step (inside the guard): the contacts for rod_state and the diagnostics.
  void watch_contacts(const corde::World& world);
  void update_stability();
  // "h/h_crit ..." or "no explicit step limit", for the log and replies.
  std::string margin_text() const;
  void log_status() const;

 private:
  void publish_reactions();
  void publish_tf();
  void send_tf_to(const ros::SingleSubscriberPublisher& pub);
  void publish_markers();
  void publish_paths();  // rods/<rod>/path and rods/<rod>/poses, at the marker rate
  void publish_state();
  void publish_cloud();  // surface_cloud, while someone subscribes (cloud_output.cpp)
  void publish_clock();
  void update_stats(double now);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  std::vector<GraspView> grasp_views() const;

  SimNode& node_;
  ros::Publisher tf_pub_, marker_pub_, state_pub_, clock_pub_;
  ros::Publisher cloud_pub_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  TfFrames tf_frames_;
  RodPaths rod_paths_;
  bool markers_clear_ = true;
  int contact_arrows_ = 0;  // contact force arrows in the last marker array (to delete stale ones)
  double last_clock_ = -1.0, last_tf_time_ = -1.0;
  // Output deadlines (steady-clock seconds).
  OutputSchedule schedule_;
  double next_status_ = 0.0;
  // Contacts for rod_state: the largest penetration over the steps since the last message.
  double max_penetration_since_state_ = 0.0;
  // And the deepest contact beyond deep_penetration (in radii, and its report), also for a
  // throttled warning and the diagnostics.
  double deepest_ratio_since_state_ = 0.0;
  std::string deepest_contact_since_state_;
  std::string deep_contact_warning_;
};

}  // namespace corde_sim
