// Scene keys for keyframed drives, their keyframe files, and initial conditions
// (docs/scene_format.md, "Keyframed drives" and "Initial conditions").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>

#include "corde_sim/io/file_read.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

const char* const kMotionKeys[] = {"keyframes", "move_by", "turns", "ramp_time", "interpolation"};

Motion::Interpolation read_interpolation(Map* m, Motion::Interpolation fallback) {
  auto v = m->find("interpolation");
  if (!v) return fallback;
  const std::string s = v->choice({"smooth", "stop", "linear"});
  return s == "smooth" ? Motion::Interpolation::kSmooth
         : s == "stop" ? Motion::Interpolation::kStop
                       : Motion::Interpolation::kLinear;
}

// Why a keyframe at time t cannot be: it does not come after the motion's start (a late grasp).
std::string not_after(double t, const MotionStart& start) {
  return num(t) + " s is not after " + start.time_key + " " + num(start.time) +
         " s: the keyframes act from when the grasp takes hold (from where the rod is then)";
}

// A keyframe as given; its channels are made relative to the start in resolve_motion().
KeyframeDescription describe_keyframe(const Value& v, const MotionStart& start) {
  Map m(v);
  KeyframeDescription k;
  const Value time = m.get("time");
  k.time = time.non_negative(SceneBounds::max_time, "s");
  if (start.time > 0.0 && !(k.time > start.time)) time.fail(not_after(k.time, start));
  if (start.translates) {
    if (m.has("position") && m.has("displacement")) m.fail("give either position or displacement");
    if (auto p = m.find("position")) {
      k.position = p->vec3(SceneBounds::max_length, "m");
      k.position_given = {true, true, true};
    }
    if (auto p = m.find("displacement")) {
      k.displacement = p->vec3(SceneBounds::max_length, "m");
      k.displacement_given = {true, true, true};
    }
  }
  if (start.rotates) {
    if (auto p = m.find("orientation")) {
      k.orientation = p->quaternion();
      k.has_orientation = true;
    }
    if (auto p = m.find("turns")) {
      k.angle = 2.0 * M_PI * p->within(-SceneBounds::max_factor, SceneBounds::max_factor, "");
      k.has_angle = true;
    }
  }
  m.finish();
  return k;
}

