// NodeOutputs: the node's topics out (tf, markers, paths, rod_state, reactions, /clock), its
// diagnostics and status line, each when due on its own rate (node_outputs.h).
#include "corde_sim/ros/node_outputs.h"

#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Float64.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include "corde_sim/WorldState.h"
#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde_sim {

void NodeOutputs::advertise() {
  ros::NodeHandle& nh = node_.nh_;
  const NodeParams& params = node_.params_;
  // A listener that connects while the simulation is paused would otherwise see no frames until
  // it resumes (frames are sent once per stamp): it alone gets the current ones.
  tf_pub_ = nh.advertise<tf2_msgs::TFMessage>(
      "/tf", 100, [this](const ros::SingleSubscriberPublisher& pub) { send_tf_to(pub); });
  marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 1);
  tf_frames_.set_node_frames(params.node_frames);  // before the first layout
  state_pub_ = nh.advertise<WorldState>("rod_state", 10);
  if (params.publish_clock) clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("surface_cloud", 1);
  schedule_.set_rate(OutputSchedule::kCloud, params.cloud_rate);
}

void NodeOutputs::start_diagnostics() {
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(node_.nh_, node_.pnh_);
  diagnostics_->setHardwareID("corde_sim");
  diagnostics_->add("simulation", this, &NodeOutputs::diagnose);
}

void NodeOutputs::update_diagnostics(double now) {
  diagnostics_->update();
  if (node_.params_.status_period > 0.0 && now >= next_status_) {
    if (next_status_ > 0.0) log_status();  // none at start: nothing has run yet
    next_status_ = now + node_.params_.status_period;
  }
}

std::string NodeOutputs::margin_text() const {
  // The explicit limit means nothing to the implicit method: saying 0 would read as a margin.
  if (!corde::has_explicit_step_limit(node_.world_.integrator)) return "no explicit step limit";
  char buf[64];
  std::snprintf(buf, sizeof buf, "h/h_crit %.3g", node_.stats_.stability_margin);
  return buf;
}

void NodeOutputs::update_stability() {
  node_.stats_.stability_margin = explicit_margin(node_.world_, &node_.stats_.limiting_rod);
}

void NodeOutputs::watch_contacts(const corde::World& world) {
  if (const corde::ContactSystem* c = world.contacts()) {
    max_penetration_since_state_ =
        std::max(max_penetration_since_state_, c->stats().max_penetration);
    // A deep contact (a cable pinched between links, a link moved into it): named, not launched.
    const double ratio = c->stats().max_ratio;
    if (ratio > world.contact.deep_penetration && ratio > deepest_ratio_since_state_) {
      deepest_ratio_since_state_ = ratio;
      deepest_contact_since_state_ =
          corde::deep_contact_report(world, world.contact.deep_penetration, 2);
    }
  }
}

std::vector<GraspView> NodeOutputs::grasp_views() const {
  std::vector<GraspView> views;
  for (const auto& kv : node_.grasps_.grasps()) {
    if (!kv.second.held) continue;
    GraspView v;
    v.name = kv.first;
    auto w = node_.wiring_.find(kv.first);
    v.id = w == node_.wiring_.end() ? 0 : w->second.marker_id;
    v.pose = kv.second.holder_pose();
    views.push_back(v);
  }
  return views;
}

void NodeOutputs::refresh_layout() {
  tf_frames_.layout(node_.world_, grasp_views(), node_.params_.frame_prefix,
                    node_.params_.world_frame, node_.params_.tf_every_k);
  markers_clear_ = true;
  update_stability();
}

void NodeOutputs::publish_tf() {
  const double t = node_.sim_time();
  if (t <= last_tf_time_) return;                       // every frame once per stamp
  if (node_.params_.publish_clock && t <= 0.0) return;  // stamp 0 means "latest" to tf
  last_tf_time_ = t;
  if (tf_pub_.getNumSubscribers() == 0) return;
  // One message per publish, handed over by pointer: in-process listeners get it without a copy.
  auto msg = boost::make_shared<tf2_msgs::TFMessage>();
  msg->transforms = tf_frames_.update(node_.world_, grasp_views(), node_.stamp());
  tf_pub_.publish(msg);
}

