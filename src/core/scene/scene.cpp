// Scene loading (scene/scene.h): the YAML text and overrides into a tree, then the three passes of
// scene_passes.h: describe (pass a, here), build (scene_build.cpp), automatic choices
// (scene_choices.cpp).
#include "corde_sim/scene/scene.h"

#include <yaml-cpp/yaml.h>

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

}  // namespace

SceneDescription describe_scene(const YAML::Node& root, const std::string& source) {
  SceneDescription d;
  d.source = source;
  d.name = source == "<string>" ? "scene" : stem(source);
  d.top.emplace(Value(root, ""));
  Map& top = *d.top;
  if (auto v = top.find("name")) d.name = v->string();
  if (auto v = top.find("description")) d.description = v->string();
  if (auto v = top.find("gravity")) d.gravity = v->vec3(SceneBounds::max_acceleration, "m/s^2");
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
  if (auto v = top.find("shape_tolerance")) {  // without elements: auto (which consumes it)
    v->positive();
    d.warnings.push_back("shape_tolerance: has no effect without a rod's elements: auto");
  }
  std::optional<Value> step = top.find("time_step");
  if (step && !(step->is_scalar() && step->node().Scalar() == "auto")) {
    d.time_step = step->positive();
    d.time_step_key = step;
    if (*d.time_step > d.duration) step->fail("longer than the duration " + num(d.duration) + " s");
  }
  const Value rods = top.get("rods");
  d.rods = limited_items(rods, SceneLimits::max_rods, "rods");
  if (d.rods.empty()) rods.fail("needs at least one rod");
  // Relative paths in the scene (keyframe files) are relative to the scene file's folder.
  const size_t slash = source.find_last_of('/');
  d.base = source == "<string>" || slash == std::string::npos
               ? std::string()
               : (slash == 0 ? std::string("/") : source.substr(0, slash));
  d.default_state = top.find("initial_state");
  if (d.default_state) wants_equilibrium(*d.default_state);  // checks the value
  d.contact = top.find("contact");
  d.obstacles = top.find("obstacles");
  d.grasps = top.find("grasps");
  return d;
}

}  // namespace scene_detail

namespace {

// The three passes on a tree whose overrides are applied and whose elements are counts.
Scene load_tree(const YAML::Node& root, const std::string& source) {
  scene_detail::SceneDescription description = scene_detail::describe_scene(root, source);
  scene_detail::AutomaticRequests requests;
  Scene scene = scene_detail::build_scene(&description, &requests);
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
    // elements: auto first: it probes the scene (passes a to c) at two resolutions per choice.
    std::vector<std::string> notes;
    if (scene_detail::has_auto_elements(root))
      notes = scene_detail::choose_elements(
          &root, [&](const YAML::Node& tree) { return load_tree(tree, source); });
    Scene scene = load_tree(root, source);
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
