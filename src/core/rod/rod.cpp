#include "corde_sim/rod/rod.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/model/drag.h"
#include "corde_sim/model/loads.h"

namespace corde {

namespace {
// Segments per block of Rod::step and Rod::compute_forces. All passes run over one block before
// the next, so the block's state and constants stay in the per-core cache across the six passes
// instead of the whole rod being streamed through it six times; the scratch holds one block only
// (no traffic to memory). 1024 measured best of 256 to 2048 (docs/benchmark.md); rods up to 1024
// segments are one block, as before.
constexpr int kStepBlock = 1024;
}  // namespace

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
  uhat_.assign(n - 1, Vec3::Zero());
  node_free_.assign(n + 1, 1.0);
  seg_free_.assign(n, 1.0);
  // Scratch for one block of segments, with the items around it (rod.h, Rod::forces_block).
  const size_t m = std::min<size_t>(n, kStepBlock);
  fs_.assign(3 * (m + 3), 0.0);
  ww_.assign(3 * (m + 1), 0.0);
  tc_.assign(2 * (m + 1), 0.0);
  ta_.assign(3 * (m + 1), 0.0);
  tb_.assign(3 * (m + 1), 0.0);
  tw_.assign(3 * (m + 2), 0.0);
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

void Rod::set_rotational_inertia_scale(double scale) {
  if (!(scale >= 1.0) || !std::isfinite(scale))
    throw std::invalid_argument("rod '" + name_ +
                                "': rotational_inertia_scale must be a finite number >= 1, got " +
                                std::to_string(scale));
  inertia_scale_ = scale;
  update_mass_and_inertia();
}

void Rod::add_node_mass(int node, double mass) {
  if (node < 0 || node >= num_nodes())
    throw std::out_of_range("rod '" + name_ + "': no node " + std::to_string(node));
  if (!(mass > 0.0) || !std::isfinite(mass))
    throw std::invalid_argument("rod '" + name_ + "': a point mass must be a finite number > 0");
  if (added_mass_.empty()) added_mass_.assign(x_.size(), 0.0);
  added_mass_[node] += mass;
  update_mass_and_inertia();
}

void Rod::add_segment_inertia(int segment, const Vec3& inertia) {
  if (segment < 0 || segment >= num_segments())
    throw std::out_of_range("rod '" + name_ + "': no segment " + std::to_string(segment));
  if (!inertia.allFinite() || (inertia.array() < 0.0).any() || inertia.x() != inertia.y())
    throw std::invalid_argument("rod '" + name_ +
                                "': an added inertia must be finite, >= 0 and equal about d1 "
                                "and d2");
  if (added_inertia_.empty()) added_inertia_.assign(q_.size(), Vec3::Zero());
  added_inertia_[segment] += inertia;
  update_mass_and_inertia();
}

void Rod::add_mass_offset(int node, double mass, const Vec3& offset) {
  const int n = num_segments();
  if (node != 0 && node != n)
    throw std::out_of_range("rod '" + name_ + "': a mass offset needs an end node (0 or " +
                            std::to_string(n) + "), got " + std::to_string(node));
  if (!(mass > 0.0) || !std::isfinite(mass) || !offset.allFinite())
    throw std::invalid_argument("rod '" + name_ +
                                "': a mass offset needs a finite mass > 0 and a finite offset");
  MassOffset m;
  m.node = node;
  m.segment = node == 0 ? 0 : n - 1;
  m.mass = mass;
  m.offset = offset;
  mass_offsets_.push_back(m);
}

Vec3 Rod::mass_offset_torque(int segment, const Vec3& gravity) const {
  Vec3 tau = Vec3::Zero();
  for (const MassOffset& m : mass_offsets_)
    if (m.segment == segment) tau += m.body_torque(q_[segment], gravity);
  return tau;
}

void Rod::set_segment_mass_scale(const std::vector<double>& scale) {
  if (!scale.empty() && scale.size() != q_.size())
    throw std::invalid_argument("rod '" + name_ +
                                "': mass scales: " + std::to_string(scale.size()) + " for " +
                                std::to_string(q_.size()) + " segments");
  for (double f : scale)
    if (!(f > 0.0) || !std::isfinite(f))
      throw std::invalid_argument("rod '" + name_ + "': mass scales must be finite and > 0");
  mass_scale_ = scale;
  update_mass_and_inertia();
}

void Rod::update_mass_and_inertia() {
  const size_t n = q_.size();
  mass_.assign(n + 1, 0.0);
  section_mass_.assign(n + 1, 0.0);
  inv_mass_.resize(n + 1);
  inertia_.resize(n);
  for (size_t s = 0; s < n; ++s) {
    const double m = section_.mass_per_length * rest_[s];
    section_mass_[s] += 0.5 * m;
    section_mass_[s + 1] += 0.5 * m;
    const double bend = inertia_scale_ * section_.inertia_bend;
    inertia_[s] = Vec3(bend, bend, section_.inertia_twist) * rest_[s];
    if (!mass_scale_.empty()) {
      const double ms = m * mass_scale_[s];
      mass_[s] += 0.5 * ms;
      mass_[s + 1] += 0.5 * ms;
      inertia_[s] *= mass_scale_[s];
    }
  }
  if (mass_scale_.empty()) mass_ = section_mass_;
  for (size_t i = 0; i < added_mass_.size(); ++i) mass_[i] += added_mass_[i];
  for (size_t s = 0; s < added_inertia_.size(); ++s) inertia_[s] += added_inertia_[s];
  for (size_t i = 0; i <= n; ++i) inv_mass_[i] = 1.0 / mass_[i];
  inv_rest_.resize(n);
  gamma_t_inv_rest_.resize(n);
  kappa_rest_.resize(n);
  inv_inertia_.resize(3 * n);
  for (size_t s = 0; s < n; ++s) {
    inv_rest_[s] = 1.0 / rest_[s];
    gamma_t_inv_rest_[s] = section_.gamma_t / rest_[s];
    kappa_rest_[s] = section_.kappa * rest_[s];
    for (int k = 0; k < 3; ++k) inv_inertia_[3 * s + k] = 1.0 / inertia_[s][k];
  }
  inv_rest_elem_.resize(n - 1);
  gamma_r_inv_rest_elem_.resize(n - 1);
  for (size_t j = 0; j + 1 < n; ++j) {
    inv_rest_elem_[j] = 1.0 / rest_elem_[j];
    gamma_r_inv_rest_elem_[j] = section_.gamma_r / rest_elem_[j];
  }
}

void Rod::set_rest_strains_from_state() {
  for (size_t j = 0; j + 1 < q_.size(); ++j) uhat_[j] = darboux(q_[j], q_[j + 1], rest_elem_[j]);
}

void Rod::add_node_drive(const NodeDrive& d) {
  if (d.node < 0 || d.node >= num_nodes())
    throw std::out_of_range("rod '" + name_ + "': no node " + std::to_string(d.node));
  for (const NodeConstraint& c : node_constraints_)
    if (c.node == d.node)
      throw std::invalid_argument("rod '" + name_ + "': node " + std::to_string(d.node) +
                                  " slides on a line or plane; it cannot also be driven");
  remove_node_drive(d.node);
  node_drives_.push_back(d);
  node_free_[d.node] = 0.0;
}

void Rod::add_load(const Load& l) {
  const bool force = l.kind == Load::Kind::kForce;
  if (l.index < 0 || l.index >= (force ? num_nodes() : num_segments()))
    throw std::out_of_range("rod '" + name_ + "': no " + (force ? "node " : "segment ") +
                            std::to_string(l.index) + " for a load");
  loads_.push_back(l);
}

void Rod::add_segment_drive(const SegmentDrive& d) {
  if (d.segment < 0 || d.segment >= num_segments())
    throw std::out_of_range("rod '" + name_ + "': no segment " + std::to_string(d.segment));
  for (const SegmentConstraint& c : segment_constraints_)
    if (c.segment == d.segment)
      throw std::invalid_argument("rod '" + name_ + "': segment " + std::to_string(d.segment) +
                                  " has a hinge; it cannot also be driven");
  remove_segment_drive(d.segment);
  segment_drives_.push_back(d);
  seg_free_[d.segment] = 0.0;
}

void Rod::add_node_constraint(const NodeConstraint& c) {
  if (c.node < 0 || c.node >= num_nodes())
    throw std::out_of_range("rod '" + name_ + "' has no node " + std::to_string(c.node));
  if (node_drive(c.node))
    throw std::invalid_argument("node " + std::to_string(c.node) + " is driven");
  if (!(c.direction.allFinite() && c.direction.norm() > 0.0) || !c.point.allFinite())
    throw std::invalid_argument("a constraint needs a finite point and a non-zero direction");
  NodeConstraint k = c;
  k.direction.normalize();
  for (NodeConstraint& e : node_constraints_)
    if (e.node == c.node) {
      e = k;
      return;
    }
  node_constraints_.push_back(k);
}

void Rod::add_segment_constraint(const SegmentConstraint& c) {
  if (c.segment < 0 || c.segment >= num_segments())
    throw std::out_of_range("rod '" + name_ + "' has no segment " + std::to_string(c.segment));
  if (segment_drive(c.segment))
    throw std::invalid_argument("segment " + std::to_string(c.segment) + " is driven");
  if (!(c.axis.allFinite() && c.axis.norm() > 0.0))
    throw std::invalid_argument("a hinge needs a finite non-zero axis");
  SegmentConstraint k = c;
  k.axis.normalize();
  k.origin.normalize();
  for (SegmentConstraint& e : segment_constraints_)
    if (e.segment == c.segment) {
      e = k;
      return;
    }
  segment_constraints_.push_back(k);
}

bool Rod::remove_node_constraint(int node) {
  auto it = std::find_if(node_constraints_.begin(), node_constraints_.end(),
                         [&](const NodeConstraint& c) { return c.node == node; });
  if (it == node_constraints_.end()) return false;
  node_constraints_.erase(it);
  return true;
}

bool Rod::remove_segment_constraint(int segment) {
  auto it = std::find_if(segment_constraints_.begin(), segment_constraints_.end(),
                         [&](const SegmentConstraint& c) { return c.segment == segment; });
  if (it == segment_constraints_.end()) return false;
  segment_constraints_.erase(it);
  return true;
}

bool Rod::remove_node_drive(int node) {
  auto it = std::find_if(node_drives_.begin(), node_drives_.end(),
                         [&](const NodeDrive& d) { return d.node == node; });
  if (it == node_drives_.end()) return false;
  node_drives_.erase(it);
  node_free_[node] = 1.0;
  return true;
}

bool Rod::remove_segment_drive(int segment) {
  auto it = std::find_if(segment_drives_.begin(), segment_drives_.end(),
                         [&](const SegmentDrive& d) { return d.segment == segment; });
  if (it == segment_drives_.end()) return false;
  segment_drives_.erase(it);
  seg_free_[segment] = 1.0;
  return true;
}

void Rod::add_external_force(int node, const Vec3& f) {
  if (node < 0 || node >= num_nodes())
    throw std::out_of_range("rod '" + name_ + "' has no node " + std::to_string(node));
  if (!has_external_) {
    ext_f_.assign(num_nodes(), Vec3::Zero());
    ext_tau_.assign(num_segments(), Vec3::Zero());
    has_external_ = true;
  }
  ext_f_[node] += f;
}

void Rod::add_external_torque(int segment, const Vec3& torque) {
  if (segment < 0 || segment >= num_segments())
    throw std::out_of_range("rod '" + name_ + "' has no segment " + std::to_string(segment));
  if (!has_external_) add_external_force(0, Vec3::Zero());
  ext_tau_[segment] += torque;
}

void Rod::set_drag(const Drag& d) {
  for (double c :
       {d.linear_normal, d.linear_tangential, d.quadratic_normal, d.quadratic_tangential})
    if (!(c >= 0.0) || !std::isfinite(c))
      throw std::invalid_argument("rod '" + name_ + "': drag coefficients must be >= 0");
  drag_ = d;
}

void Rod::drag_block(int node0, int node1) {
  const double inv_mu = 1.0 / section_.mass_per_length;
  for (int i = node0; i < node1; ++i)
    f_[i] += drag_force(node_drag(drag_, x_, i, v_[i], section_mass_[i], inv_mu));
}

void Rod::clear_external() {
  ext_f_.clear();
  ext_tau_.clear();
  has_external_ = false;
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

// The step reads the state vectors as packed doubles (x, y, z per Vec3; x, y, z, w per Quat).
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
static_assert(sizeof(Quat) == 4 * sizeof(double), "Quat must be four packed doubles");

// Rotation matrix of the unit quaternion q = (x, y, z, w), the same formulas as Eigen's
// toRotationMatrix(). Columns are the directors d1, d2, d3.
struct Rotation {
  double m00, m01, m02, m10, m11, m12, m20, m21, m22;
};
inline Rotation rotation(const double* q) {
  const double tx = 2.0 * q[0], ty = 2.0 * q[1], tz = 2.0 * q[2];
  const double twx = tx * q[3], twy = ty * q[3], twz = tz * q[3];
  const double txx = tx * q[0], txy = ty * q[0], txz = tz * q[0];
  const double tyy = ty * q[1], tyz = tz * q[1], tzz = tz * q[2];
  return {1.0 - (tyy + tzz), txy - twz,         txz + twy,  //
          txy + twz,         1.0 - (txx + tzz), tyz - twx,  //
          txz - twy,         tyz + twx,         1.0 - (txx + tyy)};
}

// Bending and twist element between the frames a and b (quaternions as x, y, z, w; rest length l,
// inv_l = 1/l, stiffness (kb, kb, kt) = (B, B, C), rest strain uhat). Writes the body torque on a
// to ta and on b to tb. With r = conj(a) (x) b and sigma = sign(r_w) (q and -q give the same
// strain), the strain is u = (2 sigma / l) vec(r) and e = l K (u - uhat) = dV/du. The gradients are
// the products of a and b with the pure quaternion e (signed permutations of e, eq. 6), which as
// body torques become tau_a = (sigma/l) vec(r (x) e) = (sigma/l) (r_w e + vec(r) x e) and tau_b =
// -(sigma/l) vec(conj(r) (x) e) = -(sigma/l) (r_w e - vec(r) x e): one cross product serves both
// frames, and no 4x4 product is formed.
inline void bend_element(const double* a, const double* b, double l, double inv_l, double kb,
                         double kt, const double* uhat, double* ta, double* tb) {
  const double rw = a[3] * b[3] + a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const double rx = a[3] * b[0] - b[3] * a[0] - (a[1] * b[2] - a[2] * b[1]);
  const double ry = a[3] * b[1] - b[3] * a[1] - (a[2] * b[0] - a[0] * b[2]);
  const double rz = a[3] * b[2] - b[3] * a[2] - (a[0] * b[1] - a[1] * b[0]);
  const double sigma = rw < 0.0 ? -1.0 : 1.0;
  const double su = 2.0 * sigma * inv_l;
  const double ex = l * (kb * (su * rx - uhat[0]));
  const double ey = l * (kb * (su * ry - uhat[1]));
  const double ez = l * (kt * (su * rz - uhat[2]));
  const double cx = ry * ez - rz * ey, cy = rz * ex - rx * ez, cz = rx * ey - ry * ex;
  const double g = sigma * inv_l;
  ta[0] = g * (rw * ex + cx);
  ta[1] = g * (rw * ey + cy);
  ta[2] = g * (rw * ez + cz);
  tb[0] = -g * (rw * ex - cx);
  tb[1] = -g * (rw * ey - cy);
  tb[2] = -g * (rw * ez - cz);
}

// x86-64: the hot loops are also compiled for AVX2 (x86-64-v3) and AVX-512 (x86-64-v4), picked at
// load time for the CPU at hand, so the build itself stays portable (no -march). rod.cpp is built
// with -ffp-contract=off so that the variants do not fuse a * b + c; GCC 12 still turns a few
// alternating add/sub lanes into fmaddsub there, so results may differ from the baseline variant
// in the last bits. -DCORDE_NO_VECTOR_CLONES builds the baseline variant only.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(CORDE_NO_VECTOR_CLONES)
#define CORDE_VECTOR_CLONES \
  [[gnu::noinline, gnu::target_clones("default", "arch=x86-64-v3", "arch=x86-64-v4")]]
#else
#define CORDE_VECTOR_CLONES [[gnu::noinline]]
#endif

// The passes of Rod::internal_forces over flat arrays. Each is a plain loop without branches or
// values carried between iterations, which the compiler vectorises. They stay out of line: GCC 12
// no longer vectorises them once inlined into the member function.
CORDE_VECTOR_CLONES void segment_pass(int s0, int s1, int off, const double* __restrict x,
                                      const double* __restrict v, const double* __restrict q,
                                      const double* __restrict w, const double* __restrict inv_rest,
                                      const double* __restrict gamma_t_inv_rest,
                                      const double* __restrict kappa_rest, double ks,
                                      double* __restrict fs, double* __restrict ww,
                                      double* __restrict tc) {
  // Segments: stretch (eq. 24) with translational friction (eq. 29) along the tangent, the
  // coupling penalty (eq. 33) and its body torque l kappa (e_z x R^T t) = l kappa (-d2.t, d1.t, 0),
  // and the world angular velocity for the rotational friction.
  for (int s = s0; s < s1; ++s) {
    const int l = s - off;  // index into the block's scratch
    const Rotation r = rotation(q + 4 * s);
    const double* ws = w + 3 * s;
    ww[3 * l + 0] = r.m00 * ws[0] + r.m01 * ws[1] + r.m02 * ws[2];
    ww[3 * l + 1] = r.m10 * ws[0] + r.m11 * ws[1] + r.m12 * ws[2];
    ww[3 * l + 2] = r.m20 * ws[0] + r.m21 * ws[1] + r.m22 * ws[2];
    const double drx = x[3 * s + 3] - x[3 * s], dry = x[3 * s + 4] - x[3 * s + 1],
                 drz = x[3 * s + 5] - x[3 * s + 2];
    const double len = std::sqrt(drx * drx + dry * dry + drz * drz);
    const double inv_len = 1.0 / len;
    const double tx = drx * inv_len, ty = dry * inv_len, tz = drz * inv_len;
    const double dvx = v[3 * s + 3] - v[3 * s], dvy = v[3 * s + 4] - v[3 * s + 1],
                 dvz = v[3 * s + 5] - v[3 * s + 2];
    const double axial =
        ks * (len * inv_rest[s] - 1.0) + gamma_t_inv_rest[s] * (tx * dvx + ty * dvy + tz * dvz);
    const double diffx = tx - r.m02, diffy = ty - r.m12, diffz = tz - r.m22;
    const double t_diff = tx * diffx + ty * diffy + tz * diffz;
    const double c = kappa_rest[s] * inv_len;
    fs[3 * l + 3] = axial * tx + c * (diffx - tx * t_diff);
    fs[3 * l + 4] = axial * ty + c * (diffy - ty * t_diff);
    fs[3 * l + 5] = axial * tz + c * (diffz - tz * t_diff);
    tc[2 * l + 0] = -kappa_rest[s] * (r.m01 * tx + r.m11 * ty + r.m21 * tz);
    tc[2 * l + 1] = kappa_rest[s] * (r.m00 * tx + r.m10 * ty + r.m20 * tz);
  }
}

CORDE_VECTOR_CLONES void element_pass(int j0, int j1, int off, const double* __restrict q,
                                      const double* __restrict uhat,
                                      const double* __restrict rest_elem,
                                      const double* __restrict inv_rest_elem,
                                      const double* __restrict gamma_r_inv_rest_elem, double kb,
                                      double kt, const double* __restrict ww, double* __restrict ta,
                                      double* __restrict tb, double* __restrict tw) {
  // Elements: bending and twist, and rotational friction (eq. 30) on the world angular velocity
  // difference, tw_j = gamma_r / l_j (ww_{j+1} - ww_j), + on segment j and - on segment j + 1.
  for (int j = j0; j < j1; ++j) {
    const int l = j - off;
    bend_element(q + 4 * j, q + 4 * j + 4, rest_elem[j], inv_rest_elem[j], kb, kt, uhat + 3 * j,
                 ta + 3 * l, tb + 3 * l + 3);
    for (int c = 0; c < 3; ++c)
      tw[3 * l + 3 + c] = gamma_r_inv_rest_elem[j] * (ww[3 * l + 3 + c] - ww[3 * l + c]);
  }
}

CORDE_VECTOR_CLONES void torque_pass(int s0, int s1, int off, const double* __restrict q,
                                     const double* __restrict tc, const double* __restrict ta,
                                     const double* __restrict tb, const double* __restrict tw,
                                     double* __restrict tau) {
  // Segments: total body torque; the friction torques of both neighbouring elements share one
  // R^T product.
  for (int s = s0; s < s1; ++s) {
    const int l = s - off;
    const Rotation r = rotation(q + 4 * s);
    const double dx = tw[3 * l + 3] - tw[3 * l], dy = tw[3 * l + 4] - tw[3 * l + 1],
                 dz = tw[3 * l + 5] - tw[3 * l + 2];
    tau[3 * s + 0] = tc[2 * l] + ta[3 * l] + tb[3 * l] + (r.m00 * dx + r.m10 * dy + r.m20 * dz);
    tau[3 * s + 1] =
        tc[2 * l + 1] + ta[3 * l + 1] + tb[3 * l + 1] + (r.m01 * dx + r.m11 * dy + r.m21 * dz);
    tau[3 * s + 2] = ta[3 * l + 2] + tb[3 * l + 2] + (r.m02 * dx + r.m12 * dy + r.m22 * dz);
  }
}

CORDE_VECTOR_CLONES void node_force_pass(int i0, int i1, int off, const double* __restrict fs,
                                         const double* __restrict mass, double gx, double gy,
                                         double gz, double* __restrict f) {
  for (int i = i0; i < i1; ++i) {
    const int l = i - off;
    f[3 * i + 0] = mass[i] * gx + (fs[3 * l + 3] - fs[3 * l + 0]);
    f[3 * i + 1] = mass[i] * gy + (fs[3 * l + 4] - fs[3 * l + 1]);
    f[3 * i + 2] = mass[i] * gz + (fs[3 * l + 5] - fs[3 * l + 2]);
  }
}

// Semi-implicit Euler (eqs. 37-42; the segments' pass is Integrator::kSemiImplicitEuler). Kinematic
// nodes and segments get increments multiplied by 0 (exactly their old state) instead of a branch,
// so the loops vectorise.
CORDE_VECTOR_CLONES void node_integrate_pass(int i0, int i1, double h, const double* __restrict f,
                                             const double* __restrict inv_mass,
                                             const double* __restrict node_free,
                                             double* __restrict x, double* __restrict v) {
  for (int i = i0; i < i1; ++i) {
    const double hm = h * inv_mass[i] * node_free[i], hx = h * node_free[i];
    for (int c = 0; c < 3; ++c) {
      v[3 * i + c] += hm * f[3 * i + c];
      x[3 * i + c] += hx * v[3 * i + c];
    }
  }
}

CORDE_VECTOR_CLONES void segment_integrate_pass(int s0, int s1, double h,
                                                const double* __restrict tau,
                                                const double* __restrict inertia,
                                                const double* __restrict inv_inertia,
                                                const double* __restrict seg_free,
                                                double* __restrict w, double* __restrict q) {
  for (int s = s0; s < s1; ++s) {
    const double* in = inertia + 3 * s;
    double* ws = w + 3 * s;
    const double wx = ws[0], wy = ws[1], wz = ws[2];
    const double lx = in[0] * wx, ly = in[1] * wy, lz = in[2] * wz;  // body angular momentum
    const double hf = h * seg_free[s];
    const double nx = wx + (hf * (tau[3 * s + 0] - (wy * lz - wz * ly))) * inv_inertia[3 * s + 0];
    const double ny = wy + (hf * (tau[3 * s + 1] - (wz * lx - wx * lz))) * inv_inertia[3 * s + 1];
    const double nz = wz + (hf * (tau[3 * s + 2] - (wx * ly - wy * lx))) * inv_inertia[3 * s + 2];
    ws[0] = nx;
    ws[1] = ny;
    ws[2] = nz;
    // q + q (x) (0, h w / 2), then normalised (a kinematic segment keeps q: scale 1).
    const double a = 0.5 * hf;
    const double hx = a * nx, hy = a * ny, hz = a * nz;
    double* qs = q + 4 * s;
    const double qx = qs[0], qy = qs[1], qz = qs[2], qw = qs[3];
    const double px = qx + (qw * hx + qy * hz - qz * hy);
    const double py = qy + (qw * hy + qz * hx - qx * hz);
    const double pz = qz + (qw * hz + qx * hy - qy * hx);
    const double pw = qw - (qx * hx + qy * hy + qz * hz);
    const double inv_norm = 1.0 / std::sqrt(px * px + py * py + pz * pz + pw * pw);
    const double scale = seg_free[s] * inv_norm + (1.0 - seg_free[s]);
    qs[0] = px * scale;
    qs[1] = py * scale;
    qs[2] = pz * scale;
    qs[3] = pw * scale;
  }
}

// The split rotation (Integrator::kSplitRotation): a kick by the torques alone, then the
// torque-free motion of the axisymmetric segment (I1 = I2) over h. That motion keeps w3 and
// |w_perp| and turns (w1, w2) about d3 at Omega = (I3 - I1)/I1 w3, while the frame turns about the
// fixed angular momentum: q(h) = q (x) rot(h a) (x) rot(-h Omega e3), a = I w / I1 (body frame).
// Both rotations are taken in Cayley form, (1, phi/2) normalised (the angle 2 atan(|phi|/2)), and
// w turns by the same angle 2 atan(h Omega/2) as the frame's counter-rotation about d3: the update
// is then the exact flow of a kinetic energy of the same |L| and L3 as the true one, so it keeps
// the kinetic energy and the world angular momentum of a free segment to round-off, and the whole
// step stays a symplectic splitting (kick, then drift). Rational: no sin/cos, so it vectorises.
CORDE_VECTOR_CLONES void segment_split_rotation_pass(int s0, int s1, double h,
                                                     const double* __restrict tau,
                                                     const double* __restrict inertia,
                                                     const double* __restrict inv_inertia,
                                                     const double* __restrict seg_free,
                                                     double* __restrict w, double* __restrict q) {
  for (int s = s0; s < s1; ++s) {
    const double* in = inertia + 3 * s;
    const double* inv = inv_inertia + 3 * s;
    double* ws = w + 3 * s;
    const double hf = h * seg_free[s];  // 0 for a kinematic segment: w and q unchanged
    const double wx = ws[0] + hf * tau[3 * s + 0] * inv[0];
    const double wy = ws[1] + hf * tau[3 * s + 1] * inv[1];
    const double wz = ws[2] + hf * tau[3 * s + 2] * inv[2];
    const double omega = (in[2] * inv[0] - 1.0) * wz;
    const double t = 0.5 * hf * omega;  // tan of half the turn of (w1, w2)
    const double d = 1.0 / (1.0 + t * t);
    const double c = (1.0 - t * t) * d, sn = 2.0 * t * d;
    ws[0] = c * wx - sn * wy;
    ws[1] = sn * wx + c * wy;
    ws[2] = wz;
    // p = (1, h a/2) (x) (1, -t e3), then q (x) p normalised.
    const double a = 0.5 * hf;
    const double ax = a * wx, ay = a * wy, az = a * (wz + omega);
    const double px = ax - ay * t, py = ay + ax * t, pz = az - t, pw = 1.0 + az * t;
    double* qs = q + 4 * s;
    const double qx = qs[0], qy = qs[1], qz = qs[2], qw = qs[3];
    const double rx = qw * px + qx * pw + (qy * pz - qz * py);
    const double ry = qw * py + qy * pw + (qz * px - qx * pz);
    const double rz = qw * pz + qz * pw + (qx * py - qy * px);
    const double rw = qw * pw - (qx * px + qy * py + qz * pz);
    // A kinematic segment's frame is left exactly as its drive set it (not renormalised).
    const double inv_norm = 1.0 / std::sqrt(rx * rx + ry * ry + rz * rz + rw * rw);
    const double scale = seg_free[s] * inv_norm + (1.0 - seg_free[s]);
    qs[0] = rx * scale;
    qs[1] = ry * scale;
    qs[2] = rz * scale;
    qs[3] = rw * scale;
  }
}

// What is complete once segments [b0, b1) of n have been through the segment pass: elements up
// to b1 - 2 (element j needs segments j and j + 1); torques and the segment integration one behind
// (segment s needs elements s - 1 and s, and its old frame is read by element s); node forces and
// the node integration up to b1 - 1 (node i needs segments i - 1 and i, node b1 is read by segment
// b1). The last block finishes the rod.
struct BlockRange {
  int elem0, elem1, seg0, seg1, node0, node1;
};
inline BlockRange block_range(int b0, int b1, int n) {
  const bool last = b1 == n;
  return {std::max(b0 - 1, 0), b1 - 1, std::max(b0 - 1, 0),
          last ? n : b1 - 1,   b0,     last ? n + 1 : b1};
}

}  // namespace

// Forces and torques of the items completed by segments [b0, b1) (block_range): segments
// (stretch, coupling, world angular velocities), elements (bending, twist, rotational friction),
// the ghost-frame clamps at the ends, the segments' total torques, node forces (gravity and the
// segments on both sides) and the loads on those nodes and segments. Each frame's rotation matrix
// is rebuilt from its quaternion where needed (cheaper than storing it).
void Rod::forces_block(int b0, int b1, double t, const Vec3& gravity) {
  const int n = num_segments();
  const BlockRange r = block_range(b0, b1, n);
  const double* q = q_.data()->coeffs().data();
  const double kb = section_.bend, kt = section_.twist;
  // The scratch holds one block: item g of the rod (segment, element or slot, see rod.h) is at
  // g - off.
  const int off = b0 - 1;
  double *fs = fs_.data(), *ww = ww_.data(), *tc = tc_.data();
  double *ta = ta_.data(), *tb = tb_.data(), *tw = tw_.data();
  if (b0 == 0) {
    std::fill(fs, fs + 6, 0.0);  // nothing before segment 0 and element 0
    std::fill(tw, tw + 6, 0.0);
  } else {
    // The previous block had kStepBlock segments, so the items of its last segment and element,
    // which this block still reads, are kStepBlock further along: move them to the front.
    const int k = kStepBlock;
    std::copy(ww + 3 * k, ww + 3 * k + 3, ww);
    std::copy(tc + 2 * k, tc + 2 * k + 2, tc);
    std::copy(tb + 3 * k, tb + 3 * k + 3, tb);
    std::copy(tw + 3 * k, tw + 3 * k + 3, tw);
    std::copy(fs + 3 * k + 3, fs + 3 * k + 6, fs + 3);
  }
  if (b1 == n) {
    std::fill(tw + 3 * (n - off), tw + 3 * (n - off) + 3, 0.0);  // nothing after the last
    std::fill(fs + 3 * (n + 1 - off), fs + 3 * (n + 1 - off) + 3, 0.0);
  }
  segment_pass(b0, b1, off, x_.data()->data(), v_.data()->data(), q, w_.data()->data(),
               inv_rest_.data(), gamma_t_inv_rest_.data(), kappa_rest_.data(), section_.stretch, fs,
               ww, tc);
  element_pass(r.elem0, r.elem1, off, q, n > 1 ? uhat_.data()->data() : nullptr, rest_elem_.data(),
               inv_rest_elem_.data(), gamma_r_inv_rest_elem_.data(), kb, kt, ww, ta, tb, tw);
  // The ends: ghost-frame clamps or nothing. The end frames are not integrated before this.
  double unused[3];
  if (b0 == 0) {
    if (ghost_[0].active) {
      double* t0 = tb - 3 * off;
      bend_element(ghost_[0].frame.coeffs().data(), q, 0.5 * rest_[0], 2.0 / rest_[0], kb, kt,
                   ghost_[0].uhat.data(), unused, t0);
      ghost_[0].reaction = q_[0] * Vec3(t0[0], t0[1], t0[2]);
    } else
      std::fill(tb - 3 * off, tb - 3 * off + 3, 0.0);
  }
  if (b1 == n) {
    double* ta_end = ta + 3 * (n - 1 - off);
    if (ghost_[1].active) {
      bend_element(q + 4 * (n - 1), ghost_[1].frame.coeffs().data(), 0.5 * rest_[n - 1],
                   2.0 / rest_[n - 1], kb, kt, ghost_[1].uhat.data(), ta_end, unused);
      ghost_[1].reaction = q_[n - 1] * Vec3(ta_end[0], ta_end[1], ta_end[2]);
    } else
      std::fill(ta_end, ta_end + 3, 0.0);
  }
  torque_pass(r.seg0, r.seg1, off, q, tc, ta, tb, tw, tau_.data()->data());
  node_force_pass(r.node0, r.node1, off, fs, mass_.data(), gravity.x(), gravity.y(), gravity.z(),
                  f_.data()->data());
  for (const Load& l : loads_) {
    const bool force = l.kind == Load::Kind::kForce;
    if (force ? (l.index < r.node0 || l.index >= r.node1) : (l.index < r.seg0 || l.index >= r.seg1))
      continue;
    const double scale = l.scale(t);
    if (scale == 0.0) continue;
    if (force)
      f_[l.index] += load_world(l, scale, q_);
    else
      tau_[l.index] += load_body_torque(l, scale, q_[l.index]);
  }
  for (const MassOffset& m : mass_offsets_)
    if (m.segment >= r.seg0 && m.segment < r.seg1)
      tau_[m.segment] += m.body_torque(q_[m.segment], gravity);
  if (drag_.active()) drag_block(r.node0, r.node1);
  if (has_external_) {
    for (int i = r.node0; i < r.node1; ++i) f_[i] += ext_f_[i];
    for (int s = r.seg0; s < r.seg1; ++s) tau_[s] += q_[s].conjugate() * ext_tau_[s];
  }
}

// Semi-implicit Euler of the nodes, and the segments' rotations by the integrator, for the items
// completed by segments [b0, b1) (block_range).
void Rod::integrate_block(int b0, int b1, double h, Integrator integrator) {
  const BlockRange r = block_range(b0, b1, num_segments());
  node_integrate_pass(r.node0, r.node1, h, f_.data()->data(), inv_mass_.data(), node_free_.data(),
                      x_.data()->data(), v_.data()->data());
  if (integrator == Integrator::kSplitRotation)
    segment_split_rotation_pass(r.seg0, r.seg1, h, tau_.data()->data(), inertia_.data()->data(),
                                inv_inertia_.data(), seg_free_.data(), w_.data()->data(),
                                q_.data()->coeffs().data());
  else
    segment_integrate_pass(r.seg0, r.seg1, h, tau_.data()->data(), inertia_.data()->data(),
                           inv_inertia_.data(), seg_free_.data(), w_.data()->data(),
                           q_.data()->coeffs().data());
}

void Rod::compute_forces(double t, const Vec3& gravity) {
  const int n = num_segments();
  for (int b0 = 0; b0 < n; b0 += kStepBlock)
    forces_block(b0, std::min(b0 + kStepBlock, n), t, gravity);
}

const char* integrator_name(Integrator integrator) {
  switch (integrator) {
    case Integrator::kSemiImplicitEuler:
      return "semi_implicit_euler";
    case Integrator::kSplitRotation:
      return "split_rotation";
    case Integrator::kImplicitEuler:
      return "implicit_euler";
    case Integrator::kBdf2:
      return "bdf2";
  }
  return "unknown";
}

bool parse_integrator(const std::string& name, Integrator* integrator) {
  for (Integrator i : kIntegrators)
    if (name == integrator_name(i)) {
      *integrator = i;
      return true;
    }
  return false;
}

namespace {
void require_explicit(const std::string& rod, Integrator integrator) {
  if (is_implicit(integrator))
    throw std::invalid_argument(
        "rod '" + rod + "': the implicit integrator runs through World::step, not Rod::step");
}
}  // namespace

void Rod::step(double t, double h, const Vec3& gravity, Integrator integrator) {
  require_explicit(name_, integrator);
  const int n = num_segments();
  for (int b0 = 0; b0 < n; b0 += kStepBlock) {
    const int b1 = std::min(b0 + kStepBlock, n);
    forces_block(b0, b1, t, gravity);
    integrate_block(b0, b1, h, integrator);
  }
  apply_drives(t + h, h);
}

void Rod::integrate(double t, double h, Integrator integrator) {
  require_explicit(name_, integrator);
  const int n = num_segments();
  for (int b0 = 0; b0 < n; b0 += kStepBlock)
    integrate_block(b0, std::min(b0 + kStepBlock, n), h, integrator);
  apply_drives(t + h, h);
}

void Rod::record_ghost_reactions() {
  const int n = num_segments();
  const double kb = section_.bend, kt = section_.twist;
  double ta[3], tb[3];
  if (ghost_[0].active) {
    bend_element(ghost_[0].frame.coeffs().data(), q_[0].coeffs().data(), 0.5 * rest_[0],
                 2.0 / rest_[0], kb, kt, ghost_[0].uhat.data(), ta, tb);
    ghost_[0].reaction = q_[0] * Vec3(tb[0], tb[1], tb[2]);
  }
  if (ghost_[1].active) {
    bend_element(q_[n - 1].coeffs().data(), ghost_[1].frame.coeffs().data(), 0.5 * rest_[n - 1],
                 2.0 / rest_[n - 1], kb, kt, ghost_[1].uhat.data(), ta, tb);
    ghost_[1].reaction = q_[n - 1] * Vec3(ta[0], ta[1], ta[2]);
  }
}

// Sets the kinematic items to their drives' state at the step's end and projects the
// constrained ones; each records the force or torque it took (a reaction, what a load cell in the
// support reads with the opposite sign): m dv/dt - f for a node, I dw/dt + w x I w - tau for a
// segment, from the velocities before and after (the integrator left kinematic ones unchanged).
void Rod::apply_drives(double t_end, double h) {
  for (NodeDrive& d : node_drives_) {
    Vec3& x = x_[d.node];
    Vec3& v = v_[d.node];
    const Vec3 v_old = v;
    const DrivenNode s = drive_state(d, t_end, h, x);
    x = s.position;
    v = s.velocity;
    d.reaction = mass_[d.node] * (v - v_old) / h - f_[d.node];
  }
  for (SegmentDrive& d : segment_drives_) {
    Quat& q = q_[d.segment];
    Vec3& w = w_[d.segment];
    const Vec3 w_old = w;
    const Quat q_old = q;
    const DrivenSegment s = drive_state(d, t_end, h, q);
    q = s.orientation;
    w = s.angular_velocity;
    const Vec3& in = inertia_[d.segment];
    const Vec3 body =
        in.cwiseProduct(w - w_old) / h + w_old.cross(in.cwiseProduct(w_old)) - tau_[d.segment];
    d.reaction = q_old * body;
  }
  for (NodeConstraint& c : node_constraints_) {
    Vec3& x = x_[c.node];
    Vec3& v = v_[c.node];
    const Vec3& a = c.direction;
    const Vec3 v_free = v;
    if (c.kind == NodeConstraint::Kind::kLine) {
      x = c.point + a * a.dot(x - c.point);
      v = a * a.dot(v);
      if (!c.velocity.isZero(0.0)) v += c.velocity - a * a.dot(c.velocity);  // moves across
    } else {
      x -= a * a.dot(x - c.point);
      v -= a * a.dot(v);
      if (!c.velocity.isZero(0.0)) v += a * a.dot(c.velocity);
    }
    c.reaction = mass_[c.node] * (v - v_free) / h;
  }
  for (SegmentConstraint& c : segment_constraints_) {
    Quat& q = q_[c.segment];
    Vec3& w = w_[c.segment];
    // Keep the twist part of q origin^-1 about the axis (swing-twist decomposition).
    const Quat rel = q * c.origin.conjugate();
    const double along = rel.vec().dot(c.axis);
    Quat twist(rel.w(), along * c.axis.x(), along * c.axis.y(), along * c.axis.z());
    if (twist.norm() < 1e-12) twist = Quat::Identity();  // a half turn about a normal: ambiguous
    twist.normalize();
    const Vec3 w_free = w;
    const Quat q_free = q;
    q = (twist * c.origin).normalized();
    w = q.conjugate() * (c.axis * c.axis.dot(q_free * w_free));
    const Vec3& in = inertia_[c.segment];
    c.reaction = (q * in.cwiseProduct(w) - q_free * in.cwiseProduct(w_free)) / h;
  }
  for (GhostFrame& g : ghost_)
    if (g.active && g.motion) g.frame = ghost_frame_at(g, t_end);
}

void Rod::set_static_reactions(double t, const Vec3& gravity) {
  compute_forces(t, gravity);  // also records the ghost frames' torques
  for (NodeDrive& d : node_drives_) d.reaction = -f_[d.node];
  for (SegmentDrive& d : segment_drives_) d.reaction = -(q_[d.segment] * tau_[d.segment]);
  for (NodeConstraint& c : node_constraints_) {
    const Vec3& a = c.direction;
    const Vec3 f = -f_[c.node];
    c.reaction =
        c.kind == NodeConstraint::Kind::kLine ? Vec3(f - a * a.dot(f)) : Vec3(a * a.dot(f));
  }
  for (SegmentConstraint& c : segment_constraints_) {
    const Vec3 tau = -(q_[c.segment] * tau_[c.segment]);
    c.reaction = tau - c.axis * c.axis.dot(tau);
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
  for (const MassOffset& m : mass_offsets_) e.gravity += m.potential(q_[m.segment], gravity);
  for (int s = 0; s < n; ++s) {
    const Vec3 dr = x_[s + 1] - x_[s];
    e.kinetic_rotation += 0.5 * w_[s].dot(inertia_[s].cwiseProduct(w_[s]));
    e.stretch += stretch_energy(dr, rest_[s], section_.stretch, nullptr);
    e.coupling += coupling_energy(dr, q_[s], rest_[s], section_.kappa, nullptr, nullptr);
  }
  for (int j = 0; j + 1 < n; ++j)
    e.bend_twist +=
        bend_twist_energy(q_[j], q_[j + 1], rest_elem_[j], k, uhat_[j], nullptr, nullptr);
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
  for (const MassOffset& mo : mass_offsets_) c += mo.mass * (q_[mo.segment] * mo.offset);
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

double Rod::max_stretch_strain(int* segment) const {
  double best = -INFINITY;
  int at = 0;
  for (int s = 0; s < num_segments(); ++s) {
    const double e = stretch_strain(s);
    if (e > best) {
      best = e;
      at = s;
    }
  }
  if (segment) *segment = at;
  return best;
}

double Rod::length() const {
  double l = 0.0;
  for (size_t s = 0; s < q_.size(); ++s) l += (x_[s + 1] - x_[s]).norm();
  return l;
}

}  // namespace corde
