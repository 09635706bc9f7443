// The implicit methods as a stepper (stepper.h): Integrator::kImplicitEuler and kBdf2, one
// ImplicitEuler (implicit_step.h) per rod. Contacts see each rod's factorised Newton system: its
// response to impulses couples the nodes, so the contact solve alternates sweeps with respond().
#pragma once

#include <vector>

#include "corde_sim/integrators/implicit_step.h"
#include "corde_sim/integrators/stepper.h"

namespace corde {

// The Newton solves of the last step.
struct ImplicitStats {
  int iterations = 0;           // Newton iterations, the most any rod took
  int unconverged = 0;          // rods whose Newton iterations stopped short of the tolerance
  double worst_residual = 0.0;  // largest residual over its reference scale (ImplicitResult)
};

class ImplicitStepper final : public Stepper {
 public:
  // BDF2 (true) or backward Euler (false).
  void set_second_order(bool on) { second_order_ = on; }

  // Each rod's Newton step with the world's ImplicitOptions, the last contact impulses as its
  // prediction; drives are set at t + h and each support records its reaction.
  void free_step(World& world, bool contacts, const ContactSystem* last) override;
  // The step's statistics (stats()); the contacts' response already set the rods' state.
  void commit(World& world, bool contacts) override;

  const ImplicitStats& stats() const { return stats_; }
  // Factorisations of the Newton matrices so far, over all rods.
  long factorisations() const;

  const std::vector<Vec3>& start_positions(const Rod&, int r) const override {
    return steps_[r].start_positions();
  }
  const std::vector<Vec3>& start_velocities(const Rod&, int r) const override {
    return steps_[r].start_velocities();
  }
  // The free step's velocities (a BDF2 step's: its displacement over h, which the contacts' gaps
  // follow); the segments' from the rod's state after the step.
  void free_motion(const Rod& rod, int r, double t, double h, bool spin, std::vector<Vec3>* v,
                   std::vector<double>* inv_mass, std::vector<Vec3>* omega) const override;
  bool lumped() const override { return false; }
  // A BDF2 step moves the rod by a third of its last step's motion whatever the impulses do: it
  // is taken again as backward Euler (ImplicitEuler::restep_first_order), its result replacing
  // the step's.
  bool may_retake(int r) const override { return steps_[r].last_step_second_order(); }
  void retake(Rod& rod, int r, double t, double h, const Vec3& gravity) override;
  bool has_prediction(int r) const override { return steps_[r].has_prediction(); }
  void respond(Rod& rod, int r, const std::vector<Vec3>& impulses,
               const std::vector<Vec3>* torque_impulses) override {
    steps_[r].respond(rod, impulses, torque_impulses);
  }
  void response(const Rod& rod, int r, const std::vector<Vec3>& impulses, std::vector<Vec3>* dv,
                const std::vector<Vec3>* torque_impulses) override {
    steps_[r].response(rod, impulses, dv, torque_impulses);
  }
  bool node_compliance(const Rod& rod, int r, std::vector<Mat3>* diag,
                       std::vector<Mat3>* lower) override {
    return steps_[r].node_compliance(rod, diag, lower);
  }

 private:
  bool second_order_ = false;
  std::vector<ImplicitEuler> steps_;     // per rod (scratch and the step's factorisation)
  std::vector<ImplicitResult> results_;  // per rod, the last step's
  ImplicitStats stats_;
};

}  // namespace corde
