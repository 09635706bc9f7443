// Reproducers from fuzzing the scene reader and corde_run (issue 8): runaway runs, step-count
// overflow, duplicate keys, CSV escaping and write errors, size limits and error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <streambuf>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "scene_test_util.h"

#ifndef CORDE_SIM_SOURCE_DIR
#define CORDE_SIM_SOURCE_DIR "."
#endif

namespace corde {
namespace {

const char* const kScene = test::kClampedCable;
using test::scene_error_of;

std::string load_error(const std::string& path) {
  try {
    load_scene(path);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::string v5_path() {
  return std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/v5_pendulum.yaml";
}

// --- Runaway runs -------------------------------------------------------------------------------

// v5_pendulum at 1.5 times its stable step blows up without ever reaching NaN (the fuzzer saw
// 4.6e10 J and the 1 m rod 5.9 m from its pin, exit 0, garbage in the CSV).
RunResult run_unstable_pendulum(RunOptions o, std::string* csv_text) {
  Scene s = load_scene(v5_path(), {"time_step=6e-6", "duration=3"});
  std::ostringstream csv;
  o.csv = &csv;
  o.every = 5;
  o.guard.enabled = false;  // the runaway checks alone (the guard recovers: step_guard_test)
  const RunResult r = run_scene(&s, o);
  *csv_text = csv.str();
  return r;
}

// Every written frame is sane: the 1 m rod pinned at the origin stays within ~1 m of it; the
// last one is before the failure.
void expect_good_frames(const std::string& csv, const RunResult& r) {
  const std::vector<std::string> rows = lines(csv);
  ASSERT_GE(rows.size(), 21u);
  for (size_t i = 1; i < rows.size(); ++i) {
    std::istringstream row(rows[i]);
    std::string field;
    for (int c = 0; std::getline(row, field, ','); ++c) {
      if (c < 3 || c > 8) continue;  // node coordinates only
      ASSERT_LT(std::abs(std::stod(field)), 1.1) << rows[i];
    }
  }
  const double last_t = std::stod(rows.back().substr(0, rows.back().find(',')));
  EXPECT_LT(last_t, r.failed_time);
}

TEST(SceneHardening, RunawayPendulumStopsAndWritesOnlyGoodFrames) {
  std::string csv;
  const RunResult r = run_unstable_pendulum(RunOptions(), &csv);
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.problem, "rod 'pendulum'")) << r.problem;
  EXPECT_GT(r.failed_step, 0);
  EXPECT_LT(r.sim_time, 0.01);
  expect_good_frames(csv, r);
}

TEST(SceneHardening, RunawayCaughtByStrainOrEnergyAlone) {
  // Without the speed and spin bounds the strain and energy checks still stop it.
  RunOptions o;
  o.limits.max_speed = 1e30;
  o.limits.max_angular_speed = 1e30;
  std::string csv;
  RunResult r = run_unstable_pendulum(o, &csv);
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(contains(r.problem, "(limit ")) << r.problem;
  expect_good_frames(csv, r);
  o.limits.max_stretch = o.limits.max_compression = 0.0;
  r = run_unstable_pendulum(o, &csv);
  EXPECT_TRUE(contains(r.problem, "J/kg of kinetic + elastic energy (limit 1e+05)")) << r.problem;
  expect_good_frames(csv, r);
}

TEST(SceneHardening, RunawayStrainAndEnergyChecks) {
  Scene s = parse_scene(kScene);
  RunOptions o;
  EXPECT_EQ(run_problem(s.world, o), "");
  // Stretch one segment to three times its length: strain 2.
  Rod& rod = s.world.rods()[0];
  const Vec3 d = rod.positions()[4] - rod.positions()[3];
  rod.positions()[4] += 2.0 * d;
  o.limits.max_stretch = 1.5;
  EXPECT_TRUE(contains(run_problem(s.world, o), "segment 3 stretched by 2 (limit 1.5)"))
      << run_problem(s.world, o);
  o.limits.max_stretch = 0.0;  // off
  o.limits.max_specific_energy = 1e-6;
  EXPECT_TRUE(contains(run_problem(s.world, o), "J/kg of kinetic + elastic energy"))
      << run_problem(s.world, o);
  o.limits.max_specific_energy = 0.0;
  EXPECT_EQ(run_problem(s.world, o), "");
}

TEST(SceneHardening, BadStartWritesNoFrame) {
  Scene s = parse_scene(kScene);
  s.world.rods()[0].velocities()[2] = Vec3(500, 0, 0);
  std::ostringstream csv;
  RunOptions o;
  o.csv = &csv;
  const RunResult r = run_scene(&s, o);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.failed_step, 0);
  EXPECT_EQ(r.steps, 0);
  EXPECT_EQ(r.problem, "rod 'cable': node 2 moves at 500 m/s (limit 100)");
  EXPECT_EQ(csv.str(), "t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw\n");
}

TEST(SceneHardening, ShippedScenesPassTheRunawayChecks) {
  // The defaults must not stop an honest run (the thread stretches to strain 2.2).
  Scene s = load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/thread.yaml");
  const RunResult r = run_scene(&s);
  EXPECT_TRUE(r.ok) << r.problem;
}

// --- Step counts --------------------------------------------------------------------------------

TEST(SceneHardening, StepCountOverflowIsRefused) {
  // These ran 0 steps ("0 s simulated", exit 0) through an overflowing conversion.
  // (A duration beyond 1e9 s is refused at load: scene_input_bounds_test.)
  for (const std::vector<std::string>& o : {std::vector<std::string>{"duration=1e9"},
                                            {"time_step=1e-300"},
                                            {"time_step=5e-324"},
                                            {"duration=1e9", "time_step=1e-300"}}) {
    Scene s = parse_scene(kScene, o);
    try {
      run_scene(&s);
      ADD_FAILURE() << o[0] << ": not refused";
    } catch (const SceneError& e) {
      EXPECT_TRUE(contains(e.what(), "steps, more than the limit of 1e+09 (max_steps)"))
          << e.what();
    }
    EXPECT_EQ(s.world.time(), 0.0);
  }
  // The runner's own duration, and a raised limit.
  Scene s = parse_scene(kScene);
  RunOptions opt;
  opt.duration = 1e15;
  EXPECT_THROW(run_scene(&s, opt), SceneError);
  opt.duration = 0.01;
  opt.max_steps = 999;
  EXPECT_THROW(run_scene(&s, opt), SceneError);
  opt.max_steps = 1000;
  EXPECT_EQ(run_scene(&s, opt).steps, 1000);
}

TEST(SceneHardening, InfiniteAutomaticStepIsRefused) {
  // Such a degenerate rod (its automatic step was infinite) is now refused by its radius.
  const std::string e = scene_error_of(
      "rods:\n  - {material: soft_cable, radius: 1.0e-100, shape: {type: straight}}\n");
  EXPECT_EQ(e.rfind("rods[0].radius: must be >= 1e-06 m, got 1e-100", 0), 0u) << e;
}

// --- Duplicate keys -----------------------------------------------------------------------------

TEST(SceneHardening, DuplicateKeysAreRefusedWithBothLines) {
  std::string yaml = kScene;
  yaml.replace(yaml.find("    elements: 4\n"), 0, "    elements: 40\n");
  EXPECT_EQ(scene_error_of(yaml),
            "rods[0].elements: duplicate key (lines 5 and 6); give each key once");
  EXPECT_EQ(scene_error_of("duration: 1\nrods: []\nduration: 2\n"),
            "duration: duplicate key (lines 1 and 3); give each key once");
  EXPECT_TRUE(contains(scene_error_of(std::string(kScene) + "      - {clamp: end, clamp: end}\n"),
                       "rods[0].boundary[1].clamp: duplicate key"));
}

// --- CSV ----------------------------------------------------------------------------------------

TEST(SceneHardening, CsvQuotesNamesWithCommasQuotesAndLineBreaks) {
  std::string yaml = kScene;
  yaml.replace(yaml.find("name: cable"), 11, "name: \"a,b \\\"c\\\"\\nd\"");
  Scene s = parse_scene(yaml);
  std::ostringstream csv;
  write_csv_rows(csv, s.world);
  EXPECT_EQ(csv.str().rfind("0,\"a,b \"\"c\"\"\nd\",0,0,0,1,", 0), 0u) << csv.str();
}

TEST(SceneHardening, CsvRowsWithLongNames) {
  // ~300 characters overflowed a fixed row buffer: rows lost their line breaks.
  const std::string name(300, 'n');
  std::string yaml = kScene;
  yaml.replace(yaml.find("name: cable"), 11, "name: " + name);
  Scene s = parse_scene(yaml);
  std::ostringstream csv;
  write_csv_rows(csv, s.world);
  const std::vector<std::string> l = lines(csv.str());
  ASSERT_EQ(l.size(), 4u);
  for (const std::string& row : l) {
    EXPECT_EQ(std::count(row.begin(), row.end(), ','), 12) << row;
    EXPECT_TRUE(contains(row, "," + name + ",")) << row;
  }
}

// A stream that accepts `room` characters, then fails (a full disk, /dev/full).
class FullBuf : public std::streambuf {
 public:
  explicit FullBuf(size_t room) : room_(room) {}

