// What the contact solver needs of the integrator that steps the rods: where each rod starts the
// step (detection), where the step without contacts takes it, and how it answers impulses. The
// integrators' steppers (integrators/stepper.h) implement it, so the solver knows no concrete
// integrator and never changes a rod's state to read another one.
#pragma once

#include <vector>

#include "corde_sim/model/element_energies.h"

namespace corde {

class Rod;

class ContactResponse {
 public:
  virtual ~ContactResponse() = default;

  // Rod r's node positions and velocities at the step's start, which detection reads. They stay
  // valid until the contact solve returns.
  virtual const std::vector<Vec3>& start_positions(const Rod& rod, int r) const = 0;
  virtual const std::vector<Vec3>& start_velocities(const Rod& rod, int r) const = 0;
  // Rod r's motion over the step without contacts, from t to t + h: each node's velocity over the
  // step (a held node's: its drive's) into *v, each node's lumped inverse mass (0 where held) into
  // *inv_mass, and with `spin` each segment's world angular velocity into *omega.
  virtual void free_motion(const Rod& rod, int r, double t, double h, bool spin,
                           std::vector<Vec3>* v, std::vector<double>* inv_mass,
                           std::vector<Vec3>* omega) const = 0;
  // True when the lumped masses are the rods' whole response to an impulse over the step (the
  // explicit methods: the impulses enter the step as forces p / h, solved in one pass of sweeps).
  // False when the rods' nodes answer together (an implicit step's stiffness): the solver then
  // alternates sweeps with respond() until the contacts hold.
  virtual bool lumped() const = 0;

  // Coupled responses only (lumped() false).
  // Whether rod r's step carries motion that impulses cannot change (BDF2's share of the last
  // step), so that a contact it would close makes it take the step again without (retake()).
  virtual bool may_retake(int /*r*/) const { return false; }
  virtual void retake(Rod& /*rod*/, int /*r*/, double /*t*/, double /*h*/,
                      const Vec3& /*gravity*/) {}
  // Whether rod r's step already included predicted impulses (respond() then takes them out).
  virtual bool has_prediction(int /*r*/) const { return false; }
  // Sets rod r to its step's result plus the response to these total node impulses (N s, world,
  // one per node) and optional segment torque impulses (N m s, world); replaces an earlier call's.
  virtual void respond(Rod& /*rod*/, int /*r*/, const std::vector<Vec3>& /*impulses*/,
                       const std::vector<Vec3>* /*torque_impulses*/) {}
  // The node velocity changes a change of the impulses makes, without changing the rod.
  virtual void response(const Rod& /*rod*/, int /*r*/, const std::vector<Vec3>& /*impulses*/,
                        std::vector<Vec3>* /*dv*/, const std::vector<Vec3>* /*torque_impulses*/) {}
  // The node blocks of response()'s compliance (dv = C p, m/s per N s): diag[i] = C_ii and
  // lower[i] = C_{i+1,i}, which give each contact's own block of the Delassus operator exactly.
  // False when not available (the contact solve then uses the rounds).
  virtual bool node_compliance(const Rod& /*rod*/, int /*r*/, std::vector<Mat3>* /*diag*/,
                               std::vector<Mat3>* /*lower*/) {
    return false;
  }
};

}  // namespace corde
