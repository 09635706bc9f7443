// SimNode: the private services (reset, configure, pause, step, grasp, release). Each callback
// runs on a service thread and waits for its command to be applied by the loop (command_queue.h).
#include <algorithm>
#include <cmath>
#include <limits>

#include "corde_sim/io/file_read.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde_sim {
namespace {

long total_elements(const corde::World& world) {
  long n = 0;
  for (const corde::Rod& r : world.rods()) n += r.num_segments();
  return n;
}

// Wall time of one step of a copy of `world` (s).
double trial_step_seconds(const corde::World& world) {
  corde::World copy = world;
  const double t0 = wall_seconds();
  copy.step();
  return wall_seconds() - t0;
}

// `text` with every occurrence of `input` clipped (clip()).
std::string clip_all(std::string text, const std::string& input) {
  if (input.size() <= kMaxEcho) return text;
  const std::string short_form = clip(input);
  for (size_t at = text.find(input); at != std::string::npos;
       at = text.find(input, at + short_form.size()))
    text.replace(at, input.size(), short_form);
  return text;
}

// "" or why a world whose steps cost more than kMaxStepSeconds of wall time cannot be run:
// estimated from `current` (a copy of the world running now, whose steps took step_time_us) per
// element first (a hopeless request costs nothing), then measured by one step of a copy. Runs on
// a service thread: the trial steps never hold the loop.
std::string check_step_cost(const corde::World& candidate, const corde::World& current,
                            double step_time_us) {
  // A scene started with slower steps (start-up is not checked) may be reset and configured at
  // up to twice its measured cost.
  const double allowed = std::max(kMaxStepSeconds, 2e-6 * step_time_us);
  const std::string limit = "more than the " + num(allowed) +
                            " s per step the node allows (it serves its outputs between steps)";
  // More elements: first a rough estimate from a step of the world running now with the
  // candidate's integrator and step, scaled by the square of the element ratio (contacts and the
  // implicit solve grow faster than the element count: corde_run steps the overhand knot with
  // implicit_euler in about 0.1 s at 8000 elements, 8 s at 100000). Ten times the limit refuses a
  // hopeless request without stepping it (the trial step below could take seconds); below that
  // the trial step decides.
  const long before = std::max(1L, total_elements(current)), after = total_elements(candidate);
  if (after > before) {
    corde::World probe = current;
    probe.integrator = candidate.integrator;
    probe.time_step = candidate.time_step;
    const double now = trial_step_seconds(probe);
    const double ratio = static_cast<double>(after) / static_cast<double>(before);
    const double estimate = now * ratio * ratio;
    if (estimate > 10.0 * allowed)
      return "one step would take roughly " + num(estimate) + " s (" + num(1e3 * now) +
             " ms per step now at " + std::to_string(before) + " elements, times the square of " +
             std::to_string(after) + " / " + std::to_string(before) + "), " + limit;
  }
  const double measured = trial_step_seconds(candidate);
  if (measured > allowed)
    return "one step takes " + num(measured) + " s (measured on a trial step of " +
           std::to_string(after) + " elements), " + limit;
  return "";
}

// A copy of a world that another thread steps gets an obstacle set of its own (the obstacles
// copied, their meshes shared): a step poses the keyframed obstacles in its set.
void own_obstacles(corde::World* world) {
  if (!world->obstacles) return;
  auto set = std::make_shared<corde::ObstacleSet>();
  for (int i = 0; i < world->obstacles->size(); ++i) set->add(world->obstacles->obstacle(i));
  world->obstacles = set;
}

// What a service thread needs of the running simulation for its checks (copied in the loop).
struct RunningCopy {
  corde::World world;
  double step_time_us = 0.0;
  std::string stopped_note, scene_path;
};

constexpr const char* kQueuedNote =
    "; they run while paused, in batches with rod_state and tf between them (unpausing or ~reset "
    "drops them)";

}  // namespace

std::string SimNode::stopped_note() const {
  return guard_.failed() ? "; the simulation is still stopped at its last good state (stability "
                           "guard: " +
                               last_problem_ + ")"
                         : "";
}

bool SimNode::on_reset(Reset::Request& req, Reset::Response& res) {
  reset(req, res);
  res.message = clip_reply(res.message);
  return true;
}

bool SimNode::on_configure(Configure::Request& req, Configure::Response& res) {
  configure(req, res);
  res.message = clip_reply(res.message);
  return true;
}

