// Scene loading (scene/scene.h): the YAML text and overrides into a tree, then the three passes of
// scene_passes.h: describe (pass a, here), build (scene_build.cpp), automatic choices
// (scene_choices.cpp).
#include "corde_sim/scene/scene.h"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/io/file_read.h"
#include "corde_sim/scene/scene_bounds.h"
#include "scene_elements.h"
#include "scene_passes.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

std::string stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = base.find_last_of('.');
  return dot == std::string::npos || dot == 0 ? base : base.substr(0, dot);
}

// A `loads` entry: a force on a node or a torque on a segment, the index left unresolved.
LoadDescription describe_load(const Value& entry) {
  Map m(entry);
  LoadDescription d;
  d.path = entry.path();
  Load& l = d.load;
  if (m.one_of({"node", "segment"}) == "node") {
    l.kind = Load::Kind::kForce;
    d.at = describe_index(m.get("node"), "node");
    l.value = m.get("force").vec3(SceneBounds::max_force, "N");
  } else {
    l.kind = Load::Kind::kTorque;
    d.at = describe_index(m.get("segment"), "segment");
    l.value = m.get("torque").vec3(SceneBounds::max_torque, "N m");
  }
  if (auto t = m.find("ramp_time")) l.ramp_time = t->non_negative(SceneBounds::max_time, "s");
  if (auto t = m.find("start_time")) l.t_start = t->non_negative(SceneBounds::max_time, "s");
  if (auto k = m.find("kind")) l.follower = k->choice({"dead", "follower"}) == "follower";
  m.finish();
  return d;
}

// A `masses` entry: a point mass at a node; at an end node also the rotary inertia of the rigid
// body it stands for (a plug), across and along the cable's axis, and its centre of mass's offset.
MassDescription describe_mass(const Value& entry) {
  Map m(entry);
  MassDescription d;
  d.path = entry.path();
  d.at = describe_index(m.get("node"), "node");
  d.mass = m.get("mass").in_range("mass");
  for (const char* key : {"inertia_across", "inertia_along"})
    if (auto v = m.find(key)) {
      (std::string(key) == "inertia_across" ? d.inertia_across : d.inertia_along) =
          v->in_range(key);
      if (!d.inertia_key) d.inertia_key = v;
    }
  if (auto v = m.find("offset")) {
    d.offset = v->vec3(SceneBounds::max_length, "m");
    d.offset_key = v;
  }
  m.finish();
  return d;
}

// A `density_ranges` entry: {from, to, rho}, from < to, arc lengths along the rest rod (m).
DensityRange describe_density_range(const Value& entry) {
  Map m(entry);
  DensityRange d;
  d.key = entry;
  d.from = m.get("from").non_negative(SceneBounds::max_length, "m");
  const Value to = m.get("to");
  d.to = to.positive(SceneBounds::max_length, "m");
  if (!(d.to > d.from)) to.fail("must be greater than from (" + num(d.from) + " m)");
  d.rho = m.get("rho").in_range("rho");
  m.finish();
  return d;
}

[[noreturn]] void fail_total(const Value& key, long total) {
  key.fail("the scene's rods would have " + std::to_string(total) +
           " elements together, more than the limit of " +
           std::to_string(SceneLimits::max_total_elements));
}

