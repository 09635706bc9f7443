// The discrete CoRdE rod: state, parameters, boundary conditions, forces and one time step.
#pragma once

#include <string>
#include <vector>

#include "corde_sim/contact/contact.h"
#include "corde_sim/model/element_energies.h"
#include "corde_sim/rod/boundary.h"
#include "corde_sim/rod/material.h"

namespace corde {

// How a step advances the segments' rotations (the nodes always take semi-implicit Euler).
// kSemiImplicitEuler: the paper's eqs. 37-42, w += h I^-1 (tau - w x I w) with the explicit
// gyroscopic term, then q += (h/2) q (x) (0, w) renormalised. The explicit gyroscopic term gives
// a free spinning segment energy every step (|w_perp|^2 grows by 1 + (h Omega)^2).
// kSplitRotation: a kick by the torques alone, w += h I^-1 tau, then the torque-free rotation of
// the axisymmetric segment over h in Cayley form (docs/model.md, "Time integration"): it keeps a
// free segment's kinetic energy and world angular momentum to round-off and the step symplectic.
// kImplicitEuler: backward Euler of nodes and rotations together (integrators/implicit_step.h),
// stable at steps far beyond the explicit limit; run by World::step (a Rod alone steps explicitly
// only). kBdf2: the second-order backward differentiation formula on the same Newton solve
// (integrators/implicit_step.h), stable at the same steps and far less damping; its first step (and
// any after a change of h or of the state from outside) is a backward Euler step.
enum class Integrator { kSemiImplicitEuler, kSplitRotation, kImplicitEuler, kBdf2 };
constexpr Integrator kDefaultIntegrator = Integrator::kSplitRotation;
// The implicit methods (World::step's Newton solve): implicit_euler and bdf2.
constexpr bool is_implicit(Integrator i) {
  return i == Integrator::kImplicitEuler || i == Integrator::kBdf2;
}
// Scene and parameter names: "semi_implicit_euler", "split_rotation", "implicit_euler", "bdf2".
const char* integrator_name(Integrator integrator);
// False for an unknown name (integrator left unchanged).
bool parse_integrator(const std::string& name, Integrator* integrator);

struct Energies {
  double stretch = 0.0, bend_twist = 0.0, coupling = 0.0;  // elastic (J)
  double kinetic_translation = 0.0, kinetic_rotation = 0.0;
  double gravity = 0.0;  // potential of gravity, zero at the world origin
  double elastic() const { return stretch + bend_twist + coupling; }
  double kinetic() const { return kinetic_translation + kinetic_rotation; }
};

class Rod {
 public:
  // Nodes x (N+1), one orientation per segment (N). Rest lengths are the initial segment
  // lengths; rest strains are zero (a straight rest shape) until set_rest_strains_from_state().
  Rod(std::string name, std::vector<Vec3> nodes, std::vector<Quat> frames, const Section& section);

  const std::string& name() const { return name_; }
  int num_nodes() const { return static_cast<int>(x_.size()); }
  int num_segments() const { return static_cast<int>(q_.size()); }
  const Section& section() const { return section_; }

  // State. Orientations are unit quaternions; omega is the body-frame angular velocity.
  std::vector<Vec3>& positions() { return x_; }
  const std::vector<Vec3>& positions() const { return x_; }
  std::vector<Vec3>& velocities() { return v_; }
  const std::vector<Vec3>& velocities() const { return v_; }
  std::vector<Quat>& orientations() { return q_; }
  const std::vector<Quat>& orientations() const { return q_; }
  std::vector<Vec3>& angular_velocities() { return w_; }
  const std::vector<Vec3>& angular_velocities() const { return w_; }

