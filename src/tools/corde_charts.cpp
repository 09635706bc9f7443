// corde_charts: the charts that compare the integrators (docs/charts/, plotted by
// scripts/plot_charts.py): work-precision on three scenes, the stability map, the cost per step
// against N, the implicit method's numerical damping, and the implicit contact solves' cost
// against the number of contacts. Library only, no ROS. `--short` runs a
// few coarse points of each in seconds (the test command runs it); the full run takes minutes.
#include <cstdio>
#include <string>
#include <vector>

#include "chart_contacts.h"
#include "chart_stability.h"
#include "chart_work_precision.h"

namespace corde {
namespace charts {
namespace {

const char* kUsage =
    "usage: corde_charts [--short] [--out DIR] [--only work,map,scaling,damping,contacts|sag]\n"
    "  --short    a few coarse points of every chart (seconds; the test runs it)\n"
    "  --only L   only these charts (default all); sag: only scene (a) of work\n"
    "  --out DIR  folder for work_precision.csv, stability_map.csv, scaling.csv, damping.csv,\n"
    "             contact_solve.csv\n"
    "             (default docs/charts)\n";

struct Plan {
  bool full = true;
  std::vector<int> sag_n, v8_n, cable_n, map_n, scale_n;
  // split_rotation with rotational_inertia_scale: auto (at 0.9 of its step only).
  std::vector<int> sag_scaled_n, cable_scaled_n;
  std::vector<double> explicit_fractions, sag_h, v8_h, cable_h, cable_h_bdf2, youngs, h_omega;
  std::vector<int> modes;
  std::vector<int> contact_rod_n, contact_coil_n;
  double contact_duration = 1.0;
  int contact_repeats = 3;
  int damping_n = 40, cable_ref_n = 320, sag_repeats = 5;
  double sag_duration = 0.5, v8_periods = 5.0, cable_duration = 0.5, scale_cpu = 0.2;
  long map_steps_explicit = 1000, map_steps_implicit = 200;
  int map_iterations = 6;
};

Plan make_plan(bool full) {
  Plan p;
  p.full = full;
  if (full) {
    p.sag_n = {10, 20, 40, 80, 160};
    p.v8_n = {10, 20, 40, 80};
    p.cable_n = {10, 20, 40, 80, 160};
    p.sag_scaled_n = {6,  8,  10, 11, 12, 13, 14, 16, 18, 20, 22, 23, 24,
                      28, 32, 40, 44, 46, 48, 56, 64, 80, 92, 96, 160};
    p.cable_scaled_n = {10, 20, 40, 80, 160};
    p.map_n = {10, 40, 160};
    p.scale_n = {10, 30, 100, 300, 1000, 3000, 10000};
    p.explicit_fractions = {0.9, 0.45};
    p.sag_h = {2e-3, 1e-3, 5e-4};
    p.v8_h = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4};
    p.cable_h = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
    p.cable_h_bdf2 = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2.5e-4};
    p.youngs = {1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 2e11};
    p.h_omega = {0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0};
    p.modes = {1, 3};
    p.contact_rod_n = {10, 20, 40, 80, 160};
    p.contact_coil_n = {25, 50, 100, 200};
  } else {
    p.sag_n = p.v8_n = p.cable_n = p.map_n = p.sag_scaled_n = p.cable_scaled_n = {10};
    p.scale_n = {10, 100};
    p.explicit_fractions = {0.9};
    p.sag_h = p.v8_h = p.cable_h = p.cable_h_bdf2 = {2e-3};
    p.youngs = {1e6, 2e11};
    p.h_omega = {0.1, 1.0};
    p.modes = {1};
    p.damping_n = 10;
    p.cable_ref_n = 20;
    p.sag_repeats = 1;
    p.sag_duration = 0.02;
    p.v8_periods = 0.2;
    p.cable_duration = 0.02;
    p.scale_cpu = 0.01;
    p.map_steps_explicit = 200;
    p.map_steps_implicit = 20;
    p.map_iterations = 3;
    p.contact_rod_n = {10};
    p.contact_coil_n = {};
    p.contact_duration = 0.02;
    p.contact_repeats = 1;
  }
  return p;
}

FILE* open_csv(const std::string& dir, const char* name, const char* header) {
  const std::string path = dir + "/" + name;
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "corde_charts: cannot write %s\n", path.c_str());
    return nullptr;
  }
  std::fprintf(f, "%s\n", header);
  return f;
}

