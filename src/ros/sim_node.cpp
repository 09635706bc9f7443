// SimNode: construction, the simulation loop and its outputs.
#include "corde_sim/ros/sim_node.h"

#include <ros/callback_queue.h>
#include <ros/package.h>
#include <rosgraph_msgs/Clock.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "corde_sim/stability/explicit_step_limit.h"

namespace corde_sim {

double wall_seconds() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

namespace {

double process_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double thread_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

}  // namespace

SimNode::SimNode(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) : nh_(nh), pnh_(pnh) {
  const std::string pkg = ros::package::getPath("corde_sim");
  params_ = load_node_params(pnh_, nh_.getNamespace(),
                             pkg.empty() ? "" : pkg + "/config/scenes/default.yaml");
  bool use_sim_time = false;
  ros::param::get("/use_sim_time", use_sim_time);
  if (params_.publish_clock && !use_sim_time)
    throw std::invalid_argument(
        "parameter ~publish_clock: true makes this node the time source, which needs "
        "/use_sim_time true before any node starts (e.g. <param name=\"use_sim_time\" "
        "value=\"true\"/> in the launch file)");
  if (!params_.publish_clock && use_sim_time)
    ROS_WARN(
        "corde_sim: /use_sim_time is true but ~publish_clock is false: expecting another "
        "node to publish /clock; stamps are that clock's time at start-up plus simulation "
        "time");

  // The holder limits are the driver's configuration: kept across scene installs and rollbacks,
  // changed by dynamic_reconfigure only (apply_reconfigure).
  corde::HolderLimits holder_limits;
  holder_limits.max_speed = params_.holder_max_speed;
  holder_limits.max_acceleration = params_.holder_max_acceleration;
  holder_limits.max_angular_speed = params_.holder_max_angular_speed;
  holder_limits.max_angular_acceleration = params_.holder_max_angular_acceleration;
  sim_.set_holder_limits(holder_limits);
  corde::GuardSettings guard_settings;
  guard_settings.limits.max_speed = params_.max_node_speed;
  guard_settings.limits.max_angular_speed = params_.max_angular_speed;
  guard_.set_settings(guard_settings);
  sim_.set_obstacle_mover([this](corde::World* w, double h) {
    if (!robot_.empty()) robot_.before_step(w->obstacles.get(), h);
  });
  sim_.set_step_observer([this](const corde::World& w) { watch_contacts(w); });
  corde::Scene scene;
  std::string resolve_error;
  const std::string scene_file = resolve_scene(params_.scene, &resolve_error);
  if (scene_file.empty()) throw std::invalid_argument("parameter ~scene: " + resolve_error);
  params_.scene = scene_file;
  try {
    scene = corde::load_scene(params_.scene, params_.overrides);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("parameter ~scene: ") + e.what());
  }
  for (const auto& g : params_.grasps) {
    const auto& specs = scene.grasps;
    if (std::none_of(specs.begin(), specs.end(),
                     [&](const corde::GraspSpec& s) { return s.name == g.first; }))
      ROS_WARN(
          "corde_sim: ~grasps/%s names no grasp of the scene (it only sets the source of a "
          "grasp made later through ~grasp with that name)",
          g.first.c_str());
  }

  // tf input: own subscriptions so that this node's own (large) /tf messages are skipped
  // without being stored; everything else goes into the buffer.
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_input_ = std::make_unique<TfInput>(nh_, tf_buffer_.get());

