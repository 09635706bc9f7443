// The rods' surface as a sensor_msgs/PointCloud2 (surface_cloud), for planners and occupancy
// maps: x, y, z as float32, in the world frame, unordered (height 1), no invalid points.
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <cstring>

#include "corde_sim/ros/node_outputs.h"
#include "corde_sim/ros/sim_node.h"
#include "corde_sim/ros/surface_cloud.h"

namespace corde_sim {

void NodeOutputs::publish_cloud() {
  if (cloud_pub_.getNumSubscribers() == 0) return;
  const NodeParams& p = node_.params_;
  std::vector<float> xyz;
  for (const corde::Rod& rod : node_.world_.rods())
    append_surface_points(rod, p.cloud_rings_per_segment, p.cloud_points_per_ring, &xyz);
  auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
  msg->header.frame_id = p.world_frame;
  msg->header.stamp = node_.stamp();
  sensor_msgs::PointCloud2Modifier modifier(*msg);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(xyz.size() / 3);
  msg->height = 1;
  msg->width = static_cast<uint32_t>(xyz.size() / 3);
  msg->is_dense = true;
  // xyz alone: the fields are packed (point_step 12 bytes, no padding) as the points are.
  if (msg->point_step == 3 * sizeof(float)) {
    if (!xyz.empty()) std::memcpy(msg->data.data(), xyz.data(), xyz.size() * sizeof(float));
  } else {
    sensor_msgs::PointCloud2Iterator<float> x(*msg, "x"), y(*msg, "y"), z(*msg, "z");
    for (size_t i = 0; i < xyz.size(); i += 3, ++x, ++y, ++z) {
      *x = xyz[i];
      *y = xyz[i + 1];
      *z = xyz[i + 2];
    }
  }
  cloud_pub_.publish(msg);
}

}  // namespace corde_sim
