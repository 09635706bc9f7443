// Materials (presets, maps, material files) and shapes of scene rods.
#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <utility>

#include "corde_sim/io/file_read.h"
#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The library's "unknown preset" message, the name in it cut short if huge.
std::string unknown_preset_message(const std::invalid_argument& e, const std::string& name) {
  std::string msg = e.what();
  const size_t at = msg.find("'" + name + "'");
  if (at != std::string::npos) msg.replace(at, name.size() + 2, echo(name));
  return msg;
}

const MaterialPreset& material_preset_of(const Value& v) {
  const std::string name = v.string();
  try {
    return material_preset(name);
  } catch (const std::invalid_argument& e) {
    v.fail(unknown_preset_message(e, name));
  }
}

// The material keys of a map (a rod's `material`, a material file), each within its range
// (scene/key_ranges.h), with the rules on which may be given together.
struct MaterialKeys {
  std::optional<double> E, G, Es, rho, B, C, Ks, kappa, gamma_t, gamma_r, tau, max_strain, nu;
  std::optional<Value> nu_key;  // G = E / (2 (1 + nu)) once E is known
};

// A key of the material map, within its range (scene/key_ranges.h).
std::optional<double> ranged_key(Map* m, const char* key) {
  if (!m) return std::nullopt;
  if (std::optional<Value> v = m->find(key)) return v->in_range(key);
  return std::nullopt;
}

void at_most_one(Map* m, const char* a, const char* b) {
  if (m && m->has(a) && m->has(b))
    m->fail(std::string("give either ") + a + " or " + b + ", not both");
}

MaterialKeys read_material_keys(Map* m) {
  MaterialKeys k;
  at_most_one(m, "E", "B");
  at_most_one(m, "E_s", "K_s");
  if (m && ((m->has("G") ? 1 : 0) + (m->has("nu") ? 1 : 0) + (m->has("C") ? 1 : 0)) > 1)
    m->fail("give only one of G, nu and C");
  k.E = ranged_key(m, "E");
  k.G = ranged_key(m, "G");
  k.Es = ranged_key(m, "E_s");
  // Bounded below too: a near-massless rod starts at an enormous energy per mass.
  k.rho = ranged_key(m, "rho");
  if (m)
    if (std::optional<Value> nv = m->find("nu")) {
      k.nu = nv->in_range("nu");
      k.nu_key = nv;
    }
  k.B = ranged_key(m, "B");
  k.C = ranged_key(m, "C");
  k.Ks = ranged_key(m, "K_s");
  k.kappa = ranged_key(m, "kappa");
  k.gamma_t = ranged_key(m, "gamma_t");
  k.gamma_r = ranged_key(m, "gamma_r");
  k.tau = ranged_key(m, "damping_time");
  k.max_strain = ranged_key(m, "max_strain");
  return k;
}

// The scene's keys over a material file's: a group the scene gives any key of (E/B; G/nu/C;
// E_s/K_s; the friction keys gamma_t, gamma_r, damping_time) replaces the file's group whole.
MaterialKeys merged(const MaterialKeys& file, const MaterialKeys& scene) {
  MaterialKeys k = file;
  if (scene.E || scene.B) {
    k.E = scene.E;
    k.B = scene.B;
  }
  if (scene.G || scene.nu || scene.C) {
    k.G = scene.G;
    k.nu = scene.nu;
    k.nu_key = scene.nu_key;
    k.C = scene.C;
  }
  if (scene.Es || scene.Ks) {
    k.Es = scene.Es;
    k.Ks = scene.Ks;
  }
  if (scene.gamma_t || scene.gamma_r || scene.tau) {
    k.gamma_t = scene.gamma_t;
    k.gamma_r = scene.gamma_r;
    k.tau = scene.tau;
  }
  for (auto [to, from] : {std::pair{&k.rho, &scene.rho}, std::pair{&k.kappa, &scene.kappa},
                          std::pair{&k.max_strain, &scene.max_strain}})
    if (*from) *to = *from;
  return k;
}

// A file's path in a message: whole, unless absurdly long (a name of a megabyte is cut short).
std::string quoted_path(const std::string& path) {
  return path.size() <= 1000 ? "'" + path + "'" : echo(path);
}

// A material file (docs/scene_format.md, "Material files"): its material keys, radius, drag and
// contact friction. Errors name the rod's key, the file and the file's key with its line.
struct MaterialFile {
  std::string path;
  MaterialKeys keys;
  std::optional<double> radius, friction;
  std::optional<Value> drag;
};