  // Parameters.
  const std::vector<double>& rest_lengths() const { return rest_; }
  const std::vector<double>& node_masses() const { return mass_; }
  Vec3 segment_inertia(int s) const { return inertia_[s]; }  // body diagonal (kg m^2)
  // Rest strains of the N-1 interior orientation elements (intrinsic bending and twist).
  std::vector<Vec3>& rest_strains() { return uhat_; }
  const std::vector<Vec3>& rest_strains() const { return uhat_; }
  void set_rest_strains_from_state();
  // Changes the section (material or radius); masses and inertia follow.
  void set_section(const Section& section);
  // Rest lengths, recomputing masses and inertia.
  void set_rest_lengths(const std::vector<double>& rest);
  // Rotary-inertia scaling (docs/model.md, "Rotary-inertia scaling"): the segments' inertia about
  // d1 and d2 (the tilt of the cross-section, the rotary inertia of bending) is `scale` times
  // the physical rho I l; the twist inertia about d3 stays physical. 1 = physical (default). It
  // leaves every equilibrium unchanged and lifts the explicit step's coupling-penalty limit by
  // sqrt(scale); a bending mode of wavenumber k shifts by -(scale - 1) (I/A) k^2 / 2 (relative,
  // to first order). Throws std::invalid_argument unless 1 <= scale < infinity.
  void set_rotational_inertia_scale(double scale);
  double rotational_inertia_scale() const { return inertia_scale_; }

  // What a real cable carries besides its section (docs/scene_format.md, "Cable bodies"): every
  // part of the model reads masses and inertia through node_masses() and segment_inertia(), so
  // these reach the steps, the explicit step limit, energies, momentum, gravity and statics.
  // A point mass (kg, > 0) added to a node's lumped mass: a clip, a connector. Adds up.
  void add_node_mass(int node, double mass);
  // A rotary inertia (kg m^2, body frame: about d1, d2, d3) added to a segment's: a rigid body
  // fixed to it (a plug on an end segment). d1 and d2 must be equal (the segments are
  // axisymmetric: the split rotation turns them in closed form). Adds up.
  void add_segment_inertia(int segment, const Vec3& inertia);
  // Per-segment factors on the section's mass per length and rotary inertia per length (a cable
  // that is not uniform: a heavier stretch, a ferrite bead), one per segment, each finite and
  // > 0; empty: uniform (the default).
  void set_segment_mass_scale(const std::vector<double>& scale);
  const std::vector<double>& segment_mass_scale() const { return mass_scale_; }
  // A rigid end body's centre of mass off its end node: `mass` (kg, > 0, also added to the node
  // with add_node_mass) sits at x_node + R_s offset, offset (m) in the end segment s's material
  // frame; node is 0 (s = 0) or N (s = N - 1). Its weight then also turns the segment: energy
  // -mass g.(R_s offset), body torque mass offset x (R_s^T g), in energies, forces, RodSystem and
  // statics. Inertia stays block-diagonal: add the parallel-axis term to the segment with
  // add_segment_inertia (docs/scene_format.md, "Cable bodies"). Adds up.
  struct MassOffset {
    int node = 0, segment = 0;
    double mass = 0.0;
    Vec3 offset = Vec3::Zero();
    // Its weight under gravity g with the segment at orientation q: the potential -m g.(R d)
    // and the body torque m d x (R^T g).
    double potential(const Quat& q, const Vec3& g) const { return -mass * g.dot(q * offset); }
    Vec3 body_torque(const Quat& q, const Vec3& g) const {
      return mass * offset.cross(q.conjugate() * g);
    }
  };
  void add_mass_offset(int node, double mass, const Vec3& offset);
  const std::vector<MassOffset>& mass_offsets() const { return mass_offsets_; }
  // The offsets' body torque on segment s under gravity g (zero without offsets there).
  Vec3 mass_offset_torque(int segment, const Vec3& gravity) const;
  // The added point masses per node and inertias per segment (empty: none).
  const std::vector<double>& added_node_masses() const { return added_mass_; }
  const std::vector<Vec3>& added_segment_inertias() const { return added_inertia_; }
  // Each node's share of the uniform section's mass (half of each adjacent segment's rest length
  // times the section's mass per length), without point masses or mass scales: the length of rod
  // a node stands for in the air drag is this over the section's mass per length (model/drag.h).
  const std::vector<double>& node_section_masses() const { return section_mass_; }

