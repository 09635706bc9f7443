#include "corde_sim/world/world.h"

#include <algorithm>
#include <stdexcept>

namespace corde {

Rod& World::add_rod(Rod rod) {
  for (const Rod& r : rods_)
    if (r.name() == rod.name())
      throw std::invalid_argument("duplicate rod name '" + r.name() + "'");
  rods_.push_back(std::move(rod));
  return rods_.back();
}

Rod& World::rod(const std::string& name) {
  for (Rod& r : rods_)
    if (r.name() == name) return r;
  throw std::out_of_range("no rod named '" + name + "'");
}

const Rod& World::rod(const std::string& name) const { return const_cast<World*>(this)->rod(name); }

void World::step() {
  if (obstacles && !obstacle_motions.empty())
    move_obstacles(obstacle_motions, time_, time_step, obstacles.get());
  if (is_implicit(integrator)) {
    step_implicit();
  } else if (!ContactSystem::needed(*this)) {
    for (Rod& r : rods_) r.step(time_, time_step, gravity, integrator);
  } else {
    for (Rod& r : rods_) r.compute_forces(time_, gravity);
    // A copy of a world (a snapshot) shares the system until it steps on its own.
    if (!contacts_ || contacts_.use_count() > 1) contacts_ = std::make_shared<ContactSystem>();
    contacts_->solve(*this, time_step);
    for (Rod& r : rods_) r.integrate(time_, time_step, integrator);
  }
  time_ += time_step;
}

long World::implicit_factorisations() const {
  long n = 0;
  for (const ImplicitEuler& e : implicit_) n += e.factorisations();
  return n;
}

void World::step_implicit() {
  implicit_.resize(rods_.size());
  implicit_results_.resize(rods_.size());
  implicit_stats_ = ImplicitStats();
  const bool contacts = ContactSystem::needed(*this);
  for (size_t r = 0; r < rods_.size(); ++r) {
    implicit_[r].set_options(implicit);
    implicit_[r].set_second_order(integrator == Integrator::kBdf2);
    // Contacts' impulses of the last step as the prediction (they change little between steps).
    const int ri = static_cast<int>(r);
    const bool have = contacts && contacts_;
    implicit_results_[r] = implicit_[r].step(rods_[r], time_, time_step, gravity,
                                             have ? contacts_->last_impulses(ri) : nullptr,
                                             have ? contacts_->last_torque_impulses(ri) : nullptr);
  }
  if (contacts) {
    if (!contacts_ || contacts_.use_count() > 1) contacts_ = std::make_shared<ContactSystem>();
    // It may take a rod's BDF2 step again as backward Euler (and replace its result).
    contacts_->solve_implicit(*this, time_step, implicit_, &implicit_results_);
  }
  for (const ImplicitResult& res : implicit_results_) {
    implicit_stats_.iterations = std::max(implicit_stats_.iterations, res.iterations);
    if (!res.converged) ++implicit_stats_.unconverged;
    if (res.reference > 0.0)
      implicit_stats_.worst_residual =
          std::max(implicit_stats_.worst_residual, res.residual / res.reference);
  }
}

bool World::finite() const {
  for (const Rod& r : rods_)
    if (!r.finite()) return false;
  return true;
}

void World::copy_to(World* out) const {
  if (out == this) return;
  std::shared_ptr<ContactSystem> mine = std::move(out->contacts_);
  *out = *this;
  if (!contacts_) return;
  if (mine && mine.use_count() == 1 && mine != contacts_) {
    *mine = *contacts_;
    out->contacts_ = std::move(mine);
  } else {
    out->contacts_ = std::make_shared<ContactSystem>(*contacts_);
  }
}

WorldEnergies World::energies() const {
  WorldEnergies w;
  for (const Rod& r : rods_) {
    const Energies e = r.energies(gravity);
    w.total.stretch += e.stretch;
    w.total.bend_twist += e.bend_twist;
    w.total.coupling += e.coupling;
    w.total.kinetic_translation += e.kinetic_translation;
    w.total.kinetic_rotation += e.kinetic_rotation;
    w.total.gravity += e.gravity;
  }
  return w;
}

}  // namespace corde
