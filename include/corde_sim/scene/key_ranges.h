// The valid ranges of the keys a user sets by value, in one table so that no two checks disagree:
// the rod keys (rods[i].material, radius, drag; docs/scene_format.md), which the scene reader and
// the node's ~configure check with one message (docs/ros_interface.md), and the node's
// dynamic_reconfigure parameters (cfg/Node.cfg, whose generated ranges a unit test compares),
// which its start-up parameters of the same names (and ~loop_rate) are checked against too.
#pragma once

#include <string>
#include <vector>

namespace corde {

struct KeyRange {
  const char* name;     // the key as written: "E", "radius", "fluid_density"
  double min, max;      // the range; max is always allowed
  bool min_inclusive;   // whether min itself is allowed (false: (min, max])
  const char* unit;     // SI unit ("" for a factor)
  const char* meaning;  // one line, for docs and messages
};

// Every entry, in the order of docs/scene_format.md's table.
const std::vector<KeyRange>& key_ranges();

// The entry named `name`, or nullptr.
const KeyRange* find_key_range(const std::string& name);

// "(0, 1e+30] Pa": the range as a message shows it.
std::string range_text(const KeyRange& range);

// "" when v is finite and within the range; otherwise the reason, naming the value and the range:
// "must be > 0, got -5 (valid: (0, 1e+30] Pa)" (a value <= 0 of a range above 0 is told it must
// be > 0 first). The caller prefixes the key (its path).
std::string range_violation(const KeyRange& range, double v);

}  // namespace corde
