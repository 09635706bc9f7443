// SimNode: the private services (reset, configure, pause, step, grasp, release).
#include <algorithm>
#include <cmath>
#include <limits>

#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/stability.h"

namespace corde_sim {

bool SimNode::on_reset(Reset::Request& req, Reset::Response& res) {
  const std::string path = req.scene.empty() ? scene_path_ : req.scene;
  corde::Scene scene;
  try {
    // The ~overrides apply to the scene file given at start-up only.
    scene = path == params_.scene ? corde::load_scene(path, params_.overrides)
                                  : corde::load_scene(path);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("scene not loaded, state unchanged: ") + e.what();
    return true;
  }
  // The new world starts at its own time 0; the node's clock continues from where it was.
  const double t = sim_time();
  const std::string error = install_scene(std::move(scene), path);
  if (!error.empty()) {
    res.success = false;
    res.message = "scene not used, state unchanged: " + error;
    return true;
  }
  time_offset_ = t;
  bump_time();
  pacer_.anchor(sim_time(), wall_seconds());
  res.success = true;
  res.message = "reset to '" + path + "' at t = " + num(sim_time()) + " s";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  publish_due(wall_seconds(), true);
  return true;
}

bool SimNode::on_configure(Configure::Request& req, Configure::Response& res) {
  ConfigurePlan plan;
  std::string error =
      plan_configure(world_, req.rod, req.keys, req.values, req.flags,
                     std::vector<bool>(req.flag_values.begin(), req.flag_values.end()), &plan);
  if (!error.empty()) {
    res.success = false;
    res.message = error;
    return true;
  }
  // Work on copies; keep them only if everything succeeds.
  corde::World world = world_;
  SimSettings settings = settings_;
  const double margin_before = stability_margin_;
  std::string summary;
  try {
    // A resampled rod loses its segment indices: take the grasps' drives off first, re-grasp
    // after (remake_grasps_on).
    for (auto& kv : grasps_)
      if (kv.second.held && std::find(plan.resample.begin(), plan.resample.end(),
                                      kv.second.grasp.rod) != plan.resample.end())
        corde::release(world.rods()[kv.second.rod_index], kv.second.grasp);
    summary = apply_configure(plan, &world, &settings);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("rejected, nothing changed: ") + e.what();
    return true;
  }
  double margin = 0.0;
  std::string limiting;
  for (const corde::Rod& rod : world.rods()) {
    const double m = world.time_step / corde::critical_time_step(rod);
    if (m > margin) {
      margin = m;
      limiting = rod.name();
    }
  }
  if (!std::isfinite(margin) || margin > std::max(1.0, margin_before)) {
    res.success = false;
    res.message = "rejected, nothing changed: time_step " + num(world.time_step) +
                  " s would exceed the stability limit of rod '" + limiting + "' (h/h_crit " +
                  num(margin) + "); give a smaller time_step in the same request";
    return true;
  }
  std::swap(world_, world);
  settings_ = settings;
  for (const std::string& rod : plan.resample) remake_grasps_on(rod);
  last_good_ = world_;
  bump_time();
  refresh_layout();
  res.success = true;
  res.message = "configured " +
                (req.rod.empty() ? std::string("all rods") : "rod '" + req.rod + "'") + ": " +
                summary + "(h/h_crit " + num(stability_margin_) + ")";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  publish_due(wall_seconds(), true);
  return true;
}

bool SimNode::on_pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  if (paused_ != static_cast<bool>(req.data)) {
    paused_ = req.data;
    if (!paused_) pacer_.anchor(sim_time(), wall_seconds());  // no backlog from the pause
  }
  res.success = true;
  res.message = std::string(paused_ ? "paused" : "running") + " at t = " + num(sim_time()) + " s";
  return true;
}

bool SimNode::on_step(Step::Request& req, Step::Response& res) {
  res.time = sim_time();
  if (!paused_) {
    res.success = false;
    res.message = "not paused: call ~pause with data: true first";
    return true;
  }
  if (req.steps < 1 || req.steps > 10000000) {
    res.success = false;
    res.message = "steps must be in [1, 10000000], got " + std::to_string(req.steps);
    return true;
  }
  update_tf_holders();
  run_steps(req.steps, std::numeric_limits<double>::infinity());
  const int before = recoveries_;
  check_finite();
  res.time = sim_time();
  res.success = recoveries_ == before;
  res.message = res.success ? "stepped " + std::to_string(req.steps) + " step(s)"
                            : "the state became non-finite; restored the last good state";
  publish_due(wall_seconds(), true);
  return true;
}

bool SimNode::on_grasp(Grasp::Request& req, Grasp::Response& res) {
  res.segment = -1;
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
    // Nearest segment midpoint; grasped by node index (segment k is node k's segment).
    int best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (int s = 0; s < rod->num_segments(); ++s) {
      const double d = (0.5 * (rod->positions()[s] + rod->positions()[s + 1]) - p).squaredNorm();
      if (d < best_d) {
        best_d = d;
        best = s;
      }
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
  bump_time();
  refresh_layout();
  publish_due(wall_seconds(), true);
  return true;
}

bool SimNode::on_release(Release::Request& req, Release::Response& res) {
  auto it = grasps_.find(req.name);
  if (it == grasps_.end() || !it->second.held) {
    res.success = false;
    res.message = it == grasps_.end() ? "no grasp named '" + req.name + "'"
                                      : "grasp '" + req.name + "' is already released";
    return true;
  }
  ActiveGrasp& g = it->second;
  corde::release(world_.rods()[g.rod_index], g.grasp);
  g.held = false;
  g.twist_rate = 0.0;
  res.success = true;
  res.message = "released grasp '" + req.name + "'";
  ROS_INFO("corde_sim: %s", res.message.c_str());
  bump_time();
  refresh_layout();
  publish_due(wall_seconds(), true);
  return true;
}

}  // namespace corde_sim
