// Scene keys for keyframed drives, their keyframe files, and initial conditions
// (docs/scene_format.md, "Keyframed drives" and "Initial conditions").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
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

// The keyframe's pose relative to the start; a channel a keyframe leaves out keeps its value
// from the keyframe before.
Keyframe read_keyframe(const Value& v, const MotionStart& start, const Keyframe& previous) {
  Map m(v);
  Keyframe k = previous;
  const Value time = m.get("time");
  k.time = time.non_negative(SceneBounds::max_time, "s");
  if (start.time > 0.0 && !(k.time > start.time)) time.fail(not_after(k.time, start));
  if (start.translates) {
    if (m.has("position") && m.has("displacement")) m.fail("give either position or displacement");
    if (auto p = m.find("position")) {
      k.displacement = p->vec3(SceneBounds::max_length, "m") - start.position;
      k.absolute_position = true;
    }
    if (auto p = m.find("displacement")) {
      k.displacement = p->vec3(SceneBounds::max_length, "m");
      k.absolute_position = false;
    }
  }
  if (start.rotates) {
    if (auto p = m.find("orientation")) {
      k.rotation = p->quaternion() * start.orientation.conjugate();
      k.absolute_orientation = true;
    }
    if (auto p = m.find("turns"))
      k.angle = 2.0 * M_PI * p->within(-SceneBounds::max_factor, SceneBounds::max_factor, "");
  }
  m.finish();
  return k;
}

// A keyframe file: CSV with a header naming its columns (time first; x,y,z or dx,dy,dz;
// qx,qy,qz,qw; turns), one keyframe a row. `where[k]` is set to "'FILE' line N" of keyframe k.
std::vector<Keyframe> read_keyframe_file(const Value& v, const MotionStart& start,
                                         const std::string& base, std::vector<std::string>* where) {
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
  std::vector<Keyframe> frames;
  Keyframe previous;
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
    Keyframe k = previous;
    Vec3 abs = start.position, rel = previous.displacement;
    bool has_abs = false, has_rel = false;
    Eigen::Vector4d q(0, 0, 0, 1);
    bool has_q = false;
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
      if (col == "x" || col == "y" || col == "z") (has_abs = true, abs[col[0] - 'x'] = x);
      if (col == "dx" || col == "dy" || col == "dz") (has_rel = true, rel[col[1] - 'x'] = x);
      if (col == "qx" || col == "qy" || col == "qz") (has_q = true, q[col[1] - 'x'] = x);
      if (col == "qw") (has_q = true, q[3] = x);
      if (col == "turns") k.angle = 2.0 * M_PI * x;
    }
    if (has_abs && has_rel) fail("give either x, y, z or dx, dy, dz");
    if ((has_abs || has_rel) && !start.translates) fail("this item cannot be moved, only turned");
    if ((has_q || k.angle != previous.angle) && !start.rotates)
      fail("this item cannot be turned, only moved");
    if (start.time > 0.0 && !(k.time > start.time)) fail("time " + not_after(k.time, start));
    if (has_abs) k.displacement = abs - start.position;
    if (has_rel) k.displacement = rel;
    if (has_abs || has_rel) k.absolute_position = has_abs;
    if (has_q) {
      const Quat qq(q[3], q[0], q[1], q[2]);
      if (std::abs(qq.norm() - 1.0) > 1e-6) fail("the quaternion is not of unit norm");
      k.rotation = qq.normalized() * start.orientation.conjugate();
      k.absolute_orientation = true;
    }
    frames.push_back(k);
    where->push_back(echo(path) + " line " + std::to_string(number));
    previous = k;
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

