// The sensitivity of a static equilibrium to material keys (statics/static_sensitivity.h,
// scene_statics_sensitivity): against central differences of re-solved equilibria, for a cantilever
// under gravity (E, G, rho), a rod whose end is moved in and twisted (E, G), a cable with point
// masses (rho moves only the cable's own weight) and a coil spring hanging from a clamp; against
// the cantilever's d delta/dE = -delta/E of beam theory; and the errors for unknown or underived
// parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/statics/scene_statics.h"

namespace corde {
namespace {

// Node positions of the scene's first rod at its equilibrium at t, with overrides.
std::vector<Vec3> equilibrium(const std::string& yaml, double t,
                              const std::vector<std::string>& overrides) {
  Scene s = parse_scene(yaml, overrides);
  const SceneEquilibrium eq = solve_scene_statics(&s, t);
  EXPECT_TRUE(eq.ok) << eq.problem;
  return s.world.rods()[0].positions();
}

// The largest difference between the analytic sensitivity of `key` (material value `value`) and
// central differences of re-solved equilibria (relative step 1e-4), over the largest entry.
double fd_mismatch(const std::string& yaml, double t, const std::string& key, double value,
                   const std::vector<Vec3>& analytic) {
  const double h = 1e-4 * value;
  const std::string k = "rods.0.material." + key + "=";
  char plus[64], minus[64];
  std::snprintf(plus, sizeof plus, "%.17g", value + h);
  std::snprintf(minus, sizeof minus, "%.17g", value - h);
  const std::vector<Vec3> xp = equilibrium(yaml, t, {k + plus});
  const std::vector<Vec3> xm = equilibrium(yaml, t, {k + minus});
  double worst = 0.0, scale = 0.0;
  for (size_t i = 0; i < analytic.size(); ++i) {
    const Vec3 fd = (xp[i] - xm[i]) / (2.0 * h);
    worst = std::max(worst, (fd - analytic[i]).norm());
    scale = std::max(scale, fd.norm());
  }
  EXPECT_GT(scale, 0.0) << key << ": the equilibrium does not move";
  return worst / scale;
}

struct Case {
  std::string name, yaml;
  double t;
  std::vector<std::pair<std::string, double>> params;  // key, value in the yaml
};

void check(const Case& c, double tol) {
  Scene s = parse_scene(c.yaml);
  const SceneEquilibrium eq = solve_scene_statics(&s, c.t);
  ASSERT_TRUE(eq.ok) << eq.problem;
  std::vector<std::string> names;
  for (const auto& p : c.params) names.push_back(p.first);
  const std::vector<StaticSensitivity> sens =
      scene_statics_sensitivity(&s, s.world.rods()[0].name(), c.t, names);
  ASSERT_EQ(sens.size(), names.size());
  for (size_t j = 0; j < names.size(); ++j) {
    const double m = fd_mismatch(c.yaml, c.t, names[j], c.params[j].second, sens[j].positions);
    std::printf("%s: d x / d %s against central differences: %.3g relative\n", c.name.c_str(),
                names[j].c_str(), m);
    EXPECT_LT(m, tol) << c.name << ", " << names[j];
  }
}

const char* kCantilever = R"(gravity: [0, 0, -9.81]
rods:
  - name: cable
    elements: 20
    radius: 0.004
    material: {E: 2.0e7, G: 7.0e6, rho: 1500}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.5}
    boundary:
      - {clamp: start, kind: ghost}
)";

TEST(StaticSensitivity, CantileverUnderGravityMatchesDifferences) {
  check({"cantilever", kCantilever, 0.0, {{"E", 2.0e7}, {"G", 7.0e6}, {"rho", 1500.0}}}, 1e-5);
}

// Both ends clamped, the end moved in by 0.15 m and turned by 0.7 turns about its tangent: a
// bent and twisted shape in 3-D where twist and bending trade (G matters through C, not only
// through the shear penalty).
const char* kTwisted = R"(gravity: [0, 0, -9.81]
rods:
  - name: cable
    elements: 24
    radius: 0.003
    material: {E: 5.0e7, G: 2.0e7, E_s: 1.0e8, rho: 1200}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.6}
    boundary:
      - {clamp: start, kind: ghost}
      - {clamp: end, kind: ghost, move_by: [-0.15, 0, 0.05], turns: 0.7, ramp_time: 1.0}
)";

