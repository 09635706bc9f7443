// Is a state fit to continue from and to show? One set of checks with one limits struct, used by
// the stability guard (every few steps, and before the node publishes), by corde_run's runaway
// stop and by the node through the guard. A blown-up step does not always end in NaN: it can
// leave finite garbage (zero quaternions, 1e100 rad/s, a rod four times its length), so each
// check is against a limit no meaningful cable state comes near. docs/stability_guard.md lists
// every check with its limits and message.
#pragma once

#include <string>

#include "corde_sim/world/world.h"

namespace corde {

// Every limit of 0 turns its check off. The defaults are the stability guard's; corde_run's
// runaway stop uses runaway_state_limits().
struct StateLimits {
  // No cable in a manipulation scene moves at 100 m/s or spins at 1e5 rad/s, and a blow-up grows
  // geometrically, so it crosses these within a few steps of starting.
  double max_speed = 100.0;            // m/s, any node
  double max_angular_speed = 1e5;      // rad/s, any segment
  double quaternion_tolerance = 1e-6;  // | |q| - 1 | of any segment (every step keeps it unit)
  // Strains no discretised rod can mean (a numerical failure, not a material one: the node's
  // max_strain warns about those). Set just outside what the softest shipped scene reaches (the
  // paper's thread stretches by 2.2 and turns its frames and elements up to 180 degrees while it
  // whips), so shear and bend are off by default; for cables with real bending and shear
  // stiffness 0.8 rad and 1.6 rad are sound (docs/stability_guard.md has the scenes' maxima).
  double max_stretch = 3.0;      // (l - l0) / l0 of any segment: four times its rest length
  double max_compression = 0.9;  // (l0 - l) / l0: a tenth of its rest length
  double max_shear_angle = 0.0;  // rad, a frame's d3 off its centreline tangent
  double max_bend_angle = 0.0;   // rad, an element turned from its rest shape
  // The deepest contact of the last step's contact stage with a static obstacle or a rod, in
  // radii: the solver keeps them within about 1 %, so one this deep went through a surface (a
  // moving obstacle can impose any depth: not checked, reported as a deep contact).
  double max_penetration = 0.5;
  // (kinetic + elastic energy) / mass of any rod, J/kg: 1e5 is a rod moving as a whole at
  // 447 m/s. The guard bounds energy growth by the work done instead (off here).
  double max_specific_energy = 0.0;
};

// corde_run's stop after the guard (and alone with --no-guard): looser strain limits (|axial
// strain| 10) and the specific energy check (1e5 J/kg), no shear, bend or penetration check.
StateLimits runaway_state_limits();

enum class StateCheck {
  kNonFinite,       // a NaN or infinity in positions, velocities, orientations, spins
  kQuaternion,      // a segment's quaternion off unit norm by more than quaternion_tolerance
  kSpeed,           // a node beyond max_speed, a segment beyond max_angular_speed
  kStretch,         // a segment beyond max_stretch or max_compression
  kShear,           // a frame beyond max_shear_angle off its tangent
  kBend,            // an element turned beyond max_bend_angle from its rest shape
  kSpecificEnergy,  // a rod beyond max_specific_energy
  kPenetration,     // a contact deeper than max_penetration radii
};
const char* state_check_name(StateCheck check);  // "non-finite", "quaternion", "speed", ...

// The first problem found, cheapest first, per rod: nodes (finite, speed), segments (finite,
// quaternion, spin), stretch and shear, bend, specific energy; then penetration.
struct StateProblem {
  bool found = false;
  StateCheck check = StateCheck::kNonFinite;
  std::string rod;     // the rod's name
  int item = -1;       // node, segment or element index (-1: the whole rod)
  std::string detail;  // "node 3 moves at 150 m/s (limit 100)"
  // "rod 'cable': node 3 moves at 150 m/s (limit 100)" ("" when none found).
  std::string message() const;
};
StateProblem check_state(const World& world, const StateLimits& limits);

}  // namespace corde
