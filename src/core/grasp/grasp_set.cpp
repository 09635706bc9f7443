#include "corde_sim/grasp/grasp_set.h"

#include <algorithm>
#include <cmath>

namespace corde {
namespace {

// Rest arc length of a segment's midpoint (its material coordinate).
double midpoint_arc_length(const Rod& rod, int segment) {
  double s = 0.0;
  for (int i = 0; i < segment; ++i) s += rod.rest_lengths()[i];
  return s + 0.5 * rod.rest_lengths()[segment];
}

// Where node k (0, 1) of the grasp's segment is held with the holder at `holder` (as hold()).
Vec3 held_node(const Rod& rod, const Grasp& grasp, const Eigen::Isometry3d& holder, int k) {
  const Eigen::Isometry3d pose = holder * grasp.offset;
  const double half = 0.5 * rod.rest_lengths()[grasp.segment];
  return pose.translation() + (k == 0 ? -half : half) * pose.linear().col(2);
}

struct Overstretch {
  double strain = 0.0;
  int anchor = -1;        // -1: within the limit
  double distance = 0.0;  // from the anchor to the held node, the holder at `from`
};

// The holder moving from `from` to `to` over the step ending at t_end: on each side of the held
// segment, the nearest held node (a node drive, where it is at t_end). A side whose distance from
// the held node grows is overstretched when that distance over the rest arc length between them,
// or the strain of a segment in between, exceeds `limit`.
Overstretch overstretch(const Rod& rod, const Grasp& grasp, const Eigen::Isometry3d& from,
                        const Eigen::Isometry3d& to, double t_end, double limit) {
  const int s = grasp.segment;
  const NodeDrive* anchors[2] = {nullptr, nullptr};  // below s, above s + 1
  for (const NodeDrive& d : rod.node_drives()) {
    if (d.node < s && (!anchors[0] || d.node > anchors[0]->node)) anchors[0] = &d;
    if (d.node > s + 1 && (!anchors[1] || d.node < anchors[1]->node)) anchors[1] = &d;
  }
  Overstretch out;
  for (int k = 0; k < 2; ++k) {
    if (!anchors[k]) continue;
    const Vec3 anchor = drive_position(*anchors[k], t_end);
    const double before = (held_node(rod, grasp, from, k) - anchor).norm();
    const double after = (held_node(rod, grasp, to, k) - anchor).norm();
    if (!(after > before)) continue;
    const int first = k == 0 ? anchors[k]->node : s + 1;
    const int last = k == 0 ? s : anchors[k]->node;  // segments [first, last)
    double arc = 0.0, strain = -INFINITY;
    for (int i = first; i < last; ++i) {
      arc += rod.rest_lengths()[i];
      strain = std::max(strain, rod.stretch_strain(i));
    }
    strain = std::max(strain, after / arc - 1.0);
    if (strain > limit && strain > out.strain) {
      out.strain = strain;
      out.anchor = anchors[k]->node;
      out.distance = before;
    }
  }
  return out;
}

}  // namespace

Eigen::Isometry3d GraspState::holder_pose() const {
  if (twist_angle == 0.0) return holder.pose();
  const Eigen::Isometry3d spin(Eigen::AngleAxisd(twist_angle, Vec3::UnitZ()));
  return holder.pose() * grasp.offset * spin * grasp.offset.inverse();
}

std::string GraspSet::check(const World& world, const GraspSpec& spec, int* rod_index,
                            int* segment) const {
  int ri = -1;
  for (size_t i = 0; i < world.rods().size(); ++i)
    if (world.rods()[i].name() == spec.rod) ri = static_cast<int>(i);
  if (ri < 0) return "no rod named '" + spec.rod + "'";
  const Rod& rod = world.rods()[ri];
  int seg;
  try {
    seg = grasp_segment(rod, spec);
  } catch (const std::exception& e) {
    return e.what();
  }
  // Drives other than the grasps' own (kTarget) are boundary conditions: a grasp would replace
  // them, and its release would free a clamped node.
  for (int node : {seg, seg + 1}) {
    const NodeDrive* d = rod.node_drive(node);
    if (d && d->kind != NodeDrive::Kind::kTarget)
      return "node " + std::to_string(node) + " of segment " + std::to_string(seg) + " of rod '" +
             spec.rod + "' has a boundary condition";
  }
  for (const NodeConstraint& c : rod.node_constraints())
    if (c.node == seg || c.node == seg + 1)
      return "node " + std::to_string(c.node) + " of segment " + std::to_string(seg) + " of rod '" +
             spec.rod + "' slides on a line or plane (a boundary condition)";
  for (const SegmentConstraint& c : rod.segment_constraints())
    if (spec.hold_orientation && c.segment == seg)
      return "segment " + std::to_string(seg) + " of rod '" + spec.rod +
             "' has a hinge (a boundary condition)";
  const SegmentDrive* sd = rod.segment_drive(seg);
  if (spec.hold_orientation && sd && sd->kind != SegmentDrive::Kind::kTarget)
    return "segment " + std::to_string(seg) + " of rod '" + spec.rod + "' has a boundary condition";
  for (const auto& kv : grasps_) {
    const GraspState& g = kv.second;
    if (!g.held || g.rod != ri || kv.first == spec.name) continue;
    const int other = g.grasp.segment;
    if (other == seg)
      return "segment " + std::to_string(seg) + " of rod '" + spec.rod +
             "' is already held by grasp '" + kv.first + "'; release it first";
    if (std::abs(other - seg) == 1)
      return "segment " + std::to_string(seg) + " of rod '" + spec.rod + "' shares node " +
             std::to_string(std::max(seg, other)) + " with segment " + std::to_string(other) +
             ", held by grasp '" + kv.first + "'; release it first or grasp further along";
  }
  *rod_index = ri;
  *segment = seg;
  return "";
}

std::string GraspSet::add(World& world, const GraspSpec& spec, const Eigen::Isometry3d& holder,
                          const Eigen::Isometry3d* offset, double now) {
  auto it = grasps_.find(spec.name);
  if (it != grasps_.end() && it->second.held)
    return "grasp '" + spec.name + "' already holds rod '" + it->second.grasp.rod +
           "'; release it first";
  int ri = -1, seg = -1;
  const std::string error = check(world, spec, &ri, &seg);
  if (!error.empty()) return error;
  const bool had_wrench = it != grasps_.end() && it->second.rod != ri;
  const int old_rod = it != grasps_.end() ? it->second.rod : -1;
  GraspState& g = grasps_[spec.name];
  g = GraspState();
  g.spec = spec;
  g.rod = ri;
  g.held = true;
  g.arc_length = midpoint_arc_length(world.rods()[ri], seg);
  g.grasp.name = spec.name;
  g.grasp.rod = spec.rod;
  g.grasp.segment = seg;
  g.grasp.hold_orientation = spec.hold_orientation;
  g.grip.on = spec.grip.friction;
  g.grip.force = spec.grip.force;
  g.grip.mu = spec.grip.mu;
  g.grip.radius = world.rods()[ri].section().radius;
  attach(world, spec.name, holder, offset, now);
  if (had_wrench) apply_wrenches(world, old_rod);
  apply_wrenches(world, ri);
  return "";
}

void GraspSet::attach(World& world, const std::string& name, const Eigen::Isometry3d& holder,
                      const Eigen::Isometry3d* offset, double now) {
  GraspState* g = find(name);
  if (!g) return;
  Rod& rod = world.rods()[g->rod];
  const bool was_slipping = g->grip.slipping || g->grip.turning;
  if (g->grip.slipping) {
    release_sliding(rod, g->grasp);
    g->grip.slipping = false;
  }
  if (g->grip.turning) {
    release_turning(rod, g->grasp);
    g->grip.turning = false;
  }
  const Eigen::Isometry3d segment = segment_pose(rod, g->grasp.segment);
  if (offset) {
    g->grasp.offset = *offset;
    g->holder.reset(segment * offset->inverse());  // where the segment is now: nothing jumps
    g->holder.set_goal(now, holder, 0.0);
  } else {
    g->grasp.offset = holder.inverse() * segment;
    g->holder.reset(holder);
  }
  g->twist_angle = 0.0;
  g->held = true;
  // A friction grasp holds the segment at the length it has (it may take hold again and again).
  const int s = g->grasp.segment;
  g->grasp.length = g->grip.on ? (rod.positions()[s + 1] - rod.positions()[s]).norm() : 0.0;
  hold(rod, g->grasp, g->holder_pose());
  g->hold_pending = true;
  if (g->grip.on) {
    // The grip point and the fingers' axis: the segment's midpoint and tangent, in the holder's
    // frame (the twist turns about that line, so it moves neither).
    FrictionGrip& f = g->grip;
    f.point = g->grasp.offset.translation();
    f.axis = g->grasp.offset.linear().col(2);
    f.arc = grip_arc(rod, g->grasp.segment, g->holder.pose() * f.point,
                     g->holder.pose().linear() * f.axis, nullptr);
    f.slip_velocity = f.slip_sum = f.slip_time = 0.0;
    f.slid_out = 0;
  }
  if (was_slipping) apply_wrenches(world, g->rod);
}

bool GraspSet::release(World& world, const std::string& name) {
  GraspState* g = find(name);
  if (!g || !g->held) return false;
  corde::release(world.rods()[g->rod], g->grasp);
  g->held = false;
  g->twist_rate = 0.0;
  if (g->grip.slipping || g->grip.turning) {
    if (g->grip.slipping) release_sliding(world.rods()[g->rod], g->grasp);
    if (g->grip.turning) release_turning(world.rods()[g->rod], g->grasp);
    g->grip.slipping = g->grip.turning = false;
    apply_wrenches(world, g->rod);
  }
  return true;
}

GraspState* GraspSet::find(const std::string& name) {
  auto it = grasps_.find(name);
  return it == grasps_.end() ? nullptr : &it->second;
}

const GraspState* GraspSet::find(const std::string& name) const {
  auto it = grasps_.find(name);
  return it == grasps_.end() ? nullptr : &it->second;
}

void GraspSet::set_goal(const std::string& name, double now, const Eigen::Isometry3d& pose,
                        double duration) {
  GraspState* g = find(name);
  if (g && g->held) g->holder.set_goal(now, pose, duration);
}

bool GraspSet::add_sample(const std::string& name, double now, double stamp,
                          const Eigen::Isometry3d& pose) {
  GraspState* g = find(name);
  return g && g->held && g->holder.add_sample(now, stamp, pose);
}

void GraspSet::set_wrench(World& world, const std::string& name, const Vec3& force,
                          const Vec3& torque) {
  GraspState* g = find(name);
  if (!g) return;
  g->force = force;
  g->torque = torque;
  apply_wrenches(world, g->rod);
}

void GraspSet::set_twist_rate(const std::string& name, double rate) {
  GraspState* g = find(name);
  if (g && g->held) g->twist_rate = rate;
}

bool GraspSet::set_grip_force(World& world, const std::string& name, double force) {
  GraspState* g = find(name);
  if (!g || !g->grip.on) return false;
  g->grip.force = force;
  if (g->grip.slipping || g->grip.turning) apply_wrenches(world, g->rod);
  return true;
}

void GraspSet::stop_all() {
  for (auto& kv : grasps_) kv.second.holder.stop();
}

void GraspSet::apply_wrenches(World& world, int rod_index) {
  // The grasps are the only source of external forces so far: rebuild the rod's from all of them
  // (two grasps may share a node).
  Rod& rod = world.rods()[rod_index];
  rod.clear_external();
  for (auto& kv : grasps_) {
    GraspState& g = kv.second;
    if (g.rod == rod_index && g.grip.slipping) {
      // Kinetic friction against the slip, on the two nodes under the grip point.
      const Vec3 f = g.grip.friction(g.holder.pose().linear() * g.grip.axis);
      rod.add_external_force(g.grasp.segment, 0.5 * f);
      rod.add_external_force(g.grasp.segment + 1, 0.5 * f);
    }
    if (g.rod == rod_index && g.grip.turning)  // kinetic friction against the turn
      rod.add_external_torque(g.grasp.segment,
                              g.grip.friction_torque(g.holder.pose().linear() * g.grip.axis));
    if (g.rod != rod_index || (g.force.isZero(0.0) && g.torque.isZero(0.0))) continue;
    // At the segment's midpoint: half on each of its nodes.
    rod.add_external_force(g.grasp.segment, 0.5 * g.force);
    rod.add_external_force(g.grasp.segment + 1, 0.5 * g.force);
    rod.add_external_torque(g.grasp.segment, g.torque);
  }
}

int GraspSet::before_step(World& world, double t, double h, const HolderLimits& limits) {
  int stalls = 0;
  for (auto& kv : grasps_) {
    GraspState& g = kv.second;
    if (!g.held) continue;
    Rod& rod = world.rods()[g.rod];
    const int s = g.grasp.segment;
    g.origin0 = g.holder_pose().translation();
    for (int k = 0; k < 2; ++k) g.x0[k] = rod.positions()[s + k];
    // A holder at rest with nothing turning leaves the drives as they are (their targets hold).
    if (!g.holder.moving() && g.twist_rate == 0.0 && !g.hold_pending) continue;
    // Stalls at the material's strain limit (limits.stall_at_max_strain): a step whose motion
    // would stretch the cable beyond it towards a held node is not taken.
    const double limit = rod.section().max_strain;
    const bool check = limits.stall_at_max_strain && limit > 0.0 && g.holder.moving();
    const HolderMotion::Kinematics before = g.holder.kinematics();
    const Eigen::Isometry3d from = g.holder_pose();
    const HolderClip clip = g.holder.advance(t, h, limits);
    const Overstretch o =
        check ? overstretch(rod, g.grasp, from, g.holder_pose(), t + h, limit) : Overstretch{};
    if (o.anchor >= 0) {
      g.holder.restore(before);
      g.holder.halt();
      if (!g.stalled) {
        g.stalled = g.stall_new = true;
        g.stall_strain = o.strain;
        g.stall_anchor = o.anchor;
        g.stall_distance = o.distance;
        ++stalls;
      }
    } else {
      g.clip.speed |= clip.speed;
      g.clip.acceleration |= clip.acceleration;
      // The stall ends once the holder is nearer its anchor than where it stalled (creeping up
      // to the limit from there is the same stall).
      if (check && g.stalled) {
        const NodeDrive* a = rod.node_drive(g.stall_anchor);
        const int k = g.stall_anchor < s ? 0 : 1;
        if (!a || (held_node(rod, g.grasp, g.holder_pose(), k) - drive_position(*a, t + h)).norm() <
                      g.stall_distance)
          g.stalled = false;
      }
    }
    if (g.twist_rate != 0.0)
      g.twist_angle = std::remainder(g.twist_angle + g.twist_rate * h, 2.0 * M_PI);
    g.hold_pending = false;
    if (!g.grip.on) {
      hold(rod, g.grasp, g.holder_pose());
      continue;
    }
    // A friction grasp: the grip point's line at the step's end, moving with the holder.
    const Eigen::Isometry3d& pose = g.holder.pose();
    const Vec3 c = pose * g.grip.point, a = pose.linear() * g.grip.axis;
    g.grip.line_velocity =
        g.holder.velocity() + g.holder.angular_velocity().cross(c - pose.translation());
    if (!g.grip.slipping) {
      // Turning in the fingers: the nodes only (the constraint lets the segment turn).
      const bool orientation = g.grasp.hold_orientation;
      g.grasp.hold_orientation = orientation && !g.grip.turning;
      hold(rod, g.grasp, g.holder_pose());
      g.grasp.hold_orientation = orientation;
      continue;
    }
    hold_sliding(rod, g.grasp, c, a, g.grip.line_velocity);
    if (!g.holder.angular_velocity().isZero(0.0)) apply_wrenches(world, g.rod);  // turns with it
  }
  return stalls;
}

int GraspSet::after_step(World& world, double h) {
  // The rod exerts on the holder the opposite of what the grasp's drives exerted on the held
  // items over the step: their reactions (boundary.h), which every integrator records with one
  // meaning, m dv/dt - f on each node and J dw/dt + w x J w - tau on the segment (the implicit
  // methods: the residual of those equations at the step's end). The nodes' forces act about the
  // holder's origin at the step's start. A slipping friction grasp exerted its line constraints'
  // reactions and the friction force.
  int let_go = 0;
  for (auto& kv : grasps_) {
    GraspState& g = kv.second;
    if (!g.held) continue;
    const Rod& rod = world.rods()[g.rod];
    const int s = g.grasp.segment;
    Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
    const Vec3 friction =
        g.grip.slipping ? g.grip.friction(g.holder.pose().linear() * g.grip.axis) : Vec3::Zero();
    for (int k = 0; k < 2; ++k) {
      const NodeDrive* d = rod.node_drive(s + k);
      if (d) {
        force -= d->reaction;
        torque -= (g.x0[k] - g.origin0).cross(d->reaction);
        continue;
      }
      if (!g.grip.slipping) continue;
      for (const NodeConstraint& c : rod.node_constraints())
        if (c.node == s + k) {
          const Vec3 r = c.reaction + 0.5 * friction;
          force -= r;
          torque -= (g.x0[k] - g.origin0).cross(r);
        }
    }
    if (g.grasp.hold_orientation)
      if (const SegmentDrive* d = rod.segment_drive(s)) torque -= d->reaction;
    if (g.grip.turning)
      for (const SegmentConstraint& c : rod.segment_constraints())
        if (c.segment == s)
          torque -= c.reaction + g.grip.friction_torque(g.holder.pose().linear() * g.grip.axis);
    g.reaction_force_sum += force;
    g.reaction_torque_sum += torque;
    ++g.reaction_steps;
    if (g.grip.on && step_grip(world, &g, h)) ++let_go;
  }
  return let_go;
}

bool GraspSet::step_grip(World& world, GraspState* g, double h) {
  Rod& rod = world.rods()[g->rod];
  FrictionGrip& f = g->grip;
  const Eigen::Isometry3d& pose = g->holder.pose();
  const Vec3 c = pose * f.point, a = pose.linear() * f.axis;
  double fraction = 0.5;
  const double arc = grip_arc(rod, g->grasp.segment, c, a, &fraction);
  f.slip_velocity = (arc - f.arc) / h;
  f.slip_sum += arc - f.arc;
  f.slip_time += h;
  f.arc = arc;
  f.slid_out = 0;
  if (!f.slipping) {
    // Sticking: slides from the next step when the drives held the cable along its axis with more
    // than mu N. The cable then moves the way the force on it (minus the reaction) pulls.
    Vec3 held = Vec3::Zero();
    for (int k = 0; k < 2; ++k)
      if (const NodeDrive* d = rod.node_drive(g->grasp.segment + k)) held += d->reaction;
    const double along = held.dot(a);
    if (!(std::abs(along) > f.limit())) {
      step_turn(world, g, a);
      return false;
    }
    if (f.turning) {
      release_turning(rod, g->grasp);
      f.turning = false;
    }
    f.slipping = true;
    f.direction = along > 0.0 ? -1.0 : 1.0;
    f.line_velocity =
        g->holder.velocity() + g->holder.angular_velocity().cross(c - pose.translation());
    hold_sliding(rod, g->grasp, c, a, f.line_velocity);
    g->hold_pending = true;
    apply_wrenches(world, g->rod);
    return false;
  }
  // Slipping: the slip stopped or turned within the step -> sticks where it is.
  const int s0 = g->grasp.segment;
  const Vec3 v = 0.5 * (rod.velocities()[s0] + rod.velocities()[s0 + 1]);
  if (!(f.direction * (v - f.line_velocity).dot(a) > 0.0)) {
    stick(world, g);
    return false;
  }
  // The grip point left the segment: the next segment along takes the line constraints, or,
  // past the rod's start or end, the cable is out of the fingers.
  bool moved = false;
  for (int guard = 0; guard < rod.num_segments() && (fraction < 0.0 || fraction > 1.0); ++guard) {
    const int s = g->grasp.segment;
    const int next = fraction < 0.0 ? s - 1 : s + 1;
    if (next < 0 || next >= rod.num_segments()) {
      release_sliding(rod, g->grasp);
      f.slipping = false;
      f.slid_out = next < 0 ? -1 : 1;
      g->held = false;
      g->twist_rate = 0.0;
      apply_wrenches(world, g->rod);
      return true;
    }
    // A node held by something else (a clamp, another grasp) stops the slide there.
    if (node_taken(rod, next < s ? next : next + 1, s)) {
      stick(world, g);
      return false;
    }
    release_sliding(rod, g->grasp);
    g->grasp.segment = next;
    hold_sliding(rod, g->grasp, c, a, f.line_velocity);
    grip_arc(rod, next, c, a, &fraction);
    moved = true;
  }
  if (moved) {
    g->arc_length = midpoint_arc_length(rod, g->grasp.segment);
    g->hold_pending = true;
    apply_wrenches(world, g->rod);
  }
  return false;
}

void GraspSet::step_turn(World& world, GraspState* g, const Vec3& a) {
  Rod& rod = world.rods()[g->rod];
  FrictionGrip& f = g->grip;
  if (!g->grasp.hold_orientation) return;
  const int s = g->grasp.segment;
  if (!f.turning) {
    // Turns from the next step when the drive held the segment about the axis with more than
    // mu N r; it then turns the way the rod's torque (minus the reaction) turns it.
    const SegmentDrive* d = rod.segment_drive(s);
    if (!d || d->kind != SegmentDrive::Kind::kTarget) return;
    const double about = d->reaction.dot(a);
    if (!(std::abs(about) > f.torque_limit())) return;
    f.turning = true;
    f.turn_direction = about > 0.0 ? -1.0 : 1.0;
    hold_turning(rod, g->grasp, a);
    g->hold_pending = true;
    apply_wrenches(world, g->rod);
    return;
  }
  // Turning: sticks where it is when the turn relative to the holder stopped or reversed, or when
  // the holder swings the axis (the constraint keeps the axis of the turn's start).
  const Vec3 wh = g->holder.angular_velocity();
  const Vec3 w = rod.orientations()[s] * rod.angular_velocities()[s];
  const double rel = (w - wh).dot(a) - g->twist_rate;
  if (!(f.turn_direction * rel > 0.0) || !(wh - a * a.dot(wh)).isZero(0.0)) stick(world, g);
}

void GraspSet::stick(World& world, GraspState* g) {
  // Holds the segment under the grip point rigidly where it is now: the offset is recorded again
  // (the twist about the fingers' axis kept), so nothing jumps.
  Rod& rod = world.rods()[g->rod];
  release_sliding(rod, g->grasp);
  g->grip.slipping = false;
  if (g->grip.turning) release_turning(rod, g->grasp);
  g->grip.turning = false;
  const Eigen::Isometry3d spin(Eigen::AngleAxisd(-g->twist_angle, Vec3::UnitZ()));
  g->grasp.offset = g->holder.pose().inverse() * segment_pose(rod, g->grasp.segment) * spin;
  const int s = g->grasp.segment;
  g->grasp.length = (rod.positions()[s + 1] - rod.positions()[s]).norm();
  hold(rod, g->grasp, g->holder_pose());
  g->hold_pending = true;
  apply_wrenches(world, g->rod);
}

bool GraspSet::take_reaction(const std::string& name, Vec3* force, Vec3* torque) {
  GraspState* g = find(name);
  if (!g || g->reaction_steps == 0) return false;
  const Eigen::Matrix3d rt = g->holder_pose().linear().transpose();
  *force = rt * (g->reaction_force_sum / g->reaction_steps);
  *torque = rt * (g->reaction_torque_sum / g->reaction_steps);
  g->reaction_force_sum.setZero();
  g->reaction_torque_sum.setZero();
  g->reaction_steps = 0;
  return true;
}

bool GraspSet::take_slip(const std::string& name, double* velocity) {
  GraspState* g = find(name);
  if (!g || !g->grip.on || !(g->grip.slip_time > 0.0)) return false;
  *velocity = g->grip.slip_sum / g->grip.slip_time;
  g->grip.slip_sum = g->grip.slip_time = 0.0;
  return true;
}

void GraspSet::remake_on(World& world, int rod_index) {
  Rod& rod = world.rods()[rod_index];
  for (auto& kv : grasps_) {
    GraspState& g = kv.second;
    if (g.rod != rod_index) continue;
    // Named places keep their names: start and end are the new first and last segments, an arc
    // length is the one asked for. Node indices change: a node becomes its segment's midpoint.
    if (g.spec.place == GraspSpec::Place::kNode) {
      g.spec.place = GraspSpec::Place::kArcLength;
      g.spec.value = g.arc_length;
    }
    if (g.grip.turning) {  // held rigidly again at the new segment
      release_turning(rod, g.grasp);
      g.grip.turning = false;
    }
    g.grasp.segment = grasp_segment(rod, g.spec);
    g.arc_length = midpoint_arc_length(rod, g.grasp.segment);
    if (g.held) {
      // Keep the holder; record the new segment's offset from it, so nothing jumps.
      const Eigen::Isometry3d holder = g.holder_pose();
      g.grasp.offset = holder.inverse() * segment_pose(rod, g.grasp.segment);
      if (g.grip.on) {
        const int s = g.grasp.segment;
        g.grasp.length = (rod.positions()[s + 1] - rod.positions()[s]).norm();
      }
      g.holder.reset(holder);
      g.twist_angle = 0.0;
      hold(rod, g.grasp, holder);
      g.hold_pending = true;
    }
  }
  apply_wrenches(world, rod_index);
}

}  // namespace corde
