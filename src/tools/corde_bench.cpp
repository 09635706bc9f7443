// corde_bench: cost of one rod time step (Rod::step) and of the force evaluation alone
// (Rod::compute_forces) for N = 50, 100, 1000 and 10000 elements (docs/benchmark.md).
//
// The rod is a coiling-like scene in which every term of the step does work: a pre-shaped helix
// (non-zero intrinsic bending and twist), clamped at the start by a fixed node and a ghost frame,
// its end node held and its end segment spun about the tangent, under gravity, with stretch and
// bend/twist internal friction, a force load and a torque load. The step's cost does not depend on
// the state (no contacts, no iterations), so the figures hold for any scene of that size.
//
// Columns: Time and CPU per step (us); ns_per_element = time per step / N. Typical use:
//   corde_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   corde_bench --benchmark_filter=BM_RodStep/100
//   corde_bench --benchmark_min_time=0.01        (quick smoke run, as the test does)
#include <benchmark/benchmark.h>

#include <chrono>
#include <utility>

#include "corde_sim/material.h"
#include "corde_sim/rod.h"
#include "corde_sim/rod_shape.h"
#include "corde_sim/stability.h"

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

void BM_RodStep(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  BenchRod b = make_rod(n);
  double t = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    b.rod.step(t, b.h, kGravity);
    t += b.h;
    benchmark::DoNotOptimize(b.rod.positions().data());
    benchmark::DoNotOptimize(b.rod.orientations().data());
    benchmark::ClobberMemory();
  }
  report(state, n, std::chrono::steady_clock::now() - start);
  if (!b.rod.finite()) state.SkipWithError("the rod blew up (non-finite state)");
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

BENCHMARK(BM_RodStep)->Arg(50)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ComputeForces)
    ->Arg(50)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
