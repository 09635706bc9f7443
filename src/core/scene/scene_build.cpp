// Pass (b) of the scene loader (scene_passes.h): the world built from the scene's description
// alone: the rods with their initial velocities, boundary, loads and rotational inertia scale,
// then contact settings, obstacles and grasps, each entry's indices and keyframes resolved against
// its built rod.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "corde_sim/stability/explicit_step_limit.h"
#include "scene_passes.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

void build_load(const LoadDescription& d, Rod* rod, std::vector<std::string>* warnings) {
  Load l = d.load;
  const int n = rod->num_segments();
  if (l.kind == Load::Kind::kForce) {
    l.index = resolve_index(d.at, n + 1, "node");
    if (rod->node_drive(l.index))
      warnings->push_back(d.path + ": force on a driven node has no effect");
  } else {
    l.index = resolve_index(d.at, n, "segment");
    if (rod->segment_drive(l.index))
      warnings->push_back(d.path + ": torque on a driven segment has no effect");
  }
  rod->add_load(l);
}

// A point mass on its node; at an end node the body's inertia on the end segment.
void build_mass(const MassDescription& d, Rod* rod) {
  const int n = rod->num_segments();
  const int node = resolve_index(d.at, n + 1, "node");
  rod->add_node_mass(node, d.mass);
  for (const std::optional<Value>* key : {&d.inertia_key, &d.offset_key})
    if (*key && node != 0 && node != n)
      (*key)->fail(std::string(key == &d.inertia_key ? "a rotary inertia" : "an offset") +
                   " needs an end node (start or end: the body is fixed to the end segment), got "
                   "node " +
                   std::to_string(node));
  double across = d.inertia_across, along = d.inertia_along;
  if (d.offset_key) {
    // The centre of mass off the node: at most 10 rod lengths (a longer one is a typo), its
    // weight's torque on the end segment exact, its inertia about the node by the parallel axis
    // (the two across terms averaged: the segments are axisymmetric).
    double length = 0.0;
    for (double l : rod->rest_lengths()) length += l;
    if (!(d.offset.norm() <= 10.0 * length))
      d.offset_key->fail("must be at most 10 times the rod's length (" +
                         scene_detail::num(10.0 * length) + " m), got a length of " +
                         scene_detail::num(d.offset.norm()) + " m");
    const Vec3 o = d.offset;
    across += d.mass * (0.5 * (o.x() * o.x() + o.y() * o.y()) + o.z() * o.z());
    along += d.mass * (o.x() * o.x() + o.y() * o.y());
    if (o != Vec3::Zero()) rod->add_mass_offset(node, d.mass, o);
  }
  if (!d.inertia_key && !d.offset_key) return;
  rod->add_segment_inertia(node == 0 ? 0 : n - 1, Vec3(across, across, along));
}

// The density ranges as factors on the section's mass per length, each segment taking the mean
// density over its rest length (mass conserved: a range boundary inside a segment splits it).
void build_density(const std::vector<DensityRange>& ranges, const Section& section, Rod* rod) {
  if (ranges.empty()) return;
  const std::vector<double>& rest = rod->rest_lengths();
  double length = 0.0;
  for (double l : rest) length += l;
  for (const DensityRange& r : ranges)
    if (r.from >= length)
      r.key.fail("starts at " + num(r.from) + " m, beyond the rod's rest length " + num(length) +
                 " m");
  const double area = M_PI * section.radius * section.radius;
  std::vector<double> scale(rest.size());
  double s0 = 0.0;
  for (size_t s = 0; s < rest.size(); ++s) {
    const double s1 = s0 + rest[s];
    double covered = 0.0, mass = 0.0;  // per the section's density
    for (const DensityRange& r : ranges) {
      const double overlap = std::min(s1, r.to) - std::max(s0, r.from);
      if (overlap <= 0.0) continue;
      covered += overlap;
      mass += overlap * r.rho * area / section.mass_per_length;
    }
    scale[s] = (std::max(0.0, rest[s] - covered) + mass) / rest[s];
    s0 = s1;
  }
  rod->set_segment_mass_scale(scale);
}

// rotational_inertia_scale: auto gives the lifting scale of the rod as it is held
// (stability/explicit_step_limit.h, lifting_inertia_scale), noted under the key's `path`.
double auto_inertia_scale(const Rod& rod, const std::string& path,
                          std::vector<std::string>* notes) {
  const double scale = lifting_inertia_scale(rod);
  Rod scaled = rod;
  scaled.set_rotational_inertia_scale(scale);
  char step[96];  // the rod's name may be long: only numbers go through the buffer
  std::snprintf(step, sizeof step, "explicit step limit %.3g s instead of %.3g s",
                critical_time_step(scaled), critical_time_step(rod));
  char sc[32];
  std::snprintf(sc, sizeof sc, "%.4g", scale);
  notes->push_back(path + ": auto: " + sc + " (rod '" + rod.name() + "'): " + step);
  return scale;
}

struct RodEntry {
  std::string path;
  Owners owners;
  // `initial_state: equilibrium` (the rod's own key, or the scene's default): the key to name in
  // errors.
  std::optional<Value> equilibrium;
};

