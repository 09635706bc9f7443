// The implicit contact solve on the Delassus operator (ContactSettings::Solver::kDelassus): many
// contacts on one stiff rod converge in few iterations where the rounds need many, sticking on an
// incline below the friction angle holds exactly, and where both solves converge they agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "corde_sim/contact/contact.h"
#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A rod of `elements` lying along x on a plane tilted by `tilt_deg` about y, its axis `lift` radii
// above the surface (1: touching), stepped by implicit Euler at 2 ms with the given solve.
// pitch_deg: the rod's axis raised from the plane by this angle (its start touching first).
std::string rod_on_plane(const std::string& solver, const std::string& material, int elements,
                         double tilt_deg, double mu, double lift, double pitch_deg = 0.0) {
  const double a = tilt_deg * kPi / 180.0, r = 0.005, l = 0.5, p = pitch_deg * kPi / 180.0;
  const Vec3 normal(std::sin(a), 0.0, std::cos(a));
  const Vec3 down = std::cos(p) * Vec3(std::cos(a), 0.0, -std::sin(a)) + std::sin(p) * normal;
  const Vec3 start = (lift * r) * normal;
  char buf[1400];
  std::snprintf(buf, sizeof buf,
                "gravity: [0, 0, -9.81]\ntime_step: 0.002\nintegrator: implicit_euler\n"
                "contact: {implicit_solver: %s}\n"
                "obstacles:\n  - {name: plane, type: plane, normal: [%.17g, 0, %.17g], friction: "
                "%.17g}\n"
                "rods:\n  - name: rod\n    elements: %d\n    radius: %g\n    material: %s\n"
                "    shape: {type: straight, start: [%.17g, 0, %.17g], direction: [%.17g, 0, "
                "%.17g], length: %g}\n",
                solver.c_str(), normal.x(), normal.z(), mu, elements, r, material.c_str(),
                start.x(), start.z(), down.x(), down.z(), l);
  return buf;
}

const char* kSteel = "{E: 2.0e11, nu: 0.3, rho: 7850, damping_time: 1.0e-3}";
const char* kSoft = "{E: 1.0e6, nu: 0.5, rho: 1000, damping_time: 1.0e-3}";

// The deepest a node of rod 0 lies below the plane through the origin with this normal, in radii.
double depth(const Scene& s, const Vec3& normal) {
  const Rod& rod = s.world.rods()[0];
  double worst = 0.0;
  for (const Vec3& x : rod.positions())
    worst = std::max(worst, (rod.section().radius - x.dot(normal)) / rod.section().radius);
  return worst;
}

struct Stats {
  int max_iterations = 0;  // per step: rounds, or Delassus iterations
  long total = 0;
  double max_depth = 0.0;  // radii, from the geometry
  int contacts = 0;
};

Stats run(Scene& s, int steps) {
  Stats out;
  const bool delassus = s.world.contact.implicit_solver == ContactSettings::Solver::kDelassus;
  for (int k = 0; k < steps; ++k) {
    s.world.step();
    const ContactStats& st = s.world.contacts()->stats();
    const int it = delassus ? st.delassus_iterations : st.rounds;
    out.max_iterations = std::max(out.max_iterations, it);
    out.total += it;
    out.contacts = std::max(out.contacts, st.active);
    out.max_depth = std::max(out.max_depth, depth(s, Vec3::UnitZ()));
  }
  return out;
}

