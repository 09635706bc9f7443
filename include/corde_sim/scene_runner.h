// Running a scene without ROS: the loop behind the corde_run tool.
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "corde_sim/scene.h"

namespace corde {

struct RunOptions {
  double duration = -1.0;       // s; < 0: the scene's duration
  int every = 0;                // CSV rows every K steps (and at the start and end); 0: auto
  std::ostream* csv = nullptr;  // where to write the trajectory, or none
  // Called about every `progress_interval` seconds of wall time with the fraction done.
  std::function<void(double fraction, double sim_time, double wall_seconds)> progress;
  double progress_interval = 0.25;
};

struct RunResult {
  long steps = 0;             // steps taken
  double sim_time = 0.0;      // s, the world's clock at the end
  double wall_seconds = 0.0;  // time spent stepping (and writing CSV)
  bool finite = true;         // false: the state blew up at failed_step
  long failed_step = -1;      // first step whose result was non-finite
  double failed_time = 0.0;   // the world's time after that step
  WorldEnergies energies;     // at the end (or at failure)
  int every = 0;              // the CSV interval used
};

// The CSV header: t,rod,segment,x0,y0,z0,x1,y1,z1,qx,qy,qz,qw
void write_csv_header(std::ostream& out);
// One row per segment of every rod: time, rod name, segment, its two nodes, its orientation.
void write_csv_rows(std::ostream& out, const World& world);

// Steps the scene's world for the duration, holding each grasp where it is at the start. Stops
// at the first non-finite state.
RunResult run_scene(Scene* scene, const RunOptions& options = {});

// Multiline summary: scene, rods and elements, steps, simulated and wall time, time per step,
// final kinetic and elastic energy.
std::string run_summary(const Scene& scene, const RunResult& result);

}  // namespace corde
