// SimNode: construction, the simulation loop and its outputs.
#include "corde_sim/ros/sim_node.h"

#include <ros/callback_queue.h>
#include <ros/package.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include "corde_sim/ros/input_checks.h"

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

// ROS time now in nanoseconds (0 while an external /clock has shown nothing yet).
std::int64_t ros_now_ns() { return static_cast<std::int64_t>(ros::Time::now().toNSec()); }

TimeSource time_source(bool publish_clock, bool use_sim_time) {
  if (publish_clock) return TimeSource::kPublishClock;
  return use_sim_time ? TimeSource::kExternalClock : TimeSource::kWall;
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
    ROS_INFO(
        "corde_sim: /use_sim_time is true and ~publish_clock false: following another node's "
        "/clock (the simulation waits for it, steps with it and pauses when it stops)");

  // The holder limits are the driver's configuration: kept across scene installs and rollbacks,
  // changed by dynamic_reconfigure only (apply_reconfigure).
  corde::HolderLimits holder_limits;
  holder_limits.max_speed = params_.holder_max_speed;
  holder_limits.max_acceleration = params_.holder_max_acceleration;
  holder_limits.max_angular_speed = params_.holder_max_angular_speed;
  holder_limits.max_angular_acceleration = params_.holder_max_angular_acceleration;
  // A holder stalls at the strain limit unless the grasp is to slip there (~strain_action).
  holder_limits.stall_at_max_strain = params_.strain_action != StrainAction::kSlip;
  sim_.set_holder_limits(holder_limits);
  corde::GuardSettings guard_settings;
  guard_settings.limits.max_speed = params_.max_node_speed;
  guard_settings.limits.max_angular_speed = params_.max_angular_speed;
  guard_.set_settings(guard_settings);
  sim_.set_obstacle_mover([this](corde::World* w, double h) {
    if (!scene_.robot().empty()) scene_.robot().before_step(w->obstacles.get(), h);
    if (!obstacles_.empty()) obstacles_.before_step(w->obstacles.get(), h);
  });
  sim_.set_step_observer([this](const corde::World& w) { outputs_.watch_contacts(w); });
  corde::Scene scene;
  std::string resolve_error;
  const std::string scene_file = scene_.resolve_scene(params_.scene, &resolve_error);
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

  inputs_.start_tf();
  outputs_.advertise();

  scene_.load_robot();
  std::string error = scene_.install_scene(std::move(scene), params_.scene);
  if (!error.empty()) throw std::invalid_argument("parameter ~scene: " + error);

  // Services on their own queue, served by their own threads (command_queue.h), started last.
  services_.advertise(pnh_);
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
  inputs_.start_reconfigure();
  drain_commands();

  outputs_.start_diagnostics();

  clock_.start(time_source(params_.publish_clock, use_sim_time), params_.real_time_factor,
               sim_time(), wall_seconds(), ros_now_ns());
  sim_.set_paused(params_.start_paused);
  // Two threads: a ~reset reading a long scene file does not hold a ~pause or ~list_grasps.
  services_.start(2);
  ROS_INFO(
      "corde_sim: scene '%s' with %zu rod(s), %zu grasp(s), integrator %s, time step %g s, "
      "%s%s",
      scene_.initial().name.c_str(), world_.rods().size(), grasps_.grasps().size(),
      corde::integrator_name(world_.integrator), world_.time_step, outputs_.margin_text().c_str(),
      sim_.paused() ? ", paused" : "");
}

SimNode::~SimNode() {
  close_commands();
  services_.stop();
  inputs_.stop_reconfigure();
}

void SimNode::close_commands() {
  // Waiting callers return (their commands are not applied), so that their threads can stop.
  loop_running_ = false;
  commands_.close();
  services_.close();
}

void SimNode::drain_commands() {
  for (CommandQueue::Command& c : commands_.take()) {
    if (c.is_input)
      inputs_.apply_input(c.input);
    else
      c.apply(c.reply);
  }
}

ros::Time SimNode::stamp() const {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(std::max<std::int64_t>(clock_.stamp_ns(sim_time()), 0)));
  return t;
}

void SimNode::bump_time() {
  // A changed state (reset, configure, grasp) gets a later stamp than anything published before,
  // so tf listeners never see two different poses at one stamp.
  time_offset_ += world_.time_step;
  anchor_clock();
}

