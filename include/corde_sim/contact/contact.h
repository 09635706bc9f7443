// Contacts of rods with obstacles, with other rods and with themselves, solved as velocity
// constraints with exact Coulomb friction (docs/model.md, "Contacts").
//
// Each step: detection finds every pair (segment, obstacle) and (segment, segment) whose surfaces
// are within a speculative margin (the distance the pair can close in one step, the obstacle's own
// motion included, plus a small skin); the solver then finds impulses such that after the step no
// gap is closed past zero (d + h v_n >= 0, v the velocity relative to the other surface, a moving
// obstacle's included: nothing tunnels at the speeds the scene reaches) and the tangential impulse
// lies in the Coulomb disc |p_t| <= mu p_n (sticking while inside, sliding on its rim), by
// projected Gauss-Seidel over the contacts, warm started from the last step's impulses. The
// impulses enter the step as forces p / h on the segments' nodes, split by the contact point's
// position along the segment, and (with surface friction, an option) the tangential impulse's
// moment about the axis as torques on the segments: friction acts at the surfaces, so a rope rolls
// and a floor brakes one spinning about its axis.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "corde_sim/contact/obstacle.h"

namespace corde {

class ContactResponse;
class Rod;
class World;

// Per rod: which contacts it takes part in.
struct ContactOptions {
  bool self = false;       // its own non-adjacent segments (costs a broad phase per step)
  bool rods = false;       // other rods that also have `rods` (opt in, like self)
  bool obstacles = true;   // the world's obstacles
  double friction = -1.0;  // rod-rod and self friction; < 0: ContactSettings::friction
};

struct ContactSettings {
  int iterations = 30;          // Gauss-Seidel sweeps per step
  double friction = 0.4;        // default rod-rod Coulomb coefficient
  double skin = 0.05;           // extra detection distance, a fraction of the rod radius
  double push_out = 0.2;        // fraction of a penetration moved out per step (push_out())
  double max_push_speed = 0.5;  // m/s, cap on the speed at which push_out() moves it
  // s: and no faster than with this time constant (a fraction h / push_out_time a step), so that a
  // stiff rod whose overlap can only go by stretching it is not stretched within a few short steps
  // and sprung loose; 0: no such bound.
  double push_out_time = 0.01;
  // Implicit integrator: rounds of sweeps, each followed by the rods' true (stiffness-coupled)
  // response to the impulses (ContactSystem::solve with a coupled response).
  int implicit_rounds = 30;  // at most
  // Sweeps per round: the sweeps answer with each node's mass alone, which a stiff rod's true
  // response corrects in the round anyway, so sweeping them to convergence is wasted (whole runs
  // of ropes on a floor with self contact: 1.1x to 1.8x less CPU with 4 than with 30).
  int implicit_sweeps = 4;
  // Rounds stop once no contact closes past its target by more than a fraction of the rod's radius
  // over the step: 1 % of the step's largest motion (in radii), within these bounds. A fixed
  // 1e-3 r is a velocity noise of 1e-3 r / h (2.5 mm/s at r = 5 mm, h = 2 ms) that keeps a rope
  // at rest trembling; relative to the motion, what moves is resolved to 1 % and what rests to
  // the lower bound.
  double implicit_tolerance = 1e-3;
  double implicit_tolerance_min = 1e-4;
  double max_round_scale = 100.0;  // cap on a round's scaling of the impulses' change
  // Implicit integrator: the rounds hold each contact's gap linearised at the step's start (its
  // closest points and normal fixed); where two rods' surfaces, at the positions the solve left,
  // are closer than that allows by more than this fraction of the radius (segments sliding over
  // each other, turning within the step), the contact is linearised again there and the rounds
  // go on, up to implicit_passes times a step.
  double implicit_geometric_tolerance = 2e-3;
  int implicit_passes = 8;
  // Implicit integrator: the contact solve. kRounds: the rounds above. kDelassus: an accelerated
  // projected gradient on the Delassus operator W = J C J^T (C the rods' compliance, applied by
  // their banded solves), preconditioned by each contact's exact block of W
  // (contact_delassus.cpp); it stops on the same tolerance, after at most implicit_iterations
  // (short of the tolerance there, the rounds go on from its best impulses). Rounds are used where
  // the rods turn with the contacts (surface friction, rolling resistance) or the response gives
  // no compliance blocks.
  enum class Solver { kRounds, kDelassus };
  Solver implicit_solver = Solver::kRounds;
  int implicit_iterations = 100;
  // Friction acts at the contact point on the surfaces (true: its moment turns the segments, so a
  // rope rolls and a floor brakes its spin) or at the axes (false: no moment; a rope spinning on a
  // floor keeps its spin; rolling_friction brakes it). Off by default: the shipped scenes and
  // their figures are those with friction at the axes (docs/model.md, "Contacts").
  bool surface_friction = false;
  // Rolling resistance (dimensionless): a contact resists the touching bodies' relative rotation
  // about axes in its tangent plane with a torque of at most rolling_friction x r x the normal
  // force (r the rod's radius; for two rods the harmonic mean of theirs). It brakes a rope
  // spinning about its own axis on a floor (twist unwinding through a lying end) and, with
  // surface friction, a rope rolling on it. Spin about the normal is left to the sliding friction
  // of neighbouring contacts.
  double rolling_friction = 0.0;
  // A contact deeper than this fraction of the rod's radius is a deep contact: reported with the
  // rod, segment, obstacle (or other rod) and depth (deep_contact_report; corde_run and the node
  // warn, throttled). The solver keeps contacts it can resolve within about 1 % of the radius;
  // deeper ones are imposed (a cable pinched between two links) or went through a surface.
  double deep_penetration = 0.1;
};

struct Contact {
  int rod_a = 0, seg_a = 0;
  double s_a = 0.0;            // along segment a, 0..1
  int rod_b = -1, seg_b = -1;  // the other rod and segment, or -1 for an obstacle
  double s_b = 0.0;
  int obstacle = -1;                     // the obstacle's index when rod_b < 0
  Vec3 normal = Vec3::UnitZ();           // unit, from b (or the obstacle) towards a
  Vec3 point = Vec3::Zero();             // on b's surface (world), for display
  Vec3 surface_velocity = Vec3::Zero();  // an obstacle's: the velocity of its surface at `point`
  double gap = 0.0;                      // distance between the surfaces (negative: penetration)
  // Implicit, linearised again at the solve's positions (ContactSystem::relinearise): how much the
  // gap at the step's end falls short of gap + h v_n there (m; normal_target opens it by this).
  double offset = 0.0;
  // Distances from the axes to the contact point along -normal (a) and +normal (b): the levers of
  // friction (0 without surface friction). For two rods they split the axes' distance in the
  // ratio of the radii, so both sides act at one point and angular momentum is kept.
  double lever_a = 0.0, lever_b = 0.0;
  double mu = 0.0;
  double roll = 0.0;                 // rolling resistance: the largest torque per normal force (m)
  Vec3 surface_spin = Vec3::Zero();  // an obstacle's angular velocity (world)
  double pn = 0.0;                   // normal impulse of the step (N s)
  Vec3 pt = Vec3::Zero();            // tangential impulse (N s)
  Vec3 pr = Vec3::Zero();  // rolling resistance's torque impulse on a's segment (N m s; -pr on b's)
  // A deep contact (beyond deep_penetration): the largest change of the pair's relative normal
  // velocity its normal impulse may make alone (m/s); infinite for the others.
  double max_dv = std::numeric_limits<double>::infinity();
  // With a moving obstacle: its surface keeps making overlap as it sweeps or turns, so a
  // penetration is pushed out by a separating speed relative to it in the solve, not by
  // ContactSystem::push_out.
  bool moving = false;
};

// Statistics of the last step, for diagnostics and tests.
struct ContactStats {
  int contacts = 0;              // pairs within the margin
  int active = 0;                // pairs that carried an impulse
  double max_penetration = 0.0;  // largest -gap at detection (m, >= 0)
  int deepest = -1;              // its contact's index in contacts() (-1: none penetrates)
  // The deepest deep contact's -gap over rod a's radius (0: no contact deeper than
  // ContactSettings::deep_penetration).
  double max_ratio = 0.0;
  int candidate_pairs = 0;      // segment pairs the broad phase passed to the narrow phase
  int iterations = 0;           // Gauss-Seidel sweeps done (they stop once converged)
  int rounds = 0;               // implicit: rounds of sweeps and rod responses
  int delassus_iterations = 0;  // implicit, ContactSettings::Solver::kDelassus: iterations done
  // Implicit: the contact solve's last measure of how far contacts close past their target (or,
  // with kDelassus, carry impulse while separating or slide while sticking) over the step, in
  // radii, and the tolerance it was held to.
  double residual = 0.0;
  double tolerance = 0.0;
};

// The contact stage of World::step: detection and the constraint solve. Holds the scratch and the
// warm-start impulses between steps.
class ContactSystem {
 public:
  // True when the world has anything to collide: obstacles, or rods that take part in rod or self
  // contact. A world without that pays nothing.
  static bool needed(const World& world);

