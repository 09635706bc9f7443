// Test helper for contact scenes: how deep any rod is inside an obstacle, another rod or itself,
// measured from the geometry alone (the rods' axes and radii, the obstacles' shapes), independent
// of what the contact solver reports. A scene run with its contacts switched off must show a
// large overlap here, so a test on this measure can fail.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "corde_sim/contact/obstacle.h"
#include "corde_sim/contact/segment_distance.h"
#include "corde_sim/world/world.h"

namespace corde {
namespace testing_overlap {

struct Overlap {
  double obstacle = 0.0;  // deepest: radius minus the axis' distance to an obstacle (m, >= 0)
  double rods = 0.0;      // deepest: sum of radii minus the distance of two rods' axes
  double self = 0.0;      // the same for a rod's own segments farther apart than the contact
                          // stage's neighbours (1 + ceil(0.8 pi r / l) segments; with
                          // `documented_window` from that many segments apart on, as
                          // docs/scene_format.md words it)
  double worst() const { return std::max({obstacle, rods, self}); }
};

// All pairs, brute force: O(segments^2); sample it every few steps in long runs.
inline Overlap measure_overlap(const World& world, bool documented_window = false) {
  Overlap out;
  const std::vector<Rod>& rods = world.rods();
  std::vector<SegmentContact> found;
  for (const Rod& rod : rods) {
    const double r = rod.section().radius;
    const auto& x = rod.positions();
    if (world.obstacles) {
      for (int s = 0; s + 1 < rod.num_nodes(); ++s) {
        found.clear();
        world.obstacles->query(x[s], x[s + 1], r, &found, nullptr);
        for (const SegmentContact& c : found) out.obstacle = std::max(out.obstacle, r - c.distance);
      }
    }
  }
  for (size_t a = 0; a < rods.size(); ++a) {
    const auto& xa = rods[a].positions();
    const double ra = rods[a].section().radius;
    for (size_t b = a; b < rods.size(); ++b) {
      const auto& xb = rods[b].positions();
      const double rb = rods[b].section().radius;
      for (int i = 0; i + 1 < rods[a].num_nodes(); ++i) {
        int skip = -1;
        if (a == b) {
          const double l = rods[a].rest_lengths()[i];
          skip = 1 + static_cast<int>(std::ceil(0.8 * M_PI * ra / l));
        }
        const int first = documented_window ? i + skip : i + skip + 1;
        for (int j = a == b ? first : 0; j + 1 < rods[b].num_nodes(); ++j) {
          const SegmentPair p = closest_points(xa[i], xa[i + 1], xb[j], xb[j + 1]);
          const Vec3 d = (xa[i] + p.s * (xa[i + 1] - xa[i])) - (xb[j] + p.t * (xb[j + 1] - xb[j]));
          const double depth = ra + rb - d.norm();
          double& slot = a == b ? out.self : out.rods;
          slot = std::max(slot, depth);
        }
      }
    }
  }
  return out;
}

// A scene run for `duration` seconds with its penetration watched: the contact stage's own report
// (every step) and the overlaps from the geometry (every `every` steps and at the end).
struct WatchedRun {
  double reported = 0.0;  // the contact stage's deepest penetration at detection, every step
  Overlap geometric;      // the deepest overlaps from the geometry, sampled
};

inline WatchedRun run_watched(World* w, double duration, int every) {
  WatchedRun out;
  const int steps = static_cast<int>(duration / w->time_step + 0.5);
  for (int k = 1; k <= steps; ++k) {
    w->step();
    if (w->contacts() != nullptr)
      out.reported = std::max(out.reported, w->contacts()->stats().max_penetration);
    if (k % every == 0 || k == steps) {
      const Overlap o = measure_overlap(*w);
      out.geometric.obstacle = std::max(out.geometric.obstacle, o.obstacle);
      out.geometric.rods = std::max(out.geometric.rods, o.rods);
      out.geometric.self = std::max(out.geometric.self, o.self);
    }
  }
  return out;
}

// The deepest overlap from the geometry after every step, with the documented self-contact window,
// and when it occurred.
struct EveryStep {
  Overlap deepest;
  double worst = 0.0;       // the largest of deepest's three
  double worst_time = 0.0;  // s, the time after the step that left it
};

inline EveryStep run_checked_every_step(World* w, double duration) {
  EveryStep out;
  const int steps = static_cast<int>(duration / w->time_step + 0.5);
  for (int k = 1; k <= steps; ++k) {
    w->step();
    const Overlap o = measure_overlap(*w, true);
    out.deepest.obstacle = std::max(out.deepest.obstacle, o.obstacle);
    out.deepest.rods = std::max(out.deepest.rods, o.rods);
    out.deepest.self = std::max(out.deepest.self, o.self);
    if (o.worst() > out.worst) {
      out.worst = o.worst();
      out.worst_time = w->time();
    }
  }
  return out;
}

}  // namespace testing_overlap
}  // namespace corde