void SimNode::anchor_clock() { clock_.anchor(sim_time(), wall_seconds(), ros_now_ns()); }

void SimNode::observe_clock(double now) {
  const bool was_ready = clock_.ready();
  const NodeClock::Event e = clock_.observe(sim_time(), now, ros_now_ns());
  if (!clock_.ready() && !waiting_logged_) {
    ROS_INFO("corde_sim: waiting for a nonzero /clock (/use_sim_time is true)");
    waiting_logged_ = true;
  }
  if (e == NodeClock::Event::kStarted && !was_ready)
    ROS_INFO("corde_sim: /clock at %.6f s: simulation time %.6f s starts there",
             ros::Time::now().toSec(), sim_time());
  if (e == NodeClock::Event::kJumpedBack || e == NodeClock::Event::kJumpedForward) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "/clock jumped %s by %.6g s (to %.6f s): stamps re-anchored there, the "
                  "simulation goes on from its state (t = %.6f s)%s",
                  e == NodeClock::Event::kJumpedBack ? "back" : "forward",
                  std::abs(clock_.last_jump()), ros::Time::now().toSec(), sim_time(),
                  e == NodeClock::Event::kJumpedForward ? " instead of running the gap" : "");
    stats_.clock_note = text;
    ROS_WARN("corde_sim: %s", text);
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
  stats_.step_cpu_total += thread_cpu_seconds() - c0;
  refresh_if_grasps_changed();
  stats_.steps_total += k;
  stats_.steps_since_stats += k;
  stats_.step_wall_since_stats += dt;
  stats_.steps_last_iteration = k;
  return k;
}

void SimNode::advance(double now) {
  if (guard_.failed()) {
    // Stopped at the last good state: the clock goes on (tf and /clock listeners see the state
    // held, not a frozen time) and the state is published as it is until a reset or configure.
    const long due =
        clock_.paced() ? clock_.steps_due(sim_time(), now, ros_now_ns(), world_.time_step) : 1;
    time_offset_ += static_cast<double>(std::max(0L, due)) * world_.time_step;
    if (!clock_.paced()) anchor_clock();
    return;
  }
  if (clock_.paced()) {
    const long due = clock_.steps_due(sim_time(), now, ros_now_ns(), world_.time_step);
    // The steps due may take a few loop periods (from when they were first due); beyond that the
    // simulation cannot keep up, and the backlog is dropped instead of growing (the measured
    // real-time factor shows it). A batch also stops at the next output and goes on after it, so
    // that no output waits for more than one step.
    const double budget = std::max(3.0 / params_.loop_rate, 0.02);
    const double budget_end = (clock_.behind_since() < 0.0 ? now : clock_.behind_since()) + budget;
    const double end = std::max(std::min(budget_end, outputs_.schedule().next_due()), now);
    const long done = due > 0 ? run_steps(due, end) : 0;
    const bool behind = done < due && !guard_.failed();
    stats_.lagging = behind && wall_seconds() >= budget_end;
    if (stats_.lagging) {
      // The backlog is dropped, and the state is stamped now: stamps do not drift behind.
      anchor_clock();
      ++stats_.backlog_drops;
    } else {
      clock_.set_behind(behind, now);
    }
  } else {
    // As fast as possible, in slices short enough to serve callbacks and outputs on time.
    const double slice_end = std::min(now + 0.005, outputs_.schedule().next_due());
    run_steps(std::numeric_limits<long>::max(), std::max(slice_end, now));
  }
  if (settle_guard()) check_holders_and_strain();
  refresh_if_grasps_changed();  // (the guard may have replayed a scripted grasp or release)
  if (!clock_.paced()) {
    // Unpaced: the state is stamped when it was computed, never ahead of ROS time.
    clock_.set_measured_rate(stats_.measured_rtf);
    anchor_clock();
  }
}

void SimNode::run_queued_steps(double now) {
  if (guard_.failed()) {
    sim_.drop_queued_steps();
    return;
  }
  // As a paced batch: a few loop periods at most, and not past the next output.
  const double budget = std::max(3.0 / params_.loop_rate, 0.02);
  const double end = std::max(std::min(now + budget, outputs_.schedule().next_due()), now);
  run_steps(sim_.queued_steps(), end);  // (each step takes one of the driver's queued steps)
  anchor_clock();  // ~step's states are stamped when computed (never ahead of ROS time)
  if (settle_guard()) {
    check_holders_and_strain();
  } else {
    ROS_WARN(
        "corde_sim: %ld queued ~step step(s) dropped: the stability guard stopped the "
        "simulation",
        sim_.drop_queued_steps());
  }
  refresh_if_grasps_changed();
  // (A call still waiting says so in its reply.)
  if (sim_.queued_steps() == 0 && !services_.step_call_waiting())
    ROS_INFO("corde_sim: queued ~step steps done at t = %.6f s", sim_time());
}

