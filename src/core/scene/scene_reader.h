// Internal to the scene loader: typed access to a YAML tree that names the offending key's path
// in every error, and catches unknown keys.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "corde_sim/model/drag.h"
#include "corde_sim/model/element_energies.h"
#include "corde_sim/rod/material.h"
#include "corde_sim/rod/motion.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/key_ranges.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_bounds.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace scene_detail {

// Formats a number for messages the way a user would type it (shortest round trip, %g-like).
std::string num(double v);
// Text from the file for a message, in quotes: line breaks shown as \n, and cut to its first 40
// characters with its length when it is longer than 60, so that a huge value is not echoed whole.
std::string echo(const std::string& text);

// A node of the tree and its path ("rods[0].material.E").
class Value {
 public:
  Value(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {}
  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }

  // Throws SceneError "<path>: <reason>", with the line in the file when known.
  [[noreturn]] void fail(const std::string& reason) const;

  bool is_scalar() const { return node_.IsScalar(); }
  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }
  std::string describe() const;  // "the string 'abc'", "a sequence of 2", "a map", "null"

  double number() const;  // finite
  double positive() const;
  double non_negative() const;
  // Bounded numbers (scene/scene_bounds.h): fail naming the bound and its unit ("must be <= 10000
  // m, got 1e+300").
  double within(double lo, double hi, const char* unit) const;
  double positive(double hi, const char* unit) const;      // in (0, hi]
  double non_negative(double hi, const char* unit) const;  // in [0, hi]
  // A number within a key's range (scene/key_ranges.h): fails with range_violation()'s text.
  double in_range(const KeyRange& range) const;
  double in_range(const char* key) const;  // the table's entry named `key`
  int integer(int lo, int hi) const;       // fails naming the range when outside [lo, hi]
  bool boolean() const;
  std::string string() const;
  Vec3 vec3() const;
  // [x, y, z] with every component in [-hi, hi].
  Vec3 vec3(double hi, const char* unit) const;
  // [x, y, z, w], of unit norm to 1e-6; normalised.
  Quat quaternion() const;
  // A direction: scaled so that its largest component is +-1 (the norm of [1e200, 0, 0] would
  // overflow).
  Vec3 nonzero_vec3() const;
  // One of `choices`; fails listing them.
  std::string choice(const std::vector<std::string>& choices) const;
  std::vector<Value> items() const;  // a sequence's items with paths "<path>[i]"

 private:
  YAML::Node node_;
  std::string path_;
};

// A mapping whose keys are accounted for: finish() fails on any key never asked for. A key given
// twice is an error naming both lines (YAML would silently keep the first).
class Map {
 public:
  explicit Map(const Value& v);
  const std::string& path() const { return path_; }
  bool has(const std::string& key) const;
  std::optional<Value> find(const std::string& key);
  Value get(const std::string& key);  // required
  // Fails unless exactly one of `keys` is present; returns it.
  std::string one_of(const std::vector<std::string>& keys) const;
  [[noreturn]] void fail(const std::string& reason) const;
  void finish() const;

 private:
  std::string child_path(const std::string& key) const;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> used_;
};

// What a material file gives a rod besides its section: its drag and contact friction, which the
// rod's own `drag` and `contact.friction` keys override.
struct MaterialExtras {
  std::string file;  // the material file read ("": none)
  std::optional<Drag> drag;
  std::optional<double> friction;
  MaterialOrigin origin;  // which key each section constant follows
};

// The section of rods[i] from its `material` and `radius` keys (scene_material.cpp): a preset, a
// map, or a material file (`{file: F}`, or a name not a preset: <base>/materials/NAME.yaml),
// whose drag and friction go to *extras (may be null).
Section read_section(Map* rod, const std::string& base, MaterialExtras* extras);
// A rod's `drag` map, for its radius (scene.cpp).
Drag read_drag(const Value& v, double radius);
// The `shape` of a rod (scene_material.cpp).
RodShape read_shape(const Value& v);

// A path from the scene file: relative ones are relative to `base`, the scene file's folder
// ("" for a scene given as text: the current directory).
std::string resolve_path(const std::string& base, const std::string& path);

// Where a driven item starts, for keyframes given as absolute poses, and what it may do. Describing
// a motion reads the rules (translates, rotates, time, time_key); resolving it reads the pose
// (position, orientation, tangent), which for a rod's item is known once the rod is built.
struct MotionStart {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
  Vec3 tangent = Vec3::UnitZ();  // the axis of `turns`
  bool translates = true, rotates = true;
  // When the motion starts (a grasp's grasp_time, named `time_key` in messages): keyframes must
  // come after it and start_time may not precede it; the motion read runs in the time since.
  double time = 0.0;
  const char* time_key = "grasp_time";
};

