// Scripted grasp and release (scene keys grasp_time and release_time): a grasp does not hold
// before its grasp_time (the rope falls freely), takes hold where the rope then is and follows
// its keyframes from there (world positions exactly, displacements from the take-hold pose), lets
// go at release_time (the rope flies freely again, with the velocity it had); its reaction is zero
// while it does not hold; statics holds it only at the times it holds; a rollback of the
// stability guard replays the take-hold and the release; bad keys are refused with their paths;
// the pick_and_place scene lays the cable down on the table at the new place (figures in
// docs/scene_format.md and the scene's header).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "corde_sim/grasp/grasp.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/statics/scene_statics.h"

namespace corde {
namespace {

constexpr double kG = 9.81;

// A free rope (paper_rope, 0.5 m, 10 elements) lying along x at z = 1, with the grasp `hand` on
// its end segment given by `grasp` (the keys after `place: end`).
std::string free_rope(const std::string& grasp, double h = 2.5e-4, double duration = 1.0,
                      const std::string& rod_extra = "") {
  char step[96];
  std::snprintf(step, sizeof step, "time_step: %.17g\nduration: %.17g\n", h, duration);
  return "gravity: [0, 0, -9.81]\n" + std::string(step) +
         "rods:\n  - name: rope\n    elements: 10\n    material: paper_rope\n"
         "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.5}\n"
         "    reference_d1: [0, 0, 1]\n" +
         rod_extra + "grasps:\n  - {name: hand, rod: rope, place: end" + grasp + "}\n";
}

// The frames of a corde_run CSV: time -> the rope's nodes.
std::map<double, std::vector<Vec3>> read_frames(const std::string& csv) {
  std::map<double, std::vector<Vec3>> frames;
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::string cell;
    std::istringstream row(line);
    for (int c = 0; std::getline(row, cell, ','); ++c)
      if (c != 1) v.push_back(std::stod(cell));
    std::vector<Vec3>& nodes = frames[v[0]];
    const int seg = static_cast<int>(v[1]);
    if (static_cast<int>(nodes.size()) == seg) nodes.push_back(Vec3(v[2], v[3], v[4]));
    if (static_cast<int>(nodes.size()) == seg + 1) nodes.push_back(Vec3(v[5], v[6], v[7]));
  }
  return frames;
}

// The frame nearest time t.
const std::vector<Vec3>& at(const std::map<double, std::vector<Vec3>>& frames, double t) {
  auto it = frames.lower_bound(t - 1e-9);
  EXPECT_TRUE(it != frames.end() && std::abs(it->first - t) < 1e-6) << "no frame at " << t;
  return it->second;
}

Vec3 end_midpoint(const std::vector<Vec3>& x) { return 0.5 * (x[x.size() - 2] + x.back()); }

// The rope's centre of mass with its node masses m.
Vec3 centre(const std::vector<Vec3>& x, const std::vector<double>& m) {
  Vec3 c = Vec3::Zero();
  double total = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    c += m[i] * x[i];
    total += m[i];
  }
  return c / total;
}

// Vertical acceleration of the centre of mass from three frames dt apart around t.
double centre_acceleration(const std::map<double, std::vector<Vec3>>& f, double t, double dt,
                           const std::vector<double>& m) {
  return (centre(at(f, t + dt), m).z() - 2.0 * centre(at(f, t), m).z() +
          centre(at(f, t - dt), m).z()) /
         (dt * dt);
}

struct Reaction {
  double t;
  Vec3 force;
};

std::vector<Reaction> read_reactions(const std::string& csv, const std::string& support) {
  std::vector<Reaction> out;
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::string cell;
    std::istringstream row(line);
    while (std::getline(row, cell, ',')) cells.push_back(cell);
    if (cells[1] != support) continue;
    out.push_back(
        {std::stod(cells[0]), Vec3(std::stod(cells[3]), std::stod(cells[4]), std::stod(cells[5]))});
  }
  return out;
}