// A keyframe file: CSV with a header naming its columns (time first; x,y,z or dx,dy,dz;
// qx,qy,qz,qw; turns), one keyframe a row. `where[k]` is set to "'FILE' line N" of keyframe k.
std::vector<KeyframeDescription> describe_keyframe_file(const Value& v, const MotionStart& start,
                                                        const std::string& base,
                                                        std::vector<std::string>* where) {
  Map m(v);
  const std::string name = m.get("file").string();
  m.finish();
  const std::string path = resolve_path(base, name);
  std::string text;
  try {  // a regular file within the limit: a FIFO would block, a device never end
    text = read_input_file(path, "keyframe file", SceneLimits::max_keyframe_file_bytes);
  } catch (const FileError& e) {
    v.fail(e.what());
  }
  // A UTF-8 byte order mark (spreadsheets write one) is not part of the header.
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  std::istringstream lines(text);
  std::string line;
  std::vector<std::string> columns;
  std::vector<KeyframeDescription> frames;
  double previous_angle = 0.0;  // a row without turns keeps the angle before
  int number = 0;
  auto fail = [&](const std::string& why) {
    v.fail(echo(path) + " line " + std::to_string(number) + ": " + why);
  };
  while (std::getline(lines, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) {
      const size_t a = cell.find_first_not_of(" \t"), b = cell.find_last_not_of(" \t");
      cells.push_back(a == std::string::npos ? "" : cell.substr(a, b - a + 1));
    }
    if (columns.empty()) {
      columns = cells;
      const std::vector<std::string> known = {"time", "x",  "y",  "z",  "dx", "dy",
                                              "dz",   "qx", "qy", "qz", "qw", "turns"};
      if (columns.empty() || columns[0] != "time") fail("the header must start with 'time'");
      for (const std::string& c : columns)
        if (std::find(known.begin(), known.end(), c) == known.end())
          fail("unknown column " + echo(c) +
               " (known: time, x, y, z, dx, dy, dz, qx, qy, qz, qw, "
               "turns)");
      continue;
    }
    if (cells.size() != columns.size())
      fail("has " + std::to_string(cells.size()) + " values, the header " +
           std::to_string(columns.size()));
    if (frames.size() >= static_cast<size_t>(SceneLimits::max_items))
      fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " keyframes");
    KeyframeDescription k;
    k.angle = previous_angle;
    Eigen::Vector4d q(0, 0, 0, 1);
    for (size_t c = 0; c < cells.size(); ++c) {
      char* end = nullptr;
      const double x = std::strtod(cells[c].c_str(), &end);
      if (cells[c].empty() || *end != '\0' || !std::isfinite(x))
        fail("column " + columns[c] + ": expected a finite number, got " + echo(cells[c]));
      const std::string& col = columns[c];
      // The bounds of the same keys in the scene (scene/scene_bounds.h).
      const bool length = col != "time" && col != "turns" && col[0] != 'q';
      const double hi = col == "time"    ? SceneBounds::max_time
                        : col == "turns" ? SceneBounds::max_factor
                        : length         ? SceneBounds::max_length
                                         : 2.0;
      if (std::abs(x) > hi)
        fail("column " + col + ": must be within +-" + num(hi) + (length ? " m" : "") + ", got " +
             num(x));
      if (col == "time") k.time = x;
      if (col == "x" || col == "y" || col == "z")
        (k.position_given[col[0] - 'x'] = true, k.position[col[0] - 'x'] = x);
      if (col == "dx" || col == "dy" || col == "dz")
        (k.displacement_given[col[1] - 'x'] = true, k.displacement[col[1] - 'x'] = x);
      if (col == "qx" || col == "qy" || col == "qz")
        (k.has_orientation = true, q[col[1] - 'x'] = x);
      if (col == "qw") (k.has_orientation = true, q[3] = x);
      if (col == "turns") (k.has_angle = true, k.angle = 2.0 * M_PI * x);
    }
    const bool has_abs = k.translates_absolute(), has_rel = k.translates_relative();
    if (has_abs && has_rel) fail("give either x, y, z or dx, dy, dz");
    if ((has_abs || has_rel) && !start.translates) fail("this item cannot be moved, only turned");
    if ((k.has_orientation || k.angle != previous_angle) && !start.rotates)
      fail("this item cannot be turned, only moved");
    if (start.time > 0.0 && !(k.time > start.time)) fail("time " + not_after(k.time, start));
    if (k.has_orientation) {
      const Quat qq(q[3], q[0], q[1], q[2]);
      if (std::abs(qq.norm() - 1.0) > 1e-6) fail("the quaternion is not of unit norm");
      k.orientation = qq.normalized();
    }
    frames.push_back(k);
    where->push_back(echo(path) + " line " + std::to_string(number));
    previous_angle = k.angle;
  }
  if (frames.empty()) v.fail("the keyframe file " + echo(path) + " has no keyframes");
  return frames;
}

}  // namespace

bool has_motion(const Map& m) {
  for (const char* k : kMotionKeys)
    if (m.has(k)) return true;
  return false;
}

