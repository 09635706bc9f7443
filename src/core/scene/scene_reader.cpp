#include "scene_reader.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace corde {
namespace scene_detail {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string echo(const std::string& text) {
  const bool cut = text.size() > 60;
  std::string out = "'";
  for (char c : cut ? text.substr(0, 40) : text) out += c == '\n' ? "\\n" : std::string(1, c);
  out += "'";
  if (cut) out += "... (" + std::to_string(text.size()) + " characters)";
  return out;
}

void Value::fail(const std::string& reason) const {
  const std::string head = (path_.empty() ? std::string("scene") : path_) + ": ";
  // A message passed on from a nested error may already name this key (and its line).
  if (reason.compare(0, head.size(), head) == 0) throw SceneError(reason);
  std::string msg = head + reason;
  const YAML::Mark mark = node_.IsDefined() ? node_.Mark() : YAML::Mark::null_mark();
  if (mark.line >= 0) msg += " (line " + std::to_string(mark.line + 1) + ")";
  throw SceneError(msg);
}

std::string Value::describe() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  if (node_.IsScalar()) return echo(node_.Scalar());
  if (node_.IsSequence()) return "a list of " + std::to_string(node_.size());
  return "a map";
}

double Value::number() const {
  if (!is_scalar()) fail("expected a number, got " + describe());
  double v = 0.0;
  try {
    v = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("expected a number, got " + describe());
  }
  if (!std::isfinite(v)) fail("must be a finite number, got " + describe());
  return v;
}

double Value::positive() const {
  const double v = number();
  if (!(v > 0.0)) fail("must be > 0, got " + num(v));
  return v;
}

double Value::non_negative() const {
  const double v = number();
  if (v < 0.0) fail("must be >= 0, got " + num(v));
  return v;
}

namespace {
std::string with_unit(double v, const char* unit) {
  return num(v) + (unit && *unit ? std::string(" ") + unit : std::string());
}
}  // namespace

double Value::within(double lo, double hi, const char* unit) const {
  const double v = number();
  if (v > hi) fail("must be <= " + with_unit(hi, unit) + ", got " + num(v));
  if (v < lo) fail("must be >= " + with_unit(lo, unit) + ", got " + num(v));
  return v;
}

double Value::positive(double hi, const char* unit) const {
  const double v = positive();
  if (v > hi) fail("must be <= " + with_unit(hi, unit) + ", got " + num(v));
  return v;
}

double Value::non_negative(double hi, const char* unit) const {
  const double v = non_negative();
  if (v > hi) fail("must be <= " + with_unit(hi, unit) + ", got " + num(v));
  return v;
}

double Value::in_range(const KeyRange& range) const {
  const double v = number();
  const std::string why = range_violation(range, v);
  if (!why.empty()) fail(why);
  return v;
}

double Value::in_range(const char* key) const {
  const KeyRange* range = find_key_range(key);
  if (!range) throw std::logic_error(std::string("no key range named ") + key);
  return in_range(*range);
}

int Value::integer(int lo, int hi) const {
  const double v = number();
  if (v != std::floor(v)) fail("expected an integer, got " + describe());
  if (v < lo) fail("must be >= " + std::to_string(lo) + ", got " + describe());
  if (v > hi) fail("must be <= " + std::to_string(hi) + ", got " + describe());
  return static_cast<int>(v);
}

bool Value::boolean() const {
  if (!is_scalar()) fail("expected true or false, got " + describe());
  try {
    return node_.as<bool>();
  } catch (const YAML::Exception&) {
    fail("expected true or false, got " + describe());
  }
}

std::string Value::string() const {
  if (!is_scalar()) fail("expected a string, got " + describe());
  return node_.Scalar();
}

Vec3 Value::vec3() const {
  if (!is_sequence() || node_.size() != 3) fail("expected [x, y, z], got " + describe());
  const std::vector<Value> v = items();
  return Vec3(v[0].number(), v[1].number(), v[2].number());
}

Vec3 Value::vec3(double hi, const char* unit) const {
  const Vec3 v = vec3();
  for (int k = 0; k < 3; ++k)
    if (std::abs(v[k]) > hi)
      fail("each component must be within +-" + with_unit(hi, unit) + ", got " + num(v[k]));
  return v;
}

Quat Value::quaternion() const {
  if (!is_sequence() || node_.size() != 4)
    fail("expected a quaternion [x, y, z, w], got " + describe());
  const std::vector<Value> c = items();
  const Quat q(c[3].number(), c[0].number(), c[1].number(), c[2].number());
  if (std::abs(q.norm() - 1.0) > 1e-6)
    fail("must be a unit quaternion (norm " + num(q.norm()) + ")");
  return q.normalized();
}

std::string resolve_path(const std::string& base, const std::string& path) {
  if (path.empty() || path[0] == '/' || base.empty()) return path;
  return base + "/" + path;
}

Vec3 Value::nonzero_vec3() const {
  const Vec3 v = vec3();
  if (!(v.norm() > 1e-12)) fail("must not be the zero vector");
  return v / v.cwiseAbs().maxCoeff();
}

std::string Value::choice(const std::vector<std::string>& choices) const {
  std::string list;
  for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
  if (!is_scalar()) fail("expected one of " + list + ", got " + describe());
  const std::string s = node_.Scalar();
  for (const std::string& c : choices)
    if (s == c) return s;
  fail("expected one of " + list + ", got " + describe());
}

