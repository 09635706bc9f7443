// libFuzzer target for the scene reader: any input must either parse into a scene or be refused
// with a SceneError; any other exception, crash or sanitizer report is a bug. Built with clang
// (-fsanitize=fuzzer,address,undefined) by run_fuzz_short.sh; see test/fuzz/README.md.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Lines after a line "--- overrides" are overrides ("key.path=value"), to fuzz those too.
  std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> overrides;
  const std::string mark = "\n--- overrides\n";
  const size_t at = text.find(mark);
  if (at != std::string::npos) {
    std::string rest = text.substr(at + mark.size());
    text.resize(at + 1);
    for (size_t start = 0; start < rest.size();) {
      size_t end = rest.find('\n', start);
      if (end == std::string::npos) end = rest.size();
      overrides.push_back(rest.substr(start, end - start));
      start = end + 1;
    }
  }
  // The scene's folder is the fixture folder (CORDE_FUZZ_FIXTURES, set by run_fuzz_short.sh), so
  // that fuzzed scenes reach its URDF, mesh and keyframe files by relative names.
  static const std::string source = [] {
    const char* dir = std::getenv("CORDE_FUZZ_FIXTURES");
    return std::string(dir && *dir ? dir : "test/fuzz/fixtures") + "/fuzzed.yaml";
  }();
  try {
    const corde::Scene scene = corde::parse_scene(text, overrides, source);
  } catch (const corde::SceneError&) {
  }
  return 0;
}
