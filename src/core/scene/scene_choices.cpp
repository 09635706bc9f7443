// Pass (c) of the scene loader (scene_passes.h): the automatic choices on the built scene,
// initial_state: equilibrium, time_step: auto and integrator: auto (scene/automatic_choices.h),
// each logged with its reason.
#include <cmath>
#include <cstdio>

#include "corde_sim/integrators/integrator_names.h"
#include "corde_sim/scene/automatic_choices.h"
#include "corde_sim/stability/explicit_step_limit.h"
#include "corde_sim/statics/scene_statics.h"
#include "scene_passes.h"

namespace corde {
namespace scene_detail {
namespace {

void check_time_step(Scene* scene, const Value* given) {
  const WorldStepLimit worst = explicit_step_limit(scene->world, false);
  const double limit = worst.time_step;
  const std::string which = worst.rod >= 0 ? scene->world.rods()[worst.rod].name() : "";
  if (!given) {
    // A degenerate rod (radius 1e-100) can give an infinite or zero limit: no step to run at.
    if (!(limit > 0.0 && std::isfinite(limit)))
      throw SceneError("time_step: auto: the estimated stability limit of rod '" + which + "' is " +
                       num(limit) +
                       " s, no step can be chosen; check the rod's "
                       "radius and material, or give time_step");
    scene->world.time_step = 0.8 * limit;
    return;
  }
  const double h = scene->world.time_step;
  if (h > limit)
    scene->warnings.push_back("time_step: " + num(h) + " s exceeds the estimated stability limit " +
                              num(limit) + " s of rod '" + which + "' (" + worst.limiting +
                              " modes); the run will likely blow up, use <= " + num(0.8 * limit) +
                              " s or time_step: auto");
}

// integrator: auto and time_step: auto for the implicit method (scene/automatic_choices.h); the
// explicit methods' step as check_time_step() has it.
void choose_step(Scene* scene, const Value* given, bool integrator_auto) {
  if (integrator_auto) {
    const IntegratorChoice c = choose_integrator(*scene, given ? scene->world.time_step : 0.0);
    scene->world.integrator = c.integrator;
    scene->world.time_step = c.time_step;
    scene->notes.push_back(c.reason);
  } else if (!has_explicit_step_limit(scene->world.integrator) && !given) {
    const ImplicitStepChoice s = implicit_time_step(*scene);
    scene->world.time_step = s.time_step;
    scene->notes.push_back("time_step: auto chose " + num(s.time_step) + " s for " +
                           integrator_name(scene->world.integrator) + ", set by " + s.why);
  }
  // The implicit methods have no stability limit to check.
  if (has_explicit_step_limit(scene->world.integrator)) check_time_step(scene, given);
}

}  // namespace

void make_automatic_choices(Scene* scene, const AutomaticRequests& requests) {
  // After the grasps (which hold the rod) and obstacles (which statics refuses) are known.
  for (const AutomaticRequests::Equilibrium& q : requests.equilibrium) {
    Rod& rod = scene->world.rods()[q.rod];
    RodEquilibrium e;
    try {
      e = settle_rod(scene, &rod);
    } catch (const SceneError& ex) {
      q.key.fail("equilibrium of " + q.rod_path + ": " + ex.what());
    }
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  ": started from its static equilibrium (residual %.3g N, %d Newton iterations, "
                  "%d load step%s)",
                  e.result.residual, e.result.iterations, e.result.load_steps,
                  e.result.load_steps == 1 ? "" : "s");
    scene->settled.push_back("rod '" + rod.name() + "'" + buf);
    if (e.potential && e.negative_modes > 0)
      scene->warnings.push_back(q.key.path() + ": the equilibrium of rod '" + rod.name() +
                                "' is unstable (" + std::to_string(e.negative_modes) +
                                " negative Hessian eigenvalues): the run will leave it");
  }
  choose_step(scene, requests.time_step ? &*requests.time_step : nullptr, requests.integrator_auto);
}

}  // namespace scene_detail
}  // namespace corde
