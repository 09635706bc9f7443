// Backward Euler on the rod system: a steel cantilever and a falling steel cable at steps of
// 1-2 ms (about 1000x the explicit critical step), stable, dissipative, and settling on statics.
#include "corde_sim/implicit_step.h"

#include <gtest/gtest.h>

#include <iostream>
#include <stdexcept>

#include "corde_sim/material.h"
#include "corde_sim/rod_shape.h"
#include "corde_sim/stability.h"
#include "corde_sim/statics.h"

namespace corde {
namespace {

const Vec3 kGravity(0.0, 0.0, -9.81);

// Steel (E = 200 GPa, G = 79 GPa, rho = 7850), r = 2 mm, horizontal along x, node 0 fixed.
Rod steel_rod(int n, double length, bool ghost_clamp) {
  RodSpec spec;
  spec.elements = n;
  spec.shape.length = length;
  spec.shape.direction = Vec3::UnitX();
  spec.section = make_section(material_preset("steel_wire").material, 0.002);
  Rod rod = build_rod(spec);
  rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  if (ghost_clamp) {
    rod.ghost_start().active = true;
    rod.ghost_start().frame = rod.orientations()[0];
  }
  return rod;
}

// Kinetic energy plus elastic and gravity potential.
double total_energy(const Rod& rod) {
  const RodSystem sys{&rod, kGravity};
  double e = sys.energy();
  for (int i = 0; i < rod.num_nodes(); ++i)
    e += 0.5 * rod.node_masses()[i] * rod.velocities()[i].squaredNorm();
  for (int s = 0; s < rod.num_segments(); ++s)
    e += 0.5 * rod.angular_velocities()[s].dot(
                   rod.segment_inertia(s).cwiseProduct(rod.angular_velocities()[s]));
  return e;
}

// A 0.5 m steel cantilever (N = 20, ghost clamp) released straight under gravity, a tip force
// and a torque at h = 2 ms:
// every step converges, the energy never rises (to 1e-9 of the elastic scale), and after 2 s
// (about 22 periods of its first mode, which backward Euler damps by ~1 % per step) the tip is
// where statics puts it to 1e-3 of the sag.
TEST(ImplicitEuler, SteelCantileverSettlesOnStatics) {
  Rod rod = steel_rod(20, 0.5, true);
  // A sideways tip force and a twisting torque on the last segment, dead loads.
  rod.add_load({Load::Kind::kForce, 20, Vec3(0.0, 0.05, 0.0)});
  rod.add_load({Load::Kind::kTorque, 19, Vec3(0.02, 0.0, 0.0)});
  Rod ref = rod;
  const Quat q_tip0 = rod.orientations()[19];
  const StaticResult st = solve_statics(ref, kGravity, 0.0);
  ASSERT_TRUE(st.converged);
  const double sag = (ref.positions()[20] - rod.positions()[20]).norm();
  const double h = 2e-3;
  std::cout << "explicit critical step " << critical_time_step(rod) << " s, implicit " << h
            << " s\n";
  ImplicitEuler integrator;
  double e_prev = total_energy(rod), t = 0.0;
  const double scale = std::abs(st.energy);
  int iterations = 0, worst = 0;
  double torque_work = 0.0;  // the dead torque's work, along each step's rotation
  for (int k = 0; k < 1000; ++k, t += h) {
    const Quat q_before = rod.orientations()[19];
    const ImplicitResult r = integrator.step(rod, t, h, kGravity);
    ASSERT_TRUE(r.converged) << "step " << k << " residual " << r.residual << " of " << r.reference;
    iterations += r.iterations;
    worst = std::max(worst, r.iterations);
    const Eigen::AngleAxisd turn(q_before.conjugate() * rod.orientations()[19]);
    torque_work += Vec3(0.02, 0.0, 0.0).dot(q_before * (turn.angle() * turn.axis()));
    const double e = total_energy(rod) - torque_work;
    ASSERT_LE(e, e_prev + 1e-9 * scale) << "step " << k;
    e_prev = e;
  }
  const double err = (rod.positions()[20] - ref.positions()[20]).norm();
  const double twist = rod.orientations()[19].angularDistance(ref.orientations()[19]);
  std::cout << "tip segment rotation " << q_tip0.angularDistance(ref.orientations()[19])
            << " rad, off by " << twist << " rad\n";
  std::cout << "static tip deflection " << sag << " m, tip after 2 s off by " << err
            << " m; Newton " << iterations / 1000.0 << " iterations per step (max " << worst
            << ")\n";
  EXPECT_GT(sag, 1e-3);
  EXPECT_LT(err, 1e-3 * sag);
  EXPECT_LT(twist, 1e-3 * q_tip0.angularDistance(ref.orientations()[19]));
}

// A 1 m steel cable of 40 elements pinned at one end (no ghost frame), released horizontal: it
// swings down through large rotations at h = 1 ms; each step converges and the energy never
// rises.
TEST(ImplicitEuler, FallingSteelCableIsStableAndDissipative) {
  Rod rod = steel_rod(40, 1.0, false);
  const double h = 1e-3;
  ImplicitEuler integrator;
  double e_prev = total_energy(rod), t = 0.0;
  const double scale = rod.node_masses()[1] * 40 * 9.81;  // weight times 1 m
  int iterations = 0;
  for (int k = 0; k < 300; ++k, t += h) {
    const ImplicitResult r = integrator.step(rod, t, h, kGravity);
    ASSERT_TRUE(r.converged) << "step " << k << " residual " << r.residual << " of " << r.reference;
    ASSERT_TRUE(rod.finite());
    iterations += r.iterations;
    const double e = total_energy(rod);
    ASSERT_LE(e, e_prev + 1e-9 * scale) << "step " << k;
    e_prev = e;
  }
  std::cout << "cable: tip z after 0.3 s " << rod.positions()[40].z() << " m, Newton "
            << iterations / 300.0 << " iterations per step, max strain " << rod.max_stretch_strain()
            << "\n";
  EXPECT_LT(rod.positions()[40].z(), -0.2);  // it fell
  EXPECT_LT(rod.max_stretch_strain(), 1e-4);
}

}  // namespace
}  // namespace corde
