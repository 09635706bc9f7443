// The ~configure service's logic without ROS: validate a request completely, then apply it to a
// world (the caller applies it to a copy and keeps the copy only if everything succeeded).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "corde_sim/rod/material.h"
#include "corde_sim/world/world.h"

namespace corde_sim {

// What a rod is made of before the effect flags switch parts of it off.
struct RodSettings {
  corde::Material material;
  double radius = 0.0;
  bool internal_friction = true;
  bool coupling = true;
};

struct SimSettings {
  corde::Vec3 gravity = corde::Vec3(0.0, 0.0, -9.81);  // used while the gravity flag is on
  bool gravity_on = true;
  std::map<std::string, RodSettings> rods;
};

// Settings that reproduce the world as it is (moduli from each rod's section).
SimSettings settings_from_world(const corde::World& world);
// The section a rod gets from its settings and flags. Throws std::invalid_argument.
corde::Section effective_section(const RodSettings& s);

struct ConfigurePlan {
  std::vector<std::string> rods;         // rods the rod keys and flags apply to
  std::map<std::string, double> values;  // validated keys
  std::map<std::string, bool> flags;     // validated flags
  std::vector<std::string> resample;     // rods whose element count changes
  bool set_integrator = false;           // the request names an integrator
  corde::Integrator integrator = corde::kDefaultIntegrator;
};

// Keys and flags accepted, for messages and docs.
const std::vector<std::string>& configure_keys();
const std::vector<std::string>& configure_flags();

// Checks every key, value and flag (names, counts, finiteness, ranges, rod name) and the
// integrator's name ("" = unchanged), and fills *plan. Returns "" if the request is usable,
// otherwise the reason.
std::string plan_configure(const corde::World& world, const std::string& rod,
                           const std::vector<std::string>& keys, const std::vector<double>& values,
                           const std::vector<std::string>& flags,
                           const std::vector<bool>& flag_values, const std::string& integrator,
                           ConfigurePlan* plan);

// Names a configure request or ~integrator may give: every integrator's.
std::string integrator_names();

// The largest h / h_crit over the rods (and the rod it belongs to) that an explicit integrator
// would run at; 0 for the implicit one, which has no such limit.
double explicit_margin(const corde::World& world, std::string* limiting_rod);

// Applies a plan from plan_configure. damping_time sets gamma_t and gamma_r from the (new) moduli;
// explicit gamma_t / gamma_r given alongside override it. Rods in plan.resample are resampled at
// their new element count (resample_rod). Throws std::invalid_argument if a material turns out
// unusable. Returns a one-line summary of the change.
std::string apply_configure(const ConfigurePlan& plan, corde::World* world, SimSettings* settings);

}  // namespace corde_sim
