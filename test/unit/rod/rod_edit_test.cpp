#include "corde_sim/rod/rod_edit.h"

#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/rod/rod_shape.h"

namespace corde {
namespace {

Section test_section() {
  Material m;
  m.youngs_modulus = 1e7;
  m.shear_modulus = 3e6;
  m.stretch_modulus = 5e7;
  m.density = 1100;
  m.kappa = 50.0;
  m.gamma_t = 1e-3;
  m.gamma_r = 1e-6;
  return make_section(m, 0.005);
}

Rod helix_rod(int n) {
  RodSpec spec;
  spec.name = "spring";
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.shape.helix_radius = 0.1;
  spec.shape.helix_pitch = 0.05;
  spec.shape.helix_turns = 2.0;
  spec.shape.direction = Vec3::UnitZ();
  spec.elements = n;
  spec.section = test_section();
  spec.rest_shape_created = true;
  return build_rod(spec);
}

TEST(EquivalentMaterial, RoundTripsTheSection) {
  const Section s = test_section();
  const Section t = make_section(equivalent_material(s), s.radius);
  EXPECT_NEAR(t.bend / s.bend, 1.0, 1e-12);
  EXPECT_NEAR(t.twist / s.twist, 1.0, 1e-12);
  EXPECT_NEAR(t.stretch / s.stretch, 1.0, 1e-12);
  EXPECT_NEAR(t.mass_per_length / s.mass_per_length, 1.0, 1e-12);
  EXPECT_NEAR(t.inertia_twist / s.inertia_twist, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(t.kappa, s.kappa);
  EXPECT_DOUBLE_EQ(t.gamma_t, s.gamma_t);
  EXPECT_DOUBLE_EQ(t.gamma_r, s.gamma_r);
  // Doubling the radius at fixed moduli scales bending stiffness by 16.
  const Section big = make_section(equivalent_material(s), 2.0 * s.radius);
  EXPECT_NEAR(big.bend / s.bend, 16.0, 1e-9);
}

// The retardation time gives the friction that a section's own stiffness times tau would:
// gamma_t = tau K_s, gamma_r = tau B.
TEST(EquivalentMaterial, RetardationTimeScalesWithStiffness) {
  const Section s = test_section();
  Material m = equivalent_material(s);
  set_retardation_time(&m, s.radius, 0.01);
  const Section t = make_section(m, s.radius);
  EXPECT_NEAR(t.gamma_t, 0.01 * s.stretch, 1e-12 * s.stretch);
  EXPECT_NEAR(t.gamma_r, 0.01 * s.bend, 1e-12 * s.bend);
}

TEST(EquivalentMaterial, RejectsZeroRadius) {
  Section s = test_section();
  s.radius = 0.0;
  EXPECT_THROW(equivalent_material(s), std::invalid_argument);
}

TEST(ResampleRod, SameCountReproducesTheRod) {
  Rod rod = helix_rod(30);
  for (int i = 0; i < rod.num_nodes(); ++i) rod.velocities()[i] = Vec3(0.1 * i, -0.2, 0.3);
  for (int s = 0; s < rod.num_segments(); ++s) rod.angular_velocities()[s] = Vec3(1.0, 2.0, s);
  const Rod out = resample_rod(rod, 30);
  ASSERT_EQ(out.num_segments(), 30);
  for (int i = 0; i < rod.num_nodes(); ++i) {
    EXPECT_LT((out.positions()[i] - rod.positions()[i]).norm(), 1e-12);
    EXPECT_LT((out.velocities()[i] - rod.velocities()[i]).norm(), 1e-12);
  }
  for (int s = 0; s < rod.num_segments(); ++s) {
    EXPECT_LT(out.orientations()[s].angularDistance(rod.orientations()[s]), 1e-9);
    EXPECT_LT((out.angular_velocities()[s] - rod.angular_velocities()[s]).norm(), 1e-9);
  }
  for (size_t j = 0; j < rod.rest_strains().size(); ++j)
    EXPECT_LT((out.rest_strains()[j] - rod.rest_strains()[j]).norm(), 1e-9);
}

// A pre-shaped helix resampled finer keeps its shape, mass, rest length and rest strains, so it
// is still (nearly) at rest: the elastic energy stays small compared with bending it straight.
TEST(ResampleRod, HelixKeepsShapeMassAndRestState) {
  const Rod rod = helix_rod(40);
  const Rod out = resample_rod(rod, 80);
  ASSERT_EQ(out.num_segments(), 80);
  const double dphi = 2.0 * M_PI * 2.0 / 40.0;
  double rest_in = 0.0, rest_out = 0.0, m_in = 0.0, m_out = 0.0;
  for (double l : rod.rest_lengths()) rest_in += l;
  for (double l : out.rest_lengths()) rest_out += l;
  for (double m : rod.node_masses()) m_in += m;
  for (double m : out.node_masses()) m_out += m;
  // The finer chords of the smooth curve through the old nodes are longer in sum than the old
  // chords (kink angle dphi = 2 pi * 2 / 40), by less than the arc exceeds them (dphi^2 / 24).
  EXPECT_GT(rest_out, rest_in);
  EXPECT_LT(rest_out, rest_in * (1.0 + dphi * dphi / 24.0));
  EXPECT_NEAR(m_out / m_in, rest_out / rest_in, 1e-12);
  // New nodes lie on the helix to within a small fraction of the old chord's sagitta
  // r (1 - cos(dphi / 2)): the cubic through the old nodes follows the curve, not the chords.
  const double sagitta = 0.1 * (1.0 - std::cos(dphi / 2.0));
  for (const Vec3& x : out.positions()) EXPECT_NEAR(std::hypot(x.x(), x.y()), 0.1, 0.1 * sagitta);
  EXPECT_LT((out.positions().front() - rod.positions().front()).norm(), 1e-12);
  EXPECT_LT((out.positions().back() - rod.positions().back()).norm(), 1e-12);
  // Parallel-transport frames on a helix: no twist, bending curvature of constant magnitude
  // (its direction turns with the torsion). Linear interpolation of the turning vector shortens
  // it by at most 1 - cos(dtheta / 2), well below 1e-3 here.
  const double kappa = rod.rest_strains()[10].head<2>().norm();
  for (const Vec3& u : out.rest_strains()) {
    EXPECT_NEAR(u.head<2>().norm(), kappa, 1e-3 * kappa);
    EXPECT_LT(std::abs(u.z()), 1e-6 * kappa);
  }
  // Elastic energy left in the resampled rest shape, against the energy of its bending.
  Rod straight = out;
  for (Vec3& u : straight.rest_strains()) u.setZero();
  const Vec3 g = Vec3::Zero();
  EXPECT_LT(out.energies(g).elastic(), 1e-3 * straight.energies(g).elastic());
}

// A rigid motion v = a + w x x is linear in x, so linear interpolation keeps it exactly.
TEST(ResampleRod, RigidVelocityFieldIsKept) {
  Rod rod = helix_rod(25);
  const Vec3 a(0.1, -0.3, 0.2), w(0.5, 1.0, -2.0);
  for (int i = 0; i < rod.num_nodes(); ++i) rod.velocities()[i] = a + w.cross(rod.positions()[i]);
  for (int s = 0; s < rod.num_segments(); ++s)
    rod.angular_velocities()[s] = rod.orientations()[s].conjugate() * w;
  const Rod out = resample_rod(rod, 37);
  for (int i = 0; i < out.num_nodes(); ++i)
    EXPECT_LT((out.velocities()[i] - (a + w.cross(out.positions()[i]))).norm(), 1e-12);
  for (int s = 0; s < out.num_segments(); ++s)
    EXPECT_LT((out.orientations()[s] * out.angular_velocities()[s] - w).norm(), 1e-9);
}

TEST(ResampleRod, BoundaryConditionsFollowTheMaterialCoordinate) {
  Rod rod = helix_rod(20);
  NodeDrive n0;
  n0.node = 0;
  n0.origin = rod.positions()[0];
  rod.add_node_drive(n0);
  NodeDrive n_end = n0;
  n_end.node = 20;
  n_end.origin = rod.positions()[20];
  rod.add_node_drive(n_end);
  SegmentDrive spin;
  spin.kind = SegmentDrive::Kind::kSpin;
  spin.segment = 19;
  spin.rate = 3.0;
  spin.origin = rod.orientations()[19];
  rod.add_segment_drive(spin);
  Load mid;
  mid.index = 10;  // the middle node
  mid.value = Vec3(0, 0, -1);
  rod.add_load(mid);
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];

  const Rod out = resample_rod(rod, 50);
  ASSERT_EQ(out.node_drives().size(), 2u);
  EXPECT_EQ(out.node_drives()[0].node, 0);
  EXPECT_EQ(out.node_drives()[1].node, 50);
  ASSERT_EQ(out.segment_drives().size(), 1u);
  EXPECT_EQ(out.segment_drives()[0].segment, 49);
  EXPECT_EQ(out.segment_drives()[0].kind, SegmentDrive::Kind::kSpin);
  EXPECT_DOUBLE_EQ(out.segment_drives()[0].rate, 3.0);
  ASSERT_EQ(out.loads().size(), 1u);
  EXPECT_EQ(out.loads()[0].index, 25);
  EXPECT_TRUE(out.ghost_start().active);
  EXPECT_FALSE(out.ghost_end().active);
}

TEST(ResampleRod, RejectsBadCounts) {
  const Rod rod = helix_rod(10);
  EXPECT_THROW(resample_rod(rod, 0), std::invalid_argument);
}

}  // namespace
}  // namespace corde
