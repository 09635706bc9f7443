// The explicit methods as a stepper (stepper.h): Integrator::kSemiImplicitEuler and
// kSplitRotation, semi-implicit Euler of the nodes and the segments' rotations by the named method
// (rod/rod.h). Contacts see each node with its lumped mass: their impulses enter the step as
// forces.
#pragma once

#include "corde_sim/integrators/stepper.h"
#include "corde_sim/rod/rod.h"

namespace corde {

class ExplicitStepper final : public Stepper {
 public:
  // How the segments' rotations are stepped: kSemiImplicitEuler or kSplitRotation.
  void set_rotation(Integrator rotation) { rotation_ = rotation; }
  Integrator rotation() const { return rotation_; }

  // Without contacts each rod takes its fused step (Rod::step: forces, integration and drives in
  // one pass over the rod, the cheapest step), which commits it too; with contacts only the
  // forces at t, which the contact solve adds to.
  void free_step(World& world, bool contacts, const ContactSystem* last) override;
  // With contacts: the integration with the forces and the contacts' (Rod::integrate), then the
  // drives and constraints, each recording its reaction. Without: nothing left.
  void commit(World& world, bool contacts) override;

  const std::vector<Vec3>& start_positions(const Rod& rod, int) const override {
    return rod.positions();
  }
  const std::vector<Vec3>& start_velocities(const Rod& rod, int) const override {
    return rod.velocities();
  }
  // The velocities after the forces' kick v + h f / m (the segments': after the torques' kick,
  // the gyroscopic or torque-free part left out: it changes them at second order in h).
  void free_motion(const Rod& rod, int r, double t, double h, bool spin, std::vector<Vec3>* v,
                   std::vector<double>* inv_mass, std::vector<Vec3>* omega) const override;
  bool lumped() const override { return true; }

 private:
  Integrator rotation_ = kDefaultIntegrator;
};

}  // namespace corde
