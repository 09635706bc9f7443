#include "corde_sim/rod/rod_edit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace corde {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Index i and weight a with s between coords[i] and coords[i + 1] (clamped to the ends).
void bracket(const std::vector<double>& coords, double s, size_t* i, double* a) {
  if (coords.size() < 2 || s <= coords.front()) {
    *i = 0;
    *a = 0.0;
    return;
  }
  if (s >= coords.back()) {
    *i = coords.size() - 2;
    *a = 1.0;
    return;
  }
  const size_t k = std::upper_bound(coords.begin(), coords.end(), s) - coords.begin();
  *i = k - 1;
  const double span = coords[k] - coords[k - 1];
  *a = span > 0.0 ? (s - coords[k - 1]) / span : 0.0;
}

template <typename T>
T lerp_at(const std::vector<double>& coords, const std::vector<T>& values, double s) {
  if (values.size() == 1) return values[0];
  size_t i;
  double a;
  bracket(coords, s, &i, &a);
  return (1.0 - a) * values[i] + a * values[i + 1];
}

// Cubic Hermite interpolation of node values in the material coordinate, slopes from the
// neighbouring chords (weighted for unequal segments) and quadratic at the ends. Between nodes
// the curve is smooth, so a refined rod keeps the curvature spread along its length instead of
// concentrated at the old nodes; it is linear in the values, which keeps rigid velocity fields.
class NodeSpline {
 public:
  NodeSpline(const std::vector<double>& coords, const std::vector<Vec3>& values)
      : s_(coords), y_(values), m_(values.size(), Vec3::Zero()) {
    const size_t n = values.size() - 1;
    std::vector<Vec3> slope(n);
    for (size_t i = 0; i < n; ++i) slope[i] = (y_[i + 1] - y_[i]) / (s_[i + 1] - s_[i]);
    if (n == 1) {
      m_[0] = m_[1] = slope[0];
      return;
    }
    for (size_t i = 1; i < n; ++i) {
      const double h0 = s_[i] - s_[i - 1], h1 = s_[i + 1] - s_[i];
      m_[i] = (h1 * slope[i - 1] + h0 * slope[i]) / (h0 + h1);
    }
    m_[0] = 2.0 * slope[0] - m_[1];
    m_[n] = 2.0 * slope[n - 1] - m_[n - 1];
  }

  Vec3 operator()(double s) const {
    size_t i;
    double a;
    bracket(s_, s, &i, &a);
    const double h = s_[i + 1] - s_[i];
    const double a2 = a * a, a3 = a2 * a;
    return (2 * a3 - 3 * a2 + 1) * y_[i] + (a3 - 2 * a2 + a) * h * m_[i] +
           (-2 * a3 + 3 * a2) * y_[i + 1] + (a3 - a2) * h * m_[i + 1];
  }

 private:
  const std::vector<double>& s_;
  const std::vector<Vec3>& y_;
  std::vector<Vec3> m_;
};

}  // namespace

Material equivalent_material(const Section& s) {
  if (!(s.radius > 0.0) || !std::isfinite(s.radius))
    throw std::invalid_argument("section radius must be > 0");
  const double area = kPi * s.radius * s.radius;
  const double polar = kPi * std::pow(s.radius, 4);
  Material m;
  m.youngs_modulus = 4.0 * s.bend / polar;
  m.shear_modulus = 2.0 * s.twist / polar;
  m.stretch_modulus = s.stretch / area;
  m.density = s.mass_per_length / area;
  m.kappa = s.kappa;
  m.gamma_t = s.gamma_t;
  m.gamma_r = s.gamma_r;
  m.max_strain = s.max_strain;
  return m;
}

void set_retardation_time(Material* m, double radius, double tau) {
  const double area = kPi * radius * radius;
  m->gamma_t = tau * m->stretch_modulus * area;
  m->gamma_r = tau * m->youngs_modulus * area * radius * radius / 4.0;
}