  // Boundary conditions and loads. Adding a drive makes the node or segment kinematic.
  void add_node_drive(const NodeDrive& d);
  void add_segment_drive(const SegmentDrive& d);
  bool remove_node_drive(int node);
  bool remove_segment_drive(int segment);
  NodeDrive* node_drive(int node);
  SegmentDrive* segment_drive(int segment);
  const NodeDrive* node_drive(int node) const { return const_cast<Rod*>(this)->node_drive(node); }
  const SegmentDrive* segment_drive(int segment) const {
    return const_cast<Rod*>(this)->segment_drive(segment);
  }
  const std::vector<NodeDrive>& node_drives() const { return node_drives_; }
  const std::vector<SegmentDrive>& segment_drives() const { return segment_drives_; }
  // Sliding and hinge constraints (boundary.h); one per node or segment, replacing an earlier
  // one. They may not share a node or segment with a drive (std::invalid_argument), and
  // directions are normalised. Throw std::out_of_range for items the rod does not have.
  void add_node_constraint(const NodeConstraint& c);
  void add_segment_constraint(const SegmentConstraint& c);
  // Removes node `node`'s constraint (false: it had none); keeps the capacity (no allocation).
  bool remove_node_constraint(int node);
  // Removes segment `segment`'s constraint (false: it had none); keeps the capacity.
  bool remove_segment_constraint(int segment);
  const std::vector<NodeConstraint>& node_constraints() const { return node_constraints_; }
  const std::vector<SegmentConstraint>& segment_constraints() const { return segment_constraints_; }
  // Throws std::out_of_range for a node or segment the rod does not have.
  void add_load(const Load& l);
  std::vector<Load>& loads() { return loads_; }
  const std::vector<Load>& loads() const { return loads_; }
  // External forces on nodes and torques on segments (world frame) that inputs set and change
  // while the rod runs (a wrench on a grasp, contacts): added to the forces each step. They cost
  // nothing until the first one is set.
  void add_external_force(int node, const Vec3& f);
  void add_external_torque(int segment, const Vec3& torque);
  void clear_external();  // all back to zero (and no cost in the step)
  bool has_external() const { return has_external_; }
  const std::vector<Vec3>& external_forces() const { return ext_f_; }
  const std::vector<Vec3>& external_torques() const { return ext_tau_; }
  // Air drag on the nodes (none by default; model/drag.h). Throws std::invalid_argument for a
  // negative or non-finite coefficient.
  void set_drag(const Drag& drag);
  const Drag& drag() const { return drag_; }
  // Ghost-frame clamps at the start (before segment 0) and end (after the last segment).
  GhostFrame& ghost_start() { return ghost_[0]; }
  GhostFrame& ghost_end() { return ghost_[1]; }
  const GhostFrame& ghost_start() const { return ghost_[0]; }
  const GhostFrame& ghost_end() const { return ghost_[1]; }

  // Forces and body torques at time t (internal, damping, gravity, loads) into forces()/torques().
  void compute_forces(double t, const Vec3& gravity);
  const std::vector<Vec3>& forces() const { return f_; }
  const std::vector<Vec3>& torques() const { return tau_; }

  // The second half of step(), for a caller that computed the forces (compute_forces at t) and
  // added to them (contacts, add_contact_force): integrates from t to t + h and applies the drives.
  void integrate(double t, double h, Integrator integrator = kDefaultIntegrator);
  // Adds to the node forces of the current step (between compute_forces and integrate).
  void add_step_force(int node, const Vec3& f) { f_[node] += f; }
  // Adds a world torque to a segment's torque of the current step (contact friction's moment).
  void add_step_torque(int segment, const Vec3& torque) {
    tau_[segment] += q_[segment].conjugate() * torque;
  }
  // Which contacts the rod takes part in (contact.h).
  ContactOptions& contact_options() { return contact_; }
  const ContactOptions& contact_options() const { return contact_; }
  // One step from t to t + h: semi-implicit Euler of the nodes (eqs. 37-38) and the segments'
  // rotations by the chosen integrator. Allocates nothing. Each drive, constraint and ghost frame
  // records the reaction it exerted over the step (boundary.h).
  void step(double t, double h, const Vec3& gravity, Integrator integrator = kDefaultIntegrator);
  // The reactions of an equilibrium (after solve_statics): at rest, each support takes what the
  // rest of the rod, gravity and the loads exert on its items at time t: -f, -tau, and for
  // constraints the part of -f across the line or plane (about the axis only the rest is held).
  void set_static_reactions(double t, const Vec3& gravity);

