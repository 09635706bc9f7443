// corde_bench: cost of one rod time step (Rod::step) and of the force evaluation alone
// (Rod::compute_forces) for N = 50, 100, 1000 and 10000 elements (docs/benchmark.md).
//
// The rod is a coiling-like scene in which every term of the step does work: a pre-shaped helix
// (non-zero intrinsic bending and twist), clamped at the start by a fixed node and a ghost frame,
// its end node held and its end segment spun about the tangent, under gravity, with stretch and
// bend/twist internal friction, a force load and a torque load. The step's cost does not depend on
// the state (no contacts, no iterations), so the figures hold for any scene of that size.
// BM_RodStep uses the default rotational update (the split rotation); BM_RodStepSemiImplicitEuler
// the same rod with the paper's explicit gyroscopic term, for the ratio in the same run.
//
// Contacts (below): BM_WorldStepNoContact (World::step without anything to collide, against
// BM_RodStep/100), BM_RopeOnFloorSelfContact (a 1 m rope coiled on a floor, self contact on: time
// per World::step, the step and the real-time factor), BM_ContactScaling/N/self, and two shipped
// scenes in their settled state: BM_RodStack (rod-rod contact) and BM_RopePile (self contact).
// BM_OverhandKnot: config/scenes/overhand_knot.yaml (N = 100, self contact with friction) pulled
// until the knot is tight, then timed with the ends held; it also reports the share of the step
// spent in the contact stage. BM_PlectonemeContact/self (the shipped scene plectoneme_contact.yaml
// from start to end, 100 elements, self contact on or off: mean time per World::step over the whole
// run, and over the steps before the first contact and from it on).
// BM_GripperSweep (config/scenes/gripper_sweep.yaml, a link sweeping through a hanging cable at
// 1 m/s: the whole run per iteration, its time per World::step and real-time factor).
//
// BM_SagFrame/N/scaled: one 2 ms frame of the self-weight cantilever of docs/charts.md (a) with
// split_rotation at 0.9 of its stable step, physical tilt inertia (0) or
// rotational_inertia_scale: auto (1), for the option's gain in the same run.
//
// BM_GuardOverhead/guard: the stability guard's cost on config/scenes/default.yaml softened and run
// explicitly (40 elements, its gripper held), 0.2 s per iteration of bare World::step (0) or
// through the guard (1): us_per_step (thread CPU time), for the ratio in the same run.
//
// Columns: Time and CPU per step (us); ns_per_element = time per step / N. Typical use:
//   corde_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   corde_bench --benchmark_filter=BM_RodStep/100
//   corde_bench --benchmark_min_time=0.01        (quick smoke run, as the test does)
//
// Implicit integration (below): BM_SystemHessian/N (analytic Hessian of a steel cable,
// RodSystem::hessian), BM_BandedFactorSolve/N (O(N) block Cholesky of M/h^2 + H and one solve)
// and BM_SparseLDLTFactorSolve/N (Eigen's SimplicialLDLT on the same matrix, pattern analysed
// once, as statics used it): the step matrix of an implicit step at h = 2 ms.
// BM_Statics/N/fd: solve_statics of a steel cantilever sagging under its weight, analytic
// Hessian (fd = 0) against the former finite-difference Hessian (fd = 1).
// BM_RopeOnFloorSelfContactImplicit/h_us: the coiled rope with the implicit integrator at that
// step. BM_ImplicitEulerStep/N/reuse: one backward Euler step (ImplicitEuler) of a 1 m steel cable
// pinned at one end and swinging down from horizontal, h = 2 ms (Newton iterations per step
// reported), with the kept factorisation (reuse 1, the default) or a fresh one per iteration (0);
// BM_Bdf2Step/N: the same with BDF2 (one step is one 2 ms frame).
// BM_StaticsMode/scene and BM_DynamicRelaxation/scene: statics as a mode (solve_scene_statics)
// against dynamic relaxation (viscous) run until the forces vanish to the same tolerance,
// on the shipped V2 cantilever (scene 0) and on a 100-element cable hanging between two pins (scene
// 1).
#include <benchmark/benchmark.h>

#include <Eigen/SparseCholesky>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "corde_sim/contact/obstacle.h"
#include "corde_sim/grasp/grasp.h"
#include "corde_sim/integrators/implicit_step.h"
#include "corde_sim/linalg/block_tridiag_sparse.h"
#include "corde_sim/model/rod_system.h"
#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/stability/step_guard.h"
#include "corde_sim/statics/scene_statics.h"
#include "corde_sim/statics/statics.h"
#include "corde_sim/world/world.h"

