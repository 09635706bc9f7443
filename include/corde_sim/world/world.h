// Several rods sharing gravity and a clock.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "corde_sim/contact/contact.h"
#include "corde_sim/contact/obstacle.h"
#include "corde_sim/contact/obstacle_motion.h"
#include "corde_sim/integrators/implicit_step.h"
#include "corde_sim/rod/rod.h"

namespace corde {

// The implicit integrator's Newton solves over the last step (Integrator::kImplicitEuler, kBdf2).
struct ImplicitStats {
  int iterations = 0;           // Newton iterations, the most any rod took
  int unconverged = 0;          // rods whose Newton iterations stopped short of the tolerance
  double worst_residual = 0.0;  // largest residual over its reference scale (ImplicitResult)
};

struct WorldEnergies {
  Energies total;
  double elastic() const { return total.elastic(); }
  double kinetic() const { return total.kinetic(); }
};

class World {
 public:
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);
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
  // Advances every rod by time_step: keyframed obstacles are posed first; with an explicit
  // integrator a world without anything to collide runs each rod's fused step, otherwise forces
  // of every rod, then contacts (detection and the constraint solve), then the integration and
  // the drives. With an implicit one every rod takes its backward Euler or BDF2 step, then
  // contacts are solved against those steps (ContactSystem::solve_implicit, with each step's own
  // compliance: BDF2's effective step 2h/3 in the response).
  void step();
  // The implicit integrator's solves in the last step (zero for the explicit methods).
  const ImplicitStats& implicit_stats() const { return implicit_stats_; }
  // Factorisations of the implicit integrator's Newton matrices so far, over all rods (they are
  // kept while the rods barely move: ImplicitOptions::reuse_factor).
  long implicit_factorisations() const;
  // The contact stage of the last step (null until a step needed it).
  const ContactSystem* contacts() const { return contacts_.get(); }
  void step(int n) {
    for (int i = 0; i < n; ++i) step();
  }
  bool finite() const;
  WorldEnergies energies() const;
  // Copies this world into *out (a snapshot, or a restore from one), the contact stage's
  // warm-start impulses included but not shared: a plain copy shares the contact stage, and the
  // world that steps next then starts its contacts cold. Reuses out's memory.
  void copy_to(World* out) const;

 private:
  std::vector<Rod> rods_;
  double time_ = 0.0;
  std::shared_ptr<ContactSystem> contacts_;
  std::vector<ImplicitEuler> implicit_;  // per rod (scratch and the step's factorisation)
  ImplicitStats implicit_stats_;
  std::vector<ImplicitResult> implicit_results_;  // per rod, the last step's (scratch)
  void step_implicit();
};

}  // namespace corde
