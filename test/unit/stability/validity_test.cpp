// The validity check that decides which states the node may fall back on.
#include <gtest/gtest.h>

#include <cmath>

#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/stability/state_checks.h"

namespace corde {
namespace {

World small_world() {
  Material m;
  m.youngs_modulus = m.shear_modulus = m.stretch_modulus = 1e6;
  m.density = 1000.0;
  m.kappa = 100.0;
  RodSpec spec;
  spec.name = "cable";
  spec.elements = 5;
  spec.section = make_section(m, 0.01);
  World w;
  w.add_rod(build_rod(spec));
  return w;
}

TEST(Validity, CatchesFiniteGarbageAsWellAsNaN) {
  const ValidityLimits lim;
  World w = small_world();
  EXPECT_EQ(validity_problem(w, lim), "");
  World z = w;
  z.rods()[0].orientations()[2].coeffs().setZero();  // what a blow-up left behind
  EXPECT_NE(validity_problem(z, lim).find("segment 2 has a quaternion of norm 0"),
            std::string::npos)
      << validity_problem(z, lim);
  World n = w;
  n.rods()[0].positions()[3].x() = NAN;
  EXPECT_NE(validity_problem(n, lim).find("node 3 is not finite"), std::string::npos);
  World s = w;
  s.rods()[0].angular_velocities()[1] = Vec3(0, 0, 1e20);
  EXPECT_NE(validity_problem(s, lim).find("spins at 1e+20"), std::string::npos);
  World v = w;
  v.rods()[0].velocities()[0] = Vec3(150, 0, 0);
  EXPECT_NE(validity_problem(v, lim).find("rod 'cable': node 0 moves at 150"), std::string::npos);
  v.rods()[0].velocities()[0] = Vec3(50, 0, 0);
  EXPECT_EQ(validity_problem(v, lim), "");
}

}  // namespace
}  // namespace corde
