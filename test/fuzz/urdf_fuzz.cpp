// libFuzzer target for the URDF reader: any input must either give obstacles or be refused with a
// std::runtime_error naming what is wrong; any other exception, crash or sanitizer report is a
// bug. Built with clang (-fsanitize=fuzzer,address,undefined) by run_urdf_fuzz_short.sh; see
// test/fuzz/README.md.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "corde_sim/contact/urdf_obstacles.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    // With the chains (the scene loader's path), and as the node reads robot_description;
    // relative mesh names point into a folder that does not exist.
    std::vector<corde::UrdfChain> chains;
    corde::parse_urdf_obstacles(text, "/nonexistent/corde_urdf_fuzz", {}, &chains);
  } catch (const std::runtime_error&) {
  }
  try {
    corde::parse_urdf_collisions(text, "/nonexistent/corde_urdf_fuzz", "fuzz");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