  // A listener that connects while the simulation is paused would otherwise see no frames until
  // it resumes (frames are sent once per stamp): it alone gets the current ones.
  tf_pub_ = nh_.advertise<tf2_msgs::TFMessage>(
      "/tf", 100, [this](const ros::SingleSubscriberPublisher& pub) { send_tf_to(pub); });
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1);
  tf_frames_.set_node_frames(params_.node_frames);  // before the first layout
  state_pub_ = nh_.advertise<WorldState>("rod_state", 10);
  if (params_.publish_clock) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);

  load_robot();
  std::string error = install_scene(std::move(scene), params_.scene);
  if (!error.empty()) throw std::invalid_argument("parameter ~scene: " + error);

  // Services on their own queue, served by their own threads (command_queue.h), started last.
  services_ = std::make_unique<ServiceThreads>(pnh_);
  services_->advertise("reset", &SimNode::on_reset, this);
  services_->advertise("configure", &SimNode::on_configure, this);
  services_->advertise("pause", &SimNode::on_pause, this);
  services_->advertise("step", &SimNode::on_step, this);
  services_->advertise("grasp", &SimNode::on_grasp, this);
  services_->advertise("release", &SimNode::on_release, this);
  services_->advertise("list_grasps", &SimNode::on_list_grasps, this);
  // A command queued from another thread wakes the loop at once (it waits on the global queue).
  commands_.set_wake([] {
    class Wake : public ros::CallbackInterface {
     public:
      CallResult call() override { return Success; }
    };
    ros::getGlobalCallbackQueue()->addCallback(boost::make_shared<Wake>());
  });

  // dynamic_reconfigure starts from the parameters as read (its first request, made in this
  // thread, is queued and applied here below); later requests are served by its own thread.
  NodeConfig initial;
  initial.real_time_factor = params_.real_time_factor;
  initial.tf_rate = params_.tf_rate;
  initial.marker_rate = params_.marker_rate;
  initial.state_rate = params_.state_rate;
  initial.marker_style =
      params_.marker_style == MarkerStyle::kLineStrip ? "line_strip" : "cylinders";
  initial.marker_min_diameter = params_.marker_min_diameter;
  initial.holder_max_speed = params_.holder_max_speed;
  initial.holder_max_acceleration = params_.holder_max_acceleration;
  reconfigure_ =
      std::make_unique<ReconfigureInput>(pnh_, initial, &commands_, &loop_running_,
                                         [this](const NodeConfig& c) { apply_reconfigure(c); });
  drain_commands();

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID("corde_sim");
  diagnostics_->add("simulation", this, &SimNode::diagnose);

  epoch_ = params_.publish_clock ? ros::Time(0) : ros::Time::now();
  sim_.set_paused(params_.start_paused);
  // Two threads: a ~reset reading a long scene file does not hold a ~pause or ~list_grasps.
  services_->start(2);
  ROS_INFO(
      "corde_sim: scene '%s' with %zu rod(s), %zu grasp(s), integrator %s, time step %g s, "
      "%s%s",
      initial_.name.c_str(), world_.rods().size(), grasps_.grasps().size(),
      corde::integrator_name(world_.integrator), world_.time_step, margin_text().c_str(),
      sim_.paused() ? ", paused" : "");
}

SimNode::~SimNode() {
  close_commands();
  if (services_) services_->stop();
  reconfigure_.reset();
}

void SimNode::close_commands() {
  // Waiting callers return (their commands are not applied), so that their threads can stop.
  loop_running_ = false;
  commands_.close();
  if (step_call_) {
    step_call_->res->success = false;
    step_call_->res->message = "the node is shutting down";
    step_call_->reply->set();
    step_call_.reset();
  }
}

void SimNode::drain_commands() {
  for (CommandQueue::Command& c : commands_.take()) {
    if (c.is_input)
      apply_input(c.input);
    else
      c.apply(c.reply);
  }
}

bool SimNode::in_loop(const std::function<void()>& fn) {
  return commands_.call([&fn](const ReplyPtr& reply) {
    fn();
    reply->set();
  });
}

ros::Time SimNode::stamp() const {
  // With /clock from this node the stamp is the simulation time itself; otherwise the ROS time
  // at start-up plus simulation time, so each message still names the instant it shows.
  return params_.publish_clock ? ros::Time(sim_time()) : epoch_ + ros::Duration(sim_time());
}

void SimNode::bump_time() {
  // A changed state (reset, configure, grasp) gets a later stamp than anything published before,
  // so tf listeners never see two different poses at one stamp.
  time_offset_ += world_.time_step;
}

std::string SimNode::margin_text() const {
  // The explicit limit means nothing to the implicit method: saying 0 would read as a margin.
  if (corde::is_implicit(world_.integrator)) return "no explicit step limit";
  char buf[64];
  std::snprintf(buf, sizeof buf, "h/h_crit %.3g", stability_margin_);
  return buf;
}

void SimNode::update_stability() { stability_margin_ = explicit_margin(world_, &limiting_rod_); }