  Energies energies(const Vec3& gravity) const;
  Vec3 center_of_mass() const;
  Vec3 linear_momentum() const;
  Vec3 angular_momentum() const;  // about the origin, including the segments' spin
  bool finite() const;
  double length() const;  // current centreline length
  // Axial strain |x_{s+1} - x_s| / l_s - 1 of segment s, and the axial force K_s times it (N).
  double stretch_strain(int s) const { return (x_[s + 1] - x_[s]).norm() / rest_[s] - 1.0; }
  double tension(int s) const { return section_.stretch * stretch_strain(s); }
  // Largest stretch_strain over the segments, and the segment where it is.
  double max_stretch_strain(int* segment = nullptr) const;

 private:
  friend class ImplicitEuler;  // records the supports' reactions of its steps
  void update_mass_and_inertia();
  // The step's passes (rod.cpp), over blocks of segments [b0, b1): forces and torques at t into
  // f_, tau_; the integrator.
  void forces_block(int b0, int b1, double t, const Vec3& gravity);
  void integrate_block(int b0, int b1, double h, Integrator integrator);
  void apply_drives(double t_end, double h);
  // The ghost elements' torques on the end segments at the current state into
  // GhostFrame::reaction, as forces_block records them (the implicit step's, at its end).
  void record_ghost_reactions();
  void drag_block(int node0, int node1);

  std::string name_;
  Section section_;
  std::vector<Vec3> x_, v_, f_;
  std::vector<Quat> q_;
  std::vector<Vec3> w_, tau_;
  std::vector<double> rest_, rest_elem_, mass_, inv_mass_, section_mass_;
  std::vector<Vec3> inertia_, uhat_;
  double inertia_scale_ = 1.0;  // set_rotational_inertia_scale
  // add_node_mass, add_segment_inertia, set_segment_mass_scale: empty until set.
  std::vector<double> added_mass_, mass_scale_;
  std::vector<Vec3> added_inertia_;
  std::vector<MassOffset> mass_offsets_;  // add_mass_offset

  // Constants precomputed from the rest lengths and the section (the step divides by nothing of
  // them), one array each so that the step's loops read unit-stride streams and vectorise.
  // Segment s: 1/l_s, gamma_t/l_s, kappa l_s; element j (segments j, j + 1): l_j, 1/l_j,
  // gamma_r/l_j; the inverse body inertia (3 per segment).
  std::vector<double> inv_rest_, gamma_t_inv_rest_, kappa_rest_;
  std::vector<double> inv_rest_elem_, gamma_r_inv_rest_elem_, inv_inertia_;
  // 1 for integrated nodes and segments, 0 for kinematic ones: the integrator multiplies its
  // increments by them instead of branching, which keeps its loops vectorisable.
  std::vector<double> node_free_, seg_free_;
  // Per-step scratch for one block of segments (the step allocates nothing), indexed as for the
  // whole rod less an offset per block (Rod::forces_block). Arrays indexed with a shift of one
  // have a zero (or the ghost frame's term) in front, so the end elements need no special case:
  // fs_[s + 1] stretch/coupling force of segment s; ww_ world angular velocities; tc_ coupling
  // body torques (2 per segment, the third is 0); ta_[s], tb_[s] bending torques on segment s from
  // the element after and before it; tw_[s + 1] world friction torque of element s.
  std::vector<double> fs_, ww_, tc_, ta_, tb_, tw_;
  std::vector<NodeDrive> node_drives_;
  std::vector<SegmentDrive> segment_drives_;
  std::vector<NodeConstraint> node_constraints_;
  std::vector<SegmentConstraint> segment_constraints_;
  std::vector<Load> loads_;
  std::vector<Vec3> ext_f_, ext_tau_;  // empty until the first external force or torque
  bool has_external_ = false;
  Drag drag_;
  ContactOptions contact_;
  GhostFrame ghost_[2];
};

}  // namespace corde
