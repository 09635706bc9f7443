// V6 (docs/validation_references.md): invariants. Rigid motions change no elastic energy and meet
// no internal friction; a free rod falls with its centre of mass at exactly g; a free undamped rod
// keeps its linear momentum to round-off, its angular momentum to a small measured drift, and its
// energy oscillates by about omega h / 2 without drift.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "validation_util.h"

namespace corde {
namespace {

std::mt19937 rng(11);
double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
Vec3 rand_vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }

// A pre-shaped helix (intrinsic curvature and twist), perturbed so that every energy term is
// nonzero: N = 20, example material with internal friction.
Rod deformed_helix() {
  Material m = val::example_material();
  m.gamma_t = 5.0;
  m.gamma_r = 1e-3;
  RodSpec spec;
  spec.shape.kind = RodShape::Kind::kHelix;
  spec.shape.helix_radius = 0.1;
  spec.shape.helix_pitch = 0.1;
  spec.shape.helix_turns = 1.5;
  spec.elements = 20;
  spec.section = make_section(m, val::kRadius);
  spec.rest_shape_created = true;
  Rod rod = build_rod(spec);
  for (auto& x : rod.positions()) x += rand_vec(2e-3);
  for (auto& q : rod.orientations())
    q = (q * Quat(Eigen::AngleAxisd(uni(0.0, 0.1), rand_vec(1.0).normalized()))).normalized();
  return rod;
}

void rigid_transform(Rod* rod, const Quat& r, const Vec3& t) {
  for (auto& x : rod->positions()) x = r * x + t;
  for (auto& q : rod->orientations()) q = (r * q).normalized();
}

// Rotating (random axis, 2.3 rad) and translating a deformed pre-shaped rod keeps each elastic
// energy term to 1e-12 relative; a non-rigid map (1% stretch) does change it (the check can fail).
TEST(Invariants, RigidMotionChangesNoElasticEnergy) {
  Rod rod = deformed_helix();
  const Energies e0 = rod.energies(Vec3::Zero());
  Rod moved = rod;
  rigid_transform(&moved, Quat(Eigen::AngleAxisd(2.3, rand_vec(1.0).normalized())),
                  Vec3(0.3, -1.2, 4.0));
  const Energies e1 = moved.energies(Vec3::Zero());
  std::printf(
      "elastic energy %.15e J, after a rigid motion %.15e J (stretch %.3e, bend %.3e, "
      "coupling %.3e)\n",
      e0.elastic(), e1.elastic(), e0.stretch, e0.bend_twist, e0.coupling);
  EXPECT_GT(e0.stretch, 0.0);
  EXPECT_GT(e0.bend_twist, 0.0);
  EXPECT_GT(e0.coupling, 0.0);
  EXPECT_NEAR(e1.stretch / e0.stretch, 1.0, 1e-12);
  EXPECT_NEAR(e1.bend_twist / e0.bend_twist, 1.0, 1e-12);
  EXPECT_NEAR(e1.coupling / e0.coupling, 1.0, 1e-12);
  Rod scaled = rod;
  for (auto& x : scaled.positions()) x *= 1.01;
  EXPECT_GT(std::abs(scaled.energies(Vec3::Zero()).elastic() / e0.elastic() - 1.0), 1e-3);
}

// Rigid velocities (v = V + Omega x x on the nodes, body omega R^T Omega on the segments) add no
// force or torque to those of the rod at rest (gravity 0): differences below 1e-9 of the friction
// that a non-rigid velocity field of the same size produces.
TEST(Invariants, FrictionIgnoresRigidMotion) {
  Rod rod = deformed_helix();
  rod.compute_forces(0.0, Vec3::Zero());
  const std::vector<Vec3> f0 = rod.forces(), t0 = rod.torques();
  const Vec3 v(0.4, -0.2, 0.7), omega(3.0, -1.0, 2.0);
  auto set_velocities = [&](Rod* r, bool rigid) {
    for (int i = 0; i < r->num_nodes(); ++i)
      r->velocities()[i] =
          v + omega.cross(r->positions()[i]) + (rigid ? Vec3::Zero() : rand_vec(0.5));
    for (int s = 0; s < r->num_segments(); ++s)
      r->angular_velocities()[s] =
          r->orientations()[s].conjugate() * omega + (rigid ? Vec3::Zero() : rand_vec(3.0));
  };
  auto deviation = [&](Rod* r, double* df, double* dt) {
    r->compute_forces(0.0, Vec3::Zero());
    *df = *dt = 0.0;
    for (int i = 0; i < r->num_nodes(); ++i) *df = std::max(*df, (r->forces()[i] - f0[i]).norm());
    for (int s = 0; s < r->num_segments(); ++s)
      *dt = std::max(*dt, (r->torques()[s] - t0[s]).norm());
  };
  Rod rigid = rod, other = rod;
  set_velocities(&rigid, true);
  set_velocities(&other, false);
  double rf, rt, of, ot;
  deviation(&rigid, &rf, &rt);
  deviation(&other, &of, &ot);
  std::printf(
      "friction under rigid motion: force %.3e N, torque %.3e N m; non-rigid: %.3e N, "
      "%.3e N m\n",
      rf, rt, of, ot);
  EXPECT_GT(of, 1e-3);
  EXPECT_GT(ot, 1e-5);
  EXPECT_LT(rf, 1e-9 * of);
  EXPECT_LT(rt, 1e-9 * ot);
}

// A free deformed rod with internal friction and random velocities, under g = (1, -2, -9.81):
// after n steps of the semi-implicit Euler, the momentum is P0 + n h M g and the centre of mass
// x0 + n h v0 + h^2 g n (n+1)/2 (internal forces cancel): both to 1e-12 relative.
TEST(Invariants, FreeFallCentreOfMassAtG) {
  Rod rod = deformed_helix();
  for (auto& vel : rod.velocities()) vel = rand_vec(0.1);
  for (auto& w : rod.angular_velocities()) w = rand_vec(1.0);
  const Vec3 g(1.0, -2.0, -9.81);
  double mass = 0.0;
  for (double m : rod.node_masses()) mass += m;
  const Vec3 c0 = rod.center_of_mass(), v0 = rod.linear_momentum() / mass;
  const double h = 0.5 * critical_time_step(rod);
  const long n = 2000;
  for (long k = 0; k < n; ++k) rod.step(k * h, h, g);
  const double nn = static_cast<double>(n);
  const Vec3 c_expected = c0 + nn * h * v0 + h * h * g * nn * (nn + 1.0) / 2.0;
  const Vec3 accel = (rod.linear_momentum() / mass - v0) / (nn * h);
  std::printf(
      "free fall: acceleration of the centre of mass (%.12f, %.12f, %.12f), centre of "
      "mass error %.3e m after %ld steps\n",
      accel.x(), accel.y(), accel.z(), (rod.center_of_mass() - c_expected).norm(), n);
  EXPECT_LT((accel - g).norm(), 1e-10 * g.norm());
  EXPECT_LT((rod.center_of_mass() - c_expected).norm(), 1e-12 * (c_expected - c0).norm());
}

// Free rod (example material, N = 20), no gravity, no friction, h = 0.5 of the critical step:
// a deformed rod (2e-4 m random node offsets) with random velocities and a rigid spin of about
// 2 rad/s, 20000 steps. Linear
// momentum is constant to 1e-12 of sum m|v|; the angular momentum drift (the explicit
// gyroscopic term and the renormalisation do not conserve it exactly) is measured and must stay
// below 1e-4 of |L|.
TEST(Invariants, FreeRodMomenta) {
  Rod rod = val::straight_rod(val::example_material(), 20);
  for (auto& x : rod.positions()) x += rand_vec(2e-4);
  const Vec3 spin(0.5, 2.0, 0.3);
  for (int i = 0; i < rod.num_nodes(); ++i)
    rod.velocities()[i] = spin.cross(rod.positions()[i]) + rand_vec(0.01);
  for (int s = 0; s < rod.num_segments(); ++s)
    rod.angular_velocities()[s] = rod.orientations()[s].conjugate() * spin + rand_vec(0.1);
  const Vec3 p0 = rod.linear_momentum(), l0 = rod.angular_momentum();
  double scale = 0.0;
  for (int i = 0; i < rod.num_nodes(); ++i)
    scale += rod.node_masses()[i] * rod.velocities()[i].norm();
  const double h = 0.5 * critical_time_step(rod);
  double dp = 0.0, dl = 0.0;
  for (long k = 0; k < 20000; ++k) {
    rod.step(k * h, h, Vec3::Zero());
    dp = std::max(dp, (rod.linear_momentum() - p0).norm());
    if (k % 100 == 99) dl = std::max(dl, (rod.angular_momentum() - l0).norm());
  }
  std::printf("free rod, %d steps of %.3e s: |dP|/sum m|v| = %.3e, max |dL|/|L| = %.3e\n", 20000, h,
              dp / scale, dl / l0.norm());
  EXPECT_LT(dp, 1e-12 * scale);
  EXPECT_LT(dl, 1e-4 * l0.norm());
}

// Free-free rod (example material, N = 20) released at rest in its first bending mode (0.5e-3 L
// at the ends, rest lengths set to the segments' lengths so that nothing is stretched), no
// gravity or friction, for 10 periods of mode 1 (omega_1 = 11.19 rad/s), at h = 0.5 and 0.25 of
// the critical step. The semi-implicit Euler keeps a modified energy, so E oscillates with
// relative amplitude omega h / 2 per mode. The shape also puts ~0.5% of the energy into the
// fast shear and stretch modes (omega h ~ 1), which adds a fast ripple of similar size; a 10 ms
// moving average (>= 30 periods of those modes, 3.6% of mode 1's energy period) removes it. The
// filtered amplitude must be omega_1 h / 2 within 20%, halve with h (ratio 2 +- 0.2), and the
// means of the first and last tenth of the run agree to 5% of the amplitude (no drift).
TEST(Invariants, FreeRodEnergyOscillatesWithoutDrift) {
  const double bl = 4.730041;
  const double omega1 = bl * bl * 0.5;  // sqrt(B / (rho A L^4)) = 0.5 for the example rod
  auto shape = [&](double xi) {
    const double s = (std::cosh(bl) - std::cos(bl)) / (std::sinh(bl) - std::sin(bl));
    return std::cosh(bl * xi) + std::cos(bl * xi) - s * (std::sinh(bl * xi) + std::sin(bl * xi));
  };
  double amp[2];
  for (int k = 0; k < 2; ++k) {
    Rod rod = val::straight_rod(val::example_material(), 20);
    std::vector<double> rest(20);
    for (int i = 0; i <= 20; ++i) rod.positions()[i].z() = 0.25e-3 * shape(i / 20.0);
    for (int s = 0; s < 20; ++s) {
      Quat& q = rod.orientations()[s];
      const Vec3 dr = rod.positions()[s + 1] - rod.positions()[s];
      q = (Quat::FromTwoVectors(q * Vec3::UnitZ(), dr.normalized()) * q).normalized();
      rest[s] = dr.norm();
    }
    rod.set_rest_lengths(rest);
    const double h = (k == 0 ? 0.5 : 0.25) * critical_time_step(rod);
    const long steps = std::lround(10.0 * 2.0 * val::kPi / omega1 / h);
    std::vector<double> e(steps + 1);
    e[0] = 0.0;  // cumulative sums
    double lo_raw = 1e300, hi_raw = -1e300;
    for (long i = 0; i < steps; ++i) {
      rod.step(i * h, h, Vec3::Zero());
      const Energies en = rod.energies(Vec3::Zero());
      const double total = en.elastic() + en.kinetic();
      lo_raw = std::min(lo_raw, total);
      hi_raw = std::max(hi_raw, total);
      e[i + 1] = e[i] + total;
    }
    const long w = std::lround(0.01 / h);
    double lo = 1e300, hi = -1e300;
    for (long i = 0; i + w <= steps; ++i) {
      const double avg = (e[i + w] - e[i]) / w;
      lo = std::min(lo, avg);
      hi = std::max(hi, avg);
    }
    const double mean = e[steps] / steps;
    const long tenth = steps / 10;
    const double first = e[tenth] / tenth, last = (e[steps] - e[steps - tenth]) / tenth;
    amp[k] = 0.5 * (hi - lo) / mean;
    const double drift = std::abs(last - first) / mean;
    std::printf(
        "free-free mode 1, h = %.3e s, %ld steps: relative energy amplitude %.3e "
        "filtered (omega1 h/2 = %.3e, ratio %.3f), %.3e raw; drift of the mean %.3e\n",
        h, steps, amp[k], omega1 * h / 2.0, amp[k] / (omega1 * h / 2.0),
        0.5 * (hi_raw - lo_raw) / mean, drift);
    EXPECT_NEAR(amp[k] / (omega1 * h / 2.0), 1.0, 0.2);
    EXPECT_LT(drift, 0.05 * amp[k]);
  }
  EXPECT_NEAR(amp[0] / amp[1], 2.0, 0.2);
}

}  // namespace
}  // namespace corde