void NodeOutputs::send_tf_to(const ros::SingleSubscriberPublisher& pub) {
  if (!node_.sim_.paused() || node_.params_.tf_rate <= 0.0 || !node_.clock_.ready() ||
      (node_.params_.publish_clock && node_.sim_time() <= 0.0))
    return;
  if (pub.getSubscriberName() == ros::this_node::getName()) return;
  auto msg = boost::make_shared<tf2_msgs::TFMessage>();
  msg->transforms = tf_frames_.update(node_.world_, grasp_views(), node_.stamp());
  pub.publish(msg);
}

void NodeOutputs::publish_markers() {
  publish_paths();  // same rate, each topic built only for its subscribers
  if (marker_pub_.getNumSubscribers() == 0) return;
  MarkerOptions o;
  o.style = node_.params_.marker_style;
  o.show_frames = node_.params_.show_frames;
  o.color_by_strain = node_.params_.color_by_strain;
  o.min_diameter = node_.params_.marker_min_diameter;
  o.frames_every_k = node_.params_.tf_every_k;
  o.world_frame = node_.params_.world_frame;
  auto msg = boost::make_shared<visualization_msgs::MarkerArray>();
  build_markers(node_.world_, grasp_views(), o, node_.stamp(), markers_clear_, msg.get());
  if (markers_clear_) contact_arrows_ = 0;  // the DELETEALL took them
  if (node_.params_.contact_markers)
    contact_arrows_ = add_contact_markers(node_.world_, node_.params_.contact_force_scale, o,
                                          node_.stamp(), contact_arrows_, msg.get());
  markers_clear_ = false;
  marker_pub_.publish(msg);
}

void NodeOutputs::publish_paths() {
  rod_paths_.publish(node_.nh_, node_.world_, node_.params_.world_frame, node_.stamp());
}

void NodeOutputs::update_stats(double now) {
  if (node_.stats_.steps_since_stats > 0)
    node_.stats_.step_time_us =
        1e6 * node_.stats_.step_wall_since_stats / node_.stats_.steps_since_stats;
  // Real-time factor averaged over about a second: one publish period holds only a few loop
  // iterations, whose batches of steps do not line up with it.
  const double wall = now - node_.stats_.wall_at_stats;
  if (wall > 0.0) {
    const double rtf = (node_.sim_time() - node_.stats_.sim_at_stats) / wall;
    const double a = std::min(1.0, wall / 1.0);
    node_.stats_.measured_rtf =
        node_.stats_.rtf_initialised
            ? node_.stats_.measured_rtf + a * (rtf - node_.stats_.measured_rtf)
            : rtf;
    node_.stats_.rtf_initialised = true;
  }
  node_.stats_.substeps_per_publish = node_.stats_.steps_since_stats;
  node_.stats_.steps_since_stats = 0;
  node_.stats_.step_wall_since_stats = 0.0;
  node_.stats_.sim_at_stats = node_.sim_time();
  node_.stats_.wall_at_stats = now;
}

void NodeOutputs::publish_state() {
  if (state_pub_.getNumSubscribers() == 0) return;
  auto msg = boost::make_shared<WorldState>();
  msg->header.stamp = node_.stamp();
  msg->header.frame_id = node_.params_.world_frame;
  fill_rod_states(node_.world_, msg.get());
  msg->sim_time = node_.sim_time();
  msg->steps = node_.stats_.steps_total;
  msg->substeps_per_publish = static_cast<int>(
      std::min<long>(node_.stats_.substeps_per_publish, std::numeric_limits<int>::max()));
  msg->time_step = node_.world_.time_step;
  msg->step_time_us = node_.stats_.step_time_us;
  msg->real_time_factor = node_.stats_.measured_rtf;
  msg->paused = node_.sim_.paused();
  const corde::ContactSystem* contacts = node_.world_.contacts();
  msg->contacts = contacts ? contacts->stats().contacts : 0;
  msg->active_contacts = contacts ? contacts->stats().active : 0;
  msg->max_penetration = max_penetration_since_state_;
  msg->deepest_contact = deepest_contact_since_state_;
  state_pub_.publish(msg);
}

void NodeOutputs::publish_clock() {
  const double t = node_.sim_time();
  if (t <= last_clock_ || t <= 0.0) return;
  last_clock_ = t;
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(t);
  clock_pub_.publish(c);
}