void SimNode::reset(Reset::Request& req, Reset::Response& res) {
  // On this thread: finding, reading and checking the scene (its statics and automatic choices
  // included) and a trial step. The loop installs it in one go (install_scene).
  RunningCopy now;
  if (!in_loop([&] {
        now.world = world_;
        own_obstacles(&now.world);
        now.step_time_us = step_time_us_;
        now.stopped_note = stopped_note();
        now.scene_path = scene_path_;
      })) {
    res.success = false;
    res.message = "the node is shutting down";
    return;
  }
  res.success = false;
  std::string path = now.scene_path;
  if (!req.scene.empty()) {
    std::string error;
    path = req.scene.size() > 4096 ? "" : resolve_scene(req.scene, &error);
    if (path.empty()) {
      res.message = "scene not loaded, state unchanged: " +
                    (error.empty() ? "scene path '" + clip(req.scene) + "' is too long" : error) +
                    now.stopped_note;
      return;
    }
  }
  // A FIFO or device would block or never end (stat only: opening a FIFO blocks).
  const std::string unusable =
      corde::check_input_file(path, "scene file", corde::SceneLimits::max_file_bytes);
  if (!unusable.empty()) {
    res.message = "scene not loaded, state unchanged: " + clip(path) +
                  unusable.substr(std::min(path.size(), unusable.size())) + now.stopped_note;
    return;
  }
  corde::Scene scene;
  try {
    // The ~overrides apply to the scene file given at start-up only.
    scene = path == params_.scene ? corde::load_scene(path, params_.overrides)
                                  : corde::load_scene(path);
  } catch (const std::exception& e) {
    res.message =
        "scene not loaded, state unchanged: " + clip_all(e.what(), path) + now.stopped_note;
    return;
  }
  const std::string cost = check_step_cost(scene.world, now.world, now.step_time_us);
  if (!cost.empty()) {
    res.message = "scene not used, state unchanged: " + cost + now.stopped_note;
    return;
  }
  if (!in_loop([&] {
        // The new world starts at its own time 0; the node's clock continues from where it was.
        const double t = sim_time();
        const long queued = sim_.queued_steps();  // (the driver drops them with its old world)
        const std::string error = install_scene(std::move(scene), path);
        if (!error.empty()) {
          res.message = "scene not used, state unchanged: " + error + stopped_note();
          return;
        }
        time_offset_ = t;
        bump_time();
        pacer_.anchor(sim_time(), wall_seconds());
        res.success = true;
        res.message =
            "reset to '" + clip(path) + "' at t = " + num(sim_time()) + " s" + guard_note_;
        guard_note_.clear();
        if (queued > 0)
          res.message += "; dropped " + std::to_string(queued) + " queued ~step step(s)";
        ROS_INFO("corde_sim: %s", res.message.c_str());
      }))
    res.message = "the node is shutting down";
}

std::string SimNode::configured_copy(const Configure::Request& req, corde::World* world,
                                     SimSettings* settings, std::vector<std::string>* resample,
                                     std::string* summary) const {
  ConfigurePlan plan;
  const std::string error = plan_configure(
      world_, req.rod, req.keys, req.values, req.flags,
      std::vector<bool>(req.flag_values.begin(), req.flag_values.end()), req.integrator, &plan);
  if (!error.empty()) return error;
  *world = world_;
  *settings = settings_;
  try {
    // A resampled rod loses its segment indices: take the grasps' drives off first, re-grasp
    // after (GraspSet::remake_on).
    for (const auto& kv : grasps_.grasps())
      if (kv.second.held && std::find(plan.resample.begin(), plan.resample.end(),
                                      kv.second.grasp.rod) != plan.resample.end())
        corde::release(world->rods()[kv.second.rod], kv.second.grasp);
    *summary = apply_configure(plan, world, settings);
  } catch (const std::exception& e) {
    return std::string("rejected, nothing changed: ") + e.what();
  }
  // An explicit integrator must stay within its stability limit (or within the margin the scene
  // already ran at); the implicit one has none to check.
  std::string limiting;
  const double margin = explicit_margin(*world, &limiting);
  if (!std::isfinite(margin) || margin > std::max(1.0, stability_margin_))
    return "rejected, nothing changed: time_step " + num(world->time_step) +
           " s would exceed the stability limit of rod '" + limiting + "' for " +
           corde::integrator_name(world->integrator) + " (h/h_crit " + num(margin) +
           "); give a smaller time_step in the same request, or integrator implicit_euler";
  *resample = plan.resample;
  return "";
}