MaterialFile read_material_file(const Value& key, const std::string& path) {
  MaterialFile f;
  f.path = path;
  std::string text;
  try {  // a regular file within the limit: a FIFO would block, a device never end
    text = read_input_file(path, "material file", SceneLimits::max_keyframe_file_bytes);
  } catch (const FileError& e) {
    key.fail(e.what());
  }
  const std::string where = key.path() + ": material file " + quoted_path(path) + ": ";
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw SceneError(where + "line " + std::to_string(e.mark.line + 1) + ":" +
                     std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  }
  try {
    const Value top(root, "");
    if (!top.is_map()) top.fail("expected a map of material keys, got " + top.describe());
    Map m(top);
    if (auto v = m.find("version")) v->integer(1, 1);
    if (auto v = m.find("name")) v->string();
    if (auto v = m.find("description")) v->string();
    m.find("fit");  // corde_fit's record of the identification: not read
    f.keys = read_material_keys(&m);
    if (auto v = m.find("radius")) f.radius = v->in_range("radius");
    if (auto v = m.find("friction")) f.friction = v->non_negative(SceneBounds::max_factor, "");
    f.drag = m.find("drag");
    if (f.drag && !f.drag->is_map()) f.drag->fail("expected a map, got " + f.drag->describe());
    m.finish();
  } catch (const SceneError& e) {
    throw SceneError(where + e.what());
  }
  return f;
}

// A material name that may name a file in the scene's materials/ folder.
bool plain_name(const std::string& name) {
  if (name.empty() || name[0] == '.') return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      return false;
  return true;
}

// `material: NAME`: a preset, else the file <scene folder>/materials/NAME.yaml.
const MaterialPreset* find_preset_or_file(const Value& v, const std::string& base,
                                          std::optional<MaterialFile>* file) {
  const std::string name = v.string();
  try {
    return &material_preset(name);
  } catch (const std::invalid_argument& e) {
    const std::string path = resolve_path(base, "materials/" + name + ".yaml");
    struct stat st;
    if (plain_name(name) && ::stat(path.c_str(), &st) == 0) {
      *file = read_material_file(v, path);
      return nullptr;
    }
    std::string msg = unknown_preset_message(e, name);
    if (plain_name(name)) msg += "; no material file " + quoted_path(path) + " either";
    v.fail(msg);
  }
}

}  // namespace

