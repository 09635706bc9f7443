// World::step's stages under every integrator: the contact stage records the same impulses and
// the supports the same reactions whichever stepper runs (docs/architecture.md, "The step, stage
// by stage").
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace {

constexpr Integrator kAll[] = {Integrator::kSplitRotation, Integrator::kSemiImplicitEuler,
                               Integrator::kImplicitEuler, Integrator::kBdf2};

// A straight rope lying at rest along x on a floor (its axis one radius above the plane), its
// first node held fixed where it lies.
World rope_on_floor() {
  const Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\n"
      "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
      "rods:\n  - name: rope\n    elements: 20\n    radius: 0.005\n"
      "    material: {E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}\n"
      "    shape: {type: straight, start: [0, 0, 0.005], direction: [1, 0, 0], length: 0.5}\n");
  World w = s.world;
  Rod& rod = w.rods()[0];
  NodeDrive d;
  d.node = 0;
  d.origin = rod.positions()[0];
  rod.add_node_drive(d);
  return w;
}

Vec3 momentum(const Rod& rod) {
  Vec3 p = Vec3::Zero();
  for (int i = 0; i < rod.num_nodes(); ++i) p += rod.node_masses()[i] * rod.velocities()[i];
  return p;
}

// At rest the floor and the held node carry the rope's weight: over the steps, the contact
// impulses and the drive's reaction balance it and the change of the rope's momentum, under every
// integrator (the implicit contact solve resolves each step's impulses only to its tolerance, so
// the balance is taken over many steps).
TEST(StepStages, FloorAndHeldNodeCarryTheWeightUnderEveryIntegrator) {
  for (Integrator integ : kAll) {
    World w = rope_on_floor();
    w.integrator = integ;
    w.time_step = is_implicit(integ) ? 1e-3 : 1e-5;
    const Rod& rod = w.rods()[0];
    Vec3 weight = Vec3::Zero();
    for (double m : rod.node_masses()) weight += m * w.gravity;
    w.step(5);
    const int n = 200;
    const Vec3 p0 = momentum(rod);
    Vec3 contact = Vec3::Zero(), held = Vec3::Zero();
    for (int k = 0; k < n; ++k) {
      w.step();
      ASSERT_NE(w.contacts(), nullptr) << integrator_name(integ);
      for (const Contact& c : w.contacts()->contacts())
        contact += (c.pn * c.normal + c.pt) / (n * w.time_step);
      held += rod.node_drives()[0].reaction / n;
    }
    const Vec3 dp = (momentum(rod) - p0) / (n * w.time_step);
    std::printf(
        "%-20s contacts %.9f N, held node %.9f N, weight %.9f N, momentum change %.3e N; "
        "imbalance %.2e\n",
        integrator_name(integ), contact.z(), held.z(), -weight.z(), dp.z(),
        (contact + held + weight - dp).norm() / weight.norm());
    // The held node carries part of the weight: it must read it, not zero.
    EXPECT_GT(held.z(), 0.01 * -weight.z()) << integrator_name(integ);
    EXPECT_LT((contact + held + weight - dp).norm(), 1e-6 * weight.norm())
        << integrator_name(integ);
  }
}

}  // namespace
}  // namespace corde