void SimNode::refresh_if_grasps_changed() {
  if (!layout_changed_) return;
  layout_changed_ = false;
  outputs_.refresh_layout();  // the grasp frames and markers follow the held grasps
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
    if (event.kind == corde::SimulationEvent::Kind::kStalled) {
      ROS_WARN("corde_sim: grasp '%s' at t = %g s: %s", event.grasp.c_str(), event.time,
               event.text.c_str());
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
    stats_.last_problem = e.message();
    if (e.kind == corde::GuardEvent::Kind::kUnrecoverable) {
      ROS_ERROR(
          "corde_sim: stability guard: %sno retry helped: %s. The simulation stopped at its "
          "last good state (published as it is); ~reset, or ~configure with a smaller "
          "time_step or another integrator, resumes it",
          when, e.message().c_str());
      continue;
    }
    ++stats_.recoveries;
    ROS_WARN_THROTTLE(1.0, "corde_sim: stability guard: %s%s (h/h_crit %.2f, limiting rod '%s')",
                      when, e.message().c_str(), stats_.stability_margin,
                      stats_.limiting_rod.c_str());
  }
}

std::string SimNode::restart_guard() {
  std::string note;
  if (guard_.failed())
    note =
        "; the simulation had stopped (stability guard: " + stats_.last_problem + ") and resumes";
  report_guard_events();
  holder_warnings_.clear();  // a new world's first lag is news again
  sim_.restart_guard();      // snapshots the world, the grasps and the scripts
  return note;
}

int SimNode::run() {
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  inputs_.wait_for_robot(params_.robot_start_timeout);
  double now = wall_seconds();
  // (Pacing starts here, not at construction: no backlog from the set-up.)
  clock_.start(clock_.source(), params_.real_time_factor, sim_time(), now, ros_now_ns());
  outputs_.schedule().set_rate(OutputSchedule::kTf, params_.tf_rate);
  outputs_.schedule().set_rate(OutputSchedule::kMarkers, params_.marker_rate);
  outputs_.schedule().set_rate(OutputSchedule::kState,
                               params_.state_rate > 0.0 ? params_.state_rate : 2.0);
  outputs_.schedule().start(now);
  stats_.sim_at_stats = sim_time();
  stats_.wall_at_stats = now;
  const double start_wall = now, start_cpu = process_cpu_seconds(), start_sim = sim_time();
  const unsigned long start_steps = stats_.steps_total;
  const double start_step_cpu = stats_.step_cpu_total;
  const double bench_end =
      params_.benchmark > 0.0 ? now + params_.benchmark : std::numeric_limits<double>::infinity();
  double output_wall_total = 0.0, output_wall_max = 0.0;
  loop_running_ = true;
  while (ros::ok()) {
    // Inputs: topic callbacks and tf-followed frames queue theirs; then every command waiting
    // (inputs, services, reconfigure) is applied, oldest first, before the steps.
    queue->callAvailable(ros::WallDuration(0));
    inputs_.update_tf_holders();
    inputs_.update_robot();
    obstacles_.update_frames();
    drain_commands();
    now = wall_seconds();
    observe_clock(now);
    // (Before an external /clock has started, nothing runs and nothing is stamped.)
    if (clock_.ready() && !sim_.paused())
      advance(now);
    else if (clock_.ready() && sim_.queued_steps() > 0)
      run_queued_steps(now);
    now = wall_seconds();
    if (services_.step_call_waiting()) services_.answer_step_call(now);
    if (clock_.ready()) outputs_.publish_due(now);
    outputs_.update_diagnostics(now);
    const double out_wall = wall_seconds() - now;
    output_wall_total += out_wall;
    output_wall_max = std::max(output_wall_max, out_wall);
    if (now >= bench_end) break;
    double wake = now;
    if (sim_.paused() && sim_.queued_steps() > 0)
      wake = now;  // more queued steps: only the callbacks waiting now are served
    else if (sim_.paused())
      wake = std::min(outputs_.schedule().next_due(),
                      now + 0.05);  // rod_state keeps its rate while paused
    else if (clock_.paced() && clock_.behind_since() < 0.0)  // (steps still due: no sleep)
      wake = std::min(outputs_.schedule().next_due(), now + 1.0 / params_.loop_rate);
    if (wake > now) queue->callAvailable(ros::WallDuration(wake - now));
  }
  close_commands();
  if (params_.benchmark > 0.0) {
    ROS_INFO(
        "corde_sim benchmark: outputs (tf, markers, state, clock, diagnostics) took %.3f s "
        "in all, %.2f ms at most per loop iteration",
        output_wall_total, 1e3 * output_wall_max);
    return benchmark_report(wall_seconds() - start_wall, process_cpu_seconds() - start_cpu,
                            stats_.steps_total - start_steps, sim_time() - start_sim,
                            stats_.step_cpu_total - start_step_cpu);
  }
  return 0;
}