 protected:
  int overflow(int c) override {
    if (room_ == 0) return traits_type::eof();
    --room_;
    return c;
  }

 private:
  size_t room_;
};

TEST(SceneHardening, CsvWriteErrorStopsTheRun) {
  Scene s = parse_scene(kScene, {"duration=1"});
  FullBuf buf(4096);
  std::ostream out(&buf);
  RunOptions o;
  o.csv = &out;
  o.every = 10;
  const RunResult r = run_scene(&s, o);
  EXPECT_TRUE(r.write_failed);
  EXPECT_TRUE(r.ok);
  EXPECT_LT(r.steps, 1000);  // stopped soon after the stream failed, not after 100000 steps
}

// --- Limits -------------------------------------------------------------------------------------

class TempFile {
 public:
  explicit TempFile(const std::string& text) {
    char name[] = "/tmp/corde_hardening_XXXXXX";
    const int fd = mkstemp(name);
    path_ = name;
    FILE* f = fdopen(fd, "w");
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
  }
  ~TempFile() { std::remove(path_.c_str()); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

TEST(SceneHardening, FileSizeLimit) {
  const TempFile big("# " + std::string(SceneLimits::max_file_bytes, 'x') + "\n" + kScene);
  EXPECT_TRUE(contains(load_error(big.path()), "larger than the limit of 1048576 bytes"));
  // /dev/zero never ends: refused at once as a device (scene_input_bounds_test).
  EXPECT_TRUE(contains(load_error("/dev/zero"), "is not a regular file"));
}

TEST(SceneHardening, DirectoryAndCrOnlyLineEndings) {
  EXPECT_EQ(load_error("/tmp"), "/tmp: is a directory, not a scene file");
  std::string cr = kScene;
  for (char& c : cr)
    if (c == '\n') c = '\r';
  const TempFile f(cr);
  const Scene s = load_scene(f.path());  // was "rods: missing"
  EXPECT_EQ(s.world.rods()[0].num_segments(), 4);
  EXPECT_EQ(s.world.time_step, 1e-5);
}

TEST(SceneHardening, CountLimits) {
  std::string rods = "rods:\n";
  for (int i = 0; i < SceneLimits::max_rods + 1; ++i) rods += "  - {elements: 1}\n";
  EXPECT_EQ(scene_error_of(rods), "rods: has 1001 rods, more than the limit of 1000 (line 2)");
  std::string loads = std::string(kScene) + "    loads:\n";
  for (int i = 0; i < SceneLimits::max_items + 1; ++i)
    loads += "      - {node: end, force: [0, 0, 1]}\n";
  EXPECT_TRUE(
      contains(scene_error_of(loads), "rods[0].loads: has 10001 loads, more than the limit"));
  std::string grasps = std::string(kScene) + "grasps:\n";
  for (int i = 0; i < SceneLimits::max_grasps + 1; ++i)
    grasps += "  - {name: g" + std::to_string(i) + "}\n";
  EXPECT_TRUE(
      contains(scene_error_of(grasps), "grasps: has 1001 grasps, more than the limit of 1000"));
}

TEST(SceneHardening, TotalElementsLimit) {
  // Two rods at the per-rod limit fill the scene's budget (about 1 s to build): a third is refused
  // before it is built.
  const std::string rod = "  - {material: soft_cable, elements: 100000, shape: {type: straight}}\n";
  const std::string e = scene_error_of("rods:\n" + rod + rod +
                                       "  - {material: soft_cable, shape: {type: straight}}\n");
  EXPECT_EQ(e,
            "rods[2]: the scene's rods would have 200050 elements together, more than the limit "
            "of 200000 (line 4)");
}

// --- Messages -----------------------------------------------------------------------------------

TEST(SceneHardening, HugeValuesAreNotEchoedWhole) {
  const std::string huge(1 << 20, 'z');
  for (const std::string& yaml :
       {"gravity: " + huge + "\n" + kScene,
        std::string(kScene) + "    reference_d1: " + huge + "\n",
        std::string(kScene) + "grasps:\n  - {name: g, rod: " + huge + "}\n"}) {
    const std::string e = scene_error_of(yaml);
    EXPECT_FALSE(e.empty());
    EXPECT_LT(e.size(), 400u) << e.substr(0, 400);
    EXPECT_TRUE(contains(e, "(1048576 characters)")) << e.substr(0, 400);
  }
}

TEST(SceneHardening, TopLevelThatIsNotAMapHasAPath) {
  EXPECT_EQ(scene_error_of("5\n", {"rods.0.elements=3"}),
            "scene (top level): is not a map, cannot set 'rods' (override 'rods.0.elements=3')");
  EXPECT_EQ(scene_error_of("- 1\n- 2\n").rfind("scene: expected a map of keys, got a list of 2", 0),
            0u);
}

TEST(SceneHardening, IntegerLimitsAreNamed) {
  EXPECT_TRUE(contains(scene_error_of(kScene, {"rods.0.elements=2147483647"}),
                       "rods[0].elements: must be <= 100000, got '2147483647'"));
  EXPECT_TRUE(contains(scene_error_of(kScene, {"rods.0.elements=1e300"}), "must be <= 100000"));
  EXPECT_TRUE(contains(scene_error_of(kScene, {"rods.0.elements=0"}), "must be >= 1, got '0'"));
  EXPECT_TRUE(contains(scene_error_of(kScene, {"rods.0.elements=2.5"}), "expected an integer"));
}

TEST(SceneHardening, TwiceOverriddenKeyBlamesTheOverrideInEffect) {
  const std::string e = scene_error_of(kScene, {"rods.0.elements=8", "rods.0.elements=-3"});
  EXPECT_TRUE(contains(e, "(set by override 'rods.0.elements=-3')")) << e;
}

TEST(SceneHardening, HugeReferenceDirectorGivesTheSameFrames) {
  const std::string base = std::string(kScene) + "    reference_d1: ";
  const Scene unit = parse_scene(base + "[0, 1, 0]\n");
  const Scene huge = parse_scene(base + "[0, 1.0e200, 0]\n");
  const Scene tiny = parse_scene(base + "[1.0e-200, 1.0e-11, 0]\n");
  for (int s = 0; s < 4; ++s) {
    const Quat& q = unit.world.rods()[0].orientations()[s];
    EXPECT_LT(q.angularDistance(huge.world.rods()[0].orientations()[s]), 1e-12);
    EXPECT_LT(q.angularDistance(tiny.world.rods()[0].orientations()[s]), 1e-12);
  }
}

}  // namespace
}  // namespace corde
