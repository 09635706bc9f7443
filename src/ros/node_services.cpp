// NodeServices: the private services (reset, configure, pause, step, grasp, release,
// list_grasps). Each callback runs on a service thread and waits for its command to be applied by
// the loop (command_queue.h).
#include "corde_sim/ros/node_services.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "corde_sim/integrators/integrator_names.h"
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
  // implicit_euler in about 0.1 s at 8000 elements, 8 s at 100000). A hundred times the limit
  // refuses a hopeless request without stepping it (the trial step below could take many
  // seconds); below that the trial step decides. (Ten times refused sane requests: a small
  // world's step is mostly fixed cost, and on a loaded machine 0.05 ms at 10 elements scaled by
  // 150^2 read 1.1 s for a 1500-element scene whose steps take 10 ms.)
  const long before = std::max(1L, total_elements(current)), after = total_elements(candidate);
  if (after > before) {
    corde::World probe = current;
    probe.integrator = candidate.integrator;
    probe.time_step = candidate.time_step;
    const double now = trial_step_seconds(probe);
    const double ratio = static_cast<double>(after) / static_cast<double>(before);
    const double estimate = now * ratio * ratio;
    if (estimate > 100.0 * allowed)
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

// Where ~grasp's request takes hold of `rod`: the node nearest to its point (within
// max_distance), or its arc length. "" or why not.
std::string grasp_place(const Grasp::Request& req, const corde::Rod& rod, double max_distance,
                        corde::GraspSpec* spec) {
  if (req.use_point) {
    const Eigen::Vector3d p(req.point.x, req.point.y, req.point.z);
    if (!p.allFinite()) return "point is not finite";
    // Nearest point of the centreline; grasped by node index (segment k is node k's segment).
    int best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (int s = 0; s < rod.num_segments(); ++s) {
      const Eigen::Vector3d a = rod.positions()[s], ab = rod.positions()[s + 1] - a;
      const double u = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
      const double d = (a + u * ab - p).norm();
      if (d < best_d) {
        best_d = d;
        best = s;
      }
    }
    if (best_d > max_distance)
      return "point is " + num(best_d) + " m from rod '" + req.rod +
             "' (nearest point of its centreline), farther than ~max_grasp_distance " +
             num(max_distance) + " m";
    spec->place = corde::GraspSpec::Place::kNode;
    spec->value = best;
  } else {
    double length = 0.0;
    for (double l : rod.rest_lengths()) length += l;
    if (!std::isfinite(req.arc_length) || req.arc_length < 0.0 || req.arc_length > length)
      return "arc_length " + num(req.arc_length) + " m is outside rod '" + req.rod +
             "' (rest length " + num(length) + " m)";
    spec->place = corde::GraspSpec::Place::kArcLength;
    spec->value = req.arc_length;
  }
  return "";
}

constexpr const char* kQueuedNote =
    "; they run while paused, in batches with rod_state and tf between them (unpausing or ~reset "
    "drops them)";

}  // namespace

void NodeServices::advertise(const ros::NodeHandle& pnh) {
  threads_ = std::make_unique<ServiceThreads>(pnh);
  threads_->advertise("reset", &NodeServices::on_reset, this);
  threads_->advertise("configure", &NodeServices::on_configure, this);
  threads_->advertise("pause", &NodeServices::on_pause, this);
  threads_->advertise("step", &NodeServices::on_step, this);
  threads_->advertise("grasp", &NodeServices::on_grasp, this);
  threads_->advertise("release", &NodeServices::on_release, this);
  threads_->advertise("list_grasps", &NodeServices::on_list_grasps, this);
  threads_->advertise("add_obstacle", &NodeObstacles::on_add, &node_.obstacles_);
  threads_->advertise("remove_obstacle", &NodeObstacles::on_remove, &node_.obstacles_);
  threads_->advertise("list_obstacles", &NodeObstacles::on_list, &node_.obstacles_);
  threads_->advertise("set_grip", &NodeServices::on_set_grip, this);
}