int SimNode::benchmark_report(double wall, double cpu, unsigned long steps, double sim,
                              double step_cpu) {
  // The bare library on the same scene: the same number of steps in a tight loop, no ROS.
  corde::World bare = scene_.initial().world;
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

void SimNode::check_holders_and_strain() {
  // One warning when a holder starts to lag (not one every few seconds while it lags); a holder
  // that flickers in and out of its limits warns at most every kHolderWarnGap seconds.
  constexpr double kHolderWarnGap = 5.0;
  const double now = wall_seconds();
  for (const auto& kv : grasps_.grasps()) {
    const corde::GraspState& g = kv.second;
    HolderWarning& w = holder_warnings_[kv.first];
    if (!g.clip.any()) {
      w.lagging = false;
      continue;
    }
    if (!w.lagging && !(now - w.last_wall < kHolderWarnGap))
      ROS_WARN(
          "corde_sim: grasp '%s': holder motion limited to %s (it lags its commanded pose; "
          "~holder_max_speed %g m/s, ~holder_max_acceleration %g m/s^2)",
          kv.first.c_str(), g.clip.speed ? "the speed limit" : "the acceleration limit",
          params_.holder_max_speed, params_.holder_max_acceleration);
    if (!w.lagging) w.last_wall = now;
    w.lagging = true;
    grasps_.find(kv.first)->clip = corde::HolderClip();
  }
  // strain_warning_ stays until the next diagnostics report (diagnose() clears it), so that a short
  // overstretch (which may end with a slip) is still reported.
  for (size_t r = 0; r < world_.rods().size(); ++r) {
    const corde::Rod& rod = world_.rods()[r];
    const double limit = rod.section().max_strain;
    if (!(limit > 0.0)) continue;
    int seg = 0;
    const double strain = rod.max_stretch_strain(&seg);
    if (strain <= limit) continue;
    stats_.strain_warning = "rod '" + rod.name() + "' stretched by " + num(100.0 * strain) +
                            "% at segment " + std::to_string(seg) +
                            ", above its material's max_strain " + num(100.0 * limit) +
                            "% (length " + num(rod.length()) + " m)";
    ROS_WARN_THROTTLE(2.0, "corde_sim: %s", stats_.strain_warning.c_str());
    if (params_.strain_action != StrainAction::kSlip) continue;
    // The holder nearest to the overstretched segment lets go, as a real grip slips first there.
    std::string nearest;
    int best = 1 << 30;
    for (const auto& kv : grasps_.grasps())
      if (kv.second.held && kv.second.rod == static_cast<int>(r) &&
          std::abs(kv.second.grasp.segment - seg) < best) {
        best = std::abs(kv.second.grasp.segment - seg);
        nearest = kv.first;
      }
    if (!nearest.empty()) {
      sim_.submit(corde::Command::release(world_.time(), nearest));
      sim_.apply_due();
      scene_.end_script(nearest, "slipped");
      // As a release by service: a rollback must not hold the segment again (grasps_ goes back
      // with the world), the node having said that it slipped.
      sim_.mark_good();
      ROS_WARN("corde_sim: grasp '%s' slipped (~strain_action slip): %s", nearest.c_str(),
               stats_.strain_warning.c_str());
      outputs_.refresh_layout();
    }
  }
}

}  // namespace corde_sim
