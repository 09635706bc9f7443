// The shipped scene files (config/scenes/*.yaml), sorted: shared by the scene tests.
#pragma once
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#ifndef CORDE_SIM_SOURCE_DIR
// Fallback when built without CMake's definition: this file is <root>/test/unit/.
#define CORDE_SIM_SOURCE_DIR \
  (std::filesystem::path(__FILE__).parent_path().parent_path().parent_path().string())
#endif

namespace corde {

inline std::vector<std::string> shipped_scene_files() {
  std::vector<std::string> files;
  const std::filesystem::path dir = std::filesystem::path(CORDE_SIM_SOURCE_DIR) / "config/scenes";
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace corde