namespace {

using corde::Rod;
using corde::Vec3;

const Vec3 kGravity(0.0, 0.0, -9.81);

struct BenchRod {
  Rod rod;
  double h;
};

BenchRod make_rod(int n) {
  corde::RodSpec spec;
  spec.name = "bench";
  spec.elements = n;
  spec.shape.kind = corde::RodShape::Kind::kHelix;
  spec.shape.direction = Vec3::UnitX();
  spec.shape.helix_radius = 0.05;
  spec.shape.helix_pitch = 0.1;
  spec.shape.helix_turns = 2.0;
  spec.shape.reference_d1 = Vec3::UnitZ();
  spec.rest_shape_created = true;  // intrinsic curvature and torsion of the helix
  const corde::MaterialPreset& rope = corde::material_preset("paper_rope");
  spec.section = corde::make_section(rope.material, rope.radius);
  Rod rod = corde::build_rod(spec);

  // Clamp at the start (fixed node and ghost frame), held end node, spun end segment.
  rod.add_node_drive({corde::NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  rod.add_node_drive({corde::NodeDrive::Kind::kFixed, n, rod.positions()[n]});
  corde::SegmentDrive spin;
  spin.kind = corde::SegmentDrive::Kind::kSpin;
  spin.segment = n - 1;
  spin.origin = rod.orientations()[n - 1];
  spin.rate = 3.14159265;
  rod.add_segment_drive(spin);
  rod.add_load({corde::Load::Kind::kForce, n / 2, Vec3(0.0, 0.05, 0.0), 0.0, 0.0});
  rod.add_load({corde::Load::Kind::kTorque, n / 3, Vec3(0.0, 0.0, 1e-4), 0.0, 0.0});

  const double h = 0.5 * corde::critical_time_step(rod);
  // A few steps so that velocities and strains are no longer exactly those of the rest shape.
  double t = 0.0;
  for (int k = 0; k < 20; ++k, t += h) rod.step(t, h, kGravity);
  return {std::move(rod), h};
}

// Per-element time from the wall clock around the timed loop (the Time column is wall time too).
void report(benchmark::State& state, int n, std::chrono::steady_clock::duration elapsed) {
  const double ns = std::chrono::duration<double, std::nano>(elapsed).count();
  const double iters = static_cast<double>(state.iterations());
  state.counters["ns_per_element"] = iters > 0 ? ns / (iters * n) : 0.0;
  state.counters["N"] = n;
}

void rod_step(benchmark::State& state, corde::Integrator integrator) {
  const int n = static_cast<int>(state.range(0));
  BenchRod b = make_rod(n);
  double t = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    b.rod.step(t, b.h, kGravity, integrator);
    t += b.h;
    benchmark::DoNotOptimize(b.rod.positions().data());
    benchmark::DoNotOptimize(b.rod.orientations().data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
  if (!b.rod.finite()) state.SkipWithError("the rod blew up (non-finite state)");
}

// Rod::step with the default rotational update (the split rotation), and with the paper's
// explicit gyroscopic term (semi-implicit Euler, eqs. 37-42) for comparison in the same run.
void BM_RodStep(benchmark::State& state) { rod_step(state, corde::Integrator::kSplitRotation); }
void BM_RodStepSemiImplicitEuler(benchmark::State& state) {
  rod_step(state, corde::Integrator::kSemiImplicitEuler);
}

void BM_ComputeForces(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  BenchRod b = make_rod(n);
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    b.rod.compute_forces(0.1, kGravity);
    benchmark::DoNotOptimize(b.rod.forces().data());
    benchmark::DoNotOptimize(b.rod.torques().data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
}

// One 2 ms frame of the peers' self-weight cantilever (docs/charts.md (a): L = 1, r = 1 cm,
// rho = 1000, E = E_s = 1e7, G = E/3, kappa = G A, ghost clamp, w = 5) with split_rotation at 0.9
// of its stable step, arg 1: physical inertia (0) or rotational_inertia_scale: auto (1). The same
// N in the same run gives the option's gain; the rod swings on from its first 0.1 s of sag.
void BM_SagFrame(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  corde::Material m;
  m.youngs_modulus = m.stretch_modulus = 1e7;
  m.shear_modulus = 1e7 / 3.0;
  m.density = 1000.0;
  m.kappa = m.shear_modulus * 3.14159265358979 * 1e-4;
  corde::RodSpec spec;
  spec.elements = n;
  spec.shape.length = 1.0;
  spec.section = corde::make_section(m, 0.01);
  Rod rod = corde::build_rod(spec);
  rod.add_node_drive(corde::NodeDrive{});
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  if (state.range(1) == 1) rod.set_rotational_inertia_scale(corde::lifting_inertia_scale(rod));
  const Vec3 g(0.0, 0.0, -5.0 * spec.section.bend / spec.section.mass_per_length);
  const int steps = static_cast<int>(std::ceil(2e-3 / (0.9 * corde::critical_time_step(rod))));
  const double h = 2e-3 / steps;
  double t = 0.0;
  for (; t < 0.1; t += h) rod.step(t, h, g);
  for (auto _ : state) {
    for (int k = 0; k < steps; ++k, t += h) rod.step(t, h, g);
    benchmark::DoNotOptimize(rod.positions().data());
    benchmark::ClobberMemory();
  }
  state.counters["steps_per_frame"] = steps;
  state.counters["scale"] = rod.rotational_inertia_scale();
  if (!rod.finite()) state.SkipWithError("the rod blew up (non-finite state)");
}
BENCHMARK(BM_SagFrame)->ArgsProduct({{10, 12, 24, 46}, {0, 1}})->Unit(benchmark::kMicrosecond);

BENCHMARK(BM_RodStep)->Arg(50)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RodStepSemiImplicitEuler)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ComputeForces)
    ->Arg(50)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Unit(benchmark::kMicrosecond);

// Cost of ObstacleSet::query for one segment against one obstacle of each kind (the argument:
// 0 capsule, 1 sphere, 2 box, 3 cylinder, 4 mesh of 1008 triangles (a UV sphere), 5 plane), about
// 0.4 across, at a tilted pose. Segments 5 cm long at random points within 0.35 of its centre,
// random directions, reach 0.5: every query is exact (about a fifth of the axes are inside or
// crossing). Time per query.
std::shared_ptr<corde::TriangleMesh> uv_sphere(double radius, int rings, int sectors) {
  auto m = std::make_shared<corde::TriangleMesh>();
  m->vertices.emplace_back(0.0, 0.0, radius);
  for (int r = 1; r < rings; ++r) {
    const double th = M_PI * r / rings;
    for (int k = 0; k < sectors; ++k) {
      const double ph = 2.0 * M_PI * k / sectors;
      m->vertices.emplace_back(radius * std::sin(th) * std::cos(ph),
                               radius * std::sin(th) * std::sin(ph), radius * std::cos(th));
    }
  }
  m->vertices.emplace_back(0.0, 0.0, -radius);
  const int south = static_cast<int>(m->vertices.size()) - 1;
  auto ring = [&](int r, int k) { return 1 + (r - 1) * sectors + (k % sectors); };
  for (int k = 0; k < sectors; ++k) {
    m->triangles.emplace_back(0, ring(1, k), ring(1, k + 1));
    m->triangles.emplace_back(south, ring(rings - 1, k + 1), ring(rings - 1, k));
    for (int r = 1; r + 1 < rings; ++r) {
      m->triangles.emplace_back(ring(r, k), ring(r + 1, k), ring(r + 1, k + 1));
      m->triangles.emplace_back(ring(r, k), ring(r + 1, k + 1), ring(r, k + 1));
    }
  }
  return m;
}

void BM_ObstacleQuery(benchmark::State& state) {
  using Kind = corde::ObstacleShape::Kind;
  static const char* const kNames[] = {"capsule", "sphere", "box", "cylinder", "mesh", "plane"};
  static const Kind kKinds[] = {Kind::kCapsule,  Kind::kSphere, Kind::kBox,
                                Kind::kCylinder, Kind::kMesh,   Kind::kPlane};
  const int kind = static_cast<int>(state.range(0));
  corde::Obstacle ob;
  ob.name = kNames[kind];
  ob.shape.kind = kKinds[kind];
  ob.shape.size =
      kind == 0 ? Vec3(0.2, 0.2, 0.0) : (kind == 2 ? Vec3(0.4, 0.4, 0.4) : Vec3(0.2, 0.4, 0.0));
  if (kKinds[kind] == Kind::kMesh) ob.shape.mesh = uv_sphere(0.2, 22, 24);  // 1008 triangles
  ob.pose.linear() = Eigen::AngleAxisd(0.4, Vec3(1.0, 2.0, 3.0).normalized()).matrix();
  ob.pose.translation() = Vec3(1.0, -2.0, 0.5);
  corde::ObstacleSet set;
  set.add(ob);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.35, 0.35);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<std::pair<Vec3, Vec3>> segments(1024);
  for (auto& [a, b] : segments) {
    a = ob.pose * Vec3(u(rng), u(rng), u(rng));
    b = a + 0.05 * Vec3(n(rng), n(rng), n(rng)).normalized();
  }
  std::vector<corde::SegmentContact> out;
  std::vector<int> which;
  out.reserve(1);
  which.reserve(1);
  size_t i = 0;
  for (auto _ : state) {
    out.clear();
    which.clear();
    const auto& [a, b] = segments[i++ & 1023];
    set.query(a, b, 0.5, &out, &which);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(kNames[kind]);
}

BENCHMARK(BM_ObstacleQuery)->DenseRange(0, 5)->Unit(benchmark::kNanosecond);

// World::step of the bench rod at N = 100 in a world without obstacles and without rod or self
// contact: the fused per-rod step, no contact work, so the same cost as BM_RodStep/100.
void BM_WorldStepNoContact(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  BenchRod b = make_rod(n);
  corde::World world;
  world.gravity = kGravity;
  world.time_step = b.h;
  world.add_rod(std::move(b.rod));
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    world.step();
    benchmark::DoNotOptimize(world.rods()[0].positions().data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
  if (world.contacts() != nullptr) state.SkipWithError("the world ran the contact stage");
  if (!world.finite()) state.SkipWithError("the rod blew up (non-finite state)");
}

BENCHMARK(BM_WorldStepNoContact)->Arg(100)->Unit(benchmark::kMicrosecond);

// A rope of n elements of 1 cm (radius 5 mm, E = E_s = 10 MPa, nylon_rope's density and damping)
// lying on a floor plane (friction 0.5) as a flat Archimedean spiral whose neighbouring turns
// touch (centre lines 2 r + 0.1 mm apart), self contact on or off; time_step auto. Every element
// rests on the floor and, with self contact, most touch the next turn: the contact count grows
// linearly with n.
// set: the coil is the rope's rest shape (rest_shape: created, a cable that has taken a set), so
// it stays coiled, its turns within the contact margin of one another.
corde::Scene rope_on_floor(int n, bool self, bool set = false) {
  const double r = 0.005, l = 0.01, spacing = 2.0 * r + 1e-4, a = 0.03;
  const double b = spacing / (2.0 * M_PI);  // radius = a + b theta
  std::ostringstream y;
  y.precision(9);
  y << "time_step: auto\nduration: 1000\n"
    << "obstacles:\n  - {name: floor, type: plane, normal: [0, 0, 1], friction: 0.5}\n"
    << "contact: {friction: 0.4}\n"
    << "rods:\n  - name: rope\n    elements: " << n << "\n    radius: " << r
    << "\n    material: {preset: nylon_rope, E: 1.0e7, E_s: 1.0e7}\n"
    << "    contact: {self: " << (self ? "true" : "false") << "}\n"
    << (set ? "    rest_shape: created\n" : "")
    << "    shape:\n      type: polyline\n      points:\n";
  // Points about 2 mm apart along the spiral up to the rope's length.
  const double length = n * l;
  double theta = 0.0, s = 0.0;
  Vec3 prev(a, 0.0, r);
  y << "        - [" << prev.x() << ", " << prev.y() << ", " << prev.z() << "]\n";
  while (s < length) {
    theta += 0.002 / (a + b * theta);
    const double rad = a + b * theta;
    const Vec3 p(rad * std::cos(theta), rad * std::sin(theta), r);
    s += (p - prev).norm();
    prev = p;
    y << "        - [" << p.x() << ", " << p.y() << ", " << p.z() << "]\n";
  }
  corde::Scene scene = corde::parse_scene(y.str());
  // 100 steps first (about 3 ms): contacts found and warm started, as in a running scene.
  scene.world.step(100);
  return scene;
}

// CPU time of the calling thread (s): the whole-run benchmarks report it beside the wall time.
double thread_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Time per World::step (Time, wall), the step (step_us), the real-time factor (simulated seconds
// per wall second, single thread) and the contacts of the last step.
// `step` advances the world by one step (default: World::step).
template <typename Step>
void run_world(benchmark::State& state, corde::World& world, int n, Step step) {
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    step();
    benchmark::DoNotOptimize(world.rods()[0].positions().data());
    benchmark::ClobberMemory();
  }
  const auto elapsed = std::chrono::steady_clock::now() - start;
  report(state, n, elapsed);
  const double secs = std::chrono::duration<double>(elapsed).count();
  state.counters["step_us"] = world.time_step * 1e6;
  state.counters["real_time_x"] =
      secs > 0 ? world.time_step * static_cast<double>(state.iterations()) / secs : 0.0;
  if (world.contacts() != nullptr) {
    state.counters["contacts"] = world.contacts()->stats().contacts;
    state.counters["max_pen_um"] = world.contacts()->stats().max_penetration * 1e6;
  }
  if (!world.finite()) state.SkipWithError("the rope blew up (non-finite state)");
}

void run_world(benchmark::State& state, corde::World& world, int n) {
  run_world(state, world, n, [&] { world.step(); });
}

// The issue's scene: a 1 m rope of 100 elements coiled on the floor, self contact on.
void BM_RopeOnFloorSelfContact(benchmark::State& state) {
  corde::Scene scene = rope_on_floor(100, true);
  run_world(state, scene.world, 100);
}

BENCHMARK(BM_RopeOnFloorSelfContact)->Unit(benchmark::kMicrosecond);

// The same rope with the implicit integrator at a step of h_us microseconds (argument), once it
// lies on the floor: the pre-stressed spiral springs open and slides in its first 1.2 s, so the
// timing starts after 2 s of it (self contact stays on; the turns have moved apart). newton:
// iterations of the last step; factorisations_per_step: of the Newton matrix, over the timed
// steps (ImplicitOptions::reuse_factor keeps it while the rope rests).
void BM_RopeOnFloorSelfContactImplicit(benchmark::State& state) {
  corde::Scene scene = rope_on_floor(100, true);
  corde::World& world = scene.world;
  world.integrator = corde::Integrator::kImplicitEuler;
  world.time_step = state.range(0) * 1e-6;
  world.step(static_cast<long>(std::lround(2.0 / world.time_step)));
  const long f0 = world.implicit_factorisations();
  run_world(state, world, 100);
  state.counters["newton"] = world.implicit_stats().iterations;
  state.counters["factorisations_per_step"] =
      static_cast<double>(world.implicit_factorisations() - f0) /
      static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1));
}

BENCHMARK(BM_RopeOnFloorSelfContactImplicit)
    ->Arg(500)
    ->Arg(1000)
    ->Arg(2000)
    ->Unit(benchmark::kMicrosecond);

// A coil that has set (rest_shape: created) lying on the floor, self contact on, implicit at
// h = 2 ms after 3 s of settling (its polygon's inner turns start slightly inside one another and
// are pushed apart): it stays coiled, about 100 floor contacts and 180 between neighbouring turns
// within the contact margin, about 140 of all carrying load.
void BM_RopeCoilSetImplicit(benchmark::State& state) {
  corde::Scene scene = rope_on_floor(100, true, true);
  corde::World& world = scene.world;
  world.integrator = corde::Integrator::kImplicitEuler;
  world.time_step = 2e-3;
  world.step(1500);
  run_world(state, world, 100);
  state.counters["newton"] = world.implicit_stats().iterations;
}

BENCHMARK(BM_RopeCoilSetImplicit)->Unit(benchmark::kMicrosecond);

// Whole runs with the implicit integrator at h = 2 ms, one run per iteration: us_per_step is the
// mean CPU time of a step over the run, real_time_x the simulated time over that CPU time.
// scene 0: the pre-stressed spiral of BM_RopeOnFloorSelfContact from its start, 3 s (it springs
// open on itself in the first 0.1 s, slides until about 1.2 s, then lies still). scene 1:
// config/scenes/rope_pile.yaml, 4 s (the rope lowered into a pile of loops on the floor, self
// contact throughout). scene 2: config/scenes/coiled_cable.yaml, 5 s (a coiled cable that has set,
// rest_shape: created, dropped from 3 cm onto the floor: 1.15 turns of 14 cm radius, its last
// turn lying across its first; it lands, settles and rests).
// Second argument: Gauss-Seidel sweeps per round of the contact solve (ContactSettings::
// implicit_sweeps; 4 is the default, 30 swept each round to convergence before).
void BM_RopeFloorWholeRunImplicit(benchmark::State& state) {
  double cpu = 0.0;
  long steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::unique_ptr<corde::Scene> scene;
    double duration = 3.0;
    if (state.range(0) == 0) {
      scene = std::make_unique<corde::Scene>(rope_on_floor(100, true));
    } else {
      const char* file = state.range(0) == 2 ? "coiled_cable.yaml" : "rope_pile.yaml";
      scene = std::make_unique<corde::Scene>(
          corde::load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/" + file));
      duration = scene->duration;
    }
    corde::World& world = scene->world;
    world.integrator = corde::Integrator::kImplicitEuler;
    world.time_step = 2e-3;
    world.contact.implicit_sweeps = static_cast<int>(state.range(1));
    const long n = std::lround(duration / world.time_step);
    state.ResumeTiming();
    const double c0 = thread_cpu_seconds();
    world.step(n);
    cpu += thread_cpu_seconds() - c0;
    steps += n;
    if (!world.finite()) state.SkipWithError("the rope blew up (non-finite state)");
  }
  state.counters["us_per_step"] = steps > 0 ? 1e6 * cpu / static_cast<double>(steps) : 0.0;
  state.counters["real_time_x"] = cpu > 0.0 ? 2e-3 * static_cast<double>(steps) / cpu : 0.0;
}

BENCHMARK(BM_RopeFloorWholeRunImplicit)
    ->ArgsProduct({{0, 1, 2}, {4, 30}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

// Cost against n: the coiled rope of n elements of 1 cm on the floor; second argument 1 = self
// contact on, 0 = floor only.
void BM_ContactScaling(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  corde::Scene scene = rope_on_floor(n, state.range(1) != 0);
  run_world(state, scene.world, n);
}

BENCHMARK(BM_ContactScaling)
    ->ArgsProduct({{50, 100, 200, 500, 1000, 2000}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

// A shipped scene run to `settle` seconds once (then kept: Google Benchmark calls a benchmark
// several times, and the state changes little once at rest), or null when the file is missing.
std::unique_ptr<corde::Scene> settled_scene(const char* file, double settle) {
  try {
    auto scene = std::make_unique<corde::Scene>(
        corde::load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/" + file));
    scene->world.step(static_cast<long>(settle / scene->world.time_step + 0.5));
    return scene;
  } catch (const std::exception&) {
    return nullptr;
  }
}

int elements(const corde::World& world) {
  int n = 0;
  for (const Rod& rod : world.rods()) n += rod.num_segments();
  return n;
}

// config/scenes/rod_stack.yaml after 0.6 s: six rods of 10 elements stacked crosswise on the
// floor, rod-rod contact (8 crossings carrying load, 30 floor contacts).
void BM_RodStack(benchmark::State& state) {
  static const std::unique_ptr<corde::Scene> scene = settled_scene("rod_stack.yaml", 0.6);
  if (scene == nullptr) return state.SkipWithError("config/scenes/rod_stack.yaml not found");
  run_world(state, scene->world, elements(scene->world));
}

BENCHMARK(BM_RodStack)->Unit(benchmark::kMicrosecond);

// config/scenes/rope_pile.yaml after 2.5 s: the rope of 100 elements lowered into a pile of loops
// on the floor, self contact (about 20 self contacts carrying load; the solve uses all 30 sweeps).
void BM_RopePile(benchmark::State& state) {
  static const std::unique_ptr<corde::Scene> scene = settled_scene("rope_pile.yaml", 2.5);
  if (scene == nullptr) return state.SkipWithError("config/scenes/rope_pile.yaml not found");
  run_world(state, scene->world, elements(scene->world));
}

BENCHMARK(BM_RopePile)->Unit(benchmark::kMicrosecond);

// config/scenes/coiled_cable.yaml after 3 s (the coil lies on the floor, its end resting across the
// strand below: about 85 contacts within the margin, a few of them self contacts carrying load),
// at the scene's own step (implicit, 2 ms).
void BM_CoiledCable(benchmark::State& state) {
  static const std::unique_ptr<corde::Scene> scene = settled_scene("coiled_cable.yaml", 3.0);
  if (scene == nullptr) return state.SkipWithError("config/scenes/coiled_cable.yaml not found");
  run_world(state, scene->world, elements(scene->world));
  state.counters["newton"] = scene->world.implicit_stats().iterations;
}

BENCHMARK(BM_CoiledCable)->Unit(benchmark::kMicrosecond);

// The knot scene, its ends pulled 0.14 m each in 3 s (as far as the scene pulls in 47 s at 3 mm/s:
// the loop about 3 cm across, the strands pressed together along the braid), then timed while the
// grasps hold the ends there (the knot under tension, its contacts active), the grasps set before
// each step as corde_run does. contact_share: the fraction of the step in the contact stage
// (ContactSystem::solve: detection and solve), timed on as many further steps (at most 2000);
// sweeps: the Gauss-Seidel sweeps of the last step.
void BM_OverhandKnot(benchmark::State& state) {
  const std::string motion = "=[{time: 3, displacement: [%g, 0, 0]}]";
  char right[100], left[100];
  std::snprintf(right, sizeof right, motion.c_str(), 0.14);
  std::snprintf(left, sizeof left, motion.c_str(), -0.14);
  corde::Scene scene;
  try {
    scene =
        corde::load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/overhand_knot.yaml",
                          {std::string("grasps.right.keyframes") + right,
                           std::string("grasps.left.keyframes") + left});
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  corde::World& world = scene.world;
  Rod& rod = world.rods()[0];
  struct Held {
    corde::Grasp grasp;
    Eigen::Isometry3d start;
    const corde::Motion* motion;
  };
  std::vector<Held> held;
  for (const corde::GraspSpec& spec : scene.grasps) {
    const Eigen::Isometry3d pose = corde::segment_pose(rod, corde::grasp_segment(rod, spec));
    held.push_back({corde::make_grasp(rod, spec, pose), pose, spec.motion.get()});
  }
  auto step = [&] {
    for (const Held& g : held)
      corde::hold(rod, g.grasp, g.motion->pose_at(world.time() + world.time_step, g.start));
    world.step();
  };
  while (world.time() < 3.5) step();
  run_world(state, world, 100, step);
  // The contact stage alone, on as many further steps (at most 2000).
  using Clock = std::chrono::steady_clock;
  Clock::duration contact{}, total{};
  corde::ContactSystem probe;
  corde::ExplicitStepper explicit_response;  // the scene steps explicitly
  explicit_response.set_rotation(world.integrator);
  const long probe_steps = std::min<long>(2000, static_cast<long>(state.iterations()));
  for (long k = 0; k < probe_steps; ++k) {
    const auto t0 = Clock::now();
    step();
    const auto t1 = Clock::now();
    // The same contact stage on the state the step left (forces first, as in the step).
    for (Rod& r : world.rods()) r.compute_forces(world.time(), world.gravity);
    const auto t2 = Clock::now();
    probe.solve(world, world.time_step, explicit_response);
    contact += Clock::now() - t2;
    total += t1 - t0;
  }
  state.counters["sweeps"] = world.contacts() ? world.contacts()->stats().iterations : 0;
  if (total.count() > 0)
    state.counters["contact_share"] = std::chrono::duration<double>(contact).count() /
                                      std::chrono::duration<double>(total).count();
}

BENCHMARK(BM_OverhandKnot)->Unit(benchmark::kMicrosecond);
// The paper's Fig. 1 with self contact, config/scenes/plectoneme_contact.yaml as shipped (100
// elements, 45 s, 430233 steps): one benchmark iteration is one World::step, and the run is the
// whole scene, so Time is the mean over it and real_time_x the scene's real-time factor.
// free_us and contact_us split it at 29 s, about when the loop lands on itself (first_contact_s:
// the first step that found a contact). Argument 0: self contact off, the same scene.
void BM_PlectonemeContact(benchmark::State& state) {
  corde::Scene scene = corde::load_scene(
      std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/plectoneme_contact.yaml",
      {state.range(0) != 0 ? "rods.0.contact={self: true}" : "rods.0.contact={self: false}"});
  corde::World& world = scene.world;
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto split = start;
  long split_step = -1, steps = 0;
  double first_contact = -1.0;
  for (auto _ : state) {
    world.step();
    ++steps;
    if (split_step < 0 && world.time() >= 29.0) {
      split = Clock::now();
      split_step = steps;
    }
    if (first_contact < 0.0 && world.contacts() && world.contacts()->stats().contacts > 0)
      first_contact = world.time();
  }
  const auto end = Clock::now();
  report(state, 100, end - start);
  const double secs = std::chrono::duration<double>(end - start).count();
  state.counters["step_us"] = world.time_step * 1e6;
  state.counters["real_time_x"] = secs > 0 ? world.time() / secs : 0.0;
  if (split_step > 0 && split_step < steps) {
    state.counters["free_us"] = std::chrono::duration<double, std::micro>(split - start).count() /
                                static_cast<double>(split_step);
    state.counters["contact_us"] = std::chrono::duration<double, std::micro>(end - split).count() /
                                   static_cast<double>(steps - split_step);
  }
  if (world.contacts()) state.counters["contacts"] = world.contacts()->stats().contacts;
  state.counters["first_contact_s"] = first_contact;
  if (!world.finite()) state.SkipWithError("the rod blew up (non-finite state)");
}

// 430233 steps of 1.046e-4 s: the scene's 45 s.
BENCHMARK(BM_PlectonemeContact)->Arg(1)->Arg(0)->Iterations(430233)->Unit(benchmark::kMicrosecond);
// ---------------------------------------------------------------------------------------------
// Implicit integration: the linear algebra of one Newton iteration on a steel cable (E = 200 GPa,
// rho = 7850, r = 2 mm, 1 m long) held by a clamp (node 0 and segment 0 fixed), stretched a little,
// frames sheared and twisted a little, at h = 2 ms.

struct StepSystem {
  Rod rod;
  corde::BlockTridiag a;
};

StepSystem make_step_system(int n) {
  corde::RodSpec spec;
  spec.elements = n;
  spec.shape.length = 1.0;
  spec.shape.direction = Vec3::UnitX();
  spec.section = corde::make_section(corde::material_preset("steel_wire").material, 0.002);
  Rod rod = corde::build_rod(spec);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Stretched by 1e-3, frames sheared and twisted by 0.02 rad.
  for (auto& x : rod.positions()) x *= 1.001;
  for (auto& q : rod.orientations())
    q = q * corde::Quat(Eigen::AngleAxisd(0.02, Vec3(u(rng), u(rng), u(rng)).normalized()));
  return {std::move(rod), {}};
}

// M/h^2 + H with the clamp and the unused slot fixed.
void step_matrix(const Rod& rod, double h, corde::BlockTridiag* a) {
  corde::RodSystem sys{&rod, kGravity};
  sys.definite = true;  // as an implicit step uses it (model/rod_system.h)
  sys.hessian(a);
  for (int i = 0; i < rod.num_nodes(); ++i)
    a->diag[i].topLeftCorner<3, 3>().diagonal().array() += rod.node_masses()[i] / (h * h);
  for (int s = 0; s < rod.num_segments(); ++s)
    a->diag[s].bottomRightCorner<3, 3>().diagonal() += rod.segment_inertia(s) / (h * h);
  for (int c = 0; c < 6; ++c) a->fix(c);
  for (int c = 3; c < 6; ++c) a->fix(6 * rod.num_segments() + c);
}

void BM_SystemHessian(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  StepSystem s = make_step_system(n);
  corde::RodSystem sys{&s.rod, kGravity};
  sys.hessian(&s.a);
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    sys.hessian(&s.a);
    benchmark::DoNotOptimize(s.a.diag.data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
}

void BM_BandedFactorSolve(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  StepSystem s = make_step_system(n);
  step_matrix(s.rod, 2e-3, &s.a);
  corde::BlockTridiagSolver solver;
  Eigen::VectorXd b = Eigen::VectorXd::Ones(s.a.size()), x;
  if (!solver.factor(s.a)) state.SkipWithError("not positive definite");
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    solver.factor(s.a);
    x = b;
    solver.solve(&x);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
}

void BM_SparseLDLTFactorSolve(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  StepSystem s = make_step_system(n);
  step_matrix(s.rod, 2e-3, &s.a);
  const Eigen::SparseMatrix<double> a = corde::to_sparse(s.a);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  ldlt.analyzePattern(a);
  Eigen::VectorXd b = Eigen::VectorXd::Ones(s.a.size()), x;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    ldlt.factorize(a);
    x = ldlt.solve(b);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
}

// A steel cantilever (r = 2 mm, 1 m, ghost clamp) sagging under gravity from straight: the same
// solve with the analytic Hessian and with the former central differences of the forces.
void BM_Statics(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Rod rod = make_step_system(n).rod;
  for (auto& x : rod.positions()) x /= 1.001;
  for (int s = 0; s < n; ++s) rod.orientations()[s] = rod.orientations()[0];
  rod.add_node_drive({corde::NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  corde::StaticOptions opt;
  opt.finite_difference_hessian = state.range(1) != 0;
  corde::StaticResult res;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    Rod r = rod;
    res = corde::solve_statics(r, kGravity, 0.0, opt);
    benchmark::DoNotOptimize(r.positions().data());
  }
  report(state, n, std::chrono::steady_clock::now() - start);
  state.counters["iterations"] = res.iterations;
  state.counters["force_evaluations"] = res.gradient_evaluations;
  if (!res.converged) state.SkipWithError("statics did not converge");
}

// A 1 m steel cable (r = 2 mm) pinned at node 0, released horizontal: steps of 2 ms while it
// swings down (restarted every 200 steps, outside the timing, so that it keeps moving; a BDF2
// run then takes one backward Euler step).
void implicit_cable_steps(benchmark::State& state, bool bdf2) {
  const int n = static_cast<int>(state.range(0));
  Rod rod = make_step_system(n).rod;
  for (auto& x : rod.positions()) x /= 1.001;
  for (int s = 0; s < n; ++s) rod.orientations()[s] = rod.orientations()[0];
  rod.add_node_drive({corde::NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  const Rod start_state = rod;
  corde::ImplicitOptions options;
  if (state.range(1) == 0) options.reuse_factor = 0.0;  // a fresh factorisation per iteration
  corde::ImplicitEuler integrator(options);
  integrator.set_second_order(bdf2);
  const double h = 2e-3;
  double t = 0.0;
  long steps = 0, iterations = 0;
  bool ok = true;
  const auto start = std::chrono::steady_clock::now();
  auto excluded = std::chrono::steady_clock::duration::zero();
  for (auto _ : state) {
    const corde::ImplicitResult r = integrator.step(rod, t, h, kGravity);
    ok = ok && r.converged;
    iterations += r.iterations;
    t += h;
    if (++steps % 200 == 0) {
      state.PauseTiming();
      const auto p0 = std::chrono::steady_clock::now();
      rod = start_state;
      t = 0.0;
      excluded += std::chrono::steady_clock::now() - p0;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(rod.positions().data());
  }
  report(state, n, std::chrono::steady_clock::now() - start - excluded);
  state.counters["newton_per_step"] = steps > 0 ? static_cast<double>(iterations) / steps : 0.0;
  if (!ok) state.SkipWithError("a step did not converge");
}

void BM_ImplicitEulerStep(benchmark::State& state) { implicit_cable_steps(state, false); }
// The same with BDF2 (integrator bdf2): the same Newton solve with another start combination.
void BM_Bdf2Step(benchmark::State& state) { implicit_cable_steps(state, true); }

BENCHMARK(BM_ImplicitEulerStep)
    ->ArgsProduct({{40, 100, 1000}, {1, 0}})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Bdf2Step)->ArgsProduct({{40, 100, 1000}, {1, 0}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Statics)->ArgsProduct({{40, 100, 1000}, {0, 1}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SystemHessian)->Arg(40)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BandedFactorSolve)->Arg(40)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SparseLDLTFactorSolve)->Arg(40)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);
// The shipped moving-obstacle scene over its whole duration (3 s, 46k steps) per iteration: the
// cable hangs contact-free until the link arrives, is pushed (about 0.6 s in contact), then swings.
// Time: one run; us_per_step: time per World::step over the run; real_time_x: simulated seconds per
// wall second; max_pen_um: the deepest penetration the contact stage saw over the run.
void BM_GripperSweep(benchmark::State& state) {
  const std::string path = std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/gripper_sweep.yaml";
  long steps = 0;
  double seconds = 0.0, simulated = 0.0, deepest = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    corde::Scene scene;
    try {
      scene = corde::load_scene(path);
    } catch (const std::exception& e) {
      state.SkipWithError(e.what());
      return;
    }
    corde::World& world = scene.world;
    for (const corde::GraspSpec& g : scene.grasps) {
      Rod& rod = world.rod(g.rod);
      const Eigen::Isometry3d holder = corde::segment_pose(rod, corde::grasp_segment(rod, g));
      corde::hold(rod, corde::make_grasp(rod, g, holder), holder);
    }
    const long n = std::lround(scene.duration / world.time_step);
    state.ResumeTiming();
    const auto start = std::chrono::steady_clock::now();
    for (long k = 0; k < n; ++k) {
      world.step();
      if (world.contacts()) deepest = std::max(deepest, world.contacts()->stats().max_penetration);
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    benchmark::DoNotOptimize(world.rods()[0].positions().data());
    steps += n;
    simulated += n * world.time_step;
    if (!world.finite()) state.SkipWithError("the cable blew up (non-finite state)");
  }
  state.counters["us_per_step"] = steps > 0 ? 1e6 * seconds / steps : 0.0;
  state.counters["real_time_x"] = seconds > 0 ? simulated / seconds : 0.0;
  state.counters["max_pen_um"] = deepest * 1e6;
}

BENCHMARK(BM_GripperSweep)->Unit(benchmark::kMillisecond);

// Statics as a mode against dynamic relaxation. Scene 0: the shipped V2 cantilever (50 elements,
// tip load alpha = 2, ramps completed as statics takes them). Scene 1: a soft cable of 100
// elements, 1.17 m long, pinned at two points 1 m apart at the same height, created as a V
// (sag 0.3 m) and left to settle into its catenary under gravity.
const char* kHangingCable = R"(
name: hanging_cable_100
rods:
  - name: cable
    elements: 100
    material: {preset: soft_cable}
    shape: {type: polyline, points: [[0, 0, 1], [0.5, 0, 0.7], [1, 0, 1]]}
    boundary:
      - {node: start, fix: true}
      - {node: end, fix: true}
)";
// The tolerance both are held to: the largest force on a free node (torque / l on a free
// segment) at rest over the rod's weight and loads. Statics reaches far below (its default
// tolerance 1e-10); above the cable's round-off floor (~1e-7 of its weight, at z = 1 m).
constexpr double kRelaxTolerance = 1e-6;

corde::Scene relaxation_scene(int which) {
  corde::Scene scene = which == 0
                           ? corde::load_scene(std::string(CORDE_SIM_SOURCE_DIR) +
                                               "/config/scenes/v2_cantilever_large_load.yaml")
                           : corde::parse_scene(kHangingCable);
  for (Rod& rod : scene.world.rods())
    for (corde::Load& l : rod.loads()) l.ramp_time = 0.0;
  return scene;
}

// Largest free force (torque / l) at rest over the weight and loads.
double rest_residual(const Rod& moving, const Vec3& g) {
  Rod rod = moving;
  for (Vec3& v : rod.velocities()) v.setZero();
  for (Vec3& w : rod.angular_velocities()) w.setZero();
  rod.compute_forces(0.0, g);
  double worst = 0.0, scale = 0.0;
  for (int i = 0; i < rod.num_nodes(); ++i) {
    scale += rod.node_masses()[i] * g.norm();
    if (!rod.node_drive(i)) worst = std::max(worst, rod.forces()[i].norm());
  }
  for (int s = 0; s < rod.num_segments(); ++s)
    if (!rod.segment_drive(s))
      worst = std::max(worst, rod.torques()[s].norm() / rod.rest_lengths()[s]);
  for (const corde::Load& l : rod.loads()) scale += l.value.norm();
  return worst / scale;
}

void BM_StaticsMode(benchmark::State& state) {
  const corde::Scene scene = relaxation_scene(static_cast<int>(state.range(0)));
  corde::SceneEquilibrium eq;
  for (auto _ : state) {
    corde::Scene s = scene;
    eq = corde::solve_scene_statics(&s, 0.0);
    benchmark::DoNotOptimize(s.world.rods()[0].positions().data());
    state.PauseTiming();
    state.counters["residual"] = rest_residual(s.world.rods()[0], s.world.gravity);
    state.ResumeTiming();
  }
  state.counters["newton"] = eq.rods[0].result.iterations;
  state.counters["load_steps"] = eq.rods[0].result.load_steps;
  if (!eq.ok) state.SkipWithError(eq.problem.c_str());
}

// Dynamic relaxation until rest_residual <= kRelaxTolerance (checked every 100 steps): the
// classic viscous form, every velocity and spin scaled by exp(-2 omega h) after each step (mass-
// and inertia-proportional damping, which damps every mode at the rate omega, the slowest one
// critically), omega an estimate of the slowest mode: 2 rad/s for the cantilever, 6 rad/s for
// the cable's swing. (Kinetic damping, zeroing the velocities at each kinetic-energy peak, blew
// up V2 at 0.8 of the stable step: the fast modes peak every few steps.) At the scene's time
// step (V2: 1e-4 s; the cable: auto), up to 60 s simulated (or CORDE_BENCH_RELAX_SECONDS). One
// run per iteration.
void BM_DynamicRelaxation(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const double omega = which == 0 ? 2.0 : 6.0;
  long steps = 0;
  double residual = 1.0, h = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    corde::Scene scene = relaxation_scene(which);
    corde::World& world = scene.world;
    Rod& rod = world.rods()[0];
    const char* env = std::getenv("CORDE_BENCH_RELAX_SECONDS");
    h = world.time_step;
    const long cap = std::lround((env ? std::atof(env) : 60.0) / h);
    const double keep = std::exp(-2.0 * omega * h);
    state.ResumeTiming();
    for (steps = 1; steps <= cap; ++steps) {
      world.step();
      for (Vec3& v : rod.velocities()) v *= keep;
      for (Vec3& w : rod.angular_velocities()) w *= keep;
      if (steps % 100 == 0 && !((residual = rest_residual(rod, world.gravity)) > kRelaxTolerance))
        break;
    }
  }
  state.counters["steps"] = static_cast<double>(steps);
  state.counters["simulated_s"] = steps * h;
  state.counters["residual"] = residual;
  if (!(residual <= kRelaxTolerance)) {
    const std::string msg = "did not relax in the time allowed (residual " +
                            std::to_string(residual) + " after " + std::to_string(steps * h) +
                            " s)";
    state.SkipWithError(msg.c_str());
  }
}

BENCHMARK(BM_StaticsMode)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DynamicRelaxation)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

// The stability guard's overhead (stability/step_guard.h): a check, an energy evaluation and a copy
// of the world per 64 steps, plus the per-step work bound, on the default scene's cord softened and
// run explicitly (E_s 50 MPa, kappa 0.2 G A, split_rotation at 65 us: the cheapest step, where the
// guard's fixed costs weigh most) with its gripper held: 0.2 s (3053 steps) per iteration of
// bare World::step (0) or StepGuard::step (1).
void BM_GuardOverhead(benchmark::State& state) {
  const bool guarded = state.range(0) != 0;
  corde::Scene base;
  try {
    base = corde::load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/default.yaml",
                             {"integrator=split_rotation",
                              "rods.cable.material={preset: soft_cable, E_s: 5.0e7, kappa: 60}"});
    for (const corde::GraspSpec& spec : base.grasps) {
      corde::Rod& rod = base.world.rod(spec.rod);
      const Eigen::Isometry3d holder = corde::segment_pose(rod, corde::grasp_segment(rod, spec));
      corde::hold(rod, corde::make_grasp(rod, spec, holder), holder);
    }
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const long steps = std::lround(0.2 / base.world.time_step);
  long total = 0;
  double seconds = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    corde::World world = base.world;
    corde::StepGuard guard;
    guard.reset(world);
    state.ResumeTiming();
    // Thread CPU time: the machine's other load does not enter the ratio.
    timespec c0, c1;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    if (guarded) {
      if (!guard.step(&world, steps) || !guard.settle(&world) || !guard.events().empty())
        state.SkipWithError("the guard reported an event");
    } else {
      world.step(steps);
    }
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    total += steps;
    seconds += (c1.tv_sec - c0.tv_sec) + 1e-9 * (c1.tv_nsec - c0.tv_nsec);
  }
  state.counters["us_per_step"] = total > 0 ? 1e6 * seconds / static_cast<double>(total) : 0.0;
}

BENCHMARK(BM_GuardOverhead)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