void SimNode::configure(Configure::Request& req, Configure::Response& res) {
  // The loop applies the request to a copy of the world; this thread times a step of it; the loop
  // then applies it again to the world as it is by then (it may have run on) and installs that.
  corde::World world;
  SimSettings settings;
  std::vector<std::string> resample;
  std::string summary, error;
  RunningCopy now;
  res.success = false;
  if (!in_loop([&] {
        error = configured_copy(req, &world, &settings, &resample, &summary);
        if (!error.empty()) error += stopped_note();
        if (error.empty()) {
          own_obstacles(&world);
          now.world = world_;
          own_obstacles(&now.world);
        }
        now.step_time_us = step_time_us_;
        now.stopped_note = stopped_note();
      })) {
    res.message = "the node is shutting down";
    return;
  }
  if (!error.empty()) {
    res.message = error;
    return;
  }
  const std::string cost = check_step_cost(world, now.world, now.step_time_us);
  if (!cost.empty()) {
    std::string asked;
    for (size_t i = 0; i < req.keys.size(); ++i)
      asked += (asked.empty() ? "" : ", ") + req.keys[i] + " " + num(req.values[i]);
    res.message = "rejected, nothing changed (" + asked + "): " + cost + now.stopped_note;
    return;
  }
  const bool applied = in_loop([&] {
    error = configured_copy(req, &world, &settings, &resample, &summary);
    if (!error.empty()) {
      res.message = error + stopped_note();
      return;
    }
    std::swap(world_, world);
    settings_ = settings;
    for (const std::string& rod : resample)
      for (size_t i = 0; i < world_.rods().size(); ++i)
        if (world_.rods()[i].name() == rod) grasps_.remake_on(world_, static_cast<int>(i));
    const std::string note = restart_guard();
    bump_time();
    refresh_layout();
    res.success = true;
    res.message = "configured " +
                  (req.rod.empty() ? std::string("all rods") : "rod '" + clip(req.rod) + "'") +
                  ": " + summary + "(" + corde::integrator_name(world_.integrator) +
                  (corde::is_implicit(world_.integrator) ? std::string(", no explicit step limit")
                                                         : ", h/h_crit " + num(stability_margin_)) +
                  ")" + note;
    ROS_INFO("corde_sim: %s", res.message.c_str());
  });
  if (!applied) res.message = "the node is shutting down";
}

