#include "corde_sim/scene/key_ranges.h"

#include <cmath>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_bounds.h"
#include "scene_reader.h"

namespace corde {
namespace {

using scene_detail::num;

// A bound with its unit; 0 is 0 in any unit.
std::string bound(double v, const char* unit) {
  return num(v) + (v != 0.0 && unit && *unit ? std::string(" ") + unit : std::string());
}

using B = SceneBounds;

}  // namespace

const std::vector<KeyRange>& key_ranges() {
  static const std::vector<KeyRange> table = {
      {"E", 0.0, B::max_modulus, false, "Pa", "Young's modulus (bending; stretch unless E_s)"},
      {"G", 0.0, B::max_modulus, false, "Pa", "shear modulus (twist, shear)"},
      {"E_s", 0.0, B::max_modulus, false, "Pa", "stretch modulus"},
      {"nu", -1.0, 0.5, false, "", "Poisson's ratio: G = E / (2 (1 + nu))"},
      {"rho", B::min_density, B::max_density, true, "kg/m^3", "density"},
      {"B", 0.0, B::max_coefficient, false, "N m^2", "bending stiffness, instead of E"},
      {"C", 0.0, B::max_coefficient, false, "N m^2", "twist stiffness, instead of G"},
      {"K_s", 0.0, B::max_coefficient, false, "N", "stretch stiffness, instead of E_s"},
      {"kappa", 0.0, B::max_coefficient, false, "N", "the coupling penalty's stiffness"},
      {"gamma_t", 0.0, B::max_coefficient, true, "N s", "internal friction of stretch"},
      {"gamma_r", 0.0, B::max_coefficient, true, "N m^2 s", "internal friction of bend and twist"},
      {"damping_time", 0.0, B::max_time, true, "s", "internal friction as a retardation time"},
      {"max_strain", 0.0, B::max_factor, true, "", "axial strain the material survives (0: none)"},
      {"radius", B::min_length, B::max_length, true, "m", "the rod's radius"},
      {"elements", 1.0, SceneLimits::max_elements, true, "", "elements of a rod (an integer)"},
      {"linear_normal", 0.0, B::max_coefficient, true, "N s/m^2", "linear drag across the rod"},
      {"linear_tangential", 0.0, B::max_coefficient, true, "N s/m^2", "linear drag along it"},
      {"quadratic_normal", 0.0, B::max_coefficient, true, "N s^2/m^3",
       "quadratic drag across the rod"},
      {"quadratic_tangential", 0.0, B::max_coefficient, true, "N s^2/m^3",
       "quadratic drag along it"},
      {"fluid_density", 0.0, B::max_density, true, "kg/m^3", "density of the surrounding fluid"},
      {"drag_coefficient", 0.0, B::max_factor, true, "", "the cylinder's normal drag coefficient"},
      {"friction_coefficient", 0.0, B::max_factor, true, "", "its tangential skin friction"},
      {"mass", 0.0, B::max_mass, false, "kg", "a point mass at a node (masses)"},
      {"inertia_across", 0.0, B::max_inertia, true, "kg m^2",
       "an end body's rotary inertia across the cable's axis"},
      {"inertia_along", 0.0, B::max_inertia, true, "kg m^2",
       "an end body's rotary inertia about the cable's axis"},
      // The node's dynamic_reconfigure parameters (cfg/Node.cfg declares the same ranges; a unit
      // test keeps the generated NodeConfig equal to these); the node's start-up parameters of
      // the same names are checked against them too (ros/node_params.h).
      {"real_time_factor", 0.0, 1000.0, true, "", "simulated time per wall-clock time (0: fast)"},
      {"tf_rate", 0.0, 1000.0, true, "Hz", "rate of the segment tf frames (0: none)"},
      {"marker_rate", 0.0, 1000.0, true, "Hz", "rate of the rviz markers (0: none)"},
      {"state_rate", 0.0, 1000.0, true, "Hz", "rate of the rod state message (0: none)"},
      {"marker_min_diameter", 0.0, 1.0, true, "m", "smallest drawn rod diameter"},
      {"holder_max_speed", 0.01, 100.0, true, "m/s", "fastest a grasp holder follows its pose"},
      {"holder_max_acceleration", 0.1, 10000.0, true, "m/s^2",
       "largest acceleration of a grasp holder"},
      // Start-up parameters only (not reconfigurable); the same upper bound as the other rates.
      {"loop_rate", 1.0, 1000.0, true, "Hz", "wake-ups of the node's paced loop"},
      {"cloud_rate", 0.0, 1000.0, true, "Hz", "rate of the surface point cloud (0: none)"},
  };
  return table;
}

const KeyRange* find_key_range(const std::string& name) {
  for (const KeyRange& r : key_ranges())
    if (name == r.name) return &r;
  return nullptr;
}

std::string range_text(const KeyRange& r) {
  return std::string(r.min_inclusive ? "[" : "(") + num(r.min) + ", " + num(r.max) + "]" +
         (r.unit && *r.unit ? std::string(" ") + r.unit : std::string());
}

std::string range_violation(const KeyRange& r, double v) {
  std::string why;
  if (!std::isfinite(v))
    why = "must be a finite number, got " + num(v);
  else if (r.min > 0.0 && v <= 0.0)  // the first thing wrong with it (a size, a density)
    why = "must be > 0, got " + num(v);
  else if (r.min_inclusive ? v < r.min : !(v > r.min))
    why = std::string(r.min_inclusive ? "must be >= " : "must be > ") + bound(r.min, r.unit) +
          ", got " + num(v);
  else if (v > r.max)
    why = "must be <= " + bound(r.max, r.unit) + ", got " + num(v);
  else
    return "";
  return why + " (valid: " + range_text(r) + ")";
}

}  // namespace corde
