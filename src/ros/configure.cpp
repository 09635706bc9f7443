#include "corde_sim/ros/configure.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/rod/rod_edit.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/scene/key_ranges.h"
#include "corde_sim/stability/explicit_step_limit.h"

namespace corde_sim {
namespace {

// The rod keys take their ranges from the library's table (scene/key_ranges.h), as the scene
// reader does; the world keys are the node's own.
const char* const kRodKeys[] = {"E",       "G",       "E_s",    "rho",      "kappa",
                                "gamma_t", "gamma_r", "radius", "elements", "damping_time"};

const corde::KeyRange kWorldRanges[] = {
    // Below 1e-9 s the clock would hardly advance.
    {"time_step", 1e-9, 0.01, true, "s", "the world's time step"},
    {"gravity_x", -1000.0, 1000.0, true, "m/s^2", "gravity, x"},
    {"gravity_y", -1000.0, 1000.0, true, "m/s^2", "gravity, y"},
    {"gravity_z", -1000.0, 1000.0, true, "m/s^2", "gravity, z"},
};

const corde::KeyRange* find_range(const std::string& key) {
  for (const char* k : kRodKeys)
    if (key == k) return corde::find_key_range(key);
  for (const corde::KeyRange& r : kWorldRanges)
    if (key == r.name) return &r;
  return nullptr;
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

bool is_world_key(const std::string& k) {
  return k == "time_step" || k == "gravity_x" || k == "gravity_y" || k == "gravity_z";
}

}  // namespace

const std::vector<std::string>& configure_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k(std::begin(kRodKeys), std::end(kRodKeys));
    for (const corde::KeyRange& r : kWorldRanges) k.push_back(r.name);
    return k;
  }();
  return keys;
}

const std::vector<std::string>& configure_flags() {
  static const std::vector<std::string> flags = {"gravity", "internal_friction", "coupling"};
  return flags;
}

std::string integrator_names() { return corde::integrator_names_joined(); }

double explicit_margin(const corde::World& world, std::string* limiting_rod) {
  limiting_rod->clear();
  if (!corde::has_explicit_step_limit(world.integrator)) return 0.0;
  const corde::WorldStepLimit limit = corde::explicit_step_limit(world, false);
  if (limit.rod < 0) return 0.0;
  *limiting_rod = world.rods()[limit.rod].name();
  return world.time_step / limit.time_step;  // NaN when the estimate is: reported, not hidden
}

SimSettings settings_from_world(const corde::World& world) {
  SimSettings s;
  s.gravity = world.gravity;
  s.gravity_on = true;
  for (const corde::Rod& rod : world.rods()) {
    RodSettings r;
    r.material = corde::equivalent_material(rod.section());
    r.radius = rod.section().radius;
    s.rods[rod.name()] = r;
  }
  return s;
}

corde::Section effective_section(const RodSettings& s) {
  corde::Material m = s.material;
  if (!s.internal_friction) m.gamma_t = m.gamma_r = 0.0;
  if (!s.coupling) m.kappa = 0.0;
  return corde::make_section(m, s.radius);
}

