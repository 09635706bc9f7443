// Pass (b) of the scene loader (scene_passes.h): the rods, contact settings, obstacles and grasps
// read from their entries and built into the world, each entry against the rods built before it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "corde_sim/stability/explicit_step_limit.h"
#include "scene_passes.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

// Which entry constrains each node and segment of a rod, to reject conflicting constraints.
struct Owners {
  std::map<int, std::string> node, segment;
  std::string ghost[2];

  void claim(std::map<int, std::string>* owners, int index, const char* what, const Value& v,
             const std::string& owner) {
    auto it = owners->find(index);
    if (it != owners->end())
      v.fail(std::string(what) + " " + std::to_string(index) + " is already constrained by " +
             it->second);
    (*owners)[index] = owner;
  }
};

// "start", "end" or an index in [0, count).
int read_index(const Value& v, int count, const char* what) {
  return resolve_index(describe_index(v, what), count, what);
}

// The one mode an entry gives among `modes` and a keyframed drive (keyframes, move_by, turns).
std::string entry_mode(const Map& b, const std::vector<std::string>& modes, bool motion_ok) {
  std::vector<std::string> present;
  for (const std::string& k : modes)
    if (b.has(k)) present.push_back(k);
  if (motion_ok && has_motion(b)) present.push_back("motion");
  if (present.size() == 1) return present[0];
  std::string list;
  for (const std::string& k : modes) list += k + ", ";
  list += motion_ok ? "keyframes, move_by or turns" : "";
  b.fail(present.empty() ? "needs one of " + list : "give only one of " + list);
}

// Where and how an entry drives: the item's start and what its keyframes may move.
MotionStart start_of(const Rod& rod, int node, int seg, bool translates, bool rotates) {
  MotionStart m;
  m.position = rod.positions()[node];
  m.orientation = rod.orientations()[seg];
  m.tangent = director3(m.orientation);
  m.translates = translates;
  m.rotates = rotates;
  return m;
}

