#include "corde_sim/scene/scene.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/io/file_read.h"
#include "corde_sim/scene/automatic_choices.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/statics/scene_statics.h"
#include "scene_elements.h"
#include "scene_reader.h"

namespace corde {
namespace {

using scene_detail::echo;
using scene_detail::has_motion;
using scene_detail::Map;
using scene_detail::MotionStart;
using scene_detail::num;
using scene_detail::read_motion;
using scene_detail::Value;

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
  if (v.is_scalar() && v.node().Scalar() == "start") return 0;
  if (v.is_scalar() && v.node().Scalar() == "end") return count - 1;
  if (!v.is_scalar()) v.fail(std::string("expected a ") + what + " index, start or end");
  double d = 0.0;
  try {
    d = v.node().as<double>();
  } catch (const YAML::Exception&) {
    v.fail(std::string("expected a ") + what + " index, start or end, got " + v.describe());
  }
  if (d != std::floor(d) || d < 0.0 || d > count - 1)
    v.fail(std::string(what) + " index " + echo(v.node().Scalar()) + " out of range (0.." +
           std::to_string(count - 1) + ", start or end)");
  return static_cast<int>(d);
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

void read_load(const Value& entry, Rod* rod, std::vector<std::string>* warnings) {
  Map m(entry);
  Load l;
  const int n = rod->num_segments();
  if (m.one_of({"node", "segment"}) == "node") {
    l.kind = Load::Kind::kForce;
    l.index = read_index(m.get("node"), n + 1, "node");
    l.value = m.get("force").vec3(SceneBounds::max_force, "N");
    if (rod->node_drive(l.index))
      warnings->push_back(entry.path() + ": force on a driven node has no effect");
  } else {
    l.kind = Load::Kind::kTorque;
    l.index = read_index(m.get("segment"), n, "segment");
    l.value = m.get("torque").vec3(SceneBounds::max_torque, "N m");
    if (rod->segment_drive(l.index))
      warnings->push_back(entry.path() + ": torque on a driven segment has no effect");
  }
  if (auto t = m.find("ramp_time")) l.ramp_time = t->non_negative(SceneBounds::max_time, "s");
  if (auto t = m.find("start_time")) l.t_start = t->non_negative(SceneBounds::max_time, "s");
  if (auto k = m.find("kind")) l.follower = k->choice({"dead", "follower"}) == "follower";
  m.finish();
  rod->add_load(l);
}

// The items of a list, failing when there are more than `limit` of them.
std::vector<Value> limited_items(const Value& list, int limit, const char* what) {
  if (list.is_sequence() && list.node().size() > static_cast<size_t>(limit))
    list.fail("has " + std::to_string(list.node().size()) + " " + what +
              ", more than the limit of " + std::to_string(limit));
  return list.items();
}

// Air drag of a rod: the coefficients per unit length, or a fluid's density with the drag
// coefficients of the rod's cylinder (normal C_d, tangential skin friction C_f), which give
// q_n = rho C_d r (1/2 rho C_d times the diameter) and q_t = rho C_f pi r (1/2 rho C_f times the
// circumference). Bounded (scene/scene_bounds.h) so that these products stay finite.
Drag read_drag(const Value& v, double radius) {
  Map m(v);
  Drag d;
  constexpr double kMax = SceneBounds::max_coefficient;
  if (auto p = m.find("linear_normal")) d.linear_normal = p->non_negative(kMax, "N s/m^2");
  if (auto p = m.find("linear_tangential")) d.linear_tangential = p->non_negative(kMax, "N s/m^2");
  if (auto p = m.find("quadratic_normal")) d.quadratic_normal = p->non_negative(kMax, "N s^2/m^3");
  if (auto p = m.find("quadratic_tangential"))
    d.quadratic_tangential = p->non_negative(kMax, "N s^2/m^3");
  if (auto rho = m.find("fluid_density")) {
    if (m.has("quadratic_normal") || m.has("quadratic_tangential"))
      rho->fail("give either fluid_density or quadratic_normal/quadratic_tangential");
    const double density = rho->non_negative(SceneBounds::max_density, "kg/m^3");
    double cd = 1.2, cf = 0.0;
    if (auto p = m.find("drag_coefficient")) cd = p->non_negative(SceneBounds::max_factor, "");
    if (auto p = m.find("friction_coefficient")) cf = p->non_negative(SceneBounds::max_factor, "");
    d.quadratic_normal = density * cd * radius;
    d.quadratic_tangential = density * cf * M_PI * radius;
  } else if (m.has("drag_coefficient") || m.has("friction_coefficient")) {
    m.fail("drag_coefficient and friction_coefficient need fluid_density");
  }
  m.finish();
  return d;
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

// `initial_state`: given (the shape and velocities as described) or equilibrium.
bool wants_equilibrium(const Value& v) {
  return v.choice({"given", "equilibrium"}) == "equilibrium";
}

void read_rod(const Value& v, int index, Scene* scene, std::vector<RodEntry>* entries,
              const std::string& base, const std::optional<Value>& default_state) {
  Map m(v);
  RodSpec spec;
  spec.name = "rod" + std::to_string(index);
  if (auto p = m.find("name")) {
    spec.name = p->string();
    if (spec.name.empty()) p->fail("must not be empty");
    for (size_t i = 0; i < entries->size(); ++i)
      if (scene->world.rods()[i].name() == spec.name)
        p->fail("duplicate rod name " + echo(spec.name) + " (also " + (*entries)[i].path + ")");
  }
  std::optional<Value> elements = m.find("elements");
  if (elements) spec.elements = elements->integer(1, SceneLimits::max_elements);
  long total = spec.elements;
  for (const Rod& r : scene->world.rods()) total += r.num_segments();
  if (total > SceneLimits::max_total_elements)
    (elements ? *elements : v)
        .fail("the scene's rods would have " + std::to_string(total) +
              " elements together, more than the limit of " +
              std::to_string(SceneLimits::max_total_elements));
  spec.section = scene_detail::read_section(&m);
  spec.shape = scene_detail::read_shape(m.get("shape"));
  if (auto p = m.find("reference_d1")) spec.shape.reference_d1 = p->nonzero_vec3();
  if (auto p = m.find("rest_shape"))
    spec.rest_shape_created = p->choice({"straight", "created"}) == "created";
  Rod* rod = nullptr;
  try {
    rod = &scene->world.add_rod(build_rod(spec));
  } catch (const std::invalid_argument& e) {
    throw SceneError(v.path() + ".shape: " + e.what());
  }
  {
    double length = 0.0;
    for (double l : rod->rest_lengths()) length += l;
    if (!(length >= SceneBounds::min_length && length <= SceneBounds::max_length))
      m.get("shape").fail("the rod's length " + num(length) + " m is outside " +
                          num(SceneBounds::min_length) + " .. " + num(SceneBounds::max_length) +
                          " m");
  }
  if (auto d = m.find("drag")) rod->set_drag(read_drag(*d, spec.section.radius));
  if (auto c = m.find("contact")) scene_detail::read_rod_contact(*c, &rod->contact_options());
  std::optional<Value> state = m.find("initial_state");
  if (!state) state = default_state;
  const bool settle = state && wants_equilibrium(*state);
  if (auto i = m.find("initial")) {
    if (settle)
      state->fail("equilibrium starts " + v.path() +
                  " at rest in its equilibrium shape; remove its `initial` key (velocities, "
                  "perturbation) or set initial_state: given on the rod");
    scene_detail::read_initial(*i, rod);
  }
  RodEntry entry{v.path(), {}, settle ? state : std::nullopt};
  if (auto b = m.find("boundary"))
    for (const Value& item : limited_items(*b, SceneLimits::max_items, "entries")) {
      Support support;
      read_boundary(item, rod, &entry.owners, base, &support);
      scene->supports.push_back(support);
    }
  if (auto l = m.find("loads"))
    for (const Value& item : limited_items(*l, SceneLimits::max_items, "loads"))
      read_load(item, rod, &scene->warnings);
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

void check_time_step(Scene* scene, const Value* given) {
  const WorldStepLimit worst = explicit_step_limit(scene->world, false);
  const double limit = worst.time_step;
  const std::string which = worst.rod >= 0 ? scene->world.rods()[worst.rod].name() : "";
  if (!given) {
    // A degenerate rod (radius 1e-100) can give an infinite or zero limit: no step to run at.
    if (!(limit > 0.0 && std::isfinite(limit)))
      throw SceneError("time_step: auto: the estimated stability limit of rod '" + which + "' is " +
                       num(limit) +
                       " s, no step can be chosen; check the rod's "
                       "radius and material, or give time_step");
    scene->world.time_step = 0.8 * limit;
    return;
  }
  const double h = scene->world.time_step;
  if (h > limit)
    scene->warnings.push_back("time_step: " + num(h) + " s exceeds the estimated stability limit " +
                              num(limit) + " s of rod '" + which + "' (" + worst.limiting +
                              " modes); the run will likely blow up, use <= " + num(0.8 * limit) +
                              " s or time_step: auto");
}

// integrator: auto and time_step: auto for the implicit method (scene/automatic_choices.h); the
// explicit methods' step as check_time_step() has it.
void choose_step(Scene* scene, const Value* given, bool integrator_auto) {
  if (integrator_auto) {
    const IntegratorChoice c = choose_integrator(*scene, given ? scene->world.time_step : 0.0);
    scene->world.integrator = c.integrator;
    scene->world.time_step = c.time_step;
    scene->notes.push_back(c.reason);
  } else if (is_implicit(scene->world.integrator) && !given) {
    const ImplicitStepChoice s = implicit_time_step(*scene);
    scene->world.time_step = s.time_step;
    scene->notes.push_back("time_step: auto chose " + num(s.time_step) + " s for " +
                           integrator_name(scene->world.integrator) + ", set by " + s.why);
  }
  // The implicit methods have no stability limit to check.
  if (!is_implicit(scene->world.integrator)) check_time_step(scene, given);
}

std::string stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = base.find_last_of('.');
  return dot == std::string::npos || dot == 0 ? base : base.substr(0, dot);
}

Scene build_scene(const YAML::Node& root, const std::string& source);

}  // namespace

Scene parse_scene(const std::string& yaml_text, const std::vector<std::string>& overrides,
                  const std::string& source) {
  YAML::Node root;
  // yaml-cpp takes a lone CR for an ordinary character (the whole file would be one line); YAML
  // reads it as a line break, and so do we.
  // A UTF-8 byte order mark (as some editors write) is not part of the text.
  std::string text = yaml_text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? yaml_text.substr(3) : yaml_text;
  for (size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n')) text[i] = '\n';
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw SceneError(source + ":" + std::to_string(e.mark.line + 1) + ":" +
                     std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  const std::vector<std::string> set = scene_detail::apply_overrides(&root, overrides);
  try {
    std::vector<std::string> notes;
    if (scene_detail::has_auto_elements(root))
      notes = scene_detail::choose_elements(
          &root, [&](const YAML::Node& tree) { return build_scene(tree, source); });
    Scene scene = build_scene(root, source);
    scene.notes.insert(scene.notes.begin(), notes.begin(), notes.end());
    return scene;
  } catch (const SceneError& e) {
    // Values from overrides carry line numbers of their own one-line text: name the override.
    std::string msg = e.what();
    const std::string path = msg.substr(0, msg.find(": "));
    for (size_t i = set.size(); i-- > 0;) {  // the last override of a key is the one in effect
      const std::string& p = set[i];
      if (path.compare(0, p.size(), p) != 0 ||
          (path.size() > p.size() && path[p.size()] != '.' && path[p.size()] != '['))
        continue;
      const size_t line = msg.rfind(" (line ");
      if (line != std::string::npos) msg.erase(line);
      throw SceneError(msg + " (set by override '" + overrides[i] + "')");
    }
    throw;
  }
}

namespace {

Scene build_scene(const YAML::Node& root, const std::string& source) {
  Scene scene;
  scene.source = source;
  scene.name = source == "<string>" ? "scene" : stem(source);
  Map top(Value(root, ""));
  if (auto v = top.find("name")) scene.name = v->string();
  if (auto v = top.find("description")) scene.description = v->string();
  if (auto v = top.find("gravity"))
    scene.world.gravity = v->vec3(SceneBounds::max_acceleration, "m/s^2");
  scene.world.integrator = kDefaultIntegrator;
  bool integrator_auto = false;
  if (auto v = top.find("integrator")) {
    std::vector<std::string> names = integrator_name_list();
    names.push_back("auto");
    const std::string name = v->choice(names);
    integrator_auto = name == "auto";
    if (!integrator_auto) parse_integrator(name, &scene.world.integrator);
  }
  if (auto v = top.find("duration")) scene.duration = v->positive(SceneBounds::max_time, "s");
  if (auto v = top.find("mode"))
    scene.mode = v->choice({"dynamics", "statics"}) == "statics" ? Scene::Mode::kStatics
                                                                 : Scene::Mode::kDynamics;
  if (auto v = top.find("statics_time"))
    scene.statics_time = v->non_negative(SceneBounds::max_time, "s");
  if (auto v = top.find("shape_tolerance")) {  // without elements: auto (which consumes it)
    v->positive();
    scene.warnings.push_back("shape_tolerance: has no effect without a rod's elements: auto");
  }
  std::optional<Value> step = top.find("time_step");
  bool step_given = false;
  if (step && !(step->is_scalar() && step->node().Scalar() == "auto")) {
    scene.world.time_step = step->positive();
    step_given = true;
  }
  if (step_given && scene.world.time_step > scene.duration)
    step->fail("longer than the duration " + num(scene.duration) + " s");

  std::vector<RodEntry> entries;
  const Value rods = top.get("rods");
  const std::vector<Value> items = limited_items(rods, SceneLimits::max_rods, "rods");
  if (items.empty()) rods.fail("needs at least one rod");
  // Relative paths in the scene (keyframe files) are relative to the scene file's folder.
  const size_t slash = source.find_last_of('/');
  const std::string base = source == "<string>" || slash == std::string::npos
                               ? std::string()
                               : (slash == 0 ? std::string("/") : source.substr(0, slash));
  std::optional<Value> default_state = top.find("initial_state");
  if (default_state) wants_equilibrium(*default_state);  // checks the value
  for (size_t i = 0; i < items.size(); ++i)
    read_rod(items[i], static_cast<int>(i), &scene, &entries, base, default_state);
  if (auto c = top.find("contact")) scene_detail::read_contact_settings(*c, &scene.world.contact);
  if (auto o = top.find("obstacles")) {
    std::vector<std::string> obstacle_paths, rod_paths;
    scene_detail::read_obstacles(*o, &scene.world, base, &obstacle_paths);
    for (const RodEntry& e : entries) rod_paths.push_back(e.path);
    scene_detail::check_obstacles_at_start(scene.world, obstacle_paths, rod_paths);
  }
  if (auto g = top.find("grasps")) {
    std::map<std::string, std::string> names;
    for (const Value& item : limited_items(*g, SceneLimits::max_grasps, "grasps")) {
      scene.grasps.push_back(read_grasp(item, scene, &entries, &names, base));
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
  top.finish();
  // After the grasps (which hold the rod) and obstacles (which statics refuses) are known.
  for (size_t i = 0; i < entries.size(); ++i) {
    if (!entries[i].equilibrium) continue;
    Rod& rod = scene.world.rods()[i];
    RodEquilibrium e;
    try {
      e = settle_rod(&scene, &rod);
    } catch (const SceneError& ex) {
      entries[i].equilibrium->fail("equilibrium of " + entries[i].path + ": " + ex.what());
    }
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  ": started from its static equilibrium (residual %.3g N, %d Newton iterations, "
                  "%d load step%s)",
                  e.result.residual, e.result.iterations, e.result.load_steps,
                  e.result.load_steps == 1 ? "" : "s");
    scene.settled.push_back("rod '" + rod.name() + "'" + buf);
    if (e.potential && e.negative_modes > 0)
      scene.warnings.push_back(entries[i].equilibrium->path() + ": the equilibrium of rod '" +
                               rod.name() + "' is unstable (" + std::to_string(e.negative_modes) +
                               " negative Hessian eigenvalues): the run will leave it");
  }
  choose_step(&scene, step_given ? &*step : nullptr, integrator_auto);
  return scene;
}

}  // namespace

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  // A regular file within the size limit only: a FIFO would block, a device never end.
  std::string text;
  try {
    text = read_input_file(path, "scene file", SceneLimits::max_file_bytes);
  } catch (const FileError& e) {
    throw SceneError(e.what());
  }
  return parse_scene(text, overrides, path);
}

}  // namespace corde