void row(FILE* f, const char* scene, Method m, int n, const WorkPoint& p) {
  std::fprintf(f, "%s,%s,%d,%.6e,%.4f,%.6e,%.3f,%ld\n", scene, method_name(m), n, p.h,
               p.cpu_per_frame_us, p.error, p.newton_per_step, p.failures);
  std::fflush(f);
  std::fprintf(stderr, "%-6s %-19s N=%-4d h=%.3g: %.2f us/frame, error %.3e\n", scene,
               method_name(m), n, p.h, p.cpu_per_frame_us, p.error);
}

// The scale `auto` chose and the steps it gives (stderr only: the CSV's h has the step).
void log_scale(const char* scene, int n, const Rod& rod) {
  Rod physical = rod;
  physical.set_rotational_inertia_scale(1.0);
  const StabilityEstimate e = estimate_stability(rod);
  std::fprintf(stderr,
               "%-6s N=%-4d rotational_inertia_scale auto = %.4g: step %.3g s (%s), "
               "physical %.3g s\n",
               scene, n, rod.rotational_inertia_scale(), e.time_step, e.limiting.c_str(),
               critical_time_step(physical));
}

// The steps each method runs a scene at: explicit methods at fractions of the critical step
// (rounded down to whole steps per `frame` when frame > 0), the implicit one at fixed steps.
std::vector<double> steps_for(Method m, const Rod& rod, const Plan& plan,
                              const std::vector<double>& implicit_h, double frame) {
  if (!is_explicit(m)) return implicit_h;
  std::vector<double> hs;
  const double crit = critical_time_step(rod);
  const std::vector<double> scaled = {0.9};
  for (double f : m == Method::kSplitRotationScaled ? scaled : plan.explicit_fractions)
    hs.push_back(frame > 0.0 ? frame / std::ceil(frame / (f * crit)) : f * crit);
  return hs;
}

bool work_precision(const Plan& plan, const std::string& dir, bool sag_only) {
  FILE* f = open_csv(dir, "work_precision.csv",
                     "scene,method,elements,h,cpu_per_frame_us,error,newton_per_step,failures");
  if (!f) return false;
  const SagElastica::Tip ref = SagScene::reference();
  std::fprintf(stderr, "sag reference tip: x %.6f z %.6f angle %.6f\n", ref.x, ref.z, ref.angle);
  for (Method m : kWorkMethods)
    for (int n : plan.sag_n)
      for (double h : steps_for(m, SagScene::rod(n), plan, plan.sag_h, 0.0))
        row(f, "sag", m, n, sag_point(m, n, h, plan.sag_duration, ref, plan.sag_repeats));
  const Method scaled = Method::kSplitRotationScaled;
  for (int n : plan.sag_scaled_n) {
    const Rod rod = SagScene::rod(n, scaled);
    log_scale("sag", n, rod);
    for (double h : steps_for(scaled, rod, plan, {}, 0.0))
      row(f, "sag", scaled, n, sag_point(scaled, n, h, plan.sag_duration, ref, plan.sag_repeats));
  }
  if (sag_only) {
    std::fclose(f);
    return true;
  }
  for (Method m : {Method::kSemiImplicitEuler, Method::kSplitRotation, Method::kImplicitEuler,
                   Method::kBdf2, Method::kSplitRotationScaled})
    for (int n : plan.v8_n) {
      v8::StepCase c;
      c.elements = n;
      c.method = m;
      for (double h : steps_for(m, v8::make_cantilever(c), plan, plan.v8_h, 0.0))
        row(f, "v8", m, n, v8_point(m, n, h, plan.v8_periods));
    }
  // The cable's reference: split_rotation at a quarter of the critical step, finest N.
  WorkPoint rp;
  const int nr = plan.cable_ref_n;
  const double hr =
      kCableFrame / std::ceil(kCableFrame / (0.25 * critical_time_step(CableScene::rod(nr))));
  const std::vector<Vec3> ref_tips =
      cable_tips(Method::kSplitRotation, nr, hr, plan.cable_duration, &rp);
  std::fprintf(stderr, "cable reference: N = %d, h = %.3g, %.1f us/frame\n", nr, hr,
               rp.cpu_per_frame_us);
  auto cable_row = [&](Method m, int n, double h) {
    WorkPoint p;
    const std::vector<Vec3> tips = cable_tips(m, n, h, plan.cable_duration, &p);
    if (std::isfinite(p.error)) p.error = tip_history_error(tips, ref_tips);
    row(f, "cable", m, n, p);
  };
  for (Method m : kWorkMethods)
    for (int n : plan.cable_n)
      for (double h : steps_for(m, CableScene::rod(n), plan,
                                m == Method::kBdf2 ? plan.cable_h_bdf2 : plan.cable_h, kCableFrame))
        cable_row(m, n, h);
  for (int n : plan.cable_scaled_n) {
    const Rod rod = CableScene::rod(n, scaled);
    log_scale("cable", n, rod);
    for (double h : steps_for(scaled, rod, plan, {}, kCableFrame)) cable_row(scaled, n, h);
  }
  std::fclose(f);
  return true;
}