void read_boundary(const Value& entry, Rod* rod, Owners* owners, const std::string& base,
                   Support* support) {
  Map b(entry);
  const std::string kind = b.one_of({"node", "segment", "clamp"});
  const std::string owner = entry.path();
  const int n = rod->num_segments();
  support->rod = rod->name();
  support->name = rod->name() + "/" + owner.substr(owner.rfind('.') + 1);
  if (kind == "node") {
    const Value nv = b.get("node");
    const int node = read_index(nv, n + 1, "node");
    support->nodes = {node};
    owners->claim(&owners->node, node, "node", nv, owner);
    const std::string mode = entry_mode(b, {"fix", "velocity", "line", "plane"}, true);
    if (mode == "line" || mode == "plane") {
      NodeConstraint c;
      c.kind = mode == "line" ? NodeConstraint::Kind::kLine : NodeConstraint::Kind::kPlane;
      c.node = node;
      c.point = rod->positions()[node];
      c.direction = b.get(mode).nonzero_vec3();
      rod->add_node_constraint(c);
      b.finish();
      return;
    }
    NodeDrive d;
    d.node = node;
    d.origin = d.pivot = rod->positions()[node];
    if (mode == "fix") {
      const Value f = b.get("fix");
      if (!f.boolean()) f.fail("must be true (leave the entry out for a free node)");
      d.kind = NodeDrive::Kind::kFixed;
    } else if (mode == "velocity") {
      d.kind = NodeDrive::Kind::kVelocity;
      d.velocity = b.get("velocity").vec3(SceneBounds::max_speed, "m/s");
      if (auto t = b.find("start_time")) d.t_start = t->non_negative(SceneBounds::max_time, "s");
    } else {
      d.kind = NodeDrive::Kind::kMotion;
      d.motion = read_motion(&b, start_of(*rod, node, std::min(node, n - 1), true, false), base);
    }
    rod->add_node_drive(d);
  } else if (kind == "segment") {
    const Value sv = b.get("segment");
    const int seg = read_index(sv, n, "segment");
    support->segments = {seg};
    owners->claim(&owners->segment, seg, "segment", sv, owner);
    const std::string mode = entry_mode(b, {"fix", "spin_rate", "free_axis"}, true);
    if (mode == "free_axis") {
      SegmentConstraint c;
      c.segment = seg;
      c.origin = rod->orientations()[seg];
      const Value a = b.get("free_axis");
      c.axis =
          a.is_scalar() && a.node().Scalar() == "tangent" ? director3(c.origin) : a.nonzero_vec3();
      rod->add_segment_constraint(c);
      b.finish();
      return;
    }
    SegmentDrive d;
    d.segment = seg;
    d.origin = rod->orientations()[seg];
    if (mode == "fix") {
      const Value f = b.get("fix");
      if (!f.boolean()) f.fail("must be true (leave the entry out for a free segment)");
      d.kind = SegmentDrive::Kind::kFixed;
    } else if (mode == "spin_rate") {
      d.kind = SegmentDrive::Kind::kSpin;
      d.rate =
          b.get("spin_rate")
              .within(-SceneBounds::max_angular_speed, SceneBounds::max_angular_speed, "rad/s");
      if (auto t = b.find("start_time")) d.t_start = t->non_negative(SceneBounds::max_time, "s");
    } else {
      d.kind = SegmentDrive::Kind::kMotion;
      d.motion = read_motion(&b, start_of(*rod, seg, seg, false, true), base);
    }
    rod->add_segment_drive(d);
  } else {
    const Value cv = b.get("clamp");
    const bool end = cv.choice({"start", "end"}) == "end";
    support->name = rod->name() + "/clamp " + (end ? "end" : "start");
    std::string how = "ghost";
    if (auto k = b.find("kind")) how = k->choice({"natural", "ghost"});
    const int node = end ? n : 0, seg = end ? n - 1 : 0;
    support->nodes = {node};
    const Quat frame = rod->orientations()[seg];
    const Vec3 tangent = director3(frame);
    std::optional<Value> slide = b.find("slide");
    bool twist_free = false;
    if (auto t = b.find("twist")) twist_free = t->choice({"held", "free"}) == "free";
    if (twist_free && how != "natural")
      b.fail("twist: free needs kind: natural (a ghost clamp holds the end frame fully)");
    if (slide && has_motion(b)) slide->fail("a sliding clamp cannot also be moved by keyframes");
    const std::shared_ptr<const Motion> motion =
        read_motion(&b, start_of(*rod, node, seg, true, !twist_free), base);
    owners->claim(&owners->node, node, "node", cv, owner);
    if (slide && !(slide->is_scalar() && slide->node().Scalar() == "false")) {
      NodeConstraint c;
      c.kind = NodeConstraint::Kind::kLine;
      c.node = node;
      c.point = rod->positions()[node];
      c.direction = slide->is_scalar() && slide->boolean() ? tangent : slide->nonzero_vec3();
      rod->add_node_constraint(c);
    } else {
      NodeDrive nd;
      nd.node = node;
      nd.origin = nd.pivot = rod->positions()[node];
      if (motion) {
        nd.kind = NodeDrive::Kind::kMotion;
        nd.motion = motion;
      }
      rod->add_node_drive(nd);
    }
    if (how == "natural") {
      support->segments = {seg};
      owners->claim(&owners->segment, seg, "segment", cv, owner);
      if (twist_free) {
        rod->add_segment_constraint(SegmentConstraint{seg, frame, tangent, Vec3::Zero()});
      } else {
        SegmentDrive sd;
        sd.segment = seg;
        sd.origin = frame;
        if (motion) {
          sd.kind = SegmentDrive::Kind::kMotion;
          sd.motion = motion;
        }
        rod->add_segment_drive(sd);
      }
    } else {
      if (!owners->ghost[end].empty())
        cv.fail("the " + cv.node().Scalar() + " is already clamped by " + owners->ghost[end]);
      owners->ghost[end] = owner;
      support->ghost = end ? 1 : 0;
      GhostFrame& g = end ? rod->ghost_end() : rod->ghost_start();
      g.active = true;
      g.frame = g.origin = frame;
      g.uhat.setZero();
      g.motion = motion;
    }
  }
  b.finish();
}

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

