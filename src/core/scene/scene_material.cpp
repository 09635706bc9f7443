// Materials and shapes of scene rods.
#include <cmath>
#include <optional>
#include <stdexcept>

#include "scene_reader.h"

namespace corde {
namespace scene_detail {
namespace {

constexpr double kPi = 3.14159265358979323846;

const MaterialPreset& find_preset(const Value& v) {
  const std::string name = v.string();
  try {
    return material_preset(name);
  } catch (const std::invalid_argument& e) {
    std::string msg = e.what();  // names the preset: cut a huge one short
    const size_t at = msg.find("'" + name + "'");
    if (at != std::string::npos) msg.replace(at, name.size() + 2, echo(name));
    v.fail(msg);
  }
}

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

}  // namespace

// A preset contributes its moduli, density, the ratio kappa / (G A) and the retardation times
// gamma_t / K_s and gamma_r / B, so that a preset used at another radius, or with some moduli
// overridden, keeps its intent instead of its absolute kappa and gamma values.
Section read_section(Map* rod) {
  const Value mv = rod->get("material");
  const MaterialPreset* preset = nullptr;
  std::optional<Map> map;
  if (mv.is_scalar()) {
    preset = &find_preset(mv);
  } else {
    map.emplace(mv);
    if (std::optional<Value> p = map->find("preset")) preset = &find_preset(*p);
  }
  double radius = 0.0;
  if (std::optional<Value> r = rod->find("radius")) {
    radius = r->in_range("radius");
  } else if (preset) {
    radius = preset->radius;
  } else {
    throw SceneError(rod->path() + ".radius: missing (required unless the material is a preset)");
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
  at_most_one(m, "E", "B");
  at_most_one(m, "E_s", "K_s");
  if (m && ((m->has("G") ? 1 : 0) + (m->has("nu") ? 1 : 0) + (m->has("C") ? 1 : 0)) > 1)
    m->fail("give only one of G, nu and C");

  if (auto v = ranged_key(m, "E")) E = v;
  if (auto v = ranged_key(m, "G")) G = v;
  if (auto v = ranged_key(m, "E_s")) Es = v;
  // Bounded below too: a near-massless rod starts at an enormous energy per mass.
  if (auto v = ranged_key(m, "rho")) rho = v;
  if (m) {
    if (std::optional<Value> nv = m->find("nu")) {
      const double nu = nv->in_range("nu");
      if (!E) nv->fail("needs E to derive G = E / (2 (1 + nu))");
      G = *E / (2.0 * (1.0 + nu));
    }
  }
  const std::optional<double> B = ranged_key(m, "B"), C = ranged_key(m, "C"),
                              Ks = ranged_key(m, "K_s");
  const std::optional<double> kappa = ranged_key(m, "kappa");
  const std::optional<double> gamma_t = ranged_key(m, "gamma_t");
  const std::optional<double> gamma_r = ranged_key(m, "gamma_r");
  const std::optional<double> tau = ranged_key(m, "damping_time");
  const std::optional<double> max_strain = ranged_key(m, "max_strain");
  if (m) m->finish();

  const double area = kPi * radius * radius;
  const double inertia = area * radius * radius / 4.0;
  auto need = [&](const char* what) -> double { throw SceneError(mpath + ": needs " + what); };
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
  try {
    return make_section(mat, radius);
  } catch (const std::invalid_argument& e) {
    throw SceneError(mpath + ": " + e.what());
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
