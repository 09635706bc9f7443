// Rod::step and World::step must not touch the heap (real-time use). The global operator new is
// replaced here for the whole unit-test executable; it only counts while a CountAllocations
// object of the calling thread is alive, so the other tests are unaffected. Eigen's fixed-size
// types never allocate and the library uses no dynamic Eigen matrices in the step, so counting
// operator new covers every allocation the step could make (std::vector, std::string, ...).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <new>
#include <vector>

#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/integrators/implicit_step.h"
#include "corde_sim/rod/boundary.h"
#include "corde_sim/rod/material.h"
#include "corde_sim/rod/rod_shape.h"
#include "corde_sim/scene/scene.h"
#include "corde_sim/world/world.h"

namespace {

// Constant-initialised thread locals: reading them from operator new needs no allocation.
thread_local bool counting = false;
thread_local long allocations = 0;

void* counted_alloc(std::size_t size, std::size_t align) {
  if (counting) ++allocations;
  if (size == 0) size = 1;
  void* p = align > alignof(std::max_align_t)
                ? std::aligned_alloc(align, (size + align - 1) / align * align)
                : std::malloc(size);
  return p;
}

// Out of line so that GCC does not inline free() into callers of operator delete and then warn
// (-Wmismatched-new-delete) about free() of memory from operator new.
[[gnu::noinline]] void release(void* p) noexcept { std::free(p); }

struct CountAllocations {
  CountAllocations() {
    allocations = 0;
    counting = true;
  }
  ~CountAllocations() { counting = false; }
  long count() const { return allocations; }
};

}  // namespace