// `rotational_inertia_scale`: a number >= 1, or auto (stability/explicit_step_limit.h,
// lifting_inertia_scale).
void read_inertia_scale(const Value& v, Rod* rod, std::vector<std::string>* notes) {
  double scale = 1.0;
  if (v.is_scalar() && v.node().Scalar() == "auto") {
    scale = lifting_inertia_scale(*rod);
    Rod scaled = *rod;
    scaled.set_rotational_inertia_scale(scale);
    char step[96];  // the rod's name may be long: only numbers go through the buffer
    std::snprintf(step, sizeof step, "explicit step limit %.3g s instead of %.3g s",
                  critical_time_step(scaled), critical_time_step(*rod));
    char sc[32];
    std::snprintf(sc, sizeof sc, "%.4g", scale);
    notes->push_back(v.path() + ": auto: " + sc + " (rod '" + rod->name() + "'): " + step);
  } else {
    scale = v.number();
    if (!(scale >= 1.0))
      v.fail("must be >= 1 (1 = physical rotary inertia) or auto, got " + num(scale));
    v.within(1.0, SceneBounds::max_factor, "");
  }
  rod->set_rotational_inertia_scale(scale);
}

struct RodEntry {
  std::string path;
  Owners owners;
  // `initial_state: equilibrium` (the rod's own key, or the scene's default): the key to name in
  // errors.
  std::optional<Value> equilibrium;
};

// Builds a rod from its description, then reads what needs the built rod: its initial
// velocities and boundary, then resolves its loads and reads rotational_inertia_scale.
void build_rod_entry(RodDescription* r, Scene* scene, std::vector<RodEntry>* entries,
                     const std::string& base) {
  Map& m = *r->map;
  Rod* rod = nullptr;
  try {
    rod = &scene->world.add_rod(build_rod(r->spec));
  } catch (const std::invalid_argument& e) {
    throw SceneError(r->path + ".shape: " + e.what());
  }
  {
    double length = 0.0;
    for (double l : rod->rest_lengths()) length += l;
    if (!(length >= SceneBounds::min_length && length <= SceneBounds::max_length))
      m.get("shape").fail("the rod's length " + num(length) + " m is outside " +
                          num(SceneBounds::min_length) + " .. " + num(SceneBounds::max_length) +
                          " m");
  }
  if (r->drag) rod->set_drag(*r->drag);
  if (r->contact) rod->contact_options() = *r->contact;
  if (auto i = m.find("initial")) read_initial(*i, rod);
  RodEntry entry{r->path, {}, r->equilibrium};
  if (auto b = m.find("boundary"))
    for (const Value& item : limited_items(*b, SceneLimits::max_items, "entries")) {
      Support support;
      read_boundary(item, rod, &entry.owners, base, &support);
      scene->supports.push_back(support);
    }
  for (const LoadDescription& l : r->loads) build_load(l, rod, &scene->warnings);
  // After the supports: `auto` reads the stability limits of the rod as it is held.
  if (auto p = m.find("rotational_inertia_scale")) read_inertia_scale(*p, rod, &scene->notes);
  m.finish();
  entries->push_back(std::move(entry));
}

