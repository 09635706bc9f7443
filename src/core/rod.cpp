#include "corde_sim/rod.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace corde {

Rod::Rod(std::string name, std::vector<Vec3> nodes, std::vector<Quat> frames,
         const Section& section)
    : name_(std::move(name)), section_(section), x_(std::move(nodes)), q_(std::move(frames)) {
  if (q_.empty() || x_.size() != q_.size() + 1)
    throw std::invalid_argument("rod '" + name_ + "' needs N >= 1 segments and N + 1 nodes");
  const size_t n = q_.size();
  v_.assign(n + 1, Vec3::Zero());
  f_.assign(n + 1, Vec3::Zero());
  w_.assign(n, Vec3::Zero());
  tau_.assign(n, Vec3::Zero());
  w_world_.assign(n, Vec3::Zero());
  uhat_.assign(n - 1, Vec3::Zero());
  node_kinematic_.assign(n + 1, 0);
  seg_kinematic_.assign(n, 0);
  for (auto& q : q_) q.normalize();
  // Same hemisphere for neighbours keeps strains continuous (darboux() handles flips too).
  for (size_t s = 1; s < n; ++s)
    if (q_[s - 1].coeffs().dot(q_[s].coeffs()) < 0.0) q_[s].coeffs() *= -1.0;
  std::vector<double> rest(n);
  for (size_t s = 0; s < n; ++s) rest[s] = (x_[s + 1] - x_[s]).norm();
  set_rest_lengths(rest);
}

void Rod::set_rest_lengths(const std::vector<double>& rest) {
  if (rest.size() != q_.size()) throw std::invalid_argument("rest lengths: wrong count");
  for (double l : rest)
    if (!(l > 0.0) || !std::isfinite(l))
      throw std::invalid_argument("rod '" + name_ + "': segment rest lengths must be > 0");
  rest_ = rest;
  rest_elem_.resize(rest_.size() - 1);
  for (size_t j = 0; j + 1 < rest_.size(); ++j) rest_elem_[j] = 0.5 * (rest_[j] + rest_[j + 1]);
  update_mass_and_inertia();
}

void Rod::set_section(const Section& section) {
  section_ = section;
  update_mass_and_inertia();
}

void Rod::update_mass_and_inertia() {
  const size_t n = q_.size();
  mass_.assign(n + 1, 0.0);
  inv_mass_.resize(n + 1);
  inertia_.resize(n);
  for (size_t s = 0; s < n; ++s) {
    const double m = section_.mass_per_length * rest_[s];
    mass_[s] += 0.5 * m;
    mass_[s + 1] += 0.5 * m;
    inertia_[s] = Vec3(section_.inertia_bend, section_.inertia_bend, section_.inertia_twist) *
                  rest_[s];
  }
  for (size_t i = 0; i <= n; ++i) inv_mass_[i] = 1.0 / mass_[i];
}

void Rod::set_rest_strains_from_state() {
  for (size_t j = 0; j + 1 < q_.size(); ++j) uhat_[j] = darboux(q_[j], q_[j + 1], rest_elem_[j]);
}

void Rod::add_node_drive(const NodeDrive& d) {
  if (d.node < 0 || d.node >= num_nodes())
    throw std::out_of_range("rod '" + name_ + "': no node " + std::to_string(d.node));
  remove_node_drive(d.node);
  node_drives_.push_back(d);
  node_kinematic_[d.node] = 1;
}

void Rod::add_segment_drive(const SegmentDrive& d) {
  if (d.segment < 0 || d.segment >= num_segments())
    throw std::out_of_range("rod '" + name_ + "': no segment " + std::to_string(d.segment));
  remove_segment_drive(d.segment);
  segment_drives_.push_back(d);
  seg_kinematic_[d.segment] = 1;
}

bool Rod::remove_node_drive(int node) {
  auto it = std::find_if(node_drives_.begin(), node_drives_.end(),
                         [&](const NodeDrive& d) { return d.node == node; });
  if (it == node_drives_.end()) return false;
  node_drives_.erase(it);
  node_kinematic_[node] = 0;
  return true;
}

bool Rod::remove_segment_drive(int segment) {
  auto it = std::find_if(segment_drives_.begin(), segment_drives_.end(),
                         [&](const SegmentDrive& d) { return d.segment == segment; });
  if (it == segment_drives_.end()) return false;
  segment_drives_.erase(it);
  seg_kinematic_[segment] = 0;
  return true;
}

NodeDrive* Rod::node_drive(int node) {
  for (auto& d : node_drives_)
    if (d.node == node) return &d;
  return nullptr;
}