// Builds a rod from its description: the rod, its initial velocities, its boundary, its loads
// (indices resolved) and rotational_inertia_scale.
void build_rod_entry(const RodDescription& r, Scene* scene, std::vector<RodEntry>* entries) {
  Rod* rod = nullptr;
  try {
    rod = &scene->world.add_rod(build_rod(r.spec));
  } catch (const std::invalid_argument& e) {
    throw SceneError(r.path + ".shape: " + e.what());
  }
  {
    double length = 0.0;
    for (double l : rod->rest_lengths()) length += l;
    if (!(length >= SceneBounds::min_length && length <= SceneBounds::max_length))
      r.shape_key->fail("the rod's length " + num(length) + " m is outside " +
                        num(SceneBounds::min_length) + " .. " + num(SceneBounds::max_length) +
                        " m");
  }
  if (r.drag) rod->set_drag(*r.drag);
  if (r.contact) rod->contact_options() = *r.contact;
  if (r.initial) apply_initial(*r.initial, rod);
  RodEntry entry{r.path, {}, r.equilibrium};
  for (const BoundaryDescription& b : r.boundary) {
    Support support;
    build_boundary(b, rod, &entry.owners, &support);
    scene->supports.push_back(support);
  }
  for (const LoadDescription& l : r.loads) build_load(l, rod, &scene->warnings);
  build_density(r.density_ranges, r.spec.section, rod);
  scene->materials.push_back(r.origin);
  if (!r.density_ranges.empty()) scene->materials.back().mass = "";
  for (const MassDescription& m : r.masses) build_mass(m, rod);
  // After the supports: `auto` reads the stability limits of the rod as it is held.
  if (r.inertia_scale_auto)
    rod->set_rotational_inertia_scale(
        auto_inertia_scale(*rod, *r.inertia_scale_auto, &scene->notes));
  else if (r.inertia_scale)
    rod->set_rotational_inertia_scale(*r.inertia_scale);
  entries->push_back(std::move(entry));
}

}  // namespace

int resolve_index(const IndexRef& ref, int count, const char* what) {
  if (ref.kind == IndexRef::Kind::kStart) return 0;
  if (ref.kind == IndexRef::Kind::kEnd) return count - 1;
  const double d = ref.index;
  if (d != std::floor(d) || d < 0.0 || d > count - 1)
    ref.key.fail(std::string(what) + " index " + echo(ref.key.node().Scalar()) +
                 " out of range (0.." + std::to_string(count - 1) + ", start or end)");
  return static_cast<int>(d);
}

Scene build_scene(const SceneDescription& d, AutomaticRequests* requests) {
  Scene scene;
  scene.source = d.source;
  scene.name = d.name;
  scene.description = d.description;
  if (d.gravity) scene.world.gravity = *d.gravity;
  scene.world.gravity_ramp = d.gravity_ramp;
  scene.world.integrator = d.integrator;
  if (d.time_step) scene.world.time_step = *d.time_step;
  scene.duration = d.duration;
  scene.mode = d.mode;
  scene.statics_time = d.statics_time;
  scene.warnings = d.warnings;

  std::vector<RodEntry> entries;
  for (const RodDescription& r : d.rods) build_rod_entry(r, &scene, &entries);
  if (d.contact) scene.world.contact = *d.contact;
  if (d.obstacles) {
    scene.world.obstacles = std::make_shared<ObstacleSet>();
    for (const Obstacle& o : d.obstacles->obstacles) scene.world.obstacles->add(o);
    scene.world.obstacle_motions = d.obstacles->motions;
    std::vector<std::string> rod_paths;
    for (const RodEntry& e : entries) rod_paths.push_back(e.path);
    check_rods_clear_of_obstacles(scene.world, d.obstacles->paths, rod_paths);
  }
  for (const GraspDescription& g : d.grasps) {
    const Rod& rod = scene.world.rods()[g.rod];
    scene.grasps.push_back(build_grasp(g, rod, &entries[g.rod].owners));
    const GraspSpec& spec = scene.grasps.back();
    if (spec.motion && spec.grasp_time + spec.motion->end_time() > spec.release_time)
      scene.warnings.push_back(
          g.entry->path() + ".release_time: the grasp lets go at " + num(spec.release_time) +
          " s, before its last keyframe at " + num(spec.grasp_time + spec.motion->end_time()) +
          " s: the segment leaves with the holder's velocity then, the later keyframes move "
          "nothing");
    const int seg = grasp_segment(rod, spec);
    Support support;
    support.name = spec.name;
    support.rod = spec.rod;
    support.nodes = {seg, seg + 1};
    if (spec.hold_orientation) support.segments = {seg};
    support.midpoint_of = seg;
    scene.supports.push_back(support);
  }
  requests->integrator_auto = d.integrator_auto;
  if (d.time_step) requests->time_step = d.time_step_key;
  for (size_t i = 0; i < entries.size(); ++i)
    if (entries[i].equilibrium)
      requests->equilibrium.push_back(
          {static_cast<int>(i), entries[i].path, *entries[i].equilibrium});
  return scene;
}

}  // namespace scene_detail
}  // namespace corde