std::vector<Value> Value::items() const {
  if (!is_sequence()) fail("expected a list, got " + describe());
  std::vector<Value> out;
  for (size_t i = 0; i < node_.size(); ++i)
    out.emplace_back(node_[i], path_ + "[" + std::to_string(i) + "]");
  return out;
}

Map::Map(const Value& v) : node_(v.node()), path_(v.path()) {
  if (!v.is_map()) v.fail("expected a map of keys, got " + v.describe());
  std::map<std::string, YAML::Mark> seen;
  for (const auto& kv : node_) {
    const std::string key = kv.first.Scalar();
    const auto [it, first] = seen.emplace(key, kv.first.Mark());
    if (first) continue;
    auto line = [](const YAML::Mark& m) { return std::to_string(m.line + 1); };
    throw SceneError(child_path(key) + ": duplicate key (lines " + line(it->second) + " and " +
                     line(kv.first.Mark()) + "); give each key once");
  }
}

std::string Map::child_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

bool Map::has(const std::string& key) const { return static_cast<bool>(node_[key]); }

std::optional<Value> Map::find(const std::string& key) {
  used_.insert(key);
  const YAML::Node child = node_[key];
  if (!child) return std::nullopt;
  return Value(child, child_path(key));
}

Value Map::get(const std::string& key) {
  std::optional<Value> v = find(key);
  if (!v) throw SceneError(child_path(key) + ": missing (required)");
  return *v;
}

std::string Map::one_of(const std::vector<std::string>& keys) const {
  std::string found, list;
  for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
  for (const std::string& k : keys) {
    if (!has(k)) continue;
    if (!found.empty()) fail("give only one of " + list + " (got " + found + " and " + k + ")");
    found = k;
  }
  if (found.empty()) fail("needs one of " + list);
  return found;
}

void Map::fail(const std::string& reason) const { Value(node_, path_).fail(reason); }

void Map::finish() const {
  for (const auto& kv : node_) {
    const std::string key = kv.first.Scalar();
    if (used_.count(key)) continue;
    std::string known;
    for (const std::string& k : used_) known += (known.empty() ? "" : ", ") + k;
    Value(kv.first, child_path(key)).fail("unknown key (known here: " + known + ")");
  }
}

namespace {

// "rods[0].material.E" and "rods.0.material.E" both give {rods, 0, material, E}.
std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : path) {
    if (c == '.' || c == '[' || c == ']') {
      if (!cur.empty()) parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) parts.push_back(cur);
  return parts;
}

// The path for a message; the top level has none.
std::string where(const std::string& path) { return path.empty() ? "scene (top level)" : path; }

bool parse_index(const std::string& s, size_t* out) {
  if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
    return false;
  *out = std::stoul(s);
  return true;
}

}  // namespace

std::vector<std::string> apply_overrides(YAML::Node* root,
                                         const std::vector<std::string>& overrides) {
  std::vector<std::string> paths;
  for (const std::string& o : overrides) {
    const size_t eq = o.find('=');
    const std::vector<std::string> parts = split_path(o.substr(0, eq));
    if (eq == std::string::npos || parts.empty())
      throw SceneError(o + ": an override must look like key.path=value");
    YAML::Node value;
    try {
      value = YAML::Load(o.substr(eq + 1));
    } catch (const YAML::Exception& e) {
      throw SceneError(o.substr(0, eq) + ": cannot parse the override's value: " + e.msg);
    }
    YAML::Node node = *root;
    std::string path;
    for (size_t i = 0; i < parts.size(); ++i) {
      const std::string& key = parts[i];
      const bool last = i + 1 == parts.size();
      YAML::Node child;
      std::string child_path;
      if (node.IsSequence()) {
        size_t index = 0;
        bool found = parse_index(key, &index) && index < node.size();
        if (!found) {  // an item named `key`
          for (index = 0; index < node.size(); ++index)
            if (node[index].IsMap() && node[index]["name"] && node[index]["name"].IsScalar() &&
                node[index]["name"].Scalar() == key) {
              found = true;
              break;
            }
        }
        if (!found)
          throw SceneError(where(path) + ": no item " + echo(key) + " (has " +
                           std::to_string(node.size()) + " items, by index or name) in override '" +
                           o + "'");
        child_path = path + "[" + std::to_string(index) + "]";
        if (last) {
          node[index] = value;
          paths.push_back(child_path);
          break;
        }
        child.reset(node[index]);
      } else {
        child_path = path.empty() ? key : path + "." + key;
        if (i > 0 && node.IsScalar() && parts[i - 1] == "material") {
          // A preset given by name becomes {preset: name} so that its fields can be overridden.
          const std::string preset = node.Scalar();
          node = YAML::Node(YAML::NodeType::Map);
          node["preset"] = preset;
        } else if (!node.IsMap() && node.IsDefined() && !node.IsNull()) {
          throw SceneError(where(path) + ": is not a map, cannot set " + echo(key) +
                           " (override '" + o + "')");
        }
        if (last) {
          node[key] = value;
          paths.push_back(child_path);
          break;
        }
        child.reset(node[key]);
      }
      path = child_path;
      node.reset(child);
    }
  }
  return paths;
}

}  // namespace scene_detail
}  // namespace corde