void* operator new(std::size_t size) {
  if (void* p = counted_alloc(size, 0)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = counted_alloc(size, 0)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t a) {
  if (void* p = counted_alloc(size, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t a) {
  if (void* p = counted_alloc(size, static_cast<std::size_t>(a))) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return counted_alloc(size, 0);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return counted_alloc(size, 0);
}
void* operator new(std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_alloc(size, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_alloc(size, static_cast<std::size_t>(a));
}
void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }

namespace corde {
namespace {

Rod make_rod(const std::string& name, int elements, const Vec3& start) {
  RodSpec spec;
  spec.name = name;
  spec.elements = elements;
  spec.shape.start = start;
  spec.shape.length = 0.5;
  spec.section = make_section(material_preset("paper_rope").material, 0.01);
  return build_rod(spec);
}

TEST(NoAllocation, CounterSeesAllocations) {
  // Guards the test below against a counter that never counts.
  CountAllocations c;
  std::vector<double> v(10);
  auto* p = new int(3);
  delete p;
  EXPECT_GE(c.count(), 2);
}

TEST(NoAllocation, WorldStepAllocatesNothing) {
  World world;
  // Every branch of the step: ghost clamp, fixed, moving and target nodes, fixed, spinning and
  // turning segments, force and torque loads in and after their ramps.
  Rod& a = world.add_rod(make_rod("clamped", 20, Vec3::Zero()));
  a.ghost_start().active = true;
  a.ghost_start().frame = a.orientations()[0];
  a.add_node_drive({NodeDrive::Kind::kFixed, 0, a.positions()[0]});
  a.add_load({Load::Kind::kForce, 20, Vec3(0.0, 0.1, 0.0), 0.0, 0.05});
  Rod& b = world.add_rod(make_rod("driven", 15, Vec3(0.0, 1.0, 0.0)));
  b.add_node_drive({NodeDrive::Kind::kVelocity, 0, b.positions()[0], Vec3(0.1, 0.0, 0.0)});
  b.add_segment_drive({SegmentDrive::Kind::kSpin, 0, b.orientations()[0], 2.0});
  b.add_segment_drive({SegmentDrive::Kind::kFixed, 14, b.orientations()[14]});
  b.ghost_end().active = true;
  b.add_load({Load::Kind::kTorque, 7, Vec3(0.0, 0.0, 1e-4), 0.0, 0.0});
  Rod& c = world.add_rod(make_rod("grasped", 10, Vec3(0.0, 2.0, 0.0)));
  NodeDrive grasp{NodeDrive::Kind::kTarget, 5, c.positions()[5]};
  grasp.target = c.positions()[5];
  c.add_node_drive(grasp);
  SegmentDrive turn{SegmentDrive::Kind::kTarget, 5, c.orientations()[5]};
  turn.target = c.orientations()[5];
  c.add_segment_drive(turn);
  world.time_step = 2e-5;

  long count = 0;
  {
    CountAllocations counter;
    for (int k = 0; k < 1000; ++k) world.step();
    count = counter.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations during 1000 World::step";
  EXPECT_TRUE(world.finite());
  EXPECT_GT(world.time(), 0.0199);
}

// A 10-element rope fixed at node 0, its end segment held by the grasp "g" (the grasp tests below).
struct HeldRope {
  World world;
  GraspSet grasps;
  std::string error;  // GraspSet::add's ("" when held)
  HeldRope() {
    Rod& rod = world.add_rod(make_rod("rope", 10, Vec3::Zero()));
    rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
    world.time_step = 2e-5;
    GraspSpec spec;
    spec.name = "g";
    spec.rod = "rope";
    error = grasps.add(world, spec, segment_pose(rod, 9), nullptr, 0.0);
  }
};

// A grasp's holder moving, then stalled at the strain limit (GraspSet::before_step's check):
// nothing on the heap either.
TEST(NoAllocation, GraspHolderStallAllocatesNothing) {
  HeldRope held;
  ASSERT_EQ(held.error, "");
  World& world = held.world;
  GraspSet& grasps = held.grasps;
  Eigen::Isometry3d far = grasps.find("g")->holder.pose();
  far.translation().x() += 5.0;
  grasps.set_goal("g", 0.0, far, 0.0);
  const HolderLimits limits;
  auto step = [&] {
    grasps.before_step(world, world.time(), world.time_step, limits);
    world.step();
    grasps.after_step(world, world.time_step);
  };
  step();  // the first hold makes the drives
  long count = 0;
  {
    CountAllocations counter;
    for (int k = 0; k < 5000; ++k) step();
    count = counter.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations during 5000 grasp steps";
  EXPECT_TRUE(grasps.find("g")->stalled);
  EXPECT_TRUE(world.finite());
}

// A grasp following a stamped pose stream (PoseTimeline): adding poses and interpolating them
// touch no heap either.
TEST(NoAllocation, GraspPoseStreamAllocatesNothing) {
  HeldRope held;
  ASSERT_EQ(held.error, "");
  World& world = held.world;
  GraspSet& grasps = held.grasps;
  const Eigen::Isometry3d start = grasps.find("g")->holder.pose();
  const HolderLimits limits;
  auto step = [&](int k) {
    if (k % 50 == 0) {  // poses at 1 kHz, stamped 2 ms before they arrive, on a 1 cm circle
      Eigen::Isometry3d p = start;
      const double s = world.time() - 2e-3;
      p.translation() += 0.01 * Vec3(0.0, std::cos(3.0 * s) - 1.0, std::sin(3.0 * s));
      ASSERT_TRUE(grasps.add_sample("g", world.time(), s, p));
    }
    grasps.before_step(world, world.time(), world.time_step, limits);
    world.step();
    grasps.after_step(world, world.time_step);
  };
  step(0);  // the first hold makes the drives
  long count = 0;
  {
    CountAllocations counter;
    for (int k = 1; k < 5000; ++k) step(k);
    count = counter.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations during 5000 steps following a pose stream";
  EXPECT_TRUE(grasps.find("g")->holder.streaming());
  EXPECT_TRUE(world.finite());
}

// A friction grasp on a hanging rope: sticking, sliding (line constraints, friction as an external
// force), moving from segment to segment, and sticking again when the grip force rises allocate
// nothing once each kind of support existed, under an explicit and an implicit method.
TEST(NoAllocation, FrictionGraspSlidingAllocatesNothing) {
  for (Integrator integrator : {Integrator::kSplitRotation, Integrator::kImplicitEuler}) {
    SCOPED_TRACE(integrator_name(integrator));
    World world;
    world.integrator = integrator;
    world.time_step = is_implicit(integrator) ? 1e-4 : 2e-5;
    RodSpec rs;
    rs.name = "rope";
    rs.elements = 20;
    rs.shape.direction = -Vec3::UnitZ();
    rs.shape.reference_d1 = Vec3::UnitX();
    rs.shape.length = 0.5;
    rs.section = make_section(material_preset("paper_rope").material, 0.01);
    Rod& rod = world.add_rod(build_rod(rs));
    double mass = 0.0;
    for (double m : rod.node_masses()) mass += m;
    GraspSpec spec;
    spec.name = "g";
    spec.rod = "rope";
    spec.place = GraspSpec::Place::kArcLength;
    spec.value = 0.2;
    spec.grip = {true, mass * 9.81, 0.5};  // mu N: half the weight
    GraspSet grasps;
    ASSERT_EQ(grasps.add(world, spec, segment_pose(rod, grasp_segment(rod, spec)), nullptr, 0.0),
              "");
    const int first = grasps.find("g")->grasp.segment;
    auto step = [&] {
      grasps.before_step(world, world.time(), world.time_step, HolderLimits());
      world.step();
      grasps.after_step(world, world.time_step);
    };
    // Until it slid into the next segment: every support made once.
    for (int k = 0; k < 200000 && grasps.find("g")->grasp.segment == first; ++k) step();
    ASSERT_EQ(grasps.find("g")->grasp.segment, first - 1);
    long count = 0;
    bool stuck = false;
    {
      CountAllocations counter;
      for (int k = 0; k < 200000 && grasps.find("g")->grasp.segment > first - 3; ++k) step();
      grasps.set_grip_force(world, "g", 20.0 * mass * 9.81);
      for (int k = 0; k < 20000 && !stuck; ++k) {
        step();
        stuck = !grasps.find("g")->grip.slipping;
      }
      for (int k = 0; k < 100; ++k) step();
      count = counter.count();
    }
    EXPECT_EQ(count, 0) << "heap allocations while sliding across segments and sticking";
    EXPECT_EQ(grasps.find("g")->grasp.segment, first - 3);
    EXPECT_TRUE(stuck);
    EXPECT_TRUE(world.finite());
  }
}

// The implicit step reuses its buffers after the first step (operator new only: Eigen's dynamic
// vectors allocate with malloc, which this counter does not see; they keep their sizes here).
TEST(NoAllocation, ImplicitStepAllocatesNothingAfterTheFirst) {
  Rod rod = make_rod("implicit", 20, Vec3::Zero());
  rod.ghost_start().active = true;
  rod.ghost_start().frame = rod.orientations()[0];
  rod.add_node_drive({NodeDrive::Kind::kFixed, 0, rod.positions()[0]});
  rod.add_load({Load::Kind::kForce, 20, Vec3(0.0, 0.1, 0.0), 0.0, 0.05});
  ImplicitEuler integrator;
  const Vec3 g(0.0, 0.0, -9.81);
  integrator.step(rod, 0.0, 1e-3, g);
  long count = 0;
  {
    CountAllocations counter;
    for (int k = 1; k < 50; ++k) integrator.step(rod, k * 1e-3, 1e-3, g);
    count = counter.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations during 49 implicit steps";
  EXPECT_TRUE(rod.finite());
}

// The implicit contact solve on the Delassus operator (contact: {implicit_solver: delassus})
// reuses its scratch: a rod landing on a slope and sliding, after its first steps.
TEST(NoAllocation, DelassusContactSolveAllocatesNothingAfterWarmUp) {
  Scene s = parse_scene(
      "gravity: [0, 0, -9.81]\ntime_step: 0.002\nintegrator: implicit_euler\n"
      "contact: {implicit_solver: delassus}\n"
      "obstacles:\n  - {name: slope, type: plane, normal: [0.5, 0, 0.8660254], friction: 0.3}\n"
      "rods:\n  - {name: rod, elements: 20, radius: 0.005, material: {E: 1.0e7, nu: 0.5, rho: "
      "1000, damping_time: 1.0e-3}, shape: {type: straight, start: [0.003, 0, 0.0052], direction: "
      "[0.8660254, 0, -0.5], length: 0.5}}\n");
  s.world.step(100);
  ASSERT_GT(s.world.contacts()->stats().active, 10);
  long count = 0;
  {
    CountAllocations counter;
    s.world.step(200);
    count = counter.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations during 200 implicit steps with the Delassus solve";
  EXPECT_GT(s.world.contacts()->stats().active, 10);
  EXPECT_TRUE(s.world.finite());
}

}  // namespace
}  // namespace corde