// A preset contributes its moduli, density, the ratio kappa / (G A) and the retardation times
// gamma_t / K_s and gamma_r / B, so that a preset used at another radius, or with some moduli
// overridden, keeps its intent instead of its absolute kappa and gamma values. A material file
// contributes its keys as given (absolute), the scene's keys overriding them (merged()).
Section read_section(Map* rod, const std::string& base, MaterialExtras* extras) {
  const Value mv = rod->get("material");
  const MaterialPreset* preset = nullptr;
  std::optional<MaterialFile> file;
  std::optional<Map> map;
  if (mv.is_scalar()) {
    preset = find_preset_or_file(mv, base, &file);
  } else {
    map.emplace(mv);
    if (map->has("preset") && map->has("file")) map->fail("give either preset or file, not both");
    if (std::optional<Value> p = map->find("preset")) preset = &material_preset_of(*p);
    if (std::optional<Value> f = map->find("file"))
      file = read_material_file(*f, resolve_path(base, f->string()));
  }
  double radius = 0.0;
  if (std::optional<Value> r = rod->find("radius")) {
    radius = r->in_range("radius");
  } else if (file && file->radius) {
    radius = *file->radius;
  } else if (preset) {
    radius = preset->radius;
  } else {
    throw SceneError(rod->path() +
                     ".radius: missing (required unless the material is a preset or a material "
                     "file that gives one)");
  }
  Map* m = map ? &*map : nullptr;
  const std::string mpath = mv.path();

  std::optional<double> E, G, Es, rho;
  double kappa_factor = 1.0, tau_t = 0.0, tau_r = 0.0;
  if (preset) {
    const Material& pm = preset->material;
    const Section ps = make_section(pm, preset->radius);
    if (pm.youngs_modulus > 0.0) E = pm.youngs_modulus;
    if (pm.shear_modulus > 0.0) G = pm.shear_modulus;
    if (pm.stretch_modulus > 0.0) Es = pm.stretch_modulus;
    rho = pm.density;
    kappa_factor = ps.kappa * preset->radius * preset->radius / (2.0 * ps.twist);
    tau_t = ps.gamma_t / ps.stretch;
    tau_r = ps.gamma_r / ps.bend;
  }
  const MaterialKeys given = read_material_keys(m);
  if (m) m->finish();
  const MaterialKeys k = file ? merged(file->keys, given) : given;
  if (k.E) E = k.E;
  if (k.G) G = k.G;
  if (k.Es) Es = k.Es;
  if (k.rho) rho = k.rho;
  if (k.nu) {
    if (!E) k.nu_key->fail("needs E to derive G = E / (2 (1 + nu))");
    G = *E / (2.0 * (1.0 + *k.nu));
  }
  const std::optional<double>&B = k.B, &C = k.C, &Ks = k.Ks, &kappa = k.kappa, &gamma_t = k.gamma_t,
        &gamma_r = k.gamma_r, &tau = k.tau, &max_strain = k.max_strain;
  const std::string of_file = file ? " (material file " + quoted_path(file->path) + ")" : "";

  const double area = kPi * radius * radius;
  const double inertia = area * radius * radius / 4.0;
  auto need = [&](const char* what) -> double {
    throw SceneError(mpath + ": needs " + what + of_file);
  };
  if (!rho) need("rho (density, kg/m^3)");
  Material mat;
  mat.density = *rho;
  mat.bend_stiffness = B ? *B : E ? *E * inertia : need("E or B");
  mat.twist_stiffness = C ? *C : G ? *G * 2.0 * inertia : need("G, nu or C");
  // Without a separate stretch modulus the material is isotropic: E_s = E.
  mat.stretch_stiffness = Ks ? *Ks : Es ? *Es * area : E ? *E * area : need("E_s or K_s");
  mat.youngs_modulus = E.value_or(0.0);
  mat.shear_modulus = G.value_or(0.0);
  mat.stretch_modulus = Es.value_or(E.value_or(0.0));
  // Default kappa: the shear stiffness G A of a circular section, G = C / (pi r^4 / 2).
  mat.kappa = kappa ? *kappa : kappa_factor * 2.0 * mat.twist_stiffness / (radius * radius);
  mat.gamma_t = gamma_t ? *gamma_t : (tau ? *tau : tau_t) * mat.stretch_stiffness;
  mat.gamma_r = gamma_r ? *gamma_r : (tau ? *tau : tau_r) * mat.bend_stiffness;
  mat.max_strain = max_strain ? *max_strain : preset ? preset->material.max_strain : 0.0;
  if (extras) {
    MaterialOrigin& o = extras->origin;
    o.bend = B ? "B" : "E";
    o.twist = C ? "C" : k.nu ? "E" : "G";
    o.stretch = Ks ? "K_s" : Es ? "E_s" : "E";
    o.kappa = kappa ? "kappa" : o.twist;
    o.mass = "rho";
    o.values.clear();
    for (auto [key, v] : {std::pair{"E", E}, std::pair{"G", G}, std::pair{"E_s", Es},
                          std::pair{"B", B}, std::pair{"C", C}, std::pair{"K_s", Ks},
                          std::pair{"kappa", kappa}, std::pair{"rho", rho}})
      if (v) o.values.emplace_back(key, *v);
  }
  if (file && extras) {
    extras->file = file->path;
    extras->friction = file->friction;
    if (file->drag) {
      try {
        extras->drag = read_drag(*file->drag, radius);
      } catch (const SceneError& e) {
        throw SceneError(mpath + ": material file " + quoted_path(file->path) + ": " + e.what());
      }
    }
  }
  try {
    return make_section(mat, radius);
  } catch (const std::invalid_argument& e) {
    throw SceneError(mpath + ": " + e.what() + of_file);
  }
}

RodShape read_shape(const Value& v) {
  Map m(v);
  RodShape s;
  const std::string type = m.get("type").choice({"straight", "helix", "polyline"});
  constexpr double kLength = SceneBounds::max_length;
  if (auto p = m.find("start")) s.start = p->vec3(kLength, "m");
  if (type == "straight") {
    s.kind = RodShape::Kind::kStraight;
    if (auto p = m.find("direction")) s.direction = p->nonzero_vec3();
    if (auto p = m.find("length")) s.length = p->positive(kLength, "m");
  } else if (type == "helix") {
    s.kind = RodShape::Kind::kHelix;
    s.direction = Vec3::UnitZ();
    if (auto p = m.find("axis")) s.direction = p->nonzero_vec3();
    s.helix_radius = m.get("radius").positive(kLength, "m");
    s.helix_pitch = m.get("pitch").non_negative(kLength, "m");
    const std::string count = m.one_of({"turns", "length"});
    const double per_turn = std::hypot(2.0 * kPi * s.helix_radius, s.helix_pitch);
    s.helix_turns = count == "turns" ? m.get("turns").positive(SceneBounds::max_factor, "")
                                     : m.get("length").positive(kLength, "m") / per_turn;
  } else {
    s.kind = RodShape::Kind::kPolyline;
    if (m.has("start")) m.fail("a polyline has no 'start'; its first point is the start");
    const Value pts = m.get("points");
    const std::vector<Value> items = pts.items();
    if (items.size() < 2) pts.fail("needs at least 2 points, got " + std::to_string(items.size()));
    for (size_t i = 0; i < items.size(); ++i) {
      s.points.push_back(items[i].vec3(kLength, "m"));
      if (i > 0 && (s.points[i] - s.points[i - 1]).norm() < 1e-12)
        items[i].fail("repeats the previous point");
    }
  }
  m.finish();
  return s;
}

}  // namespace scene_detail
}  // namespace corde
