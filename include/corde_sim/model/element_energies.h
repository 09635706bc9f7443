// Per-element energies of the discrete CoRdE rod with their exact gradients.
//
// Quaternions follow docs/model.md ("Quaternions and directors"): coeffs() = (q1, q2, q3, q4) with
// q4 the scalar part, and the directors are the columns of toRotationMatrix(). Gradients with
// respect to a quaternion are 4-vectors in coeffs() order; body_torque() turns them into body-frame
// torques.
#pragma once

#include "corde_sim/math/types.h"

namespace corde {

// Product of a quaternion with the pure quaternion (v, 0): q (x) (0, v) without a general product.
inline Quat mul_pure(const Quat& q, const Vec3& v) {
  return Quat(
      -q.x() * v.x() - q.y() * v.y() - q.z() * v.z(), q.w() * v.x() + q.y() * v.z() - q.z() * v.y(),
      q.w() * v.y() + q.z() * v.x() - q.x() * v.z(), q.w() * v.z() + q.x() * v.y() - q.y() * v.x());
}

// Vector part of conj(a) (x) b: the B_k products of eq. (6), u_k = (2/l) (B_k a) . b.
inline Vec3 rel_vec(const Quat& a, const Quat& b) {
  return Vec3(a.w() * b.x() - a.x() * b.w() - a.y() * b.z() + a.z() * b.y(),
              a.w() * b.y() - a.y() * b.w() - a.z() * b.x() + a.x() * b.z(),
              a.w() * b.z() - a.z() * b.w() - a.x() * b.y() + a.y() * b.x());
}

// Body-frame torque equivalent to an energy gradient g = dE/dq (eq. 39): a body rotation dtheta
// moves q by (1/2) q (x) (0, dtheta), so the torque is -(1/2) vec(conj(q) (x) g).
inline Vec3 body_torque(const Quat& q, const Vec4& g) {
  return -0.5 * rel_vec(q, Quat(g(3), g(0), g(1), g(2)));
}

// Third director d3 = R(q) e_z, valid for unit q; the polynomial form extends it off the sphere.
inline Vec3 director3(const Quat& q) {
  return Vec3(2.0 * (q.x() * q.z() + q.y() * q.w()), 2.0 * (q.y() * q.z() - q.x() * q.w()),
              q.w() * q.w() - q.x() * q.x() - q.y() * q.y() + q.z() * q.z());
}

// Stretch, eq. (24): V = (1/2) l K_s (|dr|/l - 1)^2 with dr = r_{i+1} - r_i.
// grad_dr = dV/d(dr); the force on r_{i+1} is -grad_dr and on r_i is +grad_dr.
inline double stretch_energy(const Vec3& dr, double rest, double ks, Vec3* grad_dr) {
  const double len = dr.norm();
  const double strain = len / rest - 1.0;
  if (grad_dr) *grad_dr = (ks * strain / len) * dr;
  return 0.5 * rest * ks * strain * strain;
}

// Coupling penalty, eq. (33): E = (l kappa / 2) |dr/|dr| - d3(q)|^2.
inline double coupling_energy(const Vec3& dr, const Quat& q, double rest, double kappa,
                              Vec3* grad_dr, Vec4* grad_q) {
  const double len = dr.norm();
  const Vec3 t = dr / len;
  const Vec3 d3 = director3(q);
  const Vec3 diff = t - d3;
  const double c = rest * kappa;
  if (grad_dr) *grad_dr = (c / len) * (diff - t * t.dot(diff));
  if (grad_q) {
    // -c diff^T d(d3)/dq, rows of the Jacobian in (q1, q2, q3, q4) order.
    const double x = q.x(), y = q.y(), z = q.z(), w = q.w();
    const Vec3 a = -2.0 * c * diff;
    *grad_q = Vec4(a.x() * z - a.y() * w - a.z() * x, a.x() * w + a.y() * z - a.z() * y,
                   a.x() * x + a.y() * y + a.z() * z, a.x() * y - a.y() * x + a.z() * w);
  }
  return 0.5 * c * diff.squaredNorm();
}

// Body torque of the coupling penalty, the same as body_torque(q, grad_q) for unit q, cheaper:
// the world torque is l kappa d3 x t, whose body components are l kappa (e_z x R^T t).
inline Vec3 coupling_torque(const Vec3& t_body, double rest, double kappa) {
  const double c = rest * kappa;
  return Vec3(-c * t_body.y(), c * t_body.x(), 0.0);
}

// Material strains (bending u1, u2 and twist u3) of the orientation element joining segments
// with orientations a and b, eq. (25) simplified with skew B_k: u = (2/l) vec(conj(a) (x) b),
// taken with the sign of a.b so that q and -q give the same strain.
inline Vec3 darboux(const Quat& a, const Quat& b, double rest) {
  const double s = a.coeffs().dot(b.coeffs()) < 0.0 ? -2.0 : 2.0;
  return (s / rest) * rel_vec(a, b);
}

// Bending and twist, eq. (25): V = (l/2) sum_k K_kk (u_k - uhat_k)^2, stiffness (B, B, C).
inline double bend_twist_energy(const Quat& a, const Quat& b, double rest, const Vec3& k,
                                const Vec3& uhat, Vec4* grad_a, Vec4* grad_b) {
  const double s = a.coeffs().dot(b.coeffs()) < 0.0 ? -2.0 : 2.0;
  const Vec3 u = (s / rest) * rel_vec(a, b);
  const Vec3 du = u - uhat;
  const Vec3 e = rest * k.cwiseProduct(du);  // dV/du
  // du_k/db = (s/l) a (x) e_k and du_k/da = -(s/l) b (x) e_k (B_k q = q (x) e_k).
  if (grad_b) *grad_b = (s / rest) * mul_pure(a, e).coeffs();
  if (grad_a) *grad_a = -(s / rest) * mul_pure(b, e).coeffs();
  return 0.5 * rest * du.dot(k.cwiseProduct(du));
}

// World-frame angular velocity of a segment from its body angular velocity.
inline Vec3 world_omega(const Quat& q, const Vec3& omega_body) { return q * omega_body; }

}  // namespace corde