Rod resample_rod(const Rod& rod, int elements) {
  if (elements < 1) throw std::invalid_argument("elements must be >= 1");
  const int n_old = rod.num_segments();
  // Material coordinates of the old nodes, segment midpoints and orientation elements.
  std::vector<double> node_s(n_old + 1, 0.0), mid_s(n_old), elem_s(std::max(0, n_old - 1));
  for (int s = 0; s < n_old; ++s) {
    node_s[s + 1] = node_s[s] + rod.rest_lengths()[s];
    mid_s[s] = node_s[s] + 0.5 * rod.rest_lengths()[s];
  }
  for (int j = 0; j + 1 < n_old; ++j) elem_s[j] = node_s[j + 1];
  const double total = node_s.back();
  const double l = total / elements;

  std::vector<Vec3> x(elements + 1), v(elements + 1);
  const NodeSpline x_of_s(node_s, rod.positions()), v_of_s(node_s, rod.velocities());
  for (int k = 0; k <= elements; ++k) {
    const double s = (k == elements) ? total : k * l;
    x[k] = x_of_s(s);
    v[k] = v_of_s(s);
  }
  std::vector<Vec3> w_world_old(n_old);
  for (int s = 0; s < n_old; ++s)
    w_world_old[s] = rod.orientations()[s] * rod.angular_velocities()[s];
  std::vector<Quat> q(elements);
  std::vector<Vec3> w_world(elements);
  for (int k = 0; k < elements; ++k) {
    const double s = (k + 0.5) * l;
    size_t i;
    double a;
    if (n_old == 1) {
      q[k] = rod.orientations()[0];
    } else {
      bracket(mid_s, s, &i, &a);
      const Quat& qa = rod.orientations()[i];
      Quat qb = rod.orientations()[i + 1];
      if (qa.coeffs().dot(qb.coeffs()) < 0.0) qb.coeffs() *= -1.0;
      q[k] = qa.slerp(a, qb);
    }
    w_world[k] = lerp_at(mid_s, w_world_old, s);
  }

  // Each new segment keeps the stretch the old rod had there, and its d3 is turned onto its
  // chord: a chord across an old kink is shorter than the arc and points between the two old
  // tangents, and equal rest lengths or slerped tangents would start the rod with a jolt of
  // stretch and coupling energy.
  std::vector<double> strain_old(n_old), rest(elements);
  for (int s = 0; s < n_old; ++s)
    strain_old[s] =
        (rod.positions()[s + 1] - rod.positions()[s]).norm() / rod.rest_lengths()[s] - 1.0;
  for (int k = 0; k < elements; ++k) {
    const Vec3 chord = x[k + 1] - x[k];
    const double len = chord.norm();
    if (!(len > 0.0)) throw std::invalid_argument("resampled segment has zero length");
    rest[k] = len / (1.0 + lerp_at(mid_s, strain_old, (k + 0.5) * l));
    q[k] = Quat::FromTwoVectors(q[k] * Vec3::UnitZ(), chord / len) * q[k];
  }
  Rod out(rod.name(), x, q, rod.section());
  out.set_rest_lengths(rest);
  out.velocities() = v;
  for (int k = 0; k < elements; ++k)
    out.angular_velocities()[k] = out.orientations()[k].conjugate() * w_world[k];
  if (n_old >= 2) {
    for (int k = 0; k + 1 < elements; ++k)
      out.rest_strains()[k] = lerp_at(elem_s, rod.rest_strains(), (k + 1) * l);
  }

  // Boundary conditions move with the material coordinate; ends stay ends.
  auto new_node = [&](int i) {
    if (i == n_old) return elements;
    return std::min(elements, static_cast<int>(std::lround(node_s[i] / l)));
  };
  auto new_segment = [&](int s) {
    if (s == n_old - 1) return elements - 1;
    if (s == 0) return 0;
    return std::min(elements - 1, static_cast<int>(mid_s[s] / l));
  };
  for (NodeDrive d : rod.node_drives()) {
    d.node = new_node(d.node);
    out.add_node_drive(d);
  }
  for (SegmentDrive d : rod.segment_drives()) {
    d.segment = new_segment(d.segment);
    out.add_segment_drive(d);
  }
  for (NodeConstraint c : rod.node_constraints()) {
    c.node = new_node(c.node);
    if (!out.node_drive(c.node)) out.add_node_constraint(c);
  }
  for (SegmentConstraint c : rod.segment_constraints()) {
    c.segment = new_segment(c.segment);
    if (!out.segment_drive(c.segment)) out.add_segment_constraint(c);
  }
  for (Load load : rod.loads()) {
    load.index = load.kind == Load::Kind::kForce ? new_node(load.index) : new_segment(load.index);
    out.add_load(load);
  }
  // Point masses and added inertias move with the material coordinate too; each new segment takes
  // the mass scale of the old segment holding its midpoint.
  const std::vector<double>& added_mass = rod.added_node_masses();
  for (int i = 0; i < static_cast<int>(added_mass.size()); ++i)
    if (added_mass[i] > 0.0) out.add_node_mass(new_node(i), added_mass[i]);
  const std::vector<Vec3>& added_inertia = rod.added_segment_inertias();
  for (int s = 0; s < static_cast<int>(added_inertia.size()); ++s)
    if (added_inertia[s] != Vec3::Zero()) out.add_segment_inertia(new_segment(s), added_inertia[s]);
  for (const Rod::MassOffset& m : rod.mass_offsets())
    out.add_mass_offset(m.node == 0 ? 0 : elements, m.mass, m.offset);
  if (!rod.segment_mass_scale().empty()) {
    std::vector<double> scale(elements);
    for (int k = 0; k < elements; ++k) {
      const double s = (k + 0.5) * l;
      const int old =
          static_cast<int>(std::upper_bound(node_s.begin(), node_s.end(), s) - node_s.begin()) - 1;
      scale[k] = rod.segment_mass_scale()[std::min(std::max(old, 0), n_old - 1)];
    }
    out.set_segment_mass_scale(scale);
  }
  out.set_drag(rod.drag());
  out.contact_options() = rod.contact_options();
  out.ghost_start() = rod.ghost_start();
  out.ghost_end() = rod.ghost_end();
  return out;
}

}  // namespace corde