// Free before grasp_time, held along the keyframes from where it took hold, free again after
// release_time with the velocity it had; the reaction is zero while it does not hold.
TEST(GraspTimes, HoldsOnlyBetweenGraspAndReleaseTime) {
  const double h = 2.5e-4;
  Scene s = parse_scene(
      free_rope(", grasp_time: 0.1, release_time: 0.6, interpolation: linear, keyframes: ["
                "{time: 0.3, displacement: [0, 0, 0.1]}, {time: 0.5, position: [0.6, 0.1, 1.0]}, "
                "{time: 0.9, displacement: [0.2, 0.1, 0.2]}]"));
  ASSERT_EQ(s.warnings.size(), 1u);  // keyframes after the release
  EXPECT_NE(s.warnings[0].find("grasps[0].release_time: the grasp lets go at 0.6 s"),
            std::string::npos)
      << s.warnings[0];
  RunOptions o;
  o.duration = 0.8;
  o.every = 1;
  std::ostringstream csv, reactions;
  o.csv = &csv;
  o.reactions = &reactions;
  const RunResult r = run_scene(&s, o);
  ASSERT_TRUE(r.ok) << r.problem;
  const auto frames = read_frames(csv.str());
  const std::vector<double>& m = s.world.rods()[0].node_masses();

  // Before 0.1 s the rope falls freely: its centre of mass with g (exact for the integrator; to
  // the CSV's 9 digits over 10 ms), its end with it (straight).
  for (double t : {0.02, 0.05, 0.085})
    EXPECT_NEAR(centre_acceleration(frames, t, 0.01, m), -kG, 1e-3) << t;
  const Vec3 p1 = end_midpoint(at(frames, 0.1));  // where it takes hold
  EXPECT_NEAR(p1.z(), 1.0 - 0.5 * kG * 0.1 * 0.1, 2e-4);
  // Held: the keyframes from the take-hold pose (displacement) and in the world (position), to
  // round-off (of the CSV's 9 digits); the centre no longer falls freely.
  EXPECT_LT((end_midpoint(at(frames, 0.3)) - (p1 + Vec3(0, 0, 0.1))).norm(), 2e-8);
  EXPECT_LT((end_midpoint(at(frames, 0.5)) - Vec3(0.6, 0.1, 1.0)).norm(), 2e-8);
  EXPECT_GT(std::abs(centre_acceleration(frames, 0.2, 0.01, m) + kG), 1.0);
  // At 0.6 s it lets go while moving (linear: at the constant velocity of the last interval):
  // the end keeps its velocity across the release, then flies freely.
  const Vec3 before = (end_midpoint(at(frames, 0.6)) - end_midpoint(at(frames, 0.6 - h))) / h;
  const Vec3 after = (end_midpoint(at(frames, 0.6 + h)) - end_midpoint(at(frames, 0.6))) / h;
  const Vec3 holder = (p1 + Vec3(0.2, 0.1, 0.2) - Vec3(0.6, 0.1, 1.0)) / 0.4;
  EXPECT_LT((before - holder).norm(), 2e-4) << before.transpose();  // CSV: 9 digits
  EXPECT_LT((after - before).norm(), 0.05 * before.norm()) << after.transpose();
  for (double t : {0.62, 0.7, 0.785})
    EXPECT_NEAR(centre_acceleration(frames, t, 0.01, m), -kG, 1e-3) << t;
  // The end no longer follows the keyframes (which go on to 0.9 s): it falls behind them.
  EXPECT_LT(end_midpoint(at(frames, 0.8)).z(), end_midpoint(at(frames, 0.6)).z());

  const std::vector<Reaction> rs = read_reactions(reactions.str(), "hand");
  ASSERT_GT(rs.size(), 3000u);
  int held = 0;
  for (const Reaction& x : rs) {
    if (x.t < 0.1 - 0.5 * h || x.t > 0.6 + 0.5 * h)
      ASSERT_EQ(x.force.norm(), 0.0) << "t = " << x.t;
    else if (x.force.norm() > 0.0)
      ++held;
  }
  EXPECT_GT(held, 1900);  // 2000 steps held, the reaction non-zero in all of them
}