// A rod's own keys (RodDescription), after the rods `before` it.
RodDescription describe_rod(const Value& v, int index, const std::vector<RodDescription>& before,
                            const std::optional<Value>& default_state, const std::string& base) {
  RodDescription r;
  r.path = v.path();
  Map m(v);
  RodSpec& spec = r.spec;
  spec.name = "rod" + std::to_string(index);
  if (auto p = m.find("name")) {
    spec.name = p->string();
    if (spec.name.empty()) p->fail("must not be empty");
    for (const RodDescription& b : before)
      if (b.spec.name == spec.name)
        p->fail("duplicate rod name " + echo(spec.name) + " (also " + b.path + ")");
  }
  std::optional<Value> elements = m.find("elements");
  r.elements_key = elements ? *elements : v;
  if (elements && elements->is_scalar() && elements->node().Scalar() == "auto") {
    r.auto_elements = true;  // counted once chosen (scene_elements.h)
    spec.elements = 0;
  } else if (elements) {
    spec.elements = elements->integer(1, SceneLimits::max_elements);
  }
  long total = spec.elements;
  for (const RodDescription& b : before) total += b.spec.elements;
  if (total > SceneLimits::max_total_elements) fail_total(*r.elements_key, total);
  MaterialExtras extras;
  spec.section = read_section(&m, base, &extras);
  r.origin = extras.origin;
  r.shape_key = m.get("shape");
  spec.shape = read_shape(*r.shape_key);
  if (auto p = m.find("reference_d1")) spec.shape.reference_d1 = p->nonzero_vec3();
  if (auto p = m.find("rest_shape"))
    spec.rest_shape_created = p->choice({"straight", "created"}) == "created";
  if (auto p = m.find("drag"))
    r.drag = read_drag(*p, spec.section.radius);
  else
    r.drag = extras.drag;
  if (auto p = m.find("contact")) {
    r.contact.emplace();
    read_rod_contact(*p, &*r.contact);
  }
  if (extras.friction && !(r.contact && r.contact->friction >= 0.0)) {
    if (!r.contact) r.contact.emplace();
    r.contact->friction = *extras.friction;
  }
  std::optional<Value> state = m.find("initial_state");
  if (!state) state = default_state;
  if (state && wants_equilibrium(*state)) {
    if (m.has("initial"))
      state->fail("equilibrium starts " + v.path() +
                  " at rest in its equilibrium shape; remove its `initial` key (velocities, "
                  "perturbation) or set initial_state: given on the rod");
    r.equilibrium = state;
  }
  if (auto i = m.find("initial"))
    r.initial = describe_initial(*i, r.auto_elements ? -1 : spec.elements);
  if (auto b = m.find("boundary"))
    for (const Value& item : limited_items(*b, SceneLimits::max_items, "entries"))
      r.boundary.push_back(describe_boundary(item, base));
  if (auto l = m.find("loads"))
    for (const Value& item : limited_items(*l, SceneLimits::max_items, "loads"))
      r.loads.push_back(describe_load(item));
  if (auto l = m.find("masses"))
    for (const Value& item : limited_items(*l, SceneLimits::max_items, "masses"))
      r.masses.push_back(describe_mass(item));
  if (auto l = m.find("density_ranges"))
    for (const Value& item : limited_items(*l, SceneLimits::max_items, "ranges")) {
      const DensityRange d = describe_density_range(item);
      for (size_t j = 0; j < r.density_ranges.size(); ++j) {
        const DensityRange& e = r.density_ranges[j];
        if (d.from < e.to && e.from < d.to)
          item.fail("overlaps " + e.key.path() + " ([" + num(e.from) + ", " + num(e.to) +
                    "] m); give each stretch of the cable one density");
      }
      r.density_ranges.push_back(d);
    }
  // A number >= 1, or auto (stability/explicit_step_limit.h, lifting_inertia_scale: computed on
  // the rod as built and held).
  if (auto p = m.find("rotational_inertia_scale")) {
    if (p->is_scalar() && p->node().Scalar() == "auto") {
      r.inertia_scale_auto = p->path();
    } else {
      const double scale = p->number();
      if (!(scale >= 1.0))
        p->fail("must be >= 1 (1 = physical rotary inertia) or auto, got " + num(scale));
      p->within(1.0, SceneBounds::max_factor, "");
      r.inertia_scale = scale;
    }
  }
  m.finish();
  return r;
}

}  // namespace

// Air drag of a rod: the coefficients per unit length, or a fluid's density with the drag
// coefficients of the rod's cylinder (normal C_d, tangential skin friction C_f), which give
// q_n = rho C_d r (1/2 rho C_d times the diameter) and q_t = rho C_f pi r (1/2 rho C_f times the
// circumference). Bounded (scene/scene_bounds.h) so that these products stay finite.
Drag read_drag(const Value& v, double radius) {
  Map m(v);
  Drag d;
  if (auto p = m.find("linear_normal")) d.linear_normal = p->in_range("linear_normal");
  if (auto p = m.find("linear_tangential")) d.linear_tangential = p->in_range("linear_tangential");
  if (auto p = m.find("quadratic_normal")) d.quadratic_normal = p->in_range("quadratic_normal");
  if (auto p = m.find("quadratic_tangential"))
    d.quadratic_tangential = p->in_range("quadratic_tangential");
  if (auto rho = m.find("fluid_density")) {
    if (m.has("quadratic_normal") || m.has("quadratic_tangential"))
      rho->fail("give either fluid_density or quadratic_normal/quadratic_tangential");
    const double density = rho->in_range("fluid_density");
    double cd = 1.2, cf = 0.0;
    if (auto p = m.find("drag_coefficient")) cd = p->in_range("drag_coefficient");
    if (auto p = m.find("friction_coefficient")) cf = p->in_range("friction_coefficient");
    d.quadratic_normal = density * cd * radius;
    d.quadratic_tangential = density * cf * M_PI * radius;
  } else if (m.has("drag_coefficient") || m.has("friction_coefficient")) {
    m.fail("drag_coefficient and friction_coefficient need fluid_density");
  }
  m.finish();
  return d;
}

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