  // The contact stage of a step from the world's time t to t + h, after the integrator's free
  // step, with `response` the integrator's view (contact_response.h): detection at the step's
  // start against each rod's motion without contacts, then the impulses.
  // Lumped response (explicit methods): Gauss-Seidel sweeps, each node answering with its own
  // mass; the impulses are added to the rods' node forces as p / h (the commit integrates them).
  // Coupled response (implicit methods): a rod whose step may be retaken (BDF2) and that meets a
  // contact the step would close is stepped again (ContactResponse::retake), then rounds of
  // sweeps (with each node's own mass, which responds more than the stiff rod does, so impulses
  // approach from below), each followed by every touched rod's true response to the impulses so
  // far (ContactResponse::respond), which leaves the rods at their final state.
  void solve(World& world, double h, ContactResponse& response);
  // After the rods' step (World::step's last stage): the contacts that penetrate at the step's
  // end (their gap at the start plus h times the final relative normal velocity) are pushed out
  // along their normals by ContactSettings::push_out of their depth, at most max_push_speed h,
  // by moving node positions alone (Gauss-Seidel over those contacts with the nodes' lumped
  // masses; a held node does not move, a node on a line or plane moves along it). The velocity
  // constraints of solve() only keep a penetration from deepening; removing it is this
  // correction's, which adds no momentum (a split of the push-out from the impulses).
  void push_out(World& world, double h);

