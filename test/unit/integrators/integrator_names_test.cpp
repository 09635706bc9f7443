// The one table of integrator names (integrators/integrator_names.h): every entry has its own
// name, parses back to itself, and the scene reader takes exactly these names and `auto`.
#include "corde_sim/integrators/integrator_names.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

std::string scene_with(const std::string& integrator) {
  return "integrator: " + integrator +
         "\ntime_step: 1e-5\nrods:\n  - {name: r, elements: 4, radius: 0.01, material: "
         "paper_rope,\n     shape: {type: straight, length: 0.2}}\n";
}

TEST(IntegratorNames, EachNameParsesBackToItsIntegrator) {
  std::set<std::string> seen;
  for (Integrator i : kIntegrators) {
    const std::string name = integrator_name(i);
    EXPECT_TRUE(seen.insert(name).second) << name;
    Integrator parsed = i == Integrator::kBdf2 ? Integrator::kSplitRotation : Integrator::kBdf2;
    ASSERT_TRUE(parse_integrator(name, &parsed)) << name;
    EXPECT_EQ(parsed, i) << name;
  }
  Integrator unchanged = Integrator::kBdf2;
  EXPECT_FALSE(parse_integrator("rk4", &unchanged));
  EXPECT_EQ(unchanged, Integrator::kBdf2);
  EXPECT_EQ(integrator_names_joined(), "semi_implicit_euler, split_rotation, implicit_euler, bdf2");
}

TEST(IntegratorNames, TheSceneReaderTakesTheTableAndAuto) {
  for (Integrator i : kIntegrators)
    EXPECT_EQ(parse_scene(scene_with(integrator_name(i))).world.integrator, i);
  try {
    parse_scene(scene_with("rk4"));
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    for (const std::string& name : integrator_name_list())
      EXPECT_NE(what.find(name), std::string::npos) << what;
    EXPECT_NE(what.find("auto"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace corde
