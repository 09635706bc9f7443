#include "corde_sim/integrators/explicit_stepper.h"

#include "corde_sim/world/world.h"

namespace corde {

void ExplicitStepper::free_step(World& world, bool contacts, const ContactSystem*) {
  const double t = world.time();
  const Vec3 g = world.gravity_at(t);
  if (contacts) {
    for (Rod& r : world.rods()) r.compute_forces(t, g);
  } else {
    for (Rod& r : world.rods()) r.step(t, world.time_step, g, rotation_);
  }
}

void ExplicitStepper::commit(World& world, bool contacts) {
  if (!contacts) return;  // the fused step committed
  for (Rod& r : world.rods()) r.integrate(world.time(), world.time_step, rotation_);
}

void ExplicitStepper::free_motion(const Rod& rod, int, double t, double h, bool spin,
                                  std::vector<Vec3>* v_out, std::vector<double>* inv_mass,
                                  std::vector<Vec3>* omega) const {
  const double t_end = t + h;
  const int nn = rod.num_nodes();
  auto& v = *v_out;
  auto& w = *inv_mass;
  v.resize(nn);
  w.resize(nn);
  for (int i = 0; i < nn; ++i) {
    w[i] = 1.0 / rod.node_masses()[i];
    v[i] = rod.velocities()[i] + (h * w[i]) * rod.forces()[i];
  }
  for (const NodeDrive& d : rod.node_drives()) {
    w[d.node] = 0.0;
    v[d.node] = drive_state(d, t_end, h, rod.positions()[d.node]).velocity;
  }
  if (!spin) return;
  const int ns = rod.num_segments();
  auto& om = *omega;
  om.resize(ns);
  for (int s = 0; s < ns; ++s)
    om[s] =
        rod.orientations()[s] * Vec3(rod.angular_velocities()[s] +
                                     h * rod.torques()[s].cwiseQuotient(rod.segment_inertia(s)));
  for (const SegmentDrive& d : rod.segment_drives())
    om[d.segment] = drive_state(d, t_end, h, rod.orientations()[d.segment]).world_angular_velocity;
  for (const SegmentConstraint& c : rod.segment_constraints())
    om[c.segment] = c.axis * c.axis.dot(om[c.segment]);
}

}  // namespace corde