void NodeServices::close() {
  if (!step_call_) return;
  step_call_->res->success = false;
  step_call_->res->message = "the node is shutting down";
  step_call_->reply->set();
  step_call_.reset();
}

std::string NodeServices::stopped_note() const {
  return node_.guard_.failed()
             ? "; the simulation is still stopped at its last good state (stability "
               "guard: " +
                   node_.stats_.last_problem + ")"
             : "";
}

bool NodeServices::on_reset(Reset::Request& req, Reset::Response& res) {
  reset(req, res);
  res.message = clip_reply(res.message);
  return true;
}

bool NodeServices::on_configure(Configure::Request& req, Configure::Response& res) {
  configure(req, res);
  res.message = clip_reply(res.message);
  return true;
}

void NodeServices::reset(Reset::Request& req, Reset::Response& res) {
  // On this thread: finding, reading and checking the scene (its statics and automatic choices
  // included) and a trial step. The loop installs it in one go (install_scene).
  RunningCopy now;
  if (!in_loop([&] {
        now.world = node_.world_;
        own_obstacles(&now.world);
        now.step_time_us = node_.stats_.step_time_us;
        now.stopped_note = stopped_note();
        now.scene_path = node_.scene_.path();
      })) {
    res.success = false;
    res.message = "the node is shutting down";
    return;
  }
  res.success = false;
  std::string path = now.scene_path;
  if (!req.scene.empty()) {
    std::string error;
    path = req.scene.size() > 4096 ? "" : node_.scene_.resolve_scene(req.scene, &error);
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
    scene = path == node_.params_.scene ? corde::load_scene(path, node_.params_.overrides)
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
        const double t = node_.sim_time();
        // (The driver drops the queued steps with its old world.)
        const long queued = node_.sim_.queued_steps();
        const std::string error = node_.scene_.install_scene(std::move(scene), path);
        if (!error.empty()) {
          res.message = "scene not used, state unchanged: " + error + stopped_note();
          return;
        }
        node_.time_offset_ = t;
        node_.bump_time();  // (stamped now: stamps back in step with ROS time)
        res.success = true;
        res.message = "reset to '" + clip(path) + "' at t = " + num(node_.sim_time()) + " s" +
                      node_.scene_.take_guard_note();
        if (queued > 0)
          res.message += "; dropped " + std::to_string(queued) + " queued ~step step(s)";
        ROS_INFO("corde_sim: %s", res.message.c_str());
      }))
    res.message = "the node is shutting down";
}

std::string NodeServices::configured_copy(const Configure::Request& req, corde::World* world,
                                          SimSettings* settings, std::vector<std::string>* resample,
                                          std::string* summary) const {
  ConfigurePlan plan;
  const std::string error = plan_configure(
      node_.world_, req.rod, req.keys, req.values, req.flags,
      std::vector<bool>(req.flag_values.begin(), req.flag_values.end()), req.integrator, &plan);
  if (!error.empty()) return error;
  *world = node_.world_;
  *settings = node_.settings_;
  try {
    // A resampled rod loses its segment indices: take the grasps' drives off first, re-grasp
    // after (GraspSet::remake_on).
    for (const auto& kv : node_.grasps_.grasps())
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
  if (!std::isfinite(margin) || margin > std::max(1.0, node_.stats_.stability_margin))
    return "rejected, nothing changed: time_step " + num(world->time_step) +
           " s would exceed the stability limit of rod '" + limiting + "' for " +
           corde::integrator_name(world->integrator) + " (h/h_crit " + num(margin) +
           "); give a smaller time_step in the same request, or integrator implicit_euler";
  *resample = plan.resample;
  return "";
}

void NodeServices::configure(Configure::Request& req, Configure::Response& res) {
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
          now.world = node_.world_;
          own_obstacles(&now.world);
        }
        now.step_time_us = node_.stats_.step_time_us;
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
    std::swap(node_.world_, world);
    node_.settings_ = settings;
    for (const std::string& rod : resample)
      for (size_t i = 0; i < node_.world_.rods().size(); ++i)
        if (node_.world_.rods()[i].name() == rod)
          node_.grasps_.remake_on(node_.world_, static_cast<int>(i));
    const std::string note = node_.restart_guard();
    node_.bump_time();
    node_.outputs_.refresh_layout();
    res.success = true;
    res.message = "configured " +
                  (req.rod.empty() ? std::string("all rods") : "rod '" + clip(req.rod) + "'") +
                  ": " + summary + "(" + corde::integrator_name(node_.world_.integrator) +
                  (!corde::has_explicit_step_limit(node_.world_.integrator)
                       ? std::string(", no explicit step limit")
                       : ", h/h_crit " + num(node_.stats_.stability_margin)) +
                  ")" + note;
    ROS_INFO("corde_sim: %s", res.message.c_str());
  });
  if (!applied) res.message = "the node is shutting down";
}