SegmentDrive* Rod::segment_drive(int segment) {
  for (auto& d : segment_drives_)
    if (d.segment == segment) return &d;
  return nullptr;
}

namespace {

// Body torques on the two frames of a bending element from its strain error (see
// bend_twist_energy for the gradients): with r = conj(a) b and sigma = sign(a.b),
// tau_a = (sigma/l) vec(r (x) e) and tau_b = -(sigma/l) vec(conj(r) (x) e), e = l K (u - uhat).
inline void bend_element(const Quat& a, const Quat& b, double rest, const Vec3& k,
                         const Vec3& uhat, Vec3* tau_a, Vec3* tau_b) {
  const Quat r = a.conjugate() * b;
  const double sigma = r.w() < 0.0 ? -1.0 : 1.0;
  const double inv_l = 1.0 / rest;
  const Vec3 u = (2.0 * sigma * inv_l) * r.vec();
  const Vec3 e = rest * k.cwiseProduct(u - uhat);
  if (tau_a) *tau_a += (sigma * inv_l) * mul_pure(r, e).vec();
  if (tau_b) *tau_b -= (sigma * inv_l) * mul_pure(r.conjugate(), e).vec();
}

}  // namespace

void Rod::compute_forces(double t, const Vec3& gravity) {
  const int n = num_segments();
  const Section& sec = section_;
  for (int i = 0; i <= n; ++i) f_[i] = mass_[i] * gravity;
  for (int s = 0; s < n; ++s) {
    tau_[s].setZero();
    w_world_[s] = q_[s] * w_[s];
  }
  for (const Load& l : loads_) {
    const double k = l.scale(t);
    if (k == 0.0) continue;
    if (l.kind == Load::Kind::kForce)
      f_[l.index] += k * l.value;
    else
      tau_[l.index] += q_[l.index].conjugate() * (k * l.value);
  }
  for (int s = 0; s < n; ++s) {
    const Vec3 dr = x_[s + 1] - x_[s];
    const double len = dr.norm();
    const Vec3 t = dr / len;
    const double rest = rest_[s];
    // Stretch (eq. 24) and translational internal friction (eq. 29) act along t.
    const Vec3 dv = v_[s + 1] - v_[s];
    const double axial = sec.stretch * (len / rest - 1.0) + sec.gamma_t / rest * t.dot(dv);
    // Coupling penalty (eq. 33).
    const Eigen::Matrix3d rot = q_[s].toRotationMatrix();
    const Vec3 diff = t - rot.col(2);
    const double c = rest * sec.kappa;
    const Vec3 fc = (c / len) * (diff - t * t.dot(diff));
    const Vec3 fs = axial * t + fc;
    f_[s] += fs;
    f_[s + 1] -= fs;
    tau_[s] += coupling_torque(rot.transpose() * t, rest, sec.kappa);
  }
  const Vec3 k(sec.bend, sec.bend, sec.twist);
  for (int j = 0; j + 1 < n; ++j) {
    const double rest = rest_elem_[j];
    bend_element(q_[j], q_[j + 1], rest, k, uhat_[j], &tau_[j], &tau_[j + 1]);
    // Rotational internal friction (eq. 30) on the world-frame angular velocity difference.
    const Vec3 tw = (sec.gamma_r / rest) * (w_world_[j + 1] - w_world_[j]);
    tau_[j] += q_[j].conjugate() * tw;
    tau_[j + 1] -= q_[j + 1].conjugate() * tw;
  }
  if (ghost_[0].active)
    bend_element(ghost_[0].frame, q_[0], 0.5 * rest_[0], k, ghost_[0].uhat, nullptr, &tau_[0]);
  if (ghost_[1].active)
    bend_element(q_[n - 1], ghost_[1].frame, 0.5 * rest_[n - 1], k, ghost_[1].uhat,
                 &tau_[n - 1], nullptr);
}

void Rod::step(double t, double h, const Vec3& gravity) {
  compute_forces(t, gravity);
  const int n = num_segments();
  for (int i = 0; i <= n; ++i) {
    if (node_kinematic_[i]) continue;
    v_[i] += (h * inv_mass_[i]) * f_[i];
    x_[i] += h * v_[i];
  }
  for (int s = 0; s < n; ++s) {
    if (seg_kinematic_[s]) continue;
    const Vec3& inertia = inertia_[s];
    Vec3& w = w_[s];
    w += h * (tau_[s] - w.cross(inertia.cwiseProduct(w))).cwiseQuotient(inertia);
    Quat& q = q_[s];
    const Quat dq = mul_pure(q, 0.5 * h * w);
    q.coeffs() += dq.coeffs();
    q.normalize();
  }
  apply_drives(t + h, h);
}