  const std::vector<Contact>& contacts() const { return contacts_; }
  // Coupled response (implicit methods): the node impulses rod r received in the last step (null
  // if none).
  const std::vector<Vec3>* last_impulses(int r) const {
    return r < static_cast<int>(last_impulse_.size()) && !last_impulse_[r].empty()
               ? &last_impulse_[r]
               : nullptr;
  }
  // And the segment torque impulses (surface friction's moments, rolling resistance; null if none).
  const std::vector<Vec3>* last_torque_impulses(int r) const {
    return r < static_cast<int>(last_torque_.size()) && !last_torque_[r].empty() ? &last_torque_[r]
                                                                                 : nullptr;
  }
  const ContactStats& stats() const { return stats_; }

 private:
  // Each rod's motion without contacts (velocity_, inv_mass_, omega_).
  void take_free_motion(const World& world, double h, const ContactResponse& response);
  // Detection from the rods' start positions and velocities as the response gives them.
  void detect(World& world, double h, const ContactResponse& response);
  void detect_rod_pairs(World& world, double h);
  // Coupled response: retakes the steps of rods meeting a contact their step would close (true:
  // some rod was stepped again).
  bool retake_closing(World& world, double h, ContactResponse& response);
  // Coupled response: contacts between rods whose surfaces, at the positions the solve left, are
  // closer than their linearisation allows are linearised there (closest points, normal, offset);
  // true: some contact was.
  bool relinearise(World& world, double h);
  // Coupled response: true where the solve sped a node up beyond what detection allowed for (its
  // skin over the step); detection is then run again with the solved velocities, the impulses
  // found so far kept as the warm start.
  bool outran_detection(const World& world, double h) const;
  void redetect(World& world, double h);
  // Coupled response: rounds of sweeps and the rods' true response.
  void solve_rounds(World& world, double h, ContactResponse& response);
  // Coupled response: accelerated projected gradient on the Delassus operator
  // (contact_delassus.cpp); false (nothing changed) when the response gives no compliance blocks.
  bool solve_delassus(World& world, double h, ContactResponse& response);
  // Coupled response: the rods touched by contacts or by a prediction (touched_).
  void mark_touched(const World& world, const ContactResponse& response);
  // Coupled response: each touched rod's node impulses (impulse_) remembered as the next step's
  // prediction, and its torque impulses with spin_.
  void remember_impulses(int nr);
  bool pair_list_valid(const World& world) const;
  void build_pair_list(const World& world);
  void warm_start();
  // Per-contact inverse masses (and levers); warm impulses into the velocities.
  void prepare_sweeps(const World& world);
  void apply_impulse(size_t k, const Vec3& p);
  // Surface friction: the segments that turn with contact k's point (a node's point turns with
  // both segments at the node, half each) and their world inverse inertia.
  void prepare_levers(const World& world, size_t k);
  // The velocity of contact k's point from the segments' rotation (relative, a's less b's).
  Vec3 lever_velocity(size_t k) const;
  // World angular velocities of rod r's segments from its state (after the step, implicit).
  void take_angular_velocities(const Rod& rod, int r);
  // Adds contact k's torque impulses for impulse p to torque_[rod][segment] (implicit).
  void gather_torques(size_t k, const Vec3& p);
  // Rolling resistance: contact k's rows (inverse inertias of the two segments, tangent basis).
  void prepare_roll(const World& world, size_t k);
  // One Gauss-Seidel update of contact k's rolling torque, bounded by roll x pn.
  void sweep_roll(size_t k);
  void apply_roll(size_t k, const Vec3& dt);
  void sweep(const ContactSettings& cs, double h, int iterations);
  void finish(World& world, double h, bool add_forces);
  static double normal_target(const Contact& c, const ContactSettings& cs, double h);
  // A coupled solve's stopping tolerance in radii: 1 % of the touched rods' largest motion over
  // the step (their current velocities), within the settings' bounds.
  double coupled_tolerance(const World& world, double h) const;

