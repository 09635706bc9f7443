// cfg/Node.cfg declares the dynamic_reconfigure ranges a second time (its generator needs them):
// the generated NodeConfig's ranges must equal the library's table (scene/key_ranges.h).
#ifdef CORDE_TEST_ROS_ADAPTER
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/NodeConfig.h"
#include "corde_sim/ros/node_params.h"
#include "corde_sim/scene/key_ranges.h"

namespace corde_sim {
namespace {

TEST(ReconfigureKeyRanges, NodeCfgRangesEqualTheTable) {
  const NodeConfig& lo = NodeConfig::__getMin__();
  const NodeConfig& hi = NodeConfig::__getMax__();
  struct Entry {
    const char* name;
    double min, max;
  } entries[] = {
      {"real_time_factor", lo.real_time_factor, hi.real_time_factor},
      {"tf_rate", lo.tf_rate, hi.tf_rate},
      {"marker_rate", lo.marker_rate, hi.marker_rate},
      {"state_rate", lo.state_rate, hi.state_rate},
      {"marker_min_diameter", lo.marker_min_diameter, hi.marker_min_diameter},
      {"holder_max_speed", lo.holder_max_speed, hi.holder_max_speed},
      {"holder_max_acceleration", lo.holder_max_acceleration, hi.holder_max_acceleration},
  };
  for (const Entry& e : entries) {
    const corde::KeyRange* r = corde::find_key_range(e.name);
    ASSERT_NE(r, nullptr) << e.name;
    EXPECT_EQ(e.min, r->min) << e.name;
    EXPECT_EQ(e.max, r->max) << e.name;
    EXPECT_TRUE(r->min_inclusive) << e.name;  // dynamic_reconfigure's ranges are closed
  }
}

// A start-up parameter takes the table's range and ~configure's wording (before, ~tf_rate 5000 was
// accepted at start-up, its own range [0, 10000] Hz, and clamped to 1000 by the reconfigure
// server).
TEST(ReconfigureKeyRanges, StartUpParametersUseTheTable) {
  for (const char* name :
       {"real_time_factor", "tf_rate", "marker_rate", "state_rate", "marker_min_diameter",
        "holder_max_speed", "holder_max_acceleration", "loop_rate", "cloud_rate"}) {
    const corde::KeyRange* r = corde::find_key_range(name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_EQ(start_up_range_error(name, r->min), "") << name;
    EXPECT_EQ(start_up_range_error(name, r->max), "") << name;
    const double above = r->max * 1.5;
    EXPECT_EQ(start_up_range_error(name, above),
              std::string("parameter ~") + name + ": " + corde::range_violation(*r, above))
        << name;
  }
  EXPECT_EQ(start_up_range_error("tf_rate", 5000.0),
            "parameter ~tf_rate: must be <= 1000 Hz, got 5000 (valid: [0, 1000] Hz)");
  EXPECT_EQ(start_up_range_error("loop_rate", 0.5),
            "parameter ~loop_rate: must be >= 1 Hz, got 0.5 (valid: [1, 1000] Hz)");
  EXPECT_NE(start_up_range_error("state_rate", std::nan("")), "");
}

}  // namespace
}  // namespace corde_sim
#endif