bool NodeServices::on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  if (!in_loop([&] { pause(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void NodeServices::pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  const long queued = node_.sim_.queued_steps();
  if (node_.sim_.paused() != static_cast<bool>(req.data)) {
    node_.sim_.set_paused(req.data);  // resuming drops the queued steps
    if (!node_.sim_.paused())
      node_.anchor_clock();  // no backlog from the pause, stamped from now on
  }
  res.success = true;
  res.message = std::string(node_.sim_.paused() ? "paused" : "running") +
                " at t = " + num(node_.sim_time()) + " s";
  if (!node_.sim_.paused() && queued > 0)
    res.message += "; dropped " + std::to_string(queued) + " queued ~step step(s)";
}

bool NodeServices::on_step(Step::Request& req, Step::Response& res) {
  // The loop answers once the steps are run (or after kStepCallSeconds, the rest queued).
  if (!node_.commands_.call([&](const ReplyPtr& reply) { start_step_call(req, &res, reply); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void NodeServices::start_step_call(const Step::Request& req, Step::Response* res,
                                   const ReplyPtr& reply) {
  res->time = node_.sim_time();
  res->success = false;
  const long queued = node_.sim_.queued_steps();
  if (!node_.sim_.paused())
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
  node_.sim_.queue_steps(req.steps);
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
  step_call_->steps_before = static_cast<long>(node_.stats_.steps_total);
  step_call_->detections_before = node_.stats_.recoveries;
  step_call_->answer_by = wall_seconds() + kStepCallSeconds;
}

void NodeServices::answer_step_call(double now) {
  StepCall& c = *step_call_;
  const bool stopped = node_.guard_.failed();
  const long queued = node_.sim_.queued_steps();
  if (queued > 0 && !stopped && node_.sim_.paused() && now < c.answer_by) return;
  Step::Response& res = *c.res;
  const long done = static_cast<long>(node_.stats_.steps_total) - c.steps_before;
  res.time = node_.sim_time();
  res.success = !stopped;
  const std::string stepped = "stepped " + std::to_string(done) + " step(s)";
  res.message = stopped ? "stopped at the last good state: the stability guard could not "
                          "recover (" +
                              node_.stats_.last_problem + "); ~reset or ~configure to resume"
                : node_.stats_.recoveries > c.detections_before
                    ? stepped + "; the stability guard rolled back and retried (" +
                          node_.stats_.last_problem + ")"
                    : stepped;
  if (!stopped && done < c.requested && queued == 0)
    res.message +=
        "; the other " + std::to_string(c.requested - done) + " were dropped (~pause, ~reset)";
  if (queued > 0) res.message += "; queued the other " + std::to_string(queued) + kQueuedNote;
  c.reply->set();  // (res belongs to the caller from here on)
  step_call_.reset();
}

bool NodeServices::on_grasp(Grasp::Request& req, Grasp::Response& res) {
  bool ok = true;
  if (!in_loop([&] { ok = grasp(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  res.message = clip_reply(res.message);
  return ok;
}

bool NodeServices::grasp(Grasp::Request& req, Grasp::Response& res) {
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
  if (!node_.grasps_.find(req.name) &&
      node_.grasps_.grasps().size() >= static_cast<size_t>(kMaxGrasps)) {
    res.success = false;
    res.message = "grasp '" + clip(req.name) + "' refused: the node has " +
                  std::to_string(node_.grasps_.grasps().size()) + " grasps, at most " +
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
  for (const corde::Rod& r : node_.world_.rods())
    if (r.name() == req.rod) rod = &r;
  if (!rod) {
    res.success = false;
    res.message = "no rod named '" + req.rod + "'";
    return true;
  }
  const std::string place = grasp_place(req, *rod, node_.params_.max_grasp_distance, &spec);
  if (!place.empty()) {
    res.success = false;
    res.message = place;
    return true;
  }
  int segment = -1;
  const std::string error =
      node_.scene_.add_grasp(spec, source, req.frame, /*from_scene=*/false, &segment);
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
  node_.sim_.mark_good();  // a rollback goes back to the grasp, not to before it
  node_.bump_time();
  node_.outputs_.refresh_layout();
  return true;
}

bool NodeServices::on_release(Release::Request& req, Release::Response& res) {
  if (!in_loop([&] { release(req, res); })) {
    res.success = false;
    res.message = "the node is shutting down";
  }
  return true;
}

void NodeServices::release(Release::Request& req, Release::Response& res) {
  if (req.name.size() > kMaxNameLength) {
    res.success = false;
    res.message = "no grasp named '" + clip(req.name) + "'";
    return;
  }
  const corde::GraspState* g = node_.grasps_.find(req.name);
  if (node_.scene_.waiting_to_take_hold(req.name)) {
    // A scene grasp waiting for its grasp_time: it will not take hold.
    node_.scene_.end_script(req.name, "was released (~release) before its grasp_time");
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
  node_.sim_.submit(corde::Command::release(node_.world_.time(), req.name));
  node_.sim_.apply_due();
  node_.scene_.end_script(req.name, "was released (~release)");
  res.success = true;
  res.message = "released grasp '" + req.name + "'";
  if (node_.scene_.forget_grasp(req.name)) res.message += " (made through ~grasp: its topics end)";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  node_.sim_.mark_good();
  node_.bump_time();
  node_.outputs_.refresh_layout();
}

bool NodeServices::on_list_grasps(ListGrasps::Request&, ListGrasps::Response& res) {
  return in_loop([&] { list_grasps(res); });  // (fails the call when the node shuts down)
}

void NodeServices::list_grasps(ListGrasps::Response& res) const {
  for (const auto& kv : node_.grasps_.grasps()) {
    const corde::GraspState& g = kv.second;
    auto w = node_.wiring_.find(kv.first);
    res.names.push_back(kv.first);
    res.rods.push_back(g.grasp.rod);
    res.segments.push_back(g.grasp.segment);
    res.arc_lengths.push_back(g.arc_length);
    // "scripted" while the scene's script (keyframes, grasp and release times) runs the grasp
    // (until an input for it).
    res.sources.push_back(w == node_.wiring_.end() ? ""
                          : w->second.scripted     ? "scripted"
                                                   : to_string(w->second.source));
    res.frames.push_back(w == node_.wiring_.end() ? "" : w->second.frame);
    res.held.push_back(g.held);
    res.holders.push_back(to_pose_msg(g.holder_pose()));
  }
}

bool NodeServices::in_loop(const std::function<void()>& fn) {
  return node_.commands_.call([&fn](const ReplyPtr& reply) {
    fn();
    reply->set();
  });
}

}  // namespace corde_sim