// Without keyframes the grasp holds the segment still where it took hold; a grasp_time of 0 and
// no release_time is the grasp as before (the same run bit for bit).
TEST(GraspTimes, HoldsStillWhereItTookHoldAndDefaultsAreTheOldGrasp) {
  Scene s = parse_scene(free_rope(", grasp_time: 0.05"));
  RunOptions o;
  o.duration = 0.3;
  std::ostringstream csv;
  o.csv = &csv;
  o.every = 4;
  ASSERT_TRUE(run_scene(&s, o).ok);
  const auto frames = read_frames(csv.str());
  const Vec3 p1 = end_midpoint(at(frames, 0.05));
  EXPECT_LT(p1.z(), 1.0 - 0.01);
  EXPECT_LT((end_midpoint(at(frames, 0.3)) - p1).norm(), 1e-12);

  Scene a = parse_scene(free_rope(", keyframes: [{time: 0.1, displacement: [0, 0, 0.05]}]")),
        b = parse_scene(
            free_rope(", grasp_time: 0, keyframes: [{time: 0.1, displacement: [0, 0, 0.05]}]"));
  o.csv = nullptr;
  o.duration = 0.2;
  ASSERT_TRUE(run_scene(&a, o).ok);
  ASSERT_TRUE(run_scene(&b, o).ok);
  EXPECT_EQ(a.world.rods()[0].positions(), b.world.rods()[0].positions());
}

// Turns and orientations of a late grasp: `turns` about the tangent where it took hold, an
// orientation in the world frame.
TEST(GraspTimes, LateGraspTurnsFromWhereItTookHold) {
  Scene s = parse_scene(free_rope(
      ", grasp_time: 0.05, keyframes: [{time: 0.2, turns: 0.25}, "
      "{time: 0.4, orientation: [0, 0, 0.7071067811865476, 0.7071067811865476], turns: 0}]",
      2.5e-4, 1.0, "    initial: {angular_velocity: [0, 0, 2]}\n"));
  RunOptions o;
  o.duration = 0.4;
  std::ostringstream csv;
  o.csv = &csv;
  o.every = 4;
  ASSERT_TRUE(run_scene(&s, o).ok);
  const Rod& rod = s.world.rods()[0];
  const Quat q = rod.orientations()[rod.num_segments() - 1];
  const Quat expected(Eigen::AngleAxisd(0.5 * M_PI, Vec3::UnitZ()));
  EXPECT_LT(q.angularDistance(expected), 1e-9);
  // A quarter turn about the tangent where it took hold (turned by 0.1 rad about z from the
  // tangent as created): the tangent stays.
  const auto frames = read_frames(csv.str());
  const std::vector<Vec3>& x05 = at(frames, 0.05);
  const std::vector<Vec3>& x20 = at(frames, 0.2);
  const Vec3 t05 = (x05.back() - x05[x05.size() - 2]).normalized();
  const Vec3 t20 = (x20.back() - x20[x20.size() - 2]).normalized();
  EXPECT_LT((t05 - t20).norm(), 1e-9);
  EXPECT_GT((t05 - Vec3::UnitX()).norm(), 0.05);
}

// Statics holds a grasp only at the times it holds: at t = 0 before its grasp_time the clamped
// rope sags freely at its end (the grasp's reaction zero), at t = 1 it is held, after its
// release_time free again; a rope held by nothing else is refused at t = 0.
TEST(GraspTimes, StaticsHoldsTheGraspOnlyWhileItHolds) {
  const std::string yaml =
      "gravity: [0, 0, -9.81]\ntime_step: 1e-4\nrods:\n  - name: rope\n    elements: 10\n"
      "    material: paper_rope\n"
      "    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.5}\n"
      "    boundary: [{clamp: start, kind: ghost}]\n"
      "grasps:\n  - {name: hand, place: end, grasp_time: 0.5, release_time: 2}\n";
  auto end_z = [&](double t, Vec3* force) {
    Scene s = parse_scene(yaml);
    const SceneEquilibrium eq = solve_scene_statics(&s, t);
    EXPECT_TRUE(eq.ok) << eq.problem;
    const Support& hand = s.supports.back();
    EXPECT_EQ(hand.name, "hand");
    *force = support_reaction(s.world.rods()[0], hand).force;
    return s.world.rods()[0].positions().back().z();
  };
  Vec3 f0, f1, f3;
  const double z0 = end_z(0.0, &f0), z1 = end_z(1.0, &f1), z3 = end_z(3.0, &f3);
  EXPECT_LT(z0, 1.0 - 0.01);
  EXPECT_NEAR(z1, 1.0, 1e-9);
  EXPECT_EQ(z3, z0);
  EXPECT_EQ(f0.norm(), 0.0);
  EXPECT_GT(f1.z(), 0.0);
  EXPECT_EQ(f3.norm(), 0.0);

  Scene free = parse_scene(free_rope(", grasp_time: 0.5"));
  EXPECT_NE(statics_unsupported(free, "", 0.0).find("is held nowhere at t = 0 s"),
            std::string::npos);
  EXPECT_EQ(statics_unsupported(free, "", 0.5), "");
}