// `initial_state`: given (the shape and velocities as described) or equilibrium.
bool wants_equilibrium(const Value& v) {
  return v.choice({"given", "equilibrium"}) == "equilibrium";
}

void check_total_elements(const std::vector<RodDescription>& rods) {
  long total = 0;
  for (const RodDescription& r : rods) {
    total += r.spec.elements;
    if (total > SceneLimits::max_total_elements) fail_total(*r.elements_key, total);
  }
}

SceneDescription describe_scene(const YAML::Node& root, const std::string& source) {
  SceneDescription d;
  d.source = source;
  d.name = source == "<string>" ? "scene" : stem(source);
  Map top(Value(root, ""));
  if (auto v = top.find("name")) d.name = v->string();
  if (auto v = top.find("description")) d.description = v->string();
  if (auto v = top.find("gravity")) d.gravity = v->vec3(SceneBounds::max_acceleration, "m/s^2");
  if (auto v = top.find("gravity_ramp"))
    d.gravity_ramp = v->non_negative(SceneBounds::max_time, "s");
  if (auto v = top.find("integrator")) {
    std::vector<std::string> names = integrator_name_list();
    names.push_back("auto");
    const std::string name = v->choice(names);
    d.integrator_auto = name == "auto";
    if (!d.integrator_auto) parse_integrator(name, &d.integrator);
  }
  if (auto v = top.find("duration")) d.duration = v->positive(SceneBounds::max_time, "s");
  if (auto v = top.find("mode"))
    d.mode = v->choice({"dynamics", "statics"}) == "statics" ? Scene::Mode::kStatics
                                                             : Scene::Mode::kDynamics;
  if (auto v = top.find("statics_time"))
    d.statics_time = v->non_negative(SceneBounds::max_time, "s");
  if (auto v = top.find("shape_tolerance")) {
    if (has_auto_elements(root)) {
      d.shape_tolerance = v->number();
      if (!(*d.shape_tolerance >= kMinShapeTolerance && *d.shape_tolerance <= kMaxShapeTolerance))
        v->fail("must be in [" + num(kMinShapeTolerance) + ", " + num(kMaxShapeTolerance) +
                "] (a fraction of the rod's length), got " + num(*d.shape_tolerance));
    } else {
      v->positive();
      d.warnings.push_back("shape_tolerance: has no effect without a rod's elements: auto");
    }
  }
  std::optional<Value> step = top.find("time_step");
  if (step && !(step->is_scalar() && step->node().Scalar() == "auto")) {
    d.time_step = step->positive();
    d.time_step_key = step;
    if (*d.time_step > d.duration) step->fail("longer than the duration " + num(d.duration) + " s");
  }
  const Value rods = top.get("rods");
  const std::vector<Value> items = limited_items(rods, SceneLimits::max_rods, "rods");
  if (items.empty()) rods.fail("needs at least one rod");
  // Relative paths in the scene (keyframe files) are relative to the scene file's folder.
  const size_t slash = source.find_last_of('/');
  d.base = source == "<string>" || slash == std::string::npos
               ? std::string()
               : (slash == 0 ? std::string("/") : source.substr(0, slash));
  const std::optional<Value> default_state = top.find("initial_state");
  if (default_state) wants_equilibrium(*default_state);  // checks the value
  for (size_t i = 0; i < items.size(); ++i)
    d.rods.push_back(describe_rod(items[i], static_cast<int>(i), d.rods, default_state, d.base));
  if (auto v = top.find("contact")) {
    d.contact = ContactSettings();
    read_contact_settings(*v, &*d.contact);
  }
  if (auto v = top.find("obstacles")) {
    ObstaclesDescription& o = d.obstacles.emplace();
    read_obstacles(*v, &o.obstacles, &o.motions, d.base, &o.paths);
    check_obstacle_placement(o.obstacles, o.paths);
  }
  if (auto v = top.find("grasps"))
    for (const Value& item : limited_items(*v, SceneLimits::max_grasps, "grasps"))
      d.grasps.push_back(describe_grasp(item, d.rods, d.grasps, d.base));
  top.finish();
  return d;
}

}  // namespace scene_detail

namespace {

// Passes (b) and (c) on a description whose rods all have their element counts.
Scene build_description(const scene_detail::SceneDescription& description) {
  scene_detail::AutomaticRequests requests;
  Scene scene = scene_detail::build_scene(description, &requests);
  scene_detail::make_automatic_choices(&scene, requests);
  return scene;
}

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
    scene_detail::SceneDescription description = scene_detail::describe_scene(root, source);
    // elements: auto: probe builds (passes b and c) of the description at two resolutions per
    // choice.
    const std::vector<std::string> notes =
        scene_detail::choose_elements(&description, build_description);
    Scene scene = build_description(description);
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