TEST(StaticSensitivity, TwistedClampedRodMatchesDifferences) {
  check({"twisted", kTwisted, 1.0, {{"E", 5.0e7}, {"G", 2.0e7}, {"E_s", 1.0e8}, {"rho", 1200.0}}},
        1e-5);
}

// Point masses on the cable: rho moves only the cable's own weight.
const char* kMasses = R"(gravity: [0, 0, -9.81]
rods:
  - name: cable
    elements: 16
    radius: 0.004
    material: {E: 3.0e7, G: 1.0e7, rho: 1500, kappa: 2.0e3}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.4}
    boundary:
      - {clamp: start, kind: ghost}
    masses:
      - {node: 8, mass: 0.01}
      - {node: end, mass: 0.02}
)";

TEST(StaticSensitivity, PointMassesMatchDifferences) {
  check({"masses", kMasses, 0.0, {{"rho", 1500.0}, {"E", 3.0e7}, {"kappa", 2.0e3}}}, 1e-5);
}

// A coil spring hanging from a clamp under its weight: its drop is carried by twist (G).
const char* kSpring = R"(gravity: [0, 0, -9.81]
rods:
  - name: spring
    elements: 60
    radius: 0.001
    rest_shape: created
    material: {B: 2.0e-3, C: 1.5e-3, K_s: 1.0e5, rho: 7800}
    shape: {type: helix, start: [0, 0, 1], axis: [0, 0, -1], radius: 0.02, pitch: 0.01, length: 0.6}
    boundary:
      - {clamp: start, kind: ghost}
)";

TEST(StaticSensitivity, HangingSpringMatchesDifferences) {
  check({"spring", kSpring, 0.0, {{"B", 2.0e-3}, {"C", 1.5e-3}, {"rho", 7800.0}}}, 1e-5);
}

// A steel rod of 1 m with a stiff shear penalty, sagging 1 mm under its weight: tip deflection
// delta = q L^4 / (8 E I) with d delta/dE = -delta/E. The discrete tip deflection's own
// derivative follows -delta/E to the geometric nonlinearity ((delta/L)^2 ~ 1e-6) and the beam
// formula to the discretisation (4e-4 at 50 elements).
TEST(StaticSensitivity, CantileverTipFollowsBeamTheory) {
  const std::string yaml = R"(gravity: [0, 0, -9.81]
rods:
  - name: beam
    elements: 50
    radius: 0.005
    material: {E: 2.0e11, G: 8.0e10, kappa: 1.0e9, rho: 1000}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 1.0}
    boundary:
      - {clamp: start, kind: ghost}
)";
  Scene s = parse_scene(yaml);
  ASSERT_TRUE(solve_scene_statics(&s, 0.0).ok);
  const Rod& rod = s.world.rods()[0];
  const double e = 2.0e11;
  const double q = rod.section().mass_per_length * 9.81;
  const double delta_beam = q / (8.0 * rod.section().bend);  // L = 1
  const double delta = 1.0 - rod.positions().back().z();
  const std::vector<StaticSensitivity> d = scene_statics_sensitivity(&s, "beam", 0.0, {"E"});
  const double ddelta = -d[0].positions.back().z();
  std::printf("tip: delta %.6e m (beam %.6e), d delta/dE %.6e (-delta/E %.6e, beam %.6e)\n", delta,
              delta_beam, ddelta, -delta / e, -delta_beam / e);
  EXPECT_NEAR(ddelta / (-delta / e), 1.0, 1e-5);
  EXPECT_NEAR(ddelta / (-delta_beam / e), 1.0, 2e-3);
}

TEST(StaticSensitivity, ErrorsNameTheParameter) {
  Scene s = parse_scene(kCantilever);
  ASSERT_TRUE(solve_scene_statics(&s, 0.0).ok);
  auto error = [&](const std::string& rod, const std::vector<std::string>& p) -> std::string {
    try {
      scene_statics_sensitivity(&s, rod, 0.0, p);
    } catch (const SceneError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("cable", {"Q"}).find("unknown parameter 'Q' (known: E, G"), std::string::npos)
      << error("cable", {"Q"});
  EXPECT_NE(error("cable", {"B"}).find("parameter 'B': its material derives nothing from B"),
            std::string::npos)
      << error("cable", {"B"});
  EXPECT_NE(error("rope", {"E"}).find("no rod named 'rope' (rods: cable)"), std::string::npos);
  EXPECT_EQ(error("cable", {"density", "E"}), "");
}

}  // namespace
}  // namespace corde