std::shared_ptr<const Motion> read_motion(Map* m, const MotionStart& start,
                                          const std::string& base) {
  if (!has_motion(*m)) return nullptr;
  std::vector<Keyframe> frames;
  Motion::Interpolation how;
  const std::string where = m->path();
  if (auto kv = m->find("keyframes")) {
    for (const char* k : {"move_by", "turns", "ramp_time"})
      if (m->has(k)) kv->fail(std::string("give either keyframes or ") + k);
    how = read_interpolation(m, Motion::Interpolation::kSmooth);
    // Where each keyframe comes from, for messages: "'FILE' line N", or the list item's path.
    std::vector<std::string> where_from;
    std::vector<Value> items;
    const bool from_file = kv->is_map();
    if (from_file) {
      frames = read_keyframe_file(*kv, start, base, &where_from);
    } else {
      if (!kv->is_sequence() || kv->node().size() == 0)
        kv->fail("expected a non-empty list of keyframes or {file: FILE}, got " + kv->describe());
      if (kv->node().size() > static_cast<size_t>(SceneLimits::max_items))
        kv->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " keyframes");
      Keyframe previous;
      items = kv->items();
      for (const Value& item : items) {
        frames.push_back(read_keyframe(item, start, previous));
        previous = frames.back();
      }
    }
    // Names keyframe k in a message: its file and line, or its item in the scene.
    auto fail_at = [&](size_t k, const std::string& why) {
      if (from_file) kv->fail(where_from[k] + ": " + why);
      const std::string path = items[k].path() + ": ";
      items[k].fail(why.compare(0, path.size(), path) == 0 ? why.substr(path.size()) : why);
    };
    for (size_t k = 0; k < frames.size(); ++k) {
      // An interval of 1e-300 s makes the speed between keyframes infinite.
      const double gap = frames[k].time - (k == 0 ? start.time : frames[k - 1].time);
      if (!(gap > 0.0 && gap < SceneBounds::min_time_interval)) continue;
      const std::string why = num(frames[k].time) + " s is less than " +
                              num(SceneBounds::min_time_interval) + " s after the " +
                              (k == 0 ? "motion's start" : "keyframe before");
      if (from_file) fail_at(k, "time " + why);
      Value(items[k].node()["time"], items[k].path() + ".time").fail(why);
    }
    for (Keyframe& f : frames) f.time -= start.time;  // the time since the motion's start
    const size_t count = frames.size();
    try {
      return std::make_shared<Motion>(std::move(frames), how, start.tangent);
    } catch (const std::invalid_argument& e) {
      // "keyframe K: why" from Motion: name keyframe K where it comes from.
      const std::string msg = e.what();
      size_t k = 0, at = 0;
      if (msg.compare(0, 9, "keyframe ") == 0 &&
          std::sscanf(msg.c_str() + 9, "%zu: %zn", &k, &at) >= 1 && at > 0 && k < count)
        fail_at(k, msg.substr(9 + at));
      kv->fail(msg);
    }
  }
  // "Move by / turn by over ramp_time from start_time, then hold".
  how = read_interpolation(m, Motion::Interpolation::kStop);
  Vec3 d = Vec3::Zero();
  double angle = 0.0;
  if (auto p = m->find("move_by")) {
    if (!start.translates) p->fail("this item cannot be moved, only turned");
    d = p->vec3(SceneBounds::max_length, "m");
  }
  if (auto p = m->find("turns")) {
    if (!start.rotates) p->fail("this item cannot be turned, only moved");
    angle = 2.0 * M_PI * p->within(-SceneBounds::max_factor, SceneBounds::max_factor, "");
  }
  if (!m->has("move_by") && !m->has("turns"))
    m->fail("ramp_time and interpolation need keyframes, move_by or turns");
  if (!m->has("ramp_time"))
    throw SceneError(where + ".ramp_time: missing (required with move_by or turns)");
  const Value ramp_key = m->get("ramp_time");
  const double ramp = ramp_key.positive(SceneBounds::max_time, "s");
  if (ramp < SceneBounds::min_time_interval)  // the speed of a move over 1e-300 s overflows
    ramp_key.fail("must be >= " + num(SceneBounds::min_time_interval) + " s, got " + num(ramp));
  double t0 = start.time;
  if (auto p = m->find("start_time")) {
    t0 = p->non_negative(SceneBounds::max_time, "s");
    if (t0 < start.time)
      p->fail(num(t0) + " s is before " + start.time_key + " " + num(start.time) +
              " s: the move starts when the grasp takes hold at the earliest");
  }
  return std::make_shared<Motion>(
      Motion::ramp(t0 - start.time, ramp, d, angle, start.tangent, how));
}

void read_initial(const Value& v, Rod* rod) {
  Map m(v);
  auto& x = rod->positions();
  auto& vel = rod->velocities();
  auto& w = rod->angular_velocities();
  const auto& q = rod->orientations();
  // Rigid motion: v = V + Omega x (x - c) about the centre of mass, spin Omega for every segment.
  const Vec3 c = rod->center_of_mass();
  const Vec3 lin =
      m.has("velocity") ? m.get("velocity").vec3(SceneBounds::max_speed, "m/s") : Vec3::Zero();
  const Vec3 spin = m.has("angular_velocity")
                        ? m.get("angular_velocity").vec3(SceneBounds::max_angular_speed, "rad/s")
                        : Vec3::Zero();
  for (size_t i = 0; i < x.size(); ++i) vel[i] = lin + spin.cross(x[i] - c);
  for (size_t s = 0; s < q.size(); ++s) w[s] = q[s].conjugate() * spin;
  if (auto list = m.find("node_velocities")) {
    if (list->is_sequence() && list->node().size() > static_cast<size_t>(SceneLimits::max_items))
      list->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " entries");
    for (const Value& item : list->items()) {
      Map e(item);
      const int i = e.get("node").integer(0, rod->num_segments());
      vel[i] = e.get("velocity").vec3(SceneBounds::max_speed, "m/s");
      e.finish();
    }
  }
  if (auto list = m.find("segment_angular_velocities")) {
    if (list->is_sequence() && list->node().size() > static_cast<size_t>(SceneLimits::max_items))
      list->fail("more than the limit of " + std::to_string(SceneLimits::max_items) + " entries");
    for (const Value& item : list->items()) {
      Map e(item);
      const int s = e.get("segment").integer(0, rod->num_segments() - 1);
      w[s] = q[s].conjugate() *
             e.get("angular_velocity").vec3(SceneBounds::max_angular_speed, "rad/s");
      e.finish();
    }
  }
  if (auto p = m.find("perturbation")) {
    // Uniform in [-a, a] per component from a 32-bit Mersenne Twister (std::mt19937, whose output
    // the C++ standard fixes), node by node, x then y then z: the same seed gives the same rod on
    // every platform.
    Map pm(*p);
    const double a =
        pm.has("position") ? pm.get("position").non_negative(SceneBounds::max_length, "m") : 0.0;
    const double b =
        pm.has("velocity") ? pm.get("velocity").non_negative(SceneBounds::max_speed, "m/s") : 0.0;
    const int seed = pm.has("seed") ? pm.get("seed").integer(0, 2147483647) : 1;
    pm.finish();
    std::mt19937 gen(static_cast<std::uint32_t>(seed));
    auto uniform = [&] { return 2.0 * (static_cast<double>(gen()) / 4294967296.0) - 1.0; };
    for (size_t i = 0; i < x.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const double dx = uniform(), dv = uniform();
        x[i][k] += a * dx;
        vel[i][k] += b * dv;
      }
  }
  m.finish();
}

}  // namespace scene_detail
}  // namespace corde