void NodeOutputs::publish_due(double now) {
  // With /clock from this node, stamp 0 would read as "latest" (tf) or "unset": wait for t > 0.
  if (node_.params_.publish_clock && node_.sim_time() <= 0.0) return;
  if (node_.params_.publish_clock) publish_clock();
  if (schedule_.take(OutputSchedule::kTf, now)) publish_tf();
  if (schedule_.take(OutputSchedule::kMarkers, now)) publish_markers();
  if (schedule_.take(OutputSchedule::kCloud, now)) publish_cloud();
  // Statistics and reactions follow the state message (which runs at 2 Hz unpublished when off).
  if (schedule_.take(OutputSchedule::kState, now)) {
    update_stats(now);
    if (node_.params_.state_rate > 0.0) publish_state();
    max_penetration_since_state_ = 0.0;
    if (!deepest_contact_since_state_.empty()) {
      deep_contact_warning_ = "deep contact: " + deepest_contact_since_state_;
      ROS_WARN_THROTTLE(2.0, "corde_sim: %s", deep_contact_warning_.c_str());
    }
    deepest_ratio_since_state_ = 0.0;
    deepest_contact_since_state_.clear();
    publish_reactions();
  }
}

void NodeOutputs::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  const double target = node_.params_.real_time_factor;
  const NodeClock& clock = node_.clock_;
  const bool external = clock.source() == TimeSource::kExternalClock;
  NodeStats& stats = node_.stats_;
  if (!clock.ready()) {
    stat.summary(DiagnosticStatus::WARN,
                 "waiting for /clock: /use_sim_time is true and ~publish_clock false, and no "
                 "node has published a nonzero time yet");
  } else if (node_.guard_.failed()) {
    stat.summaryf(DiagnosticStatus::ERROR,
                  "stopped at the last good state: the stability guard could not recover (%s); "
                  "~reset or ~configure to resume",
                  node_.stats_.last_problem.c_str());
  } else if (node_.stats_.recoveries > node_.stats_.recoveries_reported) {
    stat.summaryf(DiagnosticStatus::WARN,
                  "the stability guard rolled back and retried %d time(s) (last: %s)%s",
                  node_.stats_.recoveries - node_.stats_.recoveries_reported,
                  node_.stats_.last_problem.c_str(),
                  node_.guard_.reduced() ? "; running a reduced step or the implicit method" : "");
    node_.stats_.recoveries_reported = node_.stats_.recoveries;
  } else if (!node_.stats_.strain_warning.empty()) {
    stat.summary(DiagnosticStatus::WARN, node_.stats_.strain_warning);
    node_.stats_.strain_warning.clear();
  } else if (!deep_contact_warning_.empty()) {
    stat.summary(DiagnosticStatus::WARN, deep_contact_warning_);
  } else if (!stats.clock_note.empty()) {
    stat.summary(DiagnosticStatus::WARN, stats.clock_note);
  } else if (node_.stats_.stability_margin > 1.0) {
    stat.summaryf(DiagnosticStatus::WARN, "time step above the stability estimate (h/h_crit %.2f)",
                  node_.stats_.stability_margin);
  } else if (clock.paced() && stats.backlog_drops > stats.backlog_drops_reported) {
    if (external)
      stat.summaryf(DiagnosticStatus::WARN,
                    "slower than /clock (measured real-time factor %.3g): backlog dropped, "
                    "stamps re-anchored to /clock",
                    stats.measured_rtf);
    else
      stat.summaryf(DiagnosticStatus::WARN,
                    "slower than real_time_factor %.3g (measured %.3g): backlog dropped, stamps "
                    "re-anchored to ROS time",
                    target, stats.measured_rtf);
  } else {
    stat.summary(DiagnosticStatus::OK, node_.sim_.paused() ? "paused" : "running");
  }
  stats.clock_note.clear();
  stats.backlog_drops_reported = stats.backlog_drops;
  stat.add("simulation time (s)", node_.sim_time());
  stat.add("time source", clock.source() == TimeSource::kPublishClock ? "this node's /clock"
                          : external                                  ? "another node's /clock"
                                                                      : "wall time");
  if (clock.ready())
    stat.add("stamp behind ROS time (s)",
             clock.lag(node_.sim_time(), static_cast<std::int64_t>(ros::Time::now().toNSec())));
  stat.add("backlogs dropped (stamps re-anchored)", stats.backlog_drops);
  stat.add("/clock jumps (re-anchored)", clock.jumps());
  stat.add("steps", node_.stats_.steps_total);
  stat.add("integrator", corde::integrator_name(node_.world_.integrator));
  stat.add("time step (s)", node_.world_.time_step);
  stat.add("step time (us)", node_.stats_.step_time_us);
  stat.add("real-time factor (measured)", node_.stats_.measured_rtf);
  stat.add("real-time factor (target, 0 = max)", target);
  stat.add("substeps per loop", node_.stats_.steps_last_iteration);
  stat.add("queued steps", node_.sim_.queued_steps());  // ~step's, run while paused
  stat.add("queued inputs", node_.commands_.inputs());  // at most one per grasp and kind
  stat.add("stability margin h/h_crit", node_.stats_.stability_margin);
  stat.add("stability limiting rod", node_.stats_.limiting_rod);
  stat.add("rods", node_.world_.rods().size());
  stat.add("grasps", node_.grasps_.grasps().size());
  // Contacts of the last step (none when the scene has nothing to collide).
  const corde::ContactSystem* contacts = node_.world_.contacts();
  stat.add("obstacles", node_.world_.obstacles ? node_.world_.obstacles->size() : 0);
  stat.add("contacts", contacts ? contacts->stats().contacts : 0);
  stat.add("contacts carrying a force", contacts ? contacts->stats().active : 0);
  stat.add("largest penetration (m)", contacts ? contacts->stats().max_penetration : 0.0);
  stat.add("deep contact since the last report", deep_contact_warning_);
  deep_contact_warning_.clear();
  if (!node_.scene_.robot().empty())
    stat.addf("robot collision elements (in tf / all)", "%d / %d", node_.scene_.robot().active(),
              node_.scene_.robot().elements());
  stat.add("stability guard detections", node_.stats_.recoveries);
  stat.add("stability guard last event", node_.stats_.last_problem);
  stat.add("stability guard state", node_.guard_.failed()    ? "stopped (unrecoverable)"
                                    : node_.guard_.reduced() ? "recovering (reduced step or method)"
                                                             : "ok");
  stat.add("stability guard time step (s)", node_.guard_.time_step());
}