GraspSpec read_grasp(const Value& v, const Scene& scene, std::vector<RodEntry>* entries,
                     std::map<std::string, std::string>* names, const std::string& base) {
  Map m(v);
  GraspSpec g;
  const Value nv = m.get("name");
  g.name = nv.string();
  if (g.name.empty()) nv.fail("must not be empty");
  if (names->count(g.name))
    nv.fail("duplicate grasp name " + echo(g.name) + " (also " + names->at(g.name) + ")");
  (*names)[g.name] = v.path();
  const auto& rods = scene.world.rods();
  int r = 0;
  if (auto rv = m.find("rod")) {
    g.rod = rv->string();
    while (r < static_cast<int>(rods.size()) && rods[r].name() != g.rod) ++r;
    if (r == static_cast<int>(rods.size())) {
      std::string known;
      for (const Rod& rod : rods) known += (known.empty() ? "" : ", ") + rod.name();
      rv->fail("no rod named " + echo(g.rod) + " (rods: " + echo(known) + ")");
    }
  } else if (rods.size() == 1) {
    g.rod = rods[0].name();
  } else {
    throw SceneError(v.path() + ".rod: missing (required when the scene has several rods)");
  }
  const Rod& rod = rods[r];
  std::string place = "end";
  if (auto p = m.find("place")) place = p->choice({"start", "end", "node", "arc_length"});
  std::optional<Value> value = m.find("value");
  if (place == "start" || place == "end") {
    g.place = place == "start" ? GraspSpec::Place::kStart : GraspSpec::Place::kEnd;
    if (value) value->fail("only used with place: node or arc_length");
  } else {
    if (!value) throw SceneError(v.path() + ".value: missing (required with place: " + place + ")");
    if (place == "node") {
      g.place = GraspSpec::Place::kNode;
      g.value = read_index(*value, rod.num_nodes(), "node");
    } else {
      g.place = GraspSpec::Place::kArcLength;
      double total = 0.0;
      for (double l : rod.rest_lengths()) total += l;
      g.value = value->non_negative();
      if (g.value > total * (1.0 + 1e-12))
        value->fail("arc length " + num(g.value) + " m beyond the rod's length " + num(total) +
                    " m");
    }
  }
  if (auto p = m.find("hold_orientation")) g.hold_orientation = p->boolean();
  if (auto p = m.find("grip")) {  // a friction grasp (grasp/friction_grasp.h)
    Map grip(*p);
    g.grip.friction = true;
    g.grip.force = grip.get("force").non_negative(SceneBounds::max_force, "N");
    g.grip.mu = grip.get("mu").non_negative(SceneBounds::max_factor, "");
    grip.finish();
  }
  if (auto p = m.find("grasp_time")) g.grasp_time = p->non_negative(SceneBounds::max_time, "s");
  if (auto p = m.find("release_time")) {
    g.release_time = p->non_negative(SceneBounds::max_time, "s");
    if (!(g.release_time > g.grasp_time))
      p->fail(num(g.release_time) + " s is not after grasp_time " + num(g.grasp_time) +
              " s: a grasp lets go after it takes hold");
  }
  {
    const int seg = grasp_segment(rod, g);
    MotionStart start;
    start.position = 0.5 * (rod.positions()[seg] + rod.positions()[seg + 1]);
    start.orientation = rod.orientations()[seg];
    start.tangent = director3(start.orientation);
    start.time = g.grasp_time;
    g.motion_reference = segment_pose(rod, seg);
    g.motion = read_motion(&m, start, base);
  }
  m.finish();
  // A grasp drives its segment and both of its nodes: nothing else may.
  Owners& owners = (*entries)[r].owners;
  const int seg = grasp_segment(rod, g);
  const std::string owner = v.path() + " (grasp '" + g.name + "')";
  owners.claim(&owners.node, seg, "node", v, owner);
  owners.claim(&owners.node, seg + 1, "node", v, owner);
  if (g.hold_orientation) owners.claim(&owners.segment, seg, "segment", v, owner);
  return g;
}

}  // namespace

// The items of a list, failing when there are more than `limit` of them.
std::vector<Value> limited_items(const Value& list, int limit, const char* what) {
  if (list.is_sequence() && list.node().size() > static_cast<size_t>(limit))
    list.fail("has " + std::to_string(list.node().size()) + " " + what +
              ", more than the limit of " + std::to_string(limit));
  return list.items();
}

