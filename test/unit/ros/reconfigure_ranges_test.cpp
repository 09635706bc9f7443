// cfg/Node.cfg declares the dynamic_reconfigure ranges a second time (its generator needs them):
// the generated NodeConfig's ranges must equal the library's table (scene/key_ranges.h).
#ifdef CORDE_TEST_ROS_ADAPTER
#include <gtest/gtest.h>

#include <string>

#include "corde_sim/NodeConfig.h"
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

}  // namespace
}  // namespace corde_sim
#endif