void expect_error(const std::string& yaml, const std::string& path, const std::string& fragment) {
  try {
    parse_scene(yaml);
    ADD_FAILURE() << "no error; expected '" << path << ": ..." << fragment << "'";
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << "message: " << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << "message: " << msg;
  }
}

TEST(GraspTimes, BadKeysAreRefusedWithTheirPaths) {
  expect_error(free_rope(", grasp_time: -0.1"), "grasps[0].grasp_time", "must be >= 0");
  expect_error(free_rope(", grasp_time: .nan"), "grasps[0].grasp_time", "finite");
  expect_error(free_rope(", grasp_time: .inf"), "grasps[0].grasp_time", "finite");
  expect_error(free_rope(", release_time: -1"), "grasps[0].release_time", "must be >= 0");
  expect_error(free_rope(", release_time: .nan"), "grasps[0].release_time", "finite");
  expect_error(free_rope(", grasp_time: 0.5, release_time: 0.3"), "grasps[0].release_time",
               "0.3 s is not after grasp_time 0.5 s");
  expect_error(free_rope(", grasp_time: 0.5, release_time: 0.5"), "grasps[0].release_time",
               "is not after grasp_time");
  expect_error(free_rope(", release_time: 0"), "grasps[0].release_time", "is not after grasp_time");
  expect_error(free_rope(", grasp_time: 0.5, keyframes: [{time: 0.6, displacement: [0, 0, 1]}, "
                         "{time: 0.4, displacement: [0, 0, 2]}]"),
               "grasps[0].keyframes[1].time", "0.4 s is not after grasp_time 0.5 s");
  expect_error(free_rope(", grasp_time: 0.5, keyframes: [{time: 0.5, position: [0, 0, 1]}]"),
               "grasps[0].keyframes[0].time", "is not after grasp_time");
  expect_error(free_rope(", grasp_time: 0.5, move_by: [0, 0, 0.1], ramp_time: 1, start_time: 0.2"),
               "grasps[0].start_time", "0.2 s is before grasp_time 0.5 s");
  expect_error(free_rope(", grasp_at: 0.5"), "grasps[0].grasp_at", "unknown key");
  // A move_by without start_time starts when the grasp takes hold.
  const Scene s = parse_scene(free_rope(", grasp_time: 0.5, move_by: [0, 0, 0.1], ramp_time: 1"));
  ASSERT_TRUE(s.grasps[0].motion);
  EXPECT_DOUBLE_EQ(s.grasps[0].motion->end_time(), 1.0);  // in the time since grasp_time
}