  std::vector<Contact> contacts_;
  ContactStats stats_;
  // Scratch, reused across steps.
  std::vector<std::vector<Vec3>> velocity_;  // per rod: predicted node velocities
  std::vector<std::vector<double>> inv_mass_;
  std::vector<double> scratch_w_;      // per contact: the pair's inverse mass
  std::vector<double> scratch_inv_w_;  // and its inverse (0 where the pair cannot move)
  std::vector<double> cap_;            // per contact: the largest normal impulse (max_dv)
  // push_out(): per contact its target and displacement impulse, per rod the nodes' shifts.
  std::vector<double> push_target_, push_;
  std::vector<std::vector<Vec3>> shift_;
  bool any_cap_ = false;  // some contact has a max_dv (else cap_ is not used)
  // Surface friction. A lever: one segment turned by a contact's friction, dw = c J (n x dp) and
  // the point's velocity gains c w x n (c = -share times the lever, J the world inverse inertia).
  struct Lever {
    int rod, seg;
    double c;
    Eigen::Matrix3d inv_inertia;
  };
  struct ContactLevers {
    int first = 0, count = 0;  // into levers_
    Vec3 t1, t2;               // the tangent plane's basis
    Eigen::Matrix2d inv_k;     // inverse of the pair's tangential inverse-mass block
  };
  std::vector<Lever> levers_;
  std::vector<ContactLevers> contact_levers_;  // per contact (empty: no levers)
  struct RollRow {
    bool active = false;
    Eigen::Matrix3d wa, wb;  // world inverse inertias of a's and b's segments (b: 0, obstacle)
    Vec3 t1, t2;             // the tangent plane's basis
    Eigen::Matrix2d inv_k;   // inverse of the pair's rotational inverse inertia in that plane
  };
  std::vector<RollRow> rolls_;  // per contact when rolling resistance is on
  bool spin_ = false;           // the sweeps track the segments' angular velocities (omega_)
  std::vector<std::vector<Vec3>> omega_, torque_;  // per rod and segment (world)
  // Per rod, during detect only: its start positions and velocities (the response's).
  std::vector<const std::vector<Vec3>*> start_x_, start_v_;
  std::vector<std::vector<Vec3>> detected_v_;  // implicit: the velocities detection used
  std::vector<std::vector<Vec3>> held_v_, impulse_, change_v_;  // coupled: per rod
  std::vector<std::vector<Vec3>>
      last_dv_;  // implicit: the true response to the last round's change
  std::vector<char> touched_;
  std::vector<std::vector<Vec3>> last_impulse_;  // implicit: per rod, the last step's totals
  std::vector<std::vector<Vec3>> last_torque_;   // and its torque impulses
  std::vector<SegmentContact> found_;
  std::vector<int> which_;
  struct CellEntry {
    std::uint64_t cell;
    int item;
  };
  std::vector<CellEntry> cells_;
  std::vector<std::pair<int, int>> items_;  // (rod, segment) of a broad-phase item
  std::vector<Eigen::AlignedBox3d> boxes_;
  std::vector<double> grow_;  // per item: how far its box reaches beyond the segment
  // The rod-pair broad phase, kept across steps (a Verlet list): the item pairs whose boxes, grown
  // by list_margin_, overlapped when it was built. It holds every pair whose boxes overlap as long
  // as no item's nodes have moved, plus its box's growth, by more than list_margin_ since then.
  std::vector<std::pair<int, int>> pair_list_;
  std::vector<std::vector<Vec3>> list_positions_;  // per rod: the nodes when it was built
  std::vector<double> list_grow_;                  // per item: grow_ when it was built
  std::vector<std::uint64_t> list_rods_;           // per rod: its options and size then
  std::vector<int> list_skip_;                     // per item: its neighbour window (fold_distance)
  double list_margin_ = 0.0;
  struct Overlap {  // a listed pair whose boxes overlap this step, in the grid's order
    std::uint64_t cell;
    int i, j;
  };
  std::vector<Overlap> overlaps_;
  // The last step's impulses by pair key, sorted (kept, not reallocated, across steps).
  struct Previous {
    std::uint64_t key;
    double pn;
    Vec3 pt;
    Vec3 pr;
  };
  std::vector<Previous> previous_;
  std::vector<Previous> old_;      // implicit: the impulses before a round's sweeps
  std::vector<Previous> last_dp_;  // implicit: the last round's change per contact
  // The Delassus solve's scratch (contact_delassus.cpp).
  struct DelassusRow {
    double wn = 0.0, wt = 0.0;  // the contact's normal and tangential compliance (W's block)
    double target = 0.0;        // normal_target
    double radius = 0.0;        // rod a's
  };
  std::vector<DelassusRow> rows_;
  std::vector<std::vector<Mat3>> comp_diag_, comp_lower_;  // per rod: node compliance blocks
  // Per contact: impulses (pn n + pt) at the iterate, the extrapolated point, the trial and the
  // best; relative velocities at the iterate and the extrapolated point; the trial's change.
  std::vector<Vec3> lam_, hat_, trial_, best_, u_lam_, u_hat_, du_;
  double delassus_scale_ = 1.0;  // the last step's final step scale
};

// The rod segments with a contact deeper than `fraction` of the rod's radius in the world's last
// contact stage (its detection at the start of the last step), deepest first, at most `max_lines`
// of them, separated by "; ": "rod 'cable' segment 16: 4.2 mm (1.4 r) into 'upper', 3.9 mm
// (1.3 r) into 'lower'", naming the obstacles (a URDF's as '<name>/<link>') or the other rod and
// its segment. "" when there is none.
std::string deep_contact_report(const World& world, double fraction, int max_lines = 3);
// A contact (of world's last contact stage) as "segment 16: 4.2 mm (1.4 r) into 'upper'".
std::string describe_contact(const World& world, const Contact& c);

}  // namespace corde
