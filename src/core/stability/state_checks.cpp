#include "corde_sim/stability/state_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "corde_sim/model/element_energies.h"

namespace corde {
namespace {

std::string fmt(const char* f, double a, double b) {
  char buf[200];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

StateProblem problem(StateCheck check, const Rod& rod, int item, std::string detail) {
  StateProblem p;
  p.found = true;
  p.check = check;
  p.rod = rod.name();
  p.item = item;
  p.detail = std::move(detail);
  return p;
}

std::string node(int i) { return "node " + std::to_string(i); }
std::string segment(int k) { return "segment " + std::to_string(k); }

StateProblem check_rod(const Rod& rod, const Vec3& gravity, const StateLimits& s) {
  using C = StateCheck;
  const auto& x = rod.positions();
  const auto& v = rod.velocities();
  const auto& q = rod.orientations();
  const auto& w = rod.angular_velocities();
  for (int i = 0; i < rod.num_nodes(); ++i) {
    if (!x[i].allFinite() || !v[i].allFinite())
      return problem(C::kNonFinite, rod, i, node(i) + " is not finite");
    const double speed = v[i].norm();
    if (s.max_speed > 0.0 && speed > s.max_speed)
      return problem(C::kSpeed, rod, i,
                     node(i) + fmt(" moves at %.3g m/s (limit %.3g)", speed, s.max_speed));
  }
  for (int k = 0; k < rod.num_segments(); ++k) {
    if (!q[k].coeffs().allFinite() || !w[k].allFinite())
      return problem(C::kNonFinite, rod, k, segment(k) + " is not finite");
    const double norm = q[k].norm();
    if (s.quaternion_tolerance > 0.0 && std::abs(norm - 1.0) > s.quaternion_tolerance)
      return problem(C::kQuaternion, rod, k,
                     segment(k) + fmt(" has a quaternion of norm %.9g (tolerance %.3g)", norm,
                                      s.quaternion_tolerance));
    const double spin = w[k].norm();
    if (s.max_angular_speed > 0.0 && spin > s.max_angular_speed)
      return problem(
          C::kSpeed, rod, k,
          segment(k) + fmt(" spins at %.3g rad/s (limit %.3g)", spin, s.max_angular_speed));
  }
  const bool shear = s.max_shear_angle > 0.0 && s.max_shear_angle < M_PI;
  const double cos_shear = std::cos(s.max_shear_angle);
  const auto& rest = rod.rest_lengths();
  for (int k = 0; k < rod.num_segments(); ++k) {
    const Vec3 d = x[k + 1] - x[k];
    const double len = d.norm();
    const double e = len / rest[k] - 1.0;
    if (s.max_stretch > 0.0 && e > s.max_stretch)
      return problem(C::kStretch, rod, k,
                     segment(k) + fmt(" stretched by %.3g (limit %.3g)", e, s.max_stretch));
    if (s.max_compression > 0.0 && -e > s.max_compression)
      return problem(C::kStretch, rod, k,
                     segment(k) + fmt(" compressed by %.3g (limit %.3g)", -e, s.max_compression));
    if (!shear) continue;
    const double c = len > 0.0 ? d.dot(director3(q[k])) / len : -1.0;
    if (c < cos_shear)
      return problem(
          C::kShear, rod, k,
          segment(k) + fmt(" frame %.3g rad off its tangent (limit %.3g)",
                           std::acos(std::max(-1.0, std::min(1.0, c))), s.max_shear_angle));
  }
  // An element turned by theta from its rest shape has |u - uhat| l = 2 sin(theta / 2).
  if (s.max_bend_angle > 0.0 && s.max_bend_angle < M_PI) {
    const double max_turn = 2.0 * std::sin(0.5 * s.max_bend_angle);
    const auto& uhat = rod.rest_strains();
    for (int j = 0; j + 1 < rod.num_segments(); ++j) {
      const double l = 0.5 * (rest[j] + rest[j + 1]);
      const double turn = (darboux(q[j], q[j + 1], l) - uhat[j]).norm() * l;
      if (turn > max_turn)
        return problem(C::kBend, rod, j,
                       "element " + std::to_string(j) +
                           fmt(" turned %.3g rad from its rest shape (limit %.3g)",
                               2.0 * std::asin(std::min(1.0, 0.5 * turn)), s.max_bend_angle));
    }
  }
  if (s.max_specific_energy > 0.0) {
    double mass = 0.0;
    for (double m : rod.node_masses()) mass += m;
    const Energies e = rod.energies(gravity);
    const double specific = (e.kinetic() + e.elastic()) / mass;
    if (!(specific <= s.max_specific_energy))
      return problem(C::kSpecificEnergy, rod, -1,
                     fmt("%.3g J/kg of kinetic + elastic energy (limit %.3g)", specific,
                         s.max_specific_energy));
  }
  return StateProblem();
}

}  // namespace

StateLimits runaway_state_limits() {
  StateLimits s;
  s.max_stretch = 10.0;      // |axial strain|: the shipped scenes stay below 2.2 (thread)
  s.max_compression = 10.0;  // (never reached: a segment cannot be compressed by more than 1)
  s.max_penetration = 0.0;
  // The shipped scenes stay below 1.1e4 J/kg (helical_buckling's stored twist), the others
  // below 11 J/kg.
  s.max_specific_energy = 1e5;
  return s;
}

const char* state_check_name(StateCheck check) {
  switch (check) {
    case StateCheck::kNonFinite:
      return "non-finite";
    case StateCheck::kQuaternion:
      return "quaternion";
    case StateCheck::kSpeed:
      return "speed";
    case StateCheck::kStretch:
      return "stretch";
    case StateCheck::kShear:
      return "shear";
    case StateCheck::kBend:
      return "bend";
    case StateCheck::kSpecificEnergy:
      return "specific energy";
    case StateCheck::kPenetration:
      return "penetration";
  }
  return "?";
}

std::string StateProblem::message() const {
  if (!found) return "";
  return rod.empty() ? detail : "rod '" + rod + "': " + detail;
}

StateProblem check_state(const World& world, const StateLimits& limits) {
  for (const Rod& rod : world.rods()) {
    StateProblem p = check_rod(rod, world.gravity, limits);
    if (p.found) return p;
  }
  const ContactSystem* cs = world.contacts();
  if (!(limits.max_penetration > 0.0) || !cs || cs->stats().deepest < 0) return StateProblem();
  const auto& contacts = cs->contacts();
  const int nr = static_cast<int>(world.rods().size());
  int worst = -1;
  double deepest = limits.max_penetration;
  for (size_t k = 0; k < contacts.size(); ++k) {
    const Contact& c = contacts[k];
    if (c.gap >= 0.0 || c.rod_a >= nr) continue;
    if (c.rod_b < 0 && (!world.obstacles || c.obstacle >= world.obstacles->size() ||
                        world.obstacles->obstacle(c.obstacle).moving))
      continue;
    const double ratio = -c.gap / world.rods()[c.rod_a].section().radius;
    if (ratio > deepest) {
      deepest = ratio;
      worst = static_cast<int>(k);
    }
  }
  if (worst < 0) return StateProblem();
  const Contact& c = contacts[worst];
  char limit[64];
  std::snprintf(limit, sizeof limit, " (limit %.3g r)", limits.max_penetration);
  return problem(StateCheck::kPenetration, world.rods()[c.rod_a], c.seg_a,
                 describe_contact(world, c) + limit);
}

}  // namespace corde