std::optional<MotionDescription> describe_motion(Map* m, const MotionStart& start,
                                                 const std::string& base) {
  if (!has_motion(*m)) return std::nullopt;
  MotionDescription d;
  d.path = m->path();
  if (auto kv = m->find("keyframes")) {
    d.keyframed = true;
    d.keyframes_key = kv;
    for (const char* k : {"move_by", "turns", "ramp_time"})
      if (m->has(k)) kv->fail(std::string("give either keyframes or ") + k);
    d.interpolation = read_interpolation(m, Motion::Interpolation::kSmooth);
    d.from_file = kv->is_map();
    if (d.from_file) {
      d.frames = describe_keyframe_file(*kv, start, base, &d.where_from);
    } else {
      if (!kv->is_sequence() || kv->node().size() == 0)
        kv->fail("expected a non-empty list of keyframes or {file: FILE}, got " + kv->describe());
      if (kv->node().size() > static_cast<size_t>(SceneLimits::max_items))
        kv->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " keyframes");
      d.items = kv->items();
      for (const Value& item : d.items) d.frames.push_back(describe_keyframe(item, start));
    }
    for (size_t k = 0; k < d.frames.size(); ++k) {
      // An interval of 1e-300 s makes the speed between keyframes infinite.
      const double gap = d.frames[k].time - (k == 0 ? start.time : d.frames[k - 1].time);
      if (!(gap > 0.0 && gap < SceneBounds::min_time_interval)) continue;
      const std::string why = num(d.frames[k].time) + " s is less than " +
                              num(SceneBounds::min_time_interval) + " s after the " +
                              (k == 0 ? "motion's start" : "keyframe before");
      if (d.from_file) d.fail_at(k, "time " + why);
      Value(d.items[k].node()["time"], d.items[k].path() + ".time").fail(why);
    }
    return d;
  }
  // "Move by / turn by over ramp_time from start_time, then hold".
  d.interpolation = read_interpolation(m, Motion::Interpolation::kStop);
  if (auto p = m->find("move_by")) {
    if (!start.translates) p->fail("this item cannot be moved, only turned");
    d.move_by = p->vec3(SceneBounds::max_length, "m");
  }
  if (auto p = m->find("turns")) {
    if (!start.rotates) p->fail("this item cannot be turned, only moved");
    d.angle = 2.0 * M_PI * p->within(-SceneBounds::max_factor, SceneBounds::max_factor, "");
  }
  if (!m->has("move_by") && !m->has("turns"))
    m->fail("ramp_time and interpolation need keyframes, move_by or turns");
  if (!m->has("ramp_time"))
    throw SceneError(d.path + ".ramp_time: missing (required with move_by or turns)");
  const Value ramp_key = m->get("ramp_time");
  d.ramp_time = ramp_key.positive(SceneBounds::max_time, "s");
  if (d.ramp_time < SceneBounds::min_time_interval)  // the speed of a move over 1e-300 s overflows
    ramp_key.fail("must be >= " + num(SceneBounds::min_time_interval) + " s, got " +
                  num(d.ramp_time));
  d.start_time = start.time;
  if (auto p = m->find("start_time")) {
    d.start_time = p->non_negative(SceneBounds::max_time, "s");
    if (d.start_time < start.time)
      p->fail(num(d.start_time) + " s is before " + start.time_key + " " + num(start.time) +
              " s: the move starts when the grasp takes hold at the earliest");
  }
  return d;
}

void MotionDescription::fail_at(size_t k, const std::string& why) const {
  if (from_file) keyframes_key->fail(where_from[k] + ": " + why);
  const std::string path = items[k].path() + ": ";
  items[k].fail(why.compare(0, path.size(), path) == 0 ? why.substr(path.size()) : why);
}

std::shared_ptr<const Motion> resolve_motion(const MotionDescription& d, const MotionStart& start) {
  if (!d.keyframed)
    return std::make_shared<Motion>(Motion::ramp(d.start_time - start.time, d.ramp_time, d.move_by,
                                                 d.angle, start.tangent, d.interpolation));
  // Each keyframe's pose relative to the start; a channel a keyframe leaves out keeps its value
  // from the keyframe before.
  std::vector<Keyframe> frames;
  Keyframe previous;
  for (const KeyframeDescription& f : d.frames) {
    Keyframe k = previous;
    k.time = f.time;
    const bool has_abs = f.translates_absolute(), has_rel = f.translates_relative();
    Vec3 abs = start.position, rel = previous.displacement;
    for (int i = 0; i < 3; ++i) {
      if (f.position_given[i]) abs[i] = f.position[i];
      if (f.displacement_given[i]) rel[i] = f.displacement[i];
    }
    if (has_abs) k.displacement = abs - start.position;
    if (has_rel) k.displacement = rel;
    if (has_abs || has_rel) k.absolute_position = has_abs;
    if (f.has_orientation) {
      k.rotation = f.orientation * start.orientation.conjugate();
      k.absolute_orientation = true;
    }
    if (f.has_angle) k.angle = f.angle;
    frames.push_back(k);
    previous = k;
  }
  for (Keyframe& f : frames) f.time -= start.time;  // the time since the motion's start
  const size_t count = frames.size();
  try {
    return std::make_shared<Motion>(std::move(frames), d.interpolation, start.tangent);
  } catch (const std::invalid_argument& e) {
    // "keyframe K: why" from Motion: name keyframe K where it comes from.
    const std::string msg = e.what();
    size_t k = 0, at = 0;
    if (msg.compare(0, 9, "keyframe ") == 0 &&
        std::sscanf(msg.c_str() + 9, "%zu: %zn", &k, &at) >= 1 && at > 0 && k < count)
      d.fail_at(k, msg.substr(9 + at));
    d.keyframes_key->fail(msg);
  }
}