bool stability_map(const Plan& plan, const std::string& dir) {
  FILE* f = open_csv(dir, "stability_map.csv",
                     "method,youngs,elements,predicted_h,measured_h,capped,ratio");
  if (!f) return false;
  const double cap = 0.02;
  for (Method m : kMethods)
    for (int n : plan.map_n)
      for (double e : plan.youngs) {
        const long steps = is_explicit(m) ? plan.map_steps_explicit : plan.map_steps_implicit;
        const StabilityPoint p = stable_step(e, n, m, steps, cap, plan.map_iterations);
        std::fprintf(f, "%s,%.3e,%d,%.6e,%.6e,%d,%.4f\n", method_name(m), e, n, p.predicted,
                     p.measured, p.capped ? 1 : 0, p.measured / p.predicted);
        std::fflush(f);
        std::fprintf(stderr, "map %-19s E=%.0e N=%-4d predicted %.3g measured %.3g%s\n",
                     method_name(m), e, n, p.predicted, p.measured, p.capped ? " (cap)" : "");
      }
  std::fclose(f);
  return true;
}

bool scaling(const Plan& plan, const std::string& dir) {
  FILE* f = open_csv(dir, "scaling.csv", "method,elements,h,us_per_step,newton_per_step");
  if (!f) return false;
  for (Method m : kMethods)
    for (int n : plan.scale_n) {
      const double h = is_explicit(m) ? 0.9 * critical_time_step(scaling_rod(n)) : 1e-3;
      double newton = 0.0;
      const double us = us_per_step(m, n, h, plan.scale_cpu, &newton);
      std::fprintf(f, "%s,%d,%.6e,%.4f,%.3f\n", method_name(m), n, h, us, newton);
      std::fflush(f);
      std::fprintf(stderr, "scaling %-19s N=%-5d %.2f us/step\n", method_name(m), n, us);
    }
  std::fclose(f);
  return true;
}

// Each scene, N and solve: the median CPU of contact_repeats runs (the other figures of that run).
bool contact_solves(const Plan& plan, const std::string& dir) {
  FILE* f = open_csv(dir, "contact_solve.csv",
                     "scene,solver,elements,contacts,cpu_per_second,iterations_per_step,"
                     "max_iterations,max_depth");
  if (!f) return false;
  for (int scene : {0, 1})
    for (int n : scene == 0 ? plan.contact_rod_n : plan.contact_coil_n)
      for (auto solver : {ContactSettings::Solver::kRounds, ContactSettings::Solver::kDelassus}) {
        std::vector<ContactPoint> runs;
        for (int k = 0; k < plan.contact_repeats; ++k)
          runs.push_back(contact_chart_run(scene, n, solver, plan.contact_duration));
        std::sort(runs.begin(), runs.end(), [](const ContactPoint& a, const ContactPoint& b) {
          return a.cpu_per_second < b.cpu_per_second;
        });
        const ContactPoint& p = runs[runs.size() / 2];
        const char* name = solver == ContactSettings::Solver::kDelassus ? "delassus" : "rounds";
        const char* what = scene == 0 ? "steel_rod" : "rope_coil";
        std::fprintf(f, "%s,%s,%d,%.2f,%.5f,%.3f,%d,%.5f\n", what, name, n, p.contacts,
                     p.cpu_per_second, p.iterations, p.max_iterations, p.max_depth);
        std::fflush(f);
        std::fprintf(stderr, "contacts %-9s %-8s N=%-4d %.0f contacts: %.4f s/s, %.2f it/step\n",
                     what, name, n, p.contacts, p.cpu_per_second, p.iterations);
      }
  std::fclose(f);
  return true;
}

