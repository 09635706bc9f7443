// Reactions under every integrator: a grasp's wrench on its holder and a ghost clamp's moment mean
// the same under the implicit methods as under the explicit ones and statics (corde_sim issue 23:
// under implicit_euler and bdf2 both read zero).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/grasp/reactions.h"
#include "corde_sim/scene/scene.h"

namespace corde {
namespace {

constexpr Integrator kAll[] = {Integrator::kSplitRotation, Integrator::kSemiImplicitEuler,
                               Integrator::kImplicitEuler, Integrator::kBdf2};

// The default scene (a power cord between a ghost clamp at its start and the grasp 'gripper' at
// its end) started at rest in its static equilibrium.
Scene default_at_rest() {
  return load_scene(std::string(CORDE_SIM_SOURCE_DIR) + "/config/scenes/default.yaml",
                    {"initial_state=equilibrium"});
}

const Support& clamp_of(const Scene& s) {
  for (const Support& sp : s.supports)
    if (sp.ghost == 0) return sp;
  throw std::runtime_error("no ghost clamp at the start");
}

// The explicit methods need the cord's stable step (about 12 us); the implicit ones take the
// scene's 2 ms.
double step_for(Integrator i) { return is_implicit(i) ? 2e-3 : 5e-6; }

// Steps enough for bdf2 to take its second-order steps (its first is a backward Euler step).
constexpr int kSteps = 5;

void step(World* w, GraspSet* g, int n) {
  for (int k = 0; k < n; ++k) {
    g->before_step(*w, w->time(), w->time_step, HolderLimits());
    w->step();
    g->after_step(*w, w->time_step);
  }
}

// The ghost clamp's wrench on the cord at the equilibrium (statics' reactions).
Wrench clamp_statics(const Scene& s) {
  Rod rod = s.world.rods()[0];
  rod.set_static_reactions(0.0, s.world.gravity);
  return support_reaction(rod, clamp_of(s));
}

// The cord at rest in equilibrium, held by the gripper as the node holds it (a GraspSet, its
// holder at the held segment's pose), a few steps under each integrator: the mean wrench on the
// holder is what the gripper carries. The cord's balance gives it independently of the grasp: the
// gripper carries the weight less what the clamp carries (statics' clamp reaction), and the
// moment about the holder's origin of the weight and the clamp's wrench.
TEST(ImplicitReactions, GraspOfHangingCordCarriesItsWeightUnderEveryIntegrator) {
  const Scene scene = default_at_rest();
  const Wrench clamp = clamp_statics(scene);
  for (Integrator integ : kAll) {
    World w = scene.world;
    w.integrator = integ;
    w.time_step = step_for(integ);
    const Rod& rod = w.rods()[0];
    GraspSet g;
    const GraspSpec& spec = scene.grasps.at(0);
    const Eigen::Isometry3d holder = segment_pose(rod, grasp_segment(rod, spec));
    ASSERT_EQ(g.add(w, spec, holder, nullptr, w.time()), "");
    const Vec3 o = holder.translation();
    Vec3 weight = Vec3::Zero(), moment = Vec3::Zero();
    for (int i = 0; i < rod.num_nodes(); ++i) {
      const Vec3 wi = rod.node_masses()[i] * w.gravity;
      weight += wi;
      moment += (rod.positions()[i] - o).cross(wi);
    }
    const Vec3 force_ref = weight + clamp.force;
    const Vec3 moment_ref = moment + (clamp.point - o).cross(clamp.force) + clamp.moment;
    step(&w, &g, kSteps);
    Vec3 f, t;
    ASSERT_TRUE(g.take_reaction(spec.name, &f, &t));
    const Eigen::Matrix3d r = g.find(spec.name)->holder_pose().linear();
    f = r * f;  // holder frame to world
    t = r * t;
    std::printf(
        "%-20s gripper force %.9f %.9f %.9f N (expected %.9f %.9f %.9f; rel. error %.1e),"
        " moment %.3e N m (error %.1e)\n",
        integrator_name(integ), f.x(), f.y(), f.z(), force_ref.x(), force_ref.y(), force_ref.z(),
        (f - force_ref).norm() / force_ref.norm(), t.norm(), (t - moment_ref).norm());
    // The gripper carries about half the cord's weight: it must read it, not zero.
    EXPECT_GT(-f.z(), 0.3 * weight.norm()) << integrator_name(integ);
    EXPECT_LT((f - force_ref).norm(), 1e-6 * force_ref.norm()) << integrator_name(integ);
    EXPECT_LT((t - moment_ref).norm(), 1e-6 * force_ref.norm() * 0.6) << integrator_name(integ);
  }
}

// The ghost clamp's moment after steps from the equilibrium is statics' under every integrator
// (about 0.0077 N m: the clamp holds the cord's end at its arc's angle).
TEST(ImplicitReactions, GhostClampMomentUnderEveryIntegrator) {
  const Scene scene = default_at_rest();
  const Wrench statics = clamp_statics(scene);
  ASSERT_GT(statics.moment.norm(), 1e-3);
  for (Integrator integ : kAll) {
    Scene s = scene;
    World& w = s.world;
    w.integrator = integ;
    w.time_step = step_for(integ);
    GraspSet g;
    const Rod& rod = w.rods()[0];
    const GraspSpec& spec = s.grasps.at(0);
    ASSERT_EQ(g.add(w, spec, segment_pose(rod, grasp_segment(rod, spec)), nullptr, w.time()), "");
    step(&w, &g, kSteps);
    const Wrench r = support_reaction(w.rods()[0], clamp_of(s));
    std::printf("%-20s clamp moment %.9f %.9f %.9f N m (statics %.9f %.9f %.9f; rel. error %.1e)\n",
                integrator_name(integ), r.moment.x(), r.moment.y(), r.moment.z(),
                statics.moment.x(), statics.moment.y(), statics.moment.z(),
                (r.moment - statics.moment).norm() / statics.moment.norm());
    EXPECT_LT((r.moment - statics.moment).norm(), 1e-6 * statics.moment.norm())
        << integrator_name(integ);
  }
}

}  // namespace
}  // namespace corde
