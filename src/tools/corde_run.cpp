// corde_run: runs a scene file without ROS and prints a summary (docs/scene_format.md).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "corde_sim/scene/scene.h"
#include "corde_sim/scene/scene_runner.h"
#include "corde_sim/statics/scene_statics.h"

namespace {

const char* kUsage =
    "usage: corde_run SCENE.yaml [--duration S] [--dt H] [--set key.path=value ...]\n"
    "                 [--out FILE.csv] [--reactions FILE.csv] [--energies FILE.csv]\n"
    "                 [--every K] [--max-speed V] [--max-strain E]\n"
    "                 [--max-energy J] [--max-steps N] [--statics [--at T]] [--dynamics]\n"
    "                 [--no-guard] [--quiet]\n"
    "  --duration S   simulated time (s), overrides the scene's duration\n"
    "  --dt H         time step (s), overrides the scene's time_step\n"
    "  --set K=V      override a scene key, e.g. --set rods.0.elements=100 (repeatable)\n"
    "  --out FILE     write t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw rows as CSV\n"
    "  --reactions F  write t,support,rod,fx,fy,fz,mx,my,mz,px,py,pz rows: the force and\n"
    "                 moment each clamp, driven item and grasp exerts on its rod (about p)\n"
    "  --energies F   write t,rod,kinetic_translation,kinetic_rotation,stretch,bend_twist,\n"
    "                 coupling,gravity,total rows (J)\n"
    "  --every K      CSV rows every K steps (default: every 10 ms of simulated time)\n"
    "  --max-speed V  stop when a node moves faster than V m/s (default 100)\n"
    "  --max-strain E stop when a segment's |axial strain| exceeds E (default 10; 0: off)\n"
    "  --max-energy J stop when a rod's (kinetic + elastic energy) / mass exceeds J J/kg\n"
    "                 (default 1e5; 0: off)\n"
    "  --max-steps N  refuse runs of more than N steps (default 1e9)\n"
    "  --statics      solve the static equilibrium instead of running (scene key mode:\n"
    "                 statics): per rod its residual, Newton iterations, load steps,\n"
    "                 stability and sag, per support its reaction; --out, --reactions and\n"
    "                 --energies write the equilibrium\n"
    "  --at T         statics with the drives and grasps at time T s (scene key\n"
    "                 statics_time; default 0)\n"
    "  --dynamics     run the scene even if it says mode: statics\n"
    "  --no-guard     run without the stability guard (which checks the state every 64\n"
    "                 steps, rolls back and retries with a smaller step or the implicit\n"
    "                 method; docs/stability_guard.md), e.g. to benchmark the bare steps\n"
    "  --quiet        print only errors\n"
    "exit status: 0 done (the guard may have recovered: see stderr and the summary),\n"
    "  1 bad scene or file, or one statics cannot handle, 2 bad usage, 3 the run blew up\n"
    "  (runaway checks, --no-guard), 4 statics found no equilibrium, 5 the guard could not\n"
    "  recover (the run stopped at the last good state), 6 internal error (an unexpected\n"
    "  exception, e.g. out of memory; the message says what)\n";

int usage_error(const std::string& msg) {
  std::fprintf(stderr, "corde_run: %s\n%s", msg.c_str(), kUsage);
  return 2;
}

// --statics: solves the equilibrium, prints its report and writes the output files at it.
int run_statics(corde::Scene* scene, const std::string& scene_path, bool quiet,
                const std::string& out_path, const std::string& reactions_path,
                const std::string& energies_path) {
  corde::SceneEquilibrium eq;
  try {
    eq = corde::solve_scene_statics(scene, scene->statics_time);
  } catch (const corde::SceneError& e) {
    std::fprintf(stderr, "corde_run: %s: %s\n", scene_path.c_str(), e.what());
    return 1;
  }
  if (!quiet) std::printf("%s", corde::statics_summary(*scene, eq).c_str());
  // The last iterate of a failed solve is written too (to see where it stuck), but never a
  // non-finite state.
  const bool finite = scene->world.finite();
  auto write = [&](const std::string& path, auto&& header, auto&& rows) {
    if (path.empty()) return true;
    std::ofstream out(path);
    header(out);
    if (finite) rows(out);
    out.close();
    if (!out) std::fprintf(stderr, "corde_run: cannot write '%s'\n", path.c_str());
    return static_cast<bool>(out);
  };
  const corde::World& world = scene->world;
  const bool written = write(out_path, corde::write_csv_header,
                             [&](std::ostream& o) { corde::write_csv_rows(o, world); }) &&
                       write(reactions_path, corde::write_reaction_header,
                             [&](std::ostream& o) { corde::write_reaction_rows(o, *scene); }) &&
                       write(energies_path, corde::write_energy_header,
                             [&](std::ostream& o) { corde::write_energy_rows(o, world); });
  if (!written) return 1;
  if (!eq.ok) {
    std::fprintf(stderr, "corde_run: %s: statics: %s%s\n", scene_path.c_str(), eq.problem.c_str(),
                 out_path.empty() ? "" : "; --out holds the last iterate");
    return 4;
  }
  return 0;
}

int run(int argc, char** argv);

}  // namespace