void Rod::apply_drives(double t_end, double h) {
  for (const NodeDrive& d : node_drives_) {
    Vec3& x = x_[d.node];
    Vec3& v = v_[d.node];
    switch (d.kind) {
      case NodeDrive::Kind::kFixed:
        x = d.origin;
        v.setZero();
        break;
      case NodeDrive::Kind::kVelocity: {
        const double dt = std::max(0.0, t_end - d.t_start);
        x = d.origin + dt * d.velocity;
        v = t_end > d.t_start ? d.velocity : Vec3::Zero();
        break;
      }
      case NodeDrive::Kind::kTarget:
        v = (d.target - x) / h;
        x = d.target;
        break;
    }
  }
  for (const SegmentDrive& d : segment_drives_) {
    Quat& q = q_[d.segment];
    Vec3& w = w_[d.segment];
    switch (d.kind) {
      case SegmentDrive::Kind::kFixed:
        q = d.origin;
        w.setZero();
        break;
      case SegmentDrive::Kind::kSpin: {
        const double angle = d.rate * std::max(0.0, t_end - d.t_start);
        q = d.origin * Quat(Eigen::AngleAxisd(angle, Vec3::UnitZ()));
        w = t_end > d.t_start ? Vec3(0.0, 0.0, d.rate) : Vec3::Zero();
        break;
      }
      case SegmentDrive::Kind::kTarget: {
        Quat target = d.target.normalized();
        if (target.coeffs().dot(q.coeffs()) < 0.0) target.coeffs() *= -1.0;
        const Eigen::AngleAxisd delta(q.conjugate() * target);
        w = (delta.angle() / h) * delta.axis();
        q = target;
        break;
      }
    }
  }
}

Energies Rod::energies(const Vec3& gravity) const {
  Energies e;
  const int n = num_segments();
  const Vec3 k(section_.bend, section_.bend, section_.twist);
  for (int i = 0; i <= n; ++i) {
    e.kinetic_translation += 0.5 * mass_[i] * v_[i].squaredNorm();
    e.gravity -= mass_[i] * gravity.dot(x_[i]);
  }
  for (int s = 0; s < n; ++s) {
    const Vec3 dr = x_[s + 1] - x_[s];
    e.kinetic_rotation += 0.5 * w_[s].dot(inertia_[s].cwiseProduct(w_[s]));
    e.stretch += stretch_energy(dr, rest_[s], section_.stretch, nullptr);
    e.coupling += coupling_energy(dr, q_[s], rest_[s], section_.kappa, nullptr, nullptr);
  }
  for (int j = 0; j + 1 < n; ++j)
    e.bend_twist += bend_twist_energy(q_[j], q_[j + 1], rest_elem_[j], k, uhat_[j], nullptr,
                                      nullptr);
  if (ghost_[0].active)
    e.bend_twist += bend_twist_energy(ghost_[0].frame, q_[0], 0.5 * rest_[0], k, ghost_[0].uhat,
                                      nullptr, nullptr);
  if (ghost_[1].active)
    e.bend_twist += bend_twist_energy(q_[n - 1], ghost_[1].frame, 0.5 * rest_[n - 1], k,
                                      ghost_[1].uhat, nullptr, nullptr);
  return e;
}

Vec3 Rod::center_of_mass() const {
  Vec3 c = Vec3::Zero();
  double m = 0.0;
  for (size_t i = 0; i < x_.size(); ++i) {
    c += mass_[i] * x_[i];
    m += mass_[i];
  }
  return c / m;
}

Vec3 Rod::linear_momentum() const {
  Vec3 p = Vec3::Zero();
  for (size_t i = 0; i < x_.size(); ++i) p += mass_[i] * v_[i];
  return p;
}

Vec3 Rod::angular_momentum() const {
  Vec3 l = Vec3::Zero();
  for (size_t i = 0; i < x_.size(); ++i) l += x_[i].cross(mass_[i] * v_[i]);
  for (size_t s = 0; s < q_.size(); ++s) l += q_[s] * inertia_[s].cwiseProduct(w_[s]);
  return l;
}

bool Rod::finite() const {
  for (size_t i = 0; i < x_.size(); ++i)
    if (!x_[i].allFinite() || !v_[i].allFinite()) return false;
  for (size_t s = 0; s < q_.size(); ++s)
    if (!q_[s].coeffs().allFinite() || !w_[s].allFinite()) return false;
  return true;
}

double Rod::length() const {
  double l = 0.0;
  for (size_t s = 0; s < q_.size(); ++s) l += (x_[s + 1] - x_[s]).norm();
  return l;
}

}  // namespace corde
