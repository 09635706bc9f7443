// The one table of key ranges (scene/key_ranges.h): a value just outside each range is refused by
// the scene reader and by ~configure's check with the same text naming the value and the range.
#include "corde_sim/scene/key_ranges.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "scene_test_util.h"
#ifdef CORDE_TEST_ROS_ADAPTER
#include "corde_sim/ros/configure.h"
#endif

namespace corde {
namespace {

std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// Values just outside the range: below (the bound itself when it is excluded) and above.
std::vector<double> outside(const KeyRange& r) {
  const double below =
      r.min_inclusive ? (r.min == 0.0 ? -1e-3 : r.min - 1e-3 * std::abs(r.min)) : r.min;
  return {below, r.max + 1e-3 * std::abs(r.max)};
}

// The override that sets `key` of rods[0] to v in test::kClampedCable, and the key's path.
bool scene_override(const std::string& key, double v, std::string* text, std::string* path) {
  const std::string x = exact(v);
  for (const char* node_key :
       {"real_time_factor", "tf_rate", "marker_rate", "state_rate", "marker_min_diameter",
        "holder_max_speed", "holder_max_acceleration", "loop_rate", "cloud_rate"})
    if (key == node_key) return false;  // the node's (reconfigure_ranges_test)
  if (key == "radius") {
    *text = "rods.0.radius=" + x;
    *path = "rods[0].radius";
  } else if (key == "elements") {
    return false;  // an integer key: the reader's own message (scene_hardening_test)
  } else if (key.rfind("linear_", 0) == 0 || key.rfind("quadratic_", 0) == 0 ||
             key == "fluid_density") {
    *text = "rods.0.drag={" + key + ": " + x + "}";
    *path = "rods[0].drag." + key;
  } else if (key == "mass") {
    *text = "rods.0.masses=[{node: end, mass: " + x + "}]";
    *path = "rods[0].masses[0].mass";
  } else if (key == "inertia_across" || key == "inertia_along") {
    *text = "rods.0.masses=[{node: end, mass: 1, " + key + ": " + x + "}]";
    *path = "rods[0].masses[0]." + key;
  } else if (key == "drag_coefficient" || key == "friction_coefficient") {
    *text = "rods.0.drag={fluid_density: 1, " + key + ": " + x + "}";
    *path = "rods[0].drag." + key;
  } else {
    *text = "rods.0.material." + key + "=" + x;
    *path = "rods[0].material." + key;
  }
  return true;
}

TEST(SceneKeyRanges, ValueJustOutsideIsRefusedNamingKeyValueAndRange) {
  int checked = 0;
  for (const KeyRange& r : key_ranges()) {
    for (double v : outside(r)) {
      const std::string why = range_violation(r, v);
      ASSERT_FALSE(why.empty()) << r.name << " " << v;
      EXPECT_NE(why.find(range_text(r)), std::string::npos) << why;
      std::string text, path;
      if (!scene_override(r.name, v, &text, &path)) continue;
      const std::string e = test::scene_error_of(test::kClampedCable, {text});
      EXPECT_EQ(e.rfind(path + ": " + why, 0), 0u) << text << " gave: " << e;
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST(SceneKeyRanges, BoundsThemselvesAreJudgedByInclusiveness) {
  for (const KeyRange& r : key_ranges()) {
    EXPECT_EQ(range_violation(r, r.max), "") << r.name;
    EXPECT_EQ(range_violation(r, r.min).empty(), r.min_inclusive) << r.name;
    EXPECT_FALSE(range_violation(r, NAN).empty()) << r.name;
  }
  EXPECT_EQ(range_violation(*find_key_range("E"), -5.0),
            "must be > 0, got -5 (valid: (0, 1e+30] Pa)");
  EXPECT_EQ(find_key_range("no_such_key"), nullptr);
}

#ifdef CORDE_TEST_ROS_ADAPTER
TEST(ConfigureKeyRanges, SameMessageAsTheSceneReader) {
  const Scene scene = parse_scene(test::kClampedCable);
  int checked = 0;
  for (const std::string& key : corde_sim::configure_keys()) {
    const KeyRange* r = find_key_range(key);
    if (!r) continue;  // a world key (time_step, gravity_*): the node's own range
    for (double v : outside(*r)) {
      corde_sim::ConfigurePlan plan;
      const std::string reply =
          corde_sim::plan_configure(scene.world, "", {key}, {v}, {}, {}, "", &plan);
      EXPECT_EQ(reply, key + ": " + range_violation(*r, v)) << key << " " << v;
      std::string text, path;
      if (scene_override(key, v, &text, &path)) {
        const std::string e = test::scene_error_of(test::kClampedCable, {text});
        EXPECT_NE(e.find(": " + range_violation(*r, v)), std::string::npos) << e;
      }
      ++checked;
    }
    // Within the range: accepted.
    corde_sim::ConfigurePlan plan;
    EXPECT_EQ(corde_sim::plan_configure(scene.world, "", {key}, {r->max}, {}, {}, "", &plan), "")
        << key;
  }
  EXPECT_GE(checked, 20);  // ten rod keys, two values each
}
#endif

}  // namespace
}  // namespace corde
