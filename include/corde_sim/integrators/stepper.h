// One family of integrators behind the stages of World::step (docs/architecture.md, "The step,
// stage by stage"): the free step of every rod, the response the contact solver uses, and the
// commit. World picks the stepper for its integrator in one place (World::stepper_for); the
// stages then read the same whichever integrator runs.
#pragma once

#include "corde_sim/contact/contact_response.h"

namespace corde {

class ContactSystem;
class World;

class Stepper : public ContactResponse {
 public:
  // Stage 2: every rod from the world's time t to t + h without contacts (forces, or the Newton
  // solve), drives set at t + h where the method sets them in the step. `contacts`: the contact
  // stage follows, with this stepper as its response; `last`: that stage as the last step left it
  // (its impulses predict this step's; null: none).
  virtual void free_step(World& world, bool contacts, const ContactSystem* last) = 0;
  // Stage 4: completes the step (what the free step and the contacts left open: the explicit
  // integration with the contact forces, the drives and constraints) and its statistics. After it
  // every support holds the reaction it exerted over the step (boundary.h), whichever stepper ran:
  // the explicit one as it sets the drives (Rod::apply_drives), the implicit one from the supports'
  // residuals of its Newton solve, where the drives are held.
  virtual void commit(World& world, bool contacts) = 0;
};

}  // namespace corde