bool SimNode::on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  if (!in_loop([&] { pause(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void SimNode::pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  const long queued = sim_.queued_steps();
  if (sim_.paused() != static_cast<bool>(req.data)) {
    sim_.set_paused(req.data);  // resuming drops the queued steps
    if (!sim_.paused()) pacer_.anchor(sim_time(), wall_seconds());  // no backlog from the pause
  }
  res.success = true;
  res.message =
      std::string(sim_.paused() ? "paused" : "running") + " at t = " + num(sim_time()) + " s";
  if (!sim_.paused() && queued > 0)
    res.message += "; dropped " + std::to_string(queued) + " queued ~step step(s)";
}

bool SimNode::on_step(Step::Request& req, Step::Response& res) {
  // The loop answers once the steps are run (or after kStepCallSeconds, the rest queued).
  if (!commands_.call([&](const ReplyPtr& reply) { start_step_call(req, &res, reply); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void SimNode::start_step_call(const Step::Request& req, Step::Response* res,
                              const ReplyPtr& reply) {
  res->time = sim_time();
  res->success = false;
  const long queued = sim_.queued_steps();
  if (!sim_.paused())
    res->message = "not paused: call ~pause with data: true first";
  else if (req.steps < 1 || req.steps > 10000000)
    res->message = "steps must be in [1, 10000000], got " + std::to_string(req.steps);
  else if (queued + req.steps > kMaxQueuedSteps)
    res->message = std::to_string(queued) + " step(s) are still queued; at most " +
                   std::to_string(kMaxQueuedSteps) + " may wait";
  if (!res->message.empty()) {
    reply->set();
    return;
  }
  sim_.queue_steps(req.steps);
  if (queued > 0) {  // after the ones waiting (their call was answered)
    res->success = true;
    res->message = "queued " + std::to_string(req.steps) + " step(s) behind " +
                   std::to_string(queued) + " still queued" + kQueuedNote;
    reply->set();
    return;
  }
  // Run by the loop in slices with the outputs between (run_queued_steps); answered by
  // answer_step_call().
  step_call_ = std::make_unique<StepCall>();
  step_call_->reply = reply;
  step_call_->res = res;
  step_call_->requested = req.steps;
  step_call_->steps_before = static_cast<long>(steps_total_);
  step_call_->detections_before = recoveries_;
  step_call_->answer_by = wall_seconds() + kStepCallSeconds;
}

void SimNode::answer_step_call(double now) {
  StepCall& c = *step_call_;
  const bool stopped = guard_.failed();
  const long queued = sim_.queued_steps();
  if (queued > 0 && !stopped && sim_.paused() && now < c.answer_by) return;
  Step::Response& res = *c.res;
  const long done = static_cast<long>(steps_total_) - c.steps_before;
  res.time = sim_time();
  res.success = !stopped;
  const std::string stepped = "stepped " + std::to_string(done) + " step(s)";
  res.message =
      stopped ? "stopped at the last good state: the stability guard could not "
                "recover (" +
                    last_problem_ + "); ~reset or ~configure to resume"
      : recoveries_ > c.detections_before
          ? stepped + "; the stability guard rolled back and retried (" + last_problem_ + ")"
          : stepped;
  if (!stopped && done < c.requested && queued == 0)
    res.message +=
        "; the other " + std::to_string(c.requested - done) + " were dropped (~pause, ~reset)";
  if (queued > 0) res.message += "; queued the other " + std::to_string(queued) + kQueuedNote;
  c.reply->set();  // (res belongs to the caller from here on)
  step_call_.reset();
}

bool SimNode::on_grasp(Grasp::Request& req, Grasp::Response& res) {
  bool ok = true;
  if (!in_loop([&] { ok = grasp(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  res.message = clip_reply(res.message);
  return ok;
}

bool SimNode::grasp(Grasp::Request& req, Grasp::Response& res) {
  res.segment = -1;
  // Names become topics and tf frames: bounded, and checked before anything echoes them whole.
  for (const auto& n :
       {std::make_pair(&req.name, "grasp name"), std::make_pair(&req.rod, "rod name"),
        std::make_pair(&req.frame, "frame"), std::make_pair(&req.source, "source")}) {
    const std::string error = check_name_length(*n.first, n.second);
    if (!error.empty()) {
      res.success = false;
      res.message = error;
      return true;
    }
  }
  if (!req.frame.empty() && !valid_frame_chars(req.frame)) {
    res.success = false;
    res.message = "frame '" + clip(req.frame) + "' has characters other than [A-Za-z0-9_/.-]";
    return true;
  }
  if (!grasps_.find(req.name) && grasps_.grasps().size() >= static_cast<size_t>(kMaxGrasps)) {
    res.success = false;
    res.message = "grasp '" + clip(req.name) + "' refused: the node has " +
                  std::to_string(grasps_.grasps().size()) + " grasps, at most " +
                  std::to_string(kMaxGrasps) + " (release a grasp made through ~grasp first)";
    return true;
  }
  GraspSource source = GraspSource::kTopic;
  try {
    if (!req.source.empty()) source = parse_grasp_source(req.source);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    return true;
  }
  corde::GraspSpec spec;
  spec.name = req.name;
  spec.rod = req.rod;
  spec.hold_orientation = true;
  const corde::Rod* rod = nullptr;
  for (const corde::Rod& r : world_.rods())
    if (r.name() == req.rod) rod = &r;
  if (!rod) {
    res.success = false;
    res.message = "no rod named '" + req.rod + "'";
    return true;
  }
  if (req.use_point) {
    const Eigen::Vector3d p(req.point.x, req.point.y, req.point.z);
    if (!p.allFinite()) {
      res.success = false;
      res.message = "point is not finite";
      return true;
    }
    // Nearest point of the centreline; grasped by node index (segment k is node k's segment).
    int best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (int s = 0; s < rod->num_segments(); ++s) {
      const Eigen::Vector3d a = rod->positions()[s], ab = rod->positions()[s + 1] - a;
      const double u = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
      const double d = (a + u * ab - p).norm();
      if (d < best_d) {
        best_d = d;
        best = s;
      }
    }
    if (best_d > params_.max_grasp_distance) {
      res.success = false;
      res.message = "point is " + num(best_d) + " m from rod '" + req.rod +
                    "' (nearest point of its centreline), farther than ~max_grasp_distance " +
                    num(params_.max_grasp_distance) + " m";
      return true;
    }
    spec.place = corde::GraspSpec::Place::kNode;
    spec.value = best;
  } else {
    double length = 0.0;
    for (double l : rod->rest_lengths()) length += l;
    if (!std::isfinite(req.arc_length) || req.arc_length < 0.0 || req.arc_length > length) {
      res.success = false;
      res.message = "arc_length " + num(req.arc_length) + " m is outside rod '" + req.rod +
                    "' (rest length " + num(length) + " m)";
      return true;
    }
    spec.place = corde::GraspSpec::Place::kArcLength;
    spec.value = req.arc_length;
  }
  int segment = -1;
  const std::string error = add_grasp(spec, source, req.frame, /*from_scene=*/false, &segment);
  if (!error.empty()) {
    res.success = false;
    res.message = error;
    return true;
  }
  res.success = true;
  res.segment = segment;
  res.message = "grasp '" + req.name + "' holds segment " + std::to_string(segment) + " of rod '" +
                req.rod + "' (source " + to_string(source) + ")";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  sim_.mark_good();  // a rollback goes back to the grasp, not to before it
  bump_time();
  refresh_layout();
  return true;
}

bool SimNode::on_release(Release::Request& req, Release::Response& res) {
  if (!in_loop([&] { release(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void SimNode::release(Release::Request& req, Release::Response& res) {
  if (req.name.size() > kMaxNameLength) {
    res.success = false;
    res.message = "no grasp named '" + clip(req.name) + "'";
    return;
  }
  const corde::GraspState* g = grasps_.find(req.name);
  if (waiting_to_take_hold(req.name)) {
    // A scene grasp waiting for its grasp_time: it will not take hold.
    end_script(req.name, "was released (~release) before its grasp_time");
    res.success = true;
    res.message = "grasp '" + req.name + "' will not take hold (its scene script ended)";
    ROS_INFO("corde_sim: %s", res.message.c_str());
    return;
  }
  if (!g || !g->held) {
    res.success = false;
    res.message =
        !g ? "no grasp named '" + req.name + "'" : "grasp '" + req.name + "' is already released";
    return;
  }
  // Through the driver, behind the inputs that arrived before it: a wrench sent before the
  // release applies first. Applied now, so that the reply and ~list_grasps show it.
  sim_.submit(corde::Command::release(world_.time(), req.name));
  sim_.apply_due();
  end_script(req.name, "was released (~release)");
  res.success = true;
  res.message = "released grasp '" + req.name + "'";
  if (forget_grasp(req.name)) res.message += " (made through ~grasp: its topics end)";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  sim_.mark_good();
  bump_time();
  refresh_layout();
}

bool SimNode::on_list_grasps(ListGrasps::Request&, ListGrasps::Response& res) {
  return in_loop([&] { list_grasps(res); });  // (fails the call when the node shuts down)
}

void SimNode::list_grasps(ListGrasps::Response& res) const {
  for (const auto& kv : grasps_.grasps()) {
    const corde::GraspState& g = kv.second;
    auto w = wiring_.find(kv.first);
    res.names.push_back(kv.first);
    res.rods.push_back(g.grasp.rod);
    res.segments.push_back(g.grasp.segment);
    res.arc_lengths.push_back(g.arc_length);
    // "scripted" while the scene's script (keyframes, grasp and release times) runs the grasp
    // (until an input for it).
    res.sources.push_back(w == wiring_.end()   ? ""
                          : w->second.scripted ? "scripted"
                                               : to_string(w->second.source));
    res.frames.push_back(w == wiring_.end() ? "" : w->second.frame);
    res.held.push_back(g.held);
    const Eigen::Isometry3d h = g.holder_pose();
    const Eigen::Quaterniond q(h.linear());
    geometry_msgs::Pose p;
    p.position.x = h.translation().x();
    p.position.y = h.translation().y();
    p.position.z = h.translation().z();
    p.orientation.x = q.x();
    p.orientation.y = q.y();
    p.orientation.z = q.z();
    p.orientation.w = q.w();
    res.holders.push_back(p);
  }
}

}  // namespace corde_sim