// A steel rod of 40 elements landing on a floor at 2 ms, one end first (its axis raised 3 degrees,
// so that it lands turning): its 41 contacts load one stiff rod together. The Delassus solve meets
// its tolerance at every step within its iteration limit (not running into it), and the rod stays
// out of the floor (from the node positions) to 1 % of the radius. The rounds' counts are printed
// beside it for comparison (docs/benchmark.md).
TEST(ContactDelassus, StiffRodLandingOnManyContactsConverges) {
  Scene rounds = parse_scene(rod_on_plane("rounds", kSteel, 40, 0.0, 0.4, 1.0, 3.0));
  Scene delassus = parse_scene(rod_on_plane("delassus", kSteel, 40, 0.0, 0.4, 1.0, 3.0));
  const Stats a = run(rounds, 100);
  Stats b;
  int unconverged = 0;
  for (int k = 0; k < 100; ++k) {
    const Stats one = run(delassus, 1);
    const ContactStats& st = delassus.world.contacts()->stats();
    if (st.residual > st.tolerance) ++unconverged;
    b.max_iterations = std::max(b.max_iterations, one.max_iterations);
    b.total += one.total;
    b.contacts = std::max(b.contacts, one.contacts);
    b.max_depth = std::max(b.max_depth, one.max_depth);
  }
  std::printf(
      "rounds: at most %d a step, %ld in all, depth %.2e r; delassus: at most %d, %ld, "
      "depth %.2e r; contacts %d\n",
      a.max_iterations, a.total, a.max_depth, b.max_iterations, b.total, b.max_depth, b.contacts);
  EXPECT_GE(b.contacts, 40);
  EXPECT_EQ(unconverged, 0);
  EXPECT_LT(b.max_iterations, delassus.world.contact.implicit_iterations);
  EXPECT_LT(b.max_depth, 0.01);
  EXPECT_LT(a.max_depth, 0.01);
}

// A steel rod at rest on a plane tilted 15 degrees, below its friction angle (tan 15 = 0.27 <
// 0.5): once settled it does not move along the slope at all, 1 s at 2 ms.
TEST(ContactDelassus, StickingOnAnInclineHoldsExactly) {
  for (const char* material : {kSteel, kSoft}) {
    Scene s = parse_scene(rod_on_plane("delassus", material, 20, 15.0, 0.5, 1.0));
    s.world.step(100);  // settles
    const double a = 15.0 * kPi / 180.0;
    const Vec3 down(std::cos(a), 0.0, -std::sin(a));
    const Vec3 x0 = s.world.rods()[0].center_of_mass();
    s.world.step(500);
    const double slip = (s.world.rods()[0].center_of_mass() - x0).dot(down);
    EXPECT_LT(std::abs(slip), 1e-7) << material;
    EXPECT_LE(s.world.contacts()->stats().residual, s.world.contacts()->stats().tolerance);
  }
}

// Where both solves converge (a soft rope dropped onto a floor and sliding down a 30 degree slope
// with mu = 0.3, both to a tolerance of 1e-6 r a step) they give the same trajectory: the nodes
// after 0.2 s agree to 1e-4 of the radius.
TEST(ContactDelassus, AgreesWithTheRoundsWhereBothConverge) {
  for (double tilt : {0.0, 30.0}) {
    Scene a = parse_scene(rod_on_plane("rounds", kSoft, 20, tilt, 0.3, 1.5));
    Scene b = parse_scene(rod_on_plane("delassus", kSoft, 20, tilt, 0.3, 1.5));
    for (Scene* s : {&a, &b}) {
      s->world.contact.implicit_tolerance = s->world.contact.implicit_tolerance_min = 1e-6;
      s->world.contact.implicit_rounds = 1000;
      s->world.contact.implicit_iterations = 1000;
    }
    double worst = 0.0;
    for (int k = 0; k < 100; ++k) {
      a.world.step();
      b.world.step();
      for (int i = 0; i < a.world.rods()[0].num_nodes(); ++i)
        worst = std::max(
            worst, (a.world.rods()[0].positions()[i] - b.world.rods()[0].positions()[i]).norm());
    }
    EXPECT_GT(b.world.contacts()->stats().active, 10) << tilt;
    EXPECT_LT(worst, 1e-4 * 0.005) << tilt;
  }
}

TEST(ContactDelassus, SceneKeyIsChecked) {
  Scene s = parse_scene(rod_on_plane("delassus", kSoft, 4, 0.0, 0.3, 1.0));
  EXPECT_EQ(s.world.contact.implicit_solver, ContactSettings::Solver::kDelassus);
  try {
    parse_scene(rod_on_plane("newton", kSoft, 4, 0.0, 0.3, 1.0));
    ADD_FAILURE() << "implicit_solver: newton accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("contact.implicit_solver"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace corde
