#include "corde_sim/integrators/implicit_stepper.h"

#include <algorithm>

#include "corde_sim/world/world.h"

namespace corde {

void ImplicitStepper::free_step(World& world, bool, const ContactSystem* last) {
  auto& rods = world.rods();
  steps_.resize(rods.size());
  results_.resize(rods.size());
  // Backward Euler and BDF2 take gravity, like the loads, at the step's end.
  const Vec3 g = world.gravity_at(world.time() + world.time_step);
  for (size_t r = 0; r < rods.size(); ++r) {
    steps_[r].set_options(world.implicit);
    steps_[r].set_second_order(second_order_);
    // Contacts' impulses of the last step as the prediction (they change little between steps).
    const int ri = static_cast<int>(r);
    results_[r] = steps_[r].step(rods[r], world.time(), world.time_step, g,
                                 last ? last->last_impulses(ri) : nullptr,
                                 last ? last->last_torque_impulses(ri) : nullptr);
  }
}

void ImplicitStepper::commit(World&, bool) {
  stats_ = ImplicitStats();
  for (const ImplicitResult& res : results_) {
    stats_.iterations = std::max(stats_.iterations, res.iterations);
    if (!res.converged) ++stats_.unconverged;
    if (res.reference > 0.0)
      stats_.worst_residual = std::max(stats_.worst_residual, res.residual / res.reference);
  }
}

long ImplicitStepper::factorisations() const {
  long n = 0;
  for (const ImplicitEuler& e : steps_) n += e.factorisations();
  return n;
}

void ImplicitStepper::free_motion(const Rod& rod, int r, double, double h, bool spin,
                                  std::vector<Vec3>* v, std::vector<double>* inv_mass,
                                  std::vector<Vec3>* omega) const {
  const ImplicitEuler& e = steps_[r];
  if (e.last_step_second_order()) {
    const auto& x0 = e.start_positions();
    v->resize(x0.size());
    for (size_t i = 0; i < x0.size(); ++i) (*v)[i] = (rod.positions()[i] - x0[i]) / h;
  } else {
    *v = rod.velocities();
  }
  const int nn = rod.num_nodes();
  auto& w = *inv_mass;
  w.resize(nn);
  for (int i = 0; i < nn; ++i) w[i] = 1.0 / rod.node_masses()[i];
  for (const NodeDrive& d : rod.node_drives()) w[d.node] = 0.0;
  if (!spin) return;
  const int ns = rod.num_segments();
  omega->resize(ns);
  for (int s = 0; s < ns; ++s) (*omega)[s] = rod.orientations()[s] * rod.angular_velocities()[s];
}

void ImplicitStepper::retake(Rod& rod, int r, double t, double h, const Vec3& gravity) {
  results_[r] = steps_[r].restep_first_order(rod, t, h, gravity);
}

}  // namespace corde
