// The rod's surface as points, for planners and occupancy maps (the node's `surface_cloud`,
// a sensor_msgs/PointCloud2): rings of points around each segment's axis at the rod's radius.
// No ROS here.
#pragma once

#include <vector>

#include "corde_sim/rod/rod.h"

namespace corde_sim {

// Limits of the cloud's parameters (docs/ros_interface.md, "Outputs").
constexpr int kMaxCloudPointsPerRing = 64;
constexpr int kMaxCloudRingsPerSegment = 16;

// Appends x, y, z (world frame, m) of rings_per_segment * points_per_ring points per segment:
// ring j of segment s at the fraction (j + 0.5) / rings_per_segment of the segment from node s,
// its points evenly spaced around the axis, each at the rod's radius from it. A rod of n segments
// gives n * rings_per_segment * points_per_ring points. Both counts must be >= 1.
void append_surface_points(const corde::Rod& rod, int rings_per_segment, int points_per_ring,
                           std::vector<float>* xyz);

}  // namespace corde_sim
