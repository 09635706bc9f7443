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

// The stages in order; each names the file that holds it (docs/architecture.md).
void World::step() {
  // 1. Obstacle poses (contact/obstacle_motion.cpp): keyframed obstacles at t with the step's
  // velocity, before the contacts see them.
  if (obstacles && !obstacle_motions.empty())
    move_obstacles(obstacle_motions, time_, time_step, obstacles.get());
  Stepper& stepper = stepper_for(integrator);
  // Only a world with something to collide has a contact stage: one without pays nothing.
  const bool contacts = ContactSystem::needed(*this);
  // 2. The free step of every rod (integrators/explicit_stepper.cpp, implicit_stepper.cpp).
  stepper.free_step(*this, contacts, contacts ? contacts_.get() : nullptr);
  // 3. Contacts (contact/contact.cpp): detected at the step's start, solved against the
  // stepper's response to impulses.
  if (contacts) own_contacts().solve(*this, time_step, stepper);
  // 4. Commit: integration with the contact forces, drives, constraints, reactions, statistics.
  stepper.commit(*this, contacts);
  // 5. Push-out (contact/contact.cpp): what penetration is left is moved out of the positions.
  if (contacts) contacts_->push_out(*this, time_step);
  time_ += time_step;
}

Stepper& World::stepper_for(Integrator i) {
  switch (i) {
    case Integrator::kImplicitEuler:
    case Integrator::kBdf2:
      implicit_.set_second_order(i == Integrator::kBdf2);
      return implicit_;
    case Integrator::kSemiImplicitEuler:
    case Integrator::kSplitRotation:
      break;
  }
  explicit_.set_rotation(i);
  return explicit_;
}

ContactSystem& World::own_contacts() {
  // A copy of a world (a snapshot) shares the system until it steps on its own.
  if (!contacts_ || contacts_.use_count() > 1) contacts_ = std::make_shared<ContactSystem>();
  return *contacts_;
}

long World::implicit_factorisations() const { return implicit_.factorisations(); }

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
  const Vec3 g = gravity_at(time_);
  for (const Rod& r : rods_) {
    const Energies e = r.energies(g);
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