IndexRef describe_index(const Value& v, const char* what) {
  IndexRef ref;
  ref.key = v;
  if (v.is_scalar() && v.node().Scalar() == "start") return ref;
  ref.kind = IndexRef::Kind::kEnd;
  if (v.is_scalar() && v.node().Scalar() == "end") return ref;
  if (!v.is_scalar()) v.fail(std::string("expected a ") + what + " index, start or end");
  ref.kind = IndexRef::Kind::kIndex;
  try {
    ref.index = v.node().as<double>();
  } catch (const YAML::Exception&) {
    v.fail(std::string("expected a ") + what + " index, start or end, got " + v.describe());
  }
  return ref;
}

int resolve_index(const IndexRef& ref, int count, const char* what) {
  if (ref.kind == IndexRef::Kind::kStart) return 0;
  if (ref.kind == IndexRef::Kind::kEnd) return count - 1;
  const double d = ref.index;
  if (d != std::floor(d) || d < 0.0 || d > count - 1)
    ref.key.fail(std::string(what) + " index " + echo(ref.key.node().Scalar()) +
                 " out of range (0.." + std::to_string(count - 1) + ", start or end)");
  return static_cast<int>(d);
}

// `initial_state`: given (the shape and velocities as described) or equilibrium.
bool wants_equilibrium(const Value& v) {
  return v.choice({"given", "equilibrium"}) == "equilibrium";
}

Scene build_scene(SceneDescription* d, AutomaticRequests* requests) {
  Scene scene;
  scene.source = d->source;
  scene.name = d->name;
  scene.description = d->description;
  if (d->gravity) scene.world.gravity = *d->gravity;
  scene.world.integrator = d->integrator;
  if (d->time_step) scene.world.time_step = *d->time_step;
  scene.duration = d->duration;
  scene.mode = d->mode;
  scene.statics_time = d->statics_time;
  scene.warnings = d->warnings;

  std::vector<RodEntry> entries;
  for (RodDescription& r : d->rods) build_rod_entry(&r, &scene, &entries, d->base);
  if (d->contact) read_contact_settings(*d->contact, &scene.world.contact);
  if (d->obstacles) {
    std::vector<std::string> obstacle_paths, rod_paths;
    read_obstacles(*d->obstacles, &scene.world, d->base, &obstacle_paths);
    for (const RodEntry& e : entries) rod_paths.push_back(e.path);
    check_obstacles_at_start(scene.world, obstacle_paths, rod_paths);
  }
  if (d->grasps) {
    std::map<std::string, std::string> names;
    for (const Value& item : limited_items(*d->grasps, SceneLimits::max_grasps, "grasps")) {
      scene.grasps.push_back(read_grasp(item, scene, &entries, &names, d->base));
      const GraspSpec& spec = scene.grasps.back();
      if (spec.motion && spec.grasp_time + spec.motion->end_time() > spec.release_time)
        scene.warnings.push_back(
            item.path() + ".release_time: the grasp lets go at " + num(spec.release_time) +
            " s, before its last keyframe at " + num(spec.grasp_time + spec.motion->end_time()) +
            " s: the segment leaves with the holder's velocity then, the later keyframes move "
            "nothing");
      const int seg = grasp_segment(scene.world.rod(spec.rod), spec);
      Support support;
      support.name = spec.name;
      support.rod = spec.rod;
      support.nodes = {seg, seg + 1};
      if (spec.hold_orientation) support.segments = {seg};
      support.midpoint_of = seg;
      scene.supports.push_back(support);
    }
  }
  d->top->finish();
  requests->integrator_auto = d->integrator_auto;
  if (d->time_step) requests->time_step = d->time_step_key;
  for (size_t i = 0; i < entries.size(); ++i)
    if (entries[i].equilibrium)
      requests->equilibrium.push_back(
          {static_cast<int>(i), entries[i].path, *entries[i].equilibrium});
  return scene;
}

}  // namespace scene_detail
}  // namespace corde