void SimNode::watch_contacts(const corde::World& world) {
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

long SimNode::run_steps(long n, double deadline) {
  const double t0 = wall_seconds();
  const double c0 = thread_cpu_seconds();
  long k = 0;
  // The deadline is checked after the first step, then every 8 steps while steps are fast, and
  // after every step once they are slow (over 50 us): a batch overruns it by one step at most.
  bool slow = false;
  for (; k < n && !guard_.failed(); ++k) {
    if (k > 0 && (slow || k == 1 || (k & 7) == 0)) {
      const double now = wall_seconds();
      if (now > deadline) break;
      slow = now - t0 > 5e-5 * static_cast<double>(k);
    }
    if (!sim_.advance(1)) break;
  }
  report_guard_events();  // (scripts taking hold or letting go: the layout follows)
  const double dt = wall_seconds() - t0;
  step_cpu_total_ += thread_cpu_seconds() - c0;
  refresh_if_grasps_changed();
  steps_total_ += k;
  steps_since_stats_ += k;
  step_wall_since_stats_ += dt;
  steps_last_iteration_ = k;
  return k;
}

void SimNode::advance(double now) {
  if (guard_.failed()) {
    // Stopped at the last good state: the clock goes on (tf and /clock listeners see the state
    // held, not a frozen time) and the state is published as it is until a reset or configure.
    const long due = pacer_.paced() ? pacer_.steps_due(sim_time(), now, world_.time_step) : 1;
    time_offset_ += static_cast<double>(std::max(0L, due)) * world_.time_step;
    return;
  }
  if (pacer_.paced()) {
    const long due = pacer_.steps_due(sim_time(), now, world_.time_step);
    // The steps due may take a few loop periods (from when they were first due); beyond that the
    // simulation cannot keep up, and the backlog is dropped instead of growing (the measured
    // real-time factor shows it). A batch also stops at the next output and goes on after it, so
    // that no output waits for more than one step.
    const double budget = std::max(3.0 / params_.loop_rate, 0.02);
    const double budget_end = (pacer_.behind_since() < 0.0 ? now : pacer_.behind_since()) + budget;
    const double end = std::max(std::min(budget_end, schedule_.next_due()), now);
    const long done = due > 0 ? run_steps(due, end) : 0;
    const bool behind = done < due && !guard_.failed();
    lagging_ = behind && wall_seconds() >= budget_end;
    if (lagging_)
      pacer_.anchor(sim_time(), wall_seconds());
    else
      pacer_.set_behind(behind, now);
  } else {
    // As fast as possible, in slices short enough to serve callbacks and outputs on time.
    const double slice_end = std::min(now + 0.005, schedule_.next_due());
    run_steps(std::numeric_limits<long>::max(), std::max(slice_end, now));
  }
  if (settle_guard()) check_holders_and_strain();
  refresh_if_grasps_changed();  // (the guard may have replayed a scripted grasp or release)
}

void SimNode::run_queued_steps(double now) {
  if (guard_.failed()) {
    sim_.drop_queued_steps();
    return;
  }
  // As a paced batch: a few loop periods at most, and not past the next output.
  const double budget = std::max(3.0 / params_.loop_rate, 0.02);
  const double end = std::max(std::min(now + budget, schedule_.next_due()), now);
  run_steps(sim_.queued_steps(), end);  // (each step takes one of the driver's queued steps)
  if (settle_guard()) {
    check_holders_and_strain();
  } else {
    ROS_WARN(
        "corde_sim: %ld queued ~step step(s) dropped: the stability guard stopped the "
        "simulation",
        sim_.drop_queued_steps());
  }
  refresh_if_grasps_changed();
  if (sim_.queued_steps() == 0 && !step_call_)  // (a call still waiting says so in its reply)
    ROS_INFO("corde_sim: queued ~step steps done at t = %.6f s", sim_time());
}

void SimNode::refresh_if_grasps_changed() {
  if (!layout_changed_) return;
  layout_changed_ = false;
  refresh_layout();  // the grasp frames and markers follow the held grasps
}

bool SimNode::settle_guard() {
  const double t = sim_time();
  const bool ok = sim_.settle();
  // After giving up the world is back at its last good state: the clock keeps going forward.
  if (!ok && sim_time() < t) time_offset_ = t - world_.time();
  report_guard_events();
  return ok;
}

void SimNode::report_guard_events() {
  for (const corde::SimulationEvent& event : sim_.take_events()) {
    if (event.kind == corde::SimulationEvent::Kind::kTookHold ||
        event.kind == corde::SimulationEvent::Kind::kLetGo) {
      layout_changed_ = true;
      continue;
    }
    if (event.kind == corde::SimulationEvent::Kind::kCannotHold) {
      ROS_WARN_THROTTLE(2.0, "corde_sim: grasp '%s' cannot take hold at t = %g s: %s",
                        event.grasp.c_str(), event.time, event.text.c_str());
      continue;
    }
    if (event.kind != corde::SimulationEvent::Kind::kGuard) continue;
    const corde::GuardEvent& e = event.guard;
    // Times in the node's clock.
    const double offset = time_offset_;
    char when[64];
    std::snprintf(when, sizeof when, "(node time %.6f s) ", offset + e.time);
    if (e.kind == corde::GuardEvent::Kind::kRestored) {
      ROS_INFO_THROTTLE(5.0, "corde_sim: stability guard: %s%s", when, e.message().c_str());
      continue;
    }
    last_problem_ = e.message();
    if (e.kind == corde::GuardEvent::Kind::kUnrecoverable) {
      ROS_ERROR(
          "corde_sim: stability guard: %sno retry helped: %s. The simulation stopped at its "
          "last good state (published as it is); ~reset, or ~configure with a smaller "
          "time_step or another integrator, resumes it",
          when, e.message().c_str());
      continue;
    }
    ++recoveries_;
    ROS_WARN_THROTTLE(1.0, "corde_sim: stability guard: %s%s (h/h_crit %.2f, limiting rod '%s')",
                      when, e.message().c_str(), stability_margin_, limiting_rod_.c_str());
  }
}

std::string SimNode::restart_guard() {
  std::string note;
  if (guard_.failed())
    note = "; the simulation had stopped (stability guard: " + last_problem_ + ") and resumes";
  report_guard_events();
  sim_.restart_guard();  // snapshots the world, the grasps and the scripts
  return note;
}

std::vector<GraspView> SimNode::grasp_views() const {
  std::vector<GraspView> views;
  for (const auto& kv : grasps_.grasps()) {
    if (!kv.second.held) continue;
    GraspView v;
    v.name = kv.first;
    auto w = wiring_.find(kv.first);
    v.id = w == wiring_.end() ? 0 : w->second.marker_id;
    v.pose = kv.second.holder_pose();
    views.push_back(v);
  }
  return views;
}

void SimNode::refresh_layout() {
  tf_frames_.layout(world_, grasp_views(), params_.frame_prefix, params_.world_frame,
                    params_.tf_every_k);
  markers_clear_ = true;
  update_stability();
}

void SimNode::publish_tf() {
  const double t = sim_time();
  if (t <= last_tf_time_) return;                 // every frame once per stamp
  if (params_.publish_clock && t <= 0.0) return;  // stamp 0 means "latest" to tf
  last_tf_time_ = t;
  if (tf_pub_.getNumSubscribers() == 0) return;
  // One message per publish, handed over by pointer: in-process listeners get it without a copy.
  auto msg = boost::make_shared<tf2_msgs::TFMessage>();
  msg->transforms = tf_frames_.update(world_, grasp_views(), stamp());
  tf_pub_.publish(msg);
}

void SimNode::send_tf_to(const ros::SingleSubscriberPublisher& pub) {
  if (!sim_.paused() || params_.tf_rate <= 0.0 || (params_.publish_clock && sim_time() <= 0.0))
    return;
  if (pub.getSubscriberName() == ros::this_node::getName()) return;
  auto msg = boost::make_shared<tf2_msgs::TFMessage>();
  msg->transforms = tf_frames_.update(world_, grasp_views(), stamp());
  pub.publish(msg);
}

void SimNode::publish_markers() {
  publish_paths();  // same rate, each topic built only for its subscribers
  if (marker_pub_.getNumSubscribers() == 0) return;
  MarkerOptions o;
  o.style = params_.marker_style;
  o.show_frames = params_.show_frames;
  o.color_by_strain = params_.color_by_strain;
  o.min_diameter = params_.marker_min_diameter;
  o.frames_every_k = params_.tf_every_k;
  o.world_frame = params_.world_frame;
  auto msg = boost::make_shared<visualization_msgs::MarkerArray>();
  build_markers(world_, grasp_views(), o, stamp(), markers_clear_, msg.get());
  if (markers_clear_) contact_arrows_ = 0;  // the DELETEALL took them
  if (params_.contact_markers)
    contact_arrows_ = add_contact_markers(world_, params_.contact_force_scale, o, stamp(),
                                          contact_arrows_, msg.get());
  markers_clear_ = false;
  marker_pub_.publish(msg);
}

void SimNode::publish_paths() { rod_paths_.publish(nh_, world_, params_.world_frame, stamp()); }

void SimNode::update_stats(double now) {
  if (steps_since_stats_ > 0) step_time_us_ = 1e6 * step_wall_since_stats_ / steps_since_stats_;
  // Real-time factor averaged over about a second: one publish period holds only a few loop
  // iterations, whose batches of steps do not line up with it.
  const double wall = now - wall_at_stats_;
  if (wall > 0.0) {
    const double rtf = (sim_time() - sim_at_stats_) / wall;
    const double a = std::min(1.0, wall / 1.0);
    measured_rtf_ = rtf_initialised_ ? measured_rtf_ + a * (rtf - measured_rtf_) : rtf;
    rtf_initialised_ = true;
  }
  substeps_per_publish_ = steps_since_stats_;
  steps_since_stats_ = 0;
  step_wall_since_stats_ = 0.0;
  sim_at_stats_ = sim_time();
  wall_at_stats_ = now;
}

void SimNode::publish_state() {
  if (state_pub_.getNumSubscribers() == 0) return;
  auto msg = boost::make_shared<WorldState>();
  msg->header.stamp = stamp();
  msg->header.frame_id = params_.world_frame;
  fill_rod_states(world_, msg.get());
  msg->sim_time = sim_time();
  msg->steps = steps_total_;
  msg->substeps_per_publish =
      static_cast<int>(std::min<long>(substeps_per_publish_, std::numeric_limits<int>::max()));
  msg->time_step = world_.time_step;
  msg->step_time_us = step_time_us_;
  msg->real_time_factor = measured_rtf_;
  msg->paused = sim_.paused();
  const corde::ContactSystem* contacts = world_.contacts();
  msg->contacts = contacts ? contacts->stats().contacts : 0;
  msg->active_contacts = contacts ? contacts->stats().active : 0;
  msg->max_penetration = max_penetration_since_state_;
  msg->deepest_contact = deepest_contact_since_state_;
  state_pub_.publish(msg);
}

void SimNode::publish_clock() {
  const double t = sim_time();
  if (t <= last_clock_ || t <= 0.0) return;
  last_clock_ = t;
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(t);
  clock_pub_.publish(c);
}

void SimNode::publish_due(double now) {
  // With /clock from this node, stamp 0 would read as "latest" (tf) or "unset": wait for t > 0.
  if (params_.publish_clock && sim_time() <= 0.0) return;
  if (params_.publish_clock) publish_clock();
  if (schedule_.take(OutputSchedule::kTf, now)) publish_tf();
  if (schedule_.take(OutputSchedule::kMarkers, now)) publish_markers();
  // Statistics and reactions follow the state message (which runs at 2 Hz unpublished when off).
  if (schedule_.take(OutputSchedule::kState, now)) {
    update_stats(now);
    if (params_.state_rate > 0.0) publish_state();
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

void SimNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  const double target = params_.real_time_factor;
  if (guard_.failed()) {
    stat.summaryf(DiagnosticStatus::ERROR,
                  "stopped at the last good state: the stability guard could not recover (%s); "
                  "~reset or ~configure to resume",
                  last_problem_.c_str());
  } else if (recoveries_ > recoveries_reported_) {
    stat.summaryf(DiagnosticStatus::WARN,
                  "the stability guard rolled back and retried %d time(s) (last: %s)%s",
                  recoveries_ - recoveries_reported_, last_problem_.c_str(),
                  guard_.reduced() ? "; running a reduced step or the implicit method" : "");
    recoveries_reported_ = recoveries_;
  } else if (!strain_warning_.empty()) {
    stat.summary(DiagnosticStatus::WARN, strain_warning_);
    strain_warning_.clear();
  } else if (!deep_contact_warning_.empty()) {
    stat.summary(DiagnosticStatus::WARN, deep_contact_warning_);
  } else if (stability_margin_ > 1.0) {
    stat.summaryf(DiagnosticStatus::WARN, "time step above the stability estimate (h/h_crit %.2f)",
                  stability_margin_);
  } else if (!sim_.paused() && target > 0.0 && lagging_) {
    stat.summaryf(DiagnosticStatus::WARN, "slower than real_time_factor %.3g (measured %.3g)",
                  target, measured_rtf_);
  } else {
    stat.summary(DiagnosticStatus::OK, sim_.paused() ? "paused" : "running");
  }
  stat.add("simulation time (s)", sim_time());
  stat.add("steps", steps_total_);
  stat.add("integrator", corde::integrator_name(world_.integrator));
  stat.add("time step (s)", world_.time_step);
  stat.add("step time (us)", step_time_us_);
  stat.add("real-time factor (measured)", measured_rtf_);
  stat.add("real-time factor (target, 0 = max)", target);
  stat.add("substeps per loop", steps_last_iteration_);
  stat.add("queued steps", sim_.queued_steps());  // ~step's, run while paused
  stat.add("queued inputs", commands_.inputs());  // at most one per grasp and kind
  stat.add("stability margin h/h_crit", stability_margin_);
  stat.add("stability limiting rod", limiting_rod_);
  stat.add("rods", world_.rods().size());
  stat.add("grasps", grasps_.grasps().size());
  // Contacts of the last step (none when the scene has nothing to collide).
  const corde::ContactSystem* contacts = world_.contacts();
  stat.add("obstacles", world_.obstacles ? world_.obstacles->size() : 0);
  stat.add("contacts", contacts ? contacts->stats().contacts : 0);
  stat.add("contacts carrying a force", contacts ? contacts->stats().active : 0);
  stat.add("largest penetration (m)", contacts ? contacts->stats().max_penetration : 0.0);
  stat.add("deep contact since the last report", deep_contact_warning_);
  deep_contact_warning_.clear();
  if (!robot_.empty())
    stat.addf("robot collision elements (in tf / all)", "%d / %d", robot_.active(),
              robot_.elements());
  stat.add("stability guard detections", recoveries_);
  stat.add("stability guard last event", last_problem_);
  stat.add("stability guard state", guard_.failed()    ? "stopped (unrecoverable)"
                                    : guard_.reduced() ? "recovering (reduced step or method)"
                                                       : "ok");
  stat.add("stability guard time step (s)", guard_.time_step());
}

// A line a user watching the console (make run) can follow without rqt or rostopic.
void SimNode::log_status() const {
  ROS_INFO(
      "corde_sim: t = %.3f s, %lu steps of %g s, real-time factor %.3g (target %g%s), "
      "%.2f us/step, %s%s",
      sim_time(), steps_total_, world_.time_step, measured_rtf_, params_.real_time_factor,
      params_.real_time_factor > 0.0 ? "" : " = max", step_time_us_, margin_text().c_str(),
      sim_.paused() ? ", paused" : "");
}

int SimNode::run() {
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  double now = wall_seconds();
  pacer_.reset(params_.real_time_factor, sim_time(), now);
  schedule_.set_rate(OutputSchedule::kTf, params_.tf_rate);
  schedule_.set_rate(OutputSchedule::kMarkers, params_.marker_rate);
  schedule_.set_rate(OutputSchedule::kState, params_.state_rate > 0.0 ? params_.state_rate : 2.0);
  schedule_.start(now);
  sim_at_stats_ = sim_time();
  wall_at_stats_ = now;
  const double start_wall = now, start_cpu = process_cpu_seconds(), start_sim = sim_time();
  const unsigned long start_steps = steps_total_;
  const double start_step_cpu = step_cpu_total_;
  const double bench_end =
      params_.benchmark > 0.0 ? now + params_.benchmark : std::numeric_limits<double>::infinity();
  double output_wall_total = 0.0, output_wall_max = 0.0;
  loop_running_ = true;
  while (ros::ok()) {
    // Inputs: topic callbacks and tf-followed frames queue theirs; then every command waiting
    // (inputs, services, reconfigure) is applied, oldest first, before the steps.
    queue->callAvailable(ros::WallDuration(0));
    update_tf_holders();
    update_robot();
    drain_commands();
    now = wall_seconds();
    if (!sim_.paused())
      advance(now);
    else if (sim_.queued_steps() > 0)
      run_queued_steps(now);
    now = wall_seconds();
    if (step_call_) answer_step_call(now);
    publish_due(now);
    diagnostics_->update();
    if (params_.status_period > 0.0 && now >= next_status_) {
      if (next_status_ > 0.0) log_status();  // none at start: nothing has run yet
      next_status_ = now + params_.status_period;
    }
    const double out_wall = wall_seconds() - now;
    output_wall_total += out_wall;
    output_wall_max = std::max(output_wall_max, out_wall);
    if (now >= bench_end) break;
    double wake = now;
    if (sim_.paused() && sim_.queued_steps() > 0)
      wake = now;  // more queued steps: only the callbacks waiting now are served
    else if (sim_.paused())
      wake = std::min(schedule_.next_due(), now + 0.05);  // rod_state keeps its rate while paused
    else if (pacer_.paced() && pacer_.behind_since() < 0.0)  // (steps still due: no sleep)
      wake = std::min(schedule_.next_due(), now + 1.0 / params_.loop_rate);
    if (wake > now) queue->callAvailable(ros::WallDuration(wake - now));
  }
  close_commands();
  if (params_.benchmark > 0.0) {
    ROS_INFO(
        "corde_sim benchmark: outputs (tf, markers, state, clock, diagnostics) took %.3f s "
        "in all, %.2f ms at most per loop iteration",
        output_wall_total, 1e3 * output_wall_max);
    return benchmark_report(wall_seconds() - start_wall, process_cpu_seconds() - start_cpu,
                            steps_total_ - start_steps, sim_time() - start_sim,
                            step_cpu_total_ - start_step_cpu);
  }
  return 0;
}

int SimNode::benchmark_report(double wall, double cpu, unsigned long steps, double sim,
                              double step_cpu) {
  // The bare library on the same scene: the same number of steps in a tight loop, no ROS.
  corde::World bare = initial_.world;
  const double c0 = thread_cpu_seconds();
  for (unsigned long i = 0; i < steps; ++i) bare.step();
  const double bare_cpu = thread_cpu_seconds() - c0;
  // Two views of the overhead: CPU the node spends outside its steps (loop, callbacks, outputs,
  // roscpp threads) relative to the steps, and the node's whole CPU against the bare steps
  // (which also counts steps running slower between sleeps: caches, other load).
  const double outside = step_cpu > 0.0 ? (cpu - step_cpu) / step_cpu : 0.0;
  const double total = bare_cpu > 0.0 ? (cpu - bare_cpu) / bare_cpu : 0.0;
  const double per_step = steps ? 1e6 * step_cpu / steps : 0.0;
  const double per_bare = steps ? 1e6 * bare_cpu / steps : 0.0;
  ROS_INFO(
      "corde_sim benchmark: %.2f s wall, %lu steps, %.4f s simulated, real-time factor %.2f "
      "(target %g)",
      wall, steps, sim, sim / wall, params_.real_time_factor);
  ROS_INFO(
      "corde_sim benchmark: process CPU %.3f s (%.1f%% of wall), of which steps %.3f s "
      "(%.2f us/step); bare library %.3f s (%.2f us/step). Node CPU outside the steps: "
      "%.1f%% of the step CPU; whole node against bare steps: %+.1f%%",
      cpu, 100.0 * cpu / wall, step_cpu, per_step, bare_cpu, per_bare, 100.0 * outside,
      100.0 * total);
  std::printf(
      "benchmark wall_s=%.3f steps=%lu sim_s=%.5f rtf=%.3f cpu_s=%.4f step_cpu_s=%.4f "
      "bare_s=%.4f outside_steps_pct=%.2f vs_bare_pct=%.2f\n",
      wall, steps, sim, sim / wall, cpu, step_cpu, bare_cpu, 100.0 * outside, 100.0 * total);
  std::fflush(stdout);
  return 0;
}

}  // namespace corde_sim