// A keyframe as the file gives it: the channels it sets, absolute ones not yet relative to the
// start. A keyframe file's row may set single components (x without y).
struct KeyframeDescription {
  double time = 0.0;  // s, absolute (not yet since the motion's start)
  std::array<bool, 3> position_given{}, displacement_given{};
  Vec3 position = Vec3::Zero(), displacement = Vec3::Zero();  // m
  bool has_orientation = false, has_angle = false;
  Quat orientation = Quat::Identity();  // unit
  double angle = 0.0;                   // rad (turns)
  bool translates_absolute() const {
    return position_given[0] || position_given[1] || position_given[2];
  }
  bool translates_relative() const {
    return displacement_given[0] || displacement_given[1] || displacement_given[2];
  }
};

// A keyframed drive, read and checked (describe_motion) but not yet placed at its item's start
// (resolve_motion): keyframes, or move_by/turns over ramp_time from start_time.
struct MotionDescription {
  std::string path;  // the entry's
  Motion::Interpolation interpolation = Motion::Interpolation::kSmooth;
  bool keyframed = false;
  // Keyframes: the frames, and where each comes from for messages (the list items, or the file's
  // "'FILE' line N" under the keyframes key).
  std::vector<KeyframeDescription> frames;
  bool from_file = false;
  std::optional<Value> keyframes_key;
  std::vector<Value> items;
  std::vector<std::string> where_from;
  // move_by/turns.
  Vec3 move_by = Vec3::Zero();
  double angle = 0.0, ramp_time = 0.0, start_time = 0.0;  // rad, s, s (absolute)

  // Throws SceneError naming keyframe k where it comes from.
  [[noreturn]] void fail_at(size_t k, const std::string& why) const;
};
// Whether the entry has any of the keys of a keyframed drive (keyframes, move_by, turns,
// ramp_time, interpolation).
bool has_motion(const Map& m);
// The keyframed drive of an entry, read and checked against `start`'s rules, or none when it has
// none (scene_motion.cpp). Keyframe files are read relative to `base`.
std::optional<MotionDescription> describe_motion(Map* m, const MotionStart& start,
                                                 const std::string& base);
// The drive placed at `start`'s pose (the rules as described); fails naming a keyframe the motion
// refuses.
std::shared_ptr<const Motion> resolve_motion(const MotionDescription& d, const MotionStart& start);
// Both at once, for items whose start is known while reading (obstacles).
std::shared_ptr<const Motion> read_motion(Map* m, const MotionStart& start,
                                          const std::string& base);

// A rod's `initial` key (velocities, spins, a seeded perturbation), read for a rod of `segments`
// segments (-1: elements: auto, its node and segment numbers checked against the built rod), then
// applied to the built rod (scene_motion.cpp).
struct InitialDescription {
  struct Indexed {
    int index = 0;
    Vec3 value = Vec3::Zero();      // m/s or rad/s (world frame)
    std::optional<Value> deferred;  // the index key, when the count was unknown
  };
  std::optional<Vec3> velocity, angular_velocity;  // m/s, rad/s
  std::vector<Indexed> node_velocities, segment_angular_velocities;
  bool perturbed = false;
  double position_amplitude = 0.0, velocity_amplitude = 0.0;  // m, m/s
  int seed = 1;
};
InitialDescription describe_initial(const Value& v, int segments);
void apply_initial(const InitialDescription& d, Rod* rod);

// The top-level `obstacles` list into *obstacles (each as an ObstacleSet accepted it, in the order
// to add them) and *motions (URDF files relative to `base`), the top-level `contact` settings, and
// a rod's `contact` options (scene_contact.cpp). `paths` (optional) receives the entry's path
// ("obstacles[2]") of each obstacle.
void read_obstacles(const Value& list, std::vector<Obstacle>* obstacles,
                    std::vector<ObstacleMotion>* motions, const std::string& base,
                    std::vector<std::string>* paths = nullptr);
// Refuses an obstacle placed beyond SceneBounds::max_placed_length, naming its entry
// (scene/obstacle_checks.h). `paths` from read_obstacles().
void check_obstacle_placement(const std::vector<Obstacle>& obstacles,
                              const std::vector<std::string>& paths);
// Refuses a rod with obstacle contact whose axis starts deeper inside an obstacle than 1% of its
// radius (naming rods[i], the obstacle, the segment and the depth): the contact would throw it out
// at a runaway speed. `rod_paths` per rod.
void check_rods_clear_of_obstacles(const World& world,
                                   const std::vector<std::string>& obstacle_paths,
                                   const std::vector<std::string>& rod_paths);
void read_contact_settings(const Value& v, ContactSettings* settings);
void read_rod_contact(const Value& v, ContactOptions* options);

// Applies "key.path=value" overrides to the tree (see parse_scene()). Returns, per override, the
// path it set in message form ("rods[0].elements").
std::vector<std::string> apply_overrides(YAML::Node* root,
                                         const std::vector<std::string>& overrides);

}  // namespace scene_detail
}  // namespace corde
