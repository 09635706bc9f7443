#include "corde_sim/scene_runner.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "corde_sim/grasp.h"
#include "corde_sim/stability.h"

namespace corde {

void write_csv_header(std::ostream& out) { out << "t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw\n"; }

void write_csv_rows(std::ostream& out, const World& world) {
  char buf[320];
  for (const Rod& rod : world.rods()) {
    const auto& x = rod.positions();
    const auto& q = rod.orientations();
    for (int s = 0; s < rod.num_segments(); ++s) {
      std::snprintf(buf, sizeof buf,
                    "%.9g,%s,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", world.time(),
                    rod.name().c_str(), s, x[s].x(), x[s].y(), x[s].z(), x[s + 1].x(), x[s + 1].y(),
                    x[s + 1].z(), q[s].x(), q[s].y(), q[s].z(), q[s].w());
      out << buf;
    }
  }
}

RunResult run_scene(Scene* scene, const RunOptions& options) {
  using Clock = std::chrono::steady_clock;
  World& world = scene->world;
  const double h = world.time_step;
  const double duration = options.duration >= 0.0 ? options.duration : scene->duration;
  const long steps = std::max(0L, static_cast<long>(std::ceil(duration / h - 1e-9)));
  RunResult r;
  r.every =
      options.every > 0 ? options.every : std::max(1, static_cast<int>(std::lround(0.01 / h)));
  // Grasps hold their segments where they are (the ROS node moves them instead).
  for (const GraspSpec& spec : scene->grasps) {
    Rod& rod = world.rod(spec.rod);
    const Eigen::Isometry3d holder = segment_pose(rod, grasp_segment(rod, spec));
    hold(rod, make_grasp(rod, spec, holder), holder);
  }
  const Clock::time_point start = Clock::now();
  Clock::time_point last_report = start;
  auto wall = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  if (options.csv) {
    write_csv_header(*options.csv);
    write_csv_rows(*options.csv, world);
  }
  long written = 0;
  for (long i = 1; i <= steps; ++i) {
    world.step();
    r.steps = i;
    if (!world.finite()) {
      r.finite = false;
      r.failed_step = i;
      r.failed_time = world.time();
      break;
    }
    if (options.csv && i % r.every == 0) {
      write_csv_rows(*options.csv, world);
      written = i;
    }
    if (options.progress && (i & 255) == 0) {
      const Clock::time_point now = Clock::now();
      if (std::chrono::duration<double>(now - last_report).count() >= options.progress_interval) {
        last_report = now;
        options.progress(static_cast<double>(i) / steps, world.time(), wall());
      }
    }
  }
  if (options.csv && r.finite && written != r.steps && r.steps > 0)
    write_csv_rows(*options.csv, world);
  r.wall_seconds = wall();
  r.sim_time = world.time();
  r.energies = world.energies();
  return r;
}

std::string run_summary(const Scene& scene, const RunResult& r) {
  std::string rods;
  for (const Rod& rod : scene.world.rods())
    rods += (rods.empty() ? "" : ", ") + rod.name() + " (" + std::to_string(rod.num_segments()) +
            " elements)";
  char buf[512];
  std::string out = "scene      " + scene.name + " (" + scene.source + ")\n";
  out += "rods       " + rods + "\n";
  for (const Rod& rod : scene.world.rods()) {
    const StabilityEstimate e = estimate_stability(rod);
    std::snprintf(buf, sizeof buf, "stability  %s: step limit %.3g s (%s), time step %.2f of it\n",
                  rod.name().c_str(), e.time_step, e.limiting.c_str(),
                  scene.world.time_step / e.time_step);
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "steps      %ld of %.3g s, %.6g s simulated\n", r.steps,
                scene.world.time_step, r.sim_time);
  out += buf;
  const double per_step = r.steps > 0 ? r.wall_seconds / r.steps * 1e6 : 0.0;
  std::snprintf(buf, sizeof buf, "wall time  %.3f s, %.3g us/step, real-time factor %.3g\n",
                r.wall_seconds, per_step, r.wall_seconds > 0 ? r.sim_time / r.wall_seconds : 0.0);
  out += buf;
  std::snprintf(buf, sizeof buf, "energy     kinetic %.6g J, elastic %.6g J%s\n",
                r.energies.kinetic(), r.energies.elastic(), r.finite ? "" : " (at failure)");
  out += buf;
  return out;
}

}  // namespace corde
