// Several rods sharing gravity and a clock.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "corde_sim/contact/contact.h"
#include "corde_sim/contact/obstacle.h"
#include "corde_sim/contact/obstacle_motion.h"
#include "corde_sim/integrators/explicit_stepper.h"
#include "corde_sim/integrators/implicit_stepper.h"
#include "corde_sim/rod/rod.h"

namespace corde {

struct WorldEnergies {
  Energies total;
  double elastic() const { return total.elastic(); }
  double kinetic() const { return total.kinetic(); }
};

class World {
 public:
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);
  // Gravity grows linearly from zero at t = 0 to `gravity` at t = gravity_ramp (s) and stays
  // there; 0: whole from the start (the default). Ramping it in keeps a cable created straight
  // from ringing as it sags.
  double gravity_ramp = 0.0;
  // The gravity acting at time t: `gravity` itself (the same value, bit for bit) without a ramp
  // or from the ramp's end on.
  Vec3 gravity_at(double t) const {
    if (!(gravity_ramp > 0.0) || t >= gravity_ramp) return gravity;
    return (t > 0.0 ? t / gravity_ramp : 0.0) * gravity;
  }
  double time_step = 1e-4;  // s
  // How the rods are stepped (rod.h): the explicit methods (nodes by semi-implicit Euler, the
  // segments' rotations as named), or backward Euler (kImplicitEuler) or BDF2 (kBdf2) of
  // everything.
  Integrator integrator = kDefaultIntegrator;
  // Newton settings of the implicit integrator.
  ImplicitOptions implicit;

  std::vector<Rod>& rods() { return rods_; }
  const std::vector<Rod>& rods() const { return rods_; }
  Rod& add_rod(Rod rod);
  // Throws std::out_of_range naming the rod if there is none by that name.
  Rod& rod(const std::string& name);
  const Rod& rod(const std::string& name) const;

  // Obstacles the rods touch (none: null) and how contacts are solved (contact.h).
  std::shared_ptr<ObstacleSet> obstacles;
  ContactSettings contact;
  // Keyframed obstacles: posed at the start of every step with the step's velocity (before the
  // contacts see them). Obstacles moved from outside (set_pose) are not listed here.
  std::vector<ObstacleMotion> obstacle_motions;

  double time() const { return time_; }
  void set_time(double t) { time_ = t; }
  // Advances every rod by time_step, in stages (docs/architecture.md, "The step, stage by
  // stage"): keyframed obstacles posed; the integrator's free step of every rod (the explicit
  // methods' forces, or the implicit methods' Newton solve); contacts detected and solved against
  // that step's response, only when something can collide; the commit (the integration with the
  // contact forces, drives, constraints, reactions). Without contacts an explicit method runs each
  // rod's fused step.
  void step();
  // The implicit integrator's solves in the last implicit step (zero before one).
  const ImplicitStats& implicit_stats() const { return implicit_.stats(); }
  // Factorisations of the implicit integrator's Newton matrices so far, over all rods (they are
  // kept while the rods barely move: ImplicitOptions::reuse_factor).
  long implicit_factorisations() const;
  // The contact stage of the last step (null until a step needed it).
  const ContactSystem* contacts() const { return contacts_.get(); }
  void step(int n) {
    for (int i = 0; i < n; ++i) step();
  }
  bool finite() const;
  // The rods' energies, gravity's potential under gravity_at(time()).
  WorldEnergies energies() const;
  // Copies this world into *out (a snapshot, or a restore from one), the contact stage's
  // warm-start impulses included but not shared: a plain copy shares the contact stage, and the
  // world that steps next then starts its contacts cold. Reuses out's memory.
  void copy_to(World* out) const;

 private:
  std::vector<Rod> rods_;
  double time_ = 0.0;
  std::shared_ptr<ContactSystem> contacts_;
  ExplicitStepper explicit_;
  ImplicitStepper implicit_;
  // The stepper of `integrator`, set up for it: the one place that decides the integrator.
  Stepper& stepper_for(Integrator integrator);
  // The contact stage this world steps with (a copy of a world shares its stage until it steps).
  ContactSystem& own_contacts();
};

}  // namespace corde