// A fault (a NaN put into the rope once, as a blow-up would, at step 256 while the grasp holds)
// found by the guard's check at step 400, after the release at 300: the guard rolls back to its
// snapshot at step 200, taken while the grasp held, and replays across the release. The replay must
// go on holding the grasp as it took hold (not take hold afresh where the rope is at the snapshot,
// which would shift its keyframes by the lift so far) and let go again: the rope ends where the run
// without the fault puts it, the grasp's drives gone.
TEST(GraspTimes, RollbackReplaysTheScriptedRelease) {
  const double h = 2.5e-4;
  char keys[200];
  std::snprintf(keys, sizeof keys,
                ", grasp_time: %.17g, release_time: %.17g, interpolation: linear, keyframes: "
                "[{time: %.17g, displacement: [0, 0, 0.05]}]",
                100 * h, 300 * h, 300 * h);
  auto run = [&](bool fault, RunResult* r) {
    Scene s = parse_scene(free_rope(keys, h, 600 * h));
    RunOptions o;
    o.guard.check_every = 200;  // snapshots at 200 steps (holding) and 400 (free)
    o.progress_interval = 0.0;  // called after every 256 steps: first at 256, between 200 and 400
    bool done = false;
    if (fault)
      o.progress = [&](double, double, double) {
        if (done) return;
        done = true;
        s.world.rods()[0].velocities()[3].x() = std::nan("");
      };
    *r = run_scene(&s, o);
    EXPECT_TRUE(r->ok) << r->problem;
    return s.world.rods()[0];
  };
  RunResult faulted, clean;
  const Rod rod = run(true, &faulted), reference = run(false, &clean);
  EXPECT_EQ(clean.guard_rollbacks, 0);
  ASSERT_EQ(faulted.guard_rollbacks, 1);
  const double back = faulted.guard_events.front().rollback_to;
  EXPECT_GT(back, 100 * h);  // after the grasp took hold ...
  EXPECT_LT(back, 300 * h);  // ... before it let go
  const int last = rod.num_segments() - 1;
  EXPECT_EQ(rod.node_drive(last), nullptr);
  EXPECT_EQ(rod.node_drive(last + 1), nullptr);
  EXPECT_EQ(rod.segment_drive(last), nullptr);
  EXPECT_LT((rod.positions().back() - reference.positions().back()).norm(), 2e-3)
      << rod.positions().back().transpose() << " / " << reference.positions().back().transpose();
}

// The shipped pick_and_place scene: the gripper closes on the cable lying on the table at 0.5 s,
// carries it 0.4 m along y, lays it down and opens at 4.2 s; the cable ends at rest on the table
// top (every node within its radius of lying on it), never deeper in the table than 1 % of its
// radius (every step), moved by the carried distance. Without contacts the same script lowers it
// through the table (the check can fail).
TEST(GraspTimes, PickAndPlaceLaysTheCableDownAtTheNewPlace) {
  const std::string file = std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/pick_and_place.yaml";
  const double top = 0.75;
  auto deepest = [&](const std::map<double, std::vector<Vec3>>& frames, double r) {
    double depth = 0.0;
    for (const auto& f : frames)
      for (const Vec3& x : f.second) depth = std::max(depth, top + r - x.z());
    return depth;
  };
  auto mean = [](const std::vector<Vec3>& x) {
    Vec3 c = Vec3::Zero();
    for (const Vec3& p : x) c += p;
    return Vec3(c / static_cast<double>(x.size()));
  };
  Scene s = load_scene(file);
  const double r = s.world.rods()[0].section().radius;
  RunOptions o;
  o.every = 1;
  std::ostringstream csv;
  o.csv = &csv;
  const RunResult result = run_scene(&s, o);
  ASSERT_TRUE(result.ok) << result.problem;
  EXPECT_TRUE(result.guard_events.empty());
  const auto frames = read_frames(csv.str());
  const std::vector<Vec3>& start = frames.begin()->second;
  const std::vector<Vec3>& end = s.world.rods()[0].positions();
  for (const Vec3& x : end) EXPECT_NEAR(x.z(), top + r, r) << x.transpose();
  EXPECT_LT(deepest(frames, r), 0.01 * r);
  EXPECT_LT(s.world.energies().kinetic(), 1e-9);
  // Held up in the air while carried: the cable left the table.
  for (const Vec3& x : at(frames, 2.5)) EXPECT_GT(x.z(), top + 0.1);
  const Vec3 moved = mean(end) - mean(start);
  EXPECT_LT((moved - Vec3(0.0, 0.4, 0.0)).norm(), 0.02) << moved.transpose();

  Scene control = load_scene(file, {"rods.cable.contact.obstacles=false"});
  o.duration = 4.0;
  std::ostringstream csv2;
  o.csv = &csv2;
  ASSERT_TRUE(run_scene(&control, o).ok);
  EXPECT_GT(deepest(read_frames(csv2.str()), r), r);
}

}  // namespace
}  // namespace corde
