// The integrators a user can name, in one table: the scene key `integrator`, the node's
// ~integrator parameter and ~configure's `integrator` all read it (the scene key and the
// parameter also take `auto`), so that a new integrator is added in one place.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "corde_sim/rod/rod.h"

namespace corde {

constexpr std::array<Integrator, 4> kIntegrators = {Integrator::kSemiImplicitEuler,
                                                    Integrator::kSplitRotation,
                                                    Integrator::kImplicitEuler, Integrator::kBdf2};

// integrator_name() of each, in the table's order.
inline std::vector<std::string> integrator_name_list() {
  std::vector<std::string> out;
  for (Integrator i : kIntegrators) out.push_back(integrator_name(i));
  return out;
}

// Whether the explicit step limit (stability/explicit_step_limit.h) applies to the integrator:
// the explicit methods blow up above it, the implicit ones are stable at any step. The one
// answer to that question for the scene's step checks, ~configure, the guard and the node.
constexpr bool has_explicit_step_limit(Integrator i) { return !is_implicit(i); }

// "semi_implicit_euler, split_rotation, implicit_euler, bdf2" (for messages).
inline std::string integrator_names_joined() {
  std::string out;
  for (Integrator i : kIntegrators)
    out += (out.empty() ? "" : ", ") + std::string(integrator_name(i));
  return out;
}

}  // namespace corde