// A line a user watching the console (make run) can follow without rqt or rostopic.
void NodeOutputs::log_status() const {
  ROS_INFO(
      "corde_sim: t = %.3f s, %lu steps of %g s, real-time factor %.3g (target %g%s), "
      "%.2f us/step, %s%s",
      node_.sim_time(), node_.stats_.steps_total, node_.world_.time_step, node_.stats_.measured_rtf,
      node_.params_.real_time_factor, node_.params_.real_time_factor > 0.0 ? "" : " = max",
      node_.stats_.step_time_us, margin_text().c_str(), node_.sim_.paused() ? ", paused" : "");
}

void NodeOutputs::publish_reactions() {
  for (auto& kv : node_.wiring_) {
    Eigen::Vector3d f, tau;
    if (!node_.grasps_.take_reaction(kv.first, &f, &tau)) continue;
    if (!kv.second.reaction_pub || kv.second.reaction_pub.getNumSubscribers() == 0) continue;
    if (!f.allFinite() || !tau.allFinite()) continue;  // never leaves the node
    geometry_msgs::WrenchStamped m;
    m.header.stamp = node_.stamp();
    m.header.frame_id = node_.params_.frame_prefix + "grasp/" + kv.first;
    m.wrench.force.x = f.x();
    m.wrench.force.y = f.y();
    m.wrench.force.z = f.z();
    m.wrench.torque.x = tau.x();
    m.wrench.torque.y = tau.y();
    m.wrench.torque.z = tau.z();
    kv.second.reaction_pub.publish(m);
  }
  for (auto& kv : node_.wiring_) {
    double slip = 0.0;
    if (!node_.grasps_.take_slip(kv.first, &slip) || !std::isfinite(slip)) continue;
    if (!kv.second.slip_pub || kv.second.slip_pub.getNumSubscribers() == 0) continue;
    std_msgs::Float64 m;
    m.data = slip;
    kv.second.slip_pub.publish(m);
  }
}

}  // namespace corde_sim