std::string plan_configure(const corde::World& world, const std::string& rod,
                           const std::vector<std::string>& keys, const std::vector<double>& values,
                           const std::vector<std::string>& flags,
                           const std::vector<bool>& flag_values, const std::string& integrator,
                           ConfigurePlan* plan) {
  *plan = ConfigurePlan();
  if (keys.size() != values.size())
    return "keys and values differ in length (" + std::to_string(keys.size()) + " vs " +
           std::to_string(values.size()) + ")";
  if (flags.size() != flag_values.size())
    return "flags and flag_values differ in length (" + std::to_string(flags.size()) + " vs " +
           std::to_string(flag_values.size()) + ")";
  if (keys.empty() && flags.empty() && integrator.empty())
    return "nothing to configure: no keys, no flags and no integrator";
  if (!integrator.empty()) {
    if (!corde::parse_integrator(integrator, &plan->integrator))
      return "unknown integrator '" + clip(integrator) + "' (integrators: " + integrator_names() +
             ")";
    plan->set_integrator = true;
  }
  if (rod.empty()) {
    for (const corde::Rod& r : world.rods()) plan->rods.push_back(r.name());
  } else {
    const auto& rods = world.rods();
    if (std::none_of(rods.begin(), rods.end(),
                     [&](const corde::Rod& r) { return r.name() == rod; })) {
      std::vector<std::string> names;
      for (const corde::Rod& r : rods) names.push_back(r.name());
      return "no rod named '" + clip(rod) + "' (rods: " + join(names) + ")";
    }
    plan->rods.push_back(rod);
  }
  for (size_t i = 0; i < keys.size(); ++i) {
    const std::string& k = keys[i];
    const double v = values[i];
    const corde::KeyRange* range = find_range(k);
    if (!range) return "unknown key '" + clip(k) + "' (keys: " + join(configure_keys()) + ")";
    if (plan->values.count(k)) return "key '" + k + "' given twice";
    const std::string why = corde::range_violation(*range, v);
    if (!why.empty()) return k + ": " + why;
    if (k == "elements" && v != std::round(v)) return "elements must be an integer, got " + num(v);
    plan->values[k] = v;
  }
  for (size_t i = 0; i < flags.size(); ++i) {
    const auto& known = configure_flags();
    if (std::find(known.begin(), known.end(), flags[i]) == known.end())
      return "unknown flag '" + clip(flags[i]) + "' (flags: " + join(known) + ")";
    if (plan->flags.count(flags[i])) return "flag '" + flags[i] + "' given twice";
    plan->flags[flags[i]] = flag_values[i];
  }
  auto e = plan->values.find("elements");
  if (e != plan->values.end())
    for (const std::string& name : plan->rods)
      if (world.rod(name).num_segments() != static_cast<int>(e->second))
        plan->resample.push_back(name);
  return "";
}

std::string apply_configure(const ConfigurePlan& plan, corde::World* world, SimSettings* settings) {
  const auto& v = plan.values;
  auto has = [&](const char* k) { return v.count(k) > 0; };
  std::ostringstream summary;
  for (const auto& kv : v) summary << kv.first << "=" << kv.second << " ";
  for (const auto& kv : plan.flags) summary << kv.first << "=" << (kv.second ? "on" : "off") << " ";
  if (plan.set_integrator) {
    world->integrator = plan.integrator;
    summary << "integrator=" << corde::integrator_name(plan.integrator) << " ";
  }

  if (has("time_step")) world->time_step = v.at("time_step");
  if (has("gravity_x")) settings->gravity.x() = v.at("gravity_x");
  if (has("gravity_y")) settings->gravity.y() = v.at("gravity_y");
  if (has("gravity_z")) settings->gravity.z() = v.at("gravity_z");
  if (plan.flags.count("gravity")) settings->gravity_on = plan.flags.at("gravity");
  world->gravity = settings->gravity_on ? settings->gravity : corde::Vec3::Zero();

  bool rod_change = !plan.flags.empty();
  for (const auto& kv : v) rod_change = rod_change || !is_world_key(kv.first);
  if (!rod_change) return summary.str();
  for (const std::string& name : plan.rods) {
    RodSettings& rs = settings->rods.at(name);
    corde::Material& m = rs.material;
    if (has("E")) m.youngs_modulus = v.at("E");
    if (has("G")) m.shear_modulus = v.at("G");
    if (has("E_s")) m.stretch_modulus = v.at("E_s");
    if (has("rho")) m.density = v.at("rho");
    if (has("kappa")) m.kappa = v.at("kappa");
    if (has("radius")) rs.radius = v.at("radius");
    if (has("damping_time")) corde::set_retardation_time(&m, rs.radius, v.at("damping_time"));
    if (has("gamma_t")) m.gamma_t = v.at("gamma_t");
    if (has("gamma_r")) m.gamma_r = v.at("gamma_r");
    if (plan.flags.count("internal_friction"))
      rs.internal_friction = plan.flags.at("internal_friction");
    if (plan.flags.count("coupling")) rs.coupling = plan.flags.at("coupling");
    corde::Rod& rod = world->rod(name);
    rod.set_section(effective_section(rs));
    if (std::find(plan.resample.begin(), plan.resample.end(), name) != plan.resample.end())
      rod = corde::resample_rod(rod, static_cast<int>(v.at("elements")));
  }
  return summary.str();
}

}  // namespace corde_sim