bool damping(const Plan& plan, const std::string& dir) {
  FILE* f = open_csv(dir, "damping.csv",
                     "method,mode,elements,h_omega,omega,h,steps,factor_per_step,theory_per_step,"
                     "decay_per_period,theory_decay_per_period,damping_ratio,theory_damping_ratio");
  if (!f) return false;
  const int n = plan.damping_n;
  for (int mode : plan.modes) {
    std::vector<std::pair<Method, double>> runs;
    for (Method m : {Method::kImplicitEuler, Method::kBdf2})
      for (double x : plan.h_omega)
        // BDF2 above h w = 1: its start-up (a backward Euler step, the parasitic root) leaves
        // too little of the mode to measure its decay against.
        if (m != Method::kBdf2 || x <= 1.0) runs.push_back({m, x});
    // The explicit reference point: split_rotation at 0.9 of its critical step.
    {
      Rod r = fixed_start_rod(rod_material(1e7, 1000.0, 0.01), 0.01, 1.0, n, true);
      const Section& s = r.section();
      const v8::ModalSeries series(
          v8::Timoshenko{s.bend, s.kappa, s.mass_per_length, s.inertia_bend, 1.0}, mode);
      runs.push_back(
          {Method::kSplitRotation, 0.9 * critical_time_step(r) * series.omega(mode - 1)});
    }
    for (const auto& [m, x] : runs) {
      const DampingPoint p = mode_damping(m, n, mode, x);
      const double per_period = 2.0 * kPi / x;  // steps per period
      const double zeta = -std::log(p.factor_per_step) / x;
      const double zeta_theory = -std::log(p.theory_per_step) / x;
      std::fprintf(f, "%s,%d,%d,%.6e,%.6e,%.6e,%ld,%.9f,%.9f,%.6e,%.6e,%.6e,%.6e\n", method_name(m),
                   mode, n, x, p.omega, x / p.omega, p.steps, p.factor_per_step,
                   is_explicit(m) ? 1.0 : p.theory_per_step,
                   std::pow(p.factor_per_step, per_period),
                   is_explicit(m) ? 1.0 : std::pow(p.theory_per_step, per_period), zeta,
                   is_explicit(m) ? 0.0 : zeta_theory);
      std::fflush(f);
      std::fprintf(stderr, "damping %-19s mode %d h*omega %.3g: per step %.6f (theory %.6f)\n",
                   method_name(m), mode, x, p.factor_per_step, p.theory_per_step);
    }
  }
  std::fclose(f);
  return true;
}

}  // namespace
}  // namespace charts
}  // namespace corde

int main(int argc, char** argv) {
  using namespace corde::charts;
  bool full = true;
  std::string dir = "docs/charts", only = "work,map,scaling,damping,contacts";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::printf("%s", kUsage);
      return 0;
    } else if (a == "--short") {
      full = false;
    } else if (a == "--out" && i + 1 < argc) {
      dir = argv[++i];
    } else if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else {
      std::fprintf(stderr, "corde_charts: bad argument %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  const Plan plan = make_plan(full);
  auto want = [&](const char* name) { return only.find(name) != std::string::npos; };
  const bool ok =
      (!(want("work") || want("sag")) || work_precision(plan, dir, !want("work"))) &&
      (!want("map") || stability_map(plan, dir)) && (!want("scaling") || scaling(plan, dir)) &&
      (!want("damping") || damping(plan, dir)) && (!want("contacts") || contact_solves(plan, dir));
  return ok ? 0 : 1;
}