// Any exception that escapes is reported as corde_run's own error (status 6), never an abort.
int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "corde_run: internal error: %s\n", e.what());
  } catch (...) {
    std::fflush(stdout);
    std::fprintf(stderr, "corde_run: internal error: an unknown exception\n");
  }
  return 6;
}

namespace {

int run(int argc, char** argv) {
  std::string scene_path, out_path, reactions_path, energies_path;
  std::vector<std::string> overrides;
  int every = 0;
  bool quiet = false, at_given = false;
  std::string forced_mode;
  corde::RunOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc) return false;
      *v = argv[++i];
      return true;
    };
    std::string v;
    if (a == "-h" || a == "--help") {
      std::printf("%s", kUsage);
      return 0;
    } else if (a == "--quiet" || a == "-q") {
      quiet = true;
    } else if (a == "--statics" || a == "--dynamics") {
      overrides.push_back(a == "--statics" ? "mode=statics" : "mode=dynamics");
      forced_mode = a;
    } else if (a == "--at") {
      if (!value(&v)) return usage_error(a + " needs a value");
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !std::isfinite(x) || x < 0.0)
        return usage_error("--at needs a non-negative time in s, got '" + v + "'");
      overrides.push_back("statics_time=" + v);
      at_given = true;
    } else if (a == "--no-guard") {
      options.guard.enabled = false;
    } else if (a == "--max-speed" || a == "--max-strain" || a == "--max-energy" ||
               a == "--max-steps") {
      if (!value(&v)) return usage_error(a + " needs a value");
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      const bool zero_ok = a == "--max-strain" || a == "--max-energy";
      if (end == v.c_str() || *end != '\0' || !std::isfinite(x) || x < 0.0 || (x == 0 && !zero_ok))
        return usage_error(a + " needs a " + (zero_ok ? "non-negative" : "positive") +
                           " number, got '" + v + "'");
      if (a == "--max-speed") options.limits.max_speed = x;
      if (a == "--max-strain") options.limits.max_stretch = options.limits.max_compression = x;
      if (a == "--max-energy") options.limits.max_specific_energy = x;
      if (a == "--max-steps") options.max_steps = x;
    } else if (a == "--duration" || a == "--dt" || a == "--set" || a == "--out" || a == "--every" ||
               a == "--reactions" || a == "--energies") {
      if (!value(&v)) return usage_error(a + " needs a value");
      if (a == "--duration") overrides.push_back("duration=" + v);
      if (a == "--dt") overrides.push_back("time_step=" + v);
      if (a == "--set") {
        if (v.find('=') == std::string::npos) return usage_error("--set needs key.path=value");
        overrides.push_back(v);
      }
      if (a == "--out") out_path = v;
      if (a == "--reactions") reactions_path = v;
      if (a == "--energies") energies_path = v;
      if (a == "--every") {
        char* end = nullptr;
        const long k = std::strtol(v.c_str(), &end, 10);
        if (*end != '\0' || k < 1 || k > 1000000000)
          return usage_error("--every needs a positive integer, got '" + v + "'");
        every = static_cast<int>(k);
      }
    } else if (!a.empty() && a[0] == '-') {
      return usage_error("unknown option " + a);
    } else if (scene_path.empty()) {
      scene_path = a;
    } else {
      return usage_error("more than one scene file given ('" + scene_path + "', '" + a + "')");
    }
  }
  if (scene_path.empty()) return usage_error("no scene file given");
  if (at_given && forced_mode == "--dynamics")
    return usage_error("--at is the time of a statics solve; it does not go with --dynamics");

  corde::Scene scene;
  try {
    scene = corde::load_scene(scene_path, overrides);
  } catch (const corde::SceneError& e) {
    const std::string msg = e.what();  // file errors already start with the file's name
    if (msg.rfind(scene_path, 0) == 0)
      std::fprintf(stderr, "corde_run: %s\n", msg.c_str());
    else
      std::fprintf(stderr, "corde_run: %s: %s\n", scene_path.c_str(), msg.c_str());
    return 1;
  }
  if (!quiet)
    for (const std::string& w : scene.warnings)
      std::fprintf(stderr, "corde_run: warning: %s\n", w.c_str());

  std::ofstream csv, reactions, energies;
  options.every = every;
  for (auto [path, stream, slot] :
       {std::make_tuple(&out_path, &csv, &options.csv),
        std::make_tuple(&reactions_path, &reactions, &options.reactions),
        std::make_tuple(&energies_path, &energies, &options.energies)}) {
    if (path->empty()) continue;
    stream->open(*path);
    if (!*stream) {
      std::fprintf(stderr, "corde_run: cannot write '%s'\n", path->c_str());
      return 1;
    }
    *slot = stream;
  }
  if (scene.mode == corde::Scene::Mode::kStatics)
    return run_statics(&scene, scene_path, quiet, out_path, reactions_path, energies_path);
  if (at_given)
    return usage_error("--at is the time of a statics solve; add --statics (or mode: statics)");
  if (!quiet)
    for (const std::string& s : scene.settled) std::printf("initial    %s\n", s.c_str());
  const bool terminal = !quiet && isatty(STDERR_FILENO);
  bool progress_shown = false;
  if (terminal) {
    options.progress = [&](double fraction, double t, double wall) {
      if (wall < 2.0 || fraction <= 0.0) return;
      const double eta = wall * (1.0 - fraction) / fraction;
      std::fprintf(stderr, "\r\033[K[%3.0f%%] t = %.4g / %.4g s, ETA %.0f s", 100.0 * fraction, t,
                   scene.duration, eta);
      std::fflush(stderr);
      progress_shown = true;
    };
  }
  // Guard events as they happen; with --quiet only the unrecoverable one (an error).
  options.on_guard_event = [&](const corde::GuardEvent& e) {
    const bool fatal = e.kind == corde::GuardEvent::Kind::kUnrecoverable;
    if (quiet && !fatal) return;
    if (progress_shown) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "corde_run: guard: %s%s\n", fatal ? "UNRECOVERABLE: " : "",
                 e.message().c_str());
  };
  // Deep contacts (a pinch, an obstacle moved into the rod), throttled by run_scene.
  options.on_deep_contact = [&](double t, const std::string& report) {
    if (quiet) return;
    if (progress_shown) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "corde_run: deep contact at t = %.6g s: %s\n", t, report.c_str());
  };
  corde::RunResult result;
  try {
    result = corde::run_scene(&scene, options);
  } catch (const corde::SceneError& e) {
    std::fprintf(stderr, "corde_run: %s: %s\n", scene_path.c_str(), e.what());
    return 1;
  }
  if (progress_shown) std::fprintf(stderr, "\r\033[K");
  bool write_failed = result.write_failed;
  std::string failed_path;
  for (auto [path, stream] :
       {std::make_pair(&out_path, &csv), std::make_pair(&reactions_path, &reactions),
        std::make_pair(&energies_path, &energies)}) {
    if (!stream->is_open()) continue;
    stream->close();
    if (!*stream && failed_path.empty()) failed_path = *path;
    write_failed = write_failed || !*stream;
  }
  if (!quiet) std::printf("%s", corde::run_summary(scene, result).c_str());
  if (write_failed) {
    std::fprintf(stderr, "corde_run: error writing '%s' (disk full?)%s\n", failed_path.c_str(),
                 result.write_failed ? "; the run stopped there" : "");
    return 1;
  }
  if (!result.ok && result.guard_failed) {
    std::fprintf(stderr,
                 "corde_run: the stability guard could not recover (every retry failed); the run "
                 "stopped at its last good state, t = %.6g s%s\n",
                 result.failed_time,
                 out_path.empty() && reactions_path.empty() && energies_path.empty()
                     ? ""
                     : "; the CSV files end with the last frame before it");
    return 5;
  }
  if (!result.ok) {
    std::fprintf(stderr,
                 "corde_run: the run blew up at step %ld (t = %.6g s): %s%s; try a smaller time "
                 "step (--dt)\n",
                 result.failed_step, result.failed_time, result.problem.c_str(),
                 out_path.empty() && reactions_path.empty() && energies_path.empty()
                     ? ""
                     : "; the CSV files end with the last frame before it");
    return 3;
  }
  return 0;
}

}  // namespace