std::shared_ptr<const Motion> read_motion(Map* m, const MotionStart& start,
                                          const std::string& base) {
  const std::optional<MotionDescription> d = describe_motion(m, start, base);
  return d ? resolve_motion(*d, start) : nullptr;
}

InitialDescription describe_initial(const Value& v, int segments) {
  Map m(v);
  InitialDescription d;
  if (m.has("velocity")) d.velocity = m.get("velocity").vec3(SceneBounds::max_speed, "m/s");
  if (m.has("angular_velocity"))
    d.angular_velocity = m.get("angular_velocity").vec3(SceneBounds::max_angular_speed, "rad/s");
  if (auto list = m.find("node_velocities")) {
    if (list->is_sequence() && list->node().size() > static_cast<size_t>(SceneLimits::max_items))
      list->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " entries");
    for (const Value& item : list->items()) {
      Map e(item);
      InitialDescription::Indexed n;
      const Value key = e.get("node");
      n.index = key.integer(0, segments < 0 ? std::numeric_limits<int>::max() : segments);
      if (segments < 0) n.deferred = key;
      n.value = e.get("velocity").vec3(SceneBounds::max_speed, "m/s");
      d.node_velocities.push_back(n);
      e.finish();
    }
  }
  if (auto list = m.find("segment_angular_velocities")) {
    if (list->is_sequence() && list->node().size() > static_cast<size_t>(SceneLimits::max_items))
      list->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " entries");
    for (const Value& item : list->items()) {
      Map e(item);
      InitialDescription::Indexed n;
      const Value key = e.get("segment");
      n.index = key.integer(0, segments < 0 ? std::numeric_limits<int>::max() : segments - 1);
      if (segments < 0) n.deferred = key;
      n.value = e.get("angular_velocity").vec3(SceneBounds::max_angular_speed, "rad/s");
      d.segment_angular_velocities.push_back(n);
      e.finish();
    }
  }
  if (auto p = m.find("perturbation")) {
    Map pm(*p);
    d.perturbed = true;
    if (pm.has("position"))
      d.position_amplitude = pm.get("position").non_negative(SceneBounds::max_length, "m");
    if (pm.has("velocity"))
      d.velocity_amplitude = pm.get("velocity").non_negative(SceneBounds::max_speed, "m/s");
    if (pm.has("seed")) d.seed = pm.get("seed").integer(0, 2147483647);
    pm.finish();
  }
  m.finish();
  return d;
}

void apply_initial(const InitialDescription& d, Rod* rod) {
  auto& x = rod->positions();
  auto& vel = rod->velocities();
  auto& w = rod->angular_velocities();
  const auto& q = rod->orientations();
  // Rigid motion: v = V + Omega x (x - c) about the centre of mass, spin Omega for every segment.
  const Vec3 c = rod->center_of_mass();
  const Vec3 lin = d.velocity ? *d.velocity : Vec3::Zero();
  const Vec3 spin = d.angular_velocity ? *d.angular_velocity : Vec3::Zero();
  for (size_t i = 0; i < x.size(); ++i) vel[i] = lin + spin.cross(x[i] - c);
  for (size_t s = 0; s < q.size(); ++s) w[s] = q[s].conjugate() * spin;
  const int n = rod->num_segments();
  for (const InitialDescription::Indexed& e : d.node_velocities)
    vel[e.deferred ? e.deferred->integer(0, n) : e.index] = e.value;
  for (const InitialDescription::Indexed& e : d.segment_angular_velocities) {
    const int s = e.deferred ? e.deferred->integer(0, n - 1) : e.index;
    w[s] = q[s].conjugate() * e.value;
  }
  if (d.perturbed) {
    // Uniform in [-a, a] per component from a 32-bit Mersenne Twister (std::mt19937, whose output
    // the C++ standard fixes), node by node, x then y then z: the same seed gives the same rod on
    // every platform.
    const double a = d.position_amplitude, b = d.velocity_amplitude;
    std::mt19937 gen(static_cast<std::uint32_t>(d.seed));
    auto uniform = [&] { return 2.0 * (static_cast<double>(gen()) / 4294967296.0) - 1.0; };
    for (size_t i = 0; i < x.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const double dx = uniform(), dv = uniform();
        x[i][k] += a * dx;
        vel[i][k] += b * dv;
      }
  }
}

}  // namespace scene_detail
}  // namespace corde
