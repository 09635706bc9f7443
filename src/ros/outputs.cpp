#include "corde_sim/ros/outputs.h"

#include <ros/console.h>
#include <ros/names.h>

#include <algorithm>
#include <boost/make_shared.hpp>
#include <cmath>
#include <cstdio>
#include <iterator>

namespace corde_sim {
namespace {

void set_transform(const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                   geometry_msgs::Transform* t) {
  t->translation.x = p.x();
  t->translation.y = p.y();
  t->translation.z = p.z();
  t->rotation.x = q.x();
  t->rotation.y = q.y();
  t->rotation.z = q.z();
  t->rotation.w = q.w();
}

void set_pose(const Eigen::Vector3d& p, const Eigen::Quaterniond& q, geometry_msgs::Pose* pose) {
  pose->position.x = p.x();
  pose->position.y = p.y();
  pose->position.z = p.z();
  pose->orientation.x = q.x();
  pose->orientation.y = q.y();
  pose->orientation.z = q.z();
  pose->orientation.w = q.w();
}

geometry_msgs::Point point(const Eigen::Vector3d& p) {
  geometry_msgs::Point out;
  out.x = p.x();
  out.y = p.y();
  out.z = p.z();
  return out;
}

std_msgs::ColorRGBA rgba(double r, double g, double b, double a = 1.0) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

// Blue (unstrained) through green to red (the rod's largest strain).
std_msgs::ColorRGBA strain_color(double v) {
  v = std::min(1.0, std::max(0.0, v));
  if (v < 0.5) {
    const double a = 2.0 * v;
    return rgba(0.15, 0.35 + 0.45 * a, 0.9 - 0.6 * a);
  }
  const double a = 2.0 * (v - 0.5);
  return rgba(0.15 + 0.8 * a, 0.8 - 0.6 * a, 0.3 - 0.2 * a);
}

std_msgs::ColorRGBA rod_color(size_t index) {
  static const double palette[][3] = {
      {0.85, 0.45, 0.1}, {0.2, 0.5, 0.9}, {0.3, 0.75, 0.3}, {0.8, 0.3, 0.7}, {0.9, 0.8, 0.2}};
  const double* c = palette[index % 5];
  return rgba(c[0], c[1], c[2]);
}

visualization_msgs::Marker base_marker(const std::string& ns, int id, int type,
                                       const MarkerOptions& o, const ros::Time& stamp) {
  visualization_msgs::Marker m;
  m.header.frame_id = o.world_frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

// The obstacles (the scene's, the robot's, those added at run time), grey and half transparent:
// planes as a 10 m square slab below their surface, capsules as a cylinder and two spheres, meshes
// as triangle lists.
void add_obstacle_markers(const corde::ObstacleSet& set, const MarkerOptions& o,
                          const ros::Time& stamp, visualization_msgs::MarkerArray* out) {
  using visualization_msgs::Marker;
  using Kind = corde::ObstacleShape::Kind;
  int id = 0;
  for (int i = 0; i < set.size(); ++i) {
    const corde::Obstacle& ob = set.obstacle(i);
    if (!ob.enabled) continue;  // removed at run time
    const Eigen::Isometry3d& pose = ob.pose;
    const Eigen::Quaterniond q(pose.linear());
    const corde::Vec3& size = ob.shape.size;
    Marker m = base_marker("obstacles", id++, Marker::CUBE, o, stamp);
    // Moving ones (robot links) tinted, to tell them from the scene's fixed obstacles.
    m.color = ob.moving ? rgba(0.55, 0.65, 0.85, 0.5) : rgba(0.6, 0.6, 0.65, 0.5);
    set_pose(pose.translation(), q, &m.pose);
    switch (ob.shape.kind) {
      case Kind::kPlane:
        set_pose(pose * Eigen::Vector3d(0, 0, -0.005), q, &m.pose);
        m.scale.x = m.scale.y = 10.0;
        m.scale.z = 0.01;
        break;
      case Kind::kBox:
        m.scale.x = size.x();
        m.scale.y = size.y();
        m.scale.z = size.z();
        break;
      case Kind::kSphere:
        m.type = Marker::SPHERE;
        m.scale.x = m.scale.y = m.scale.z = 2.0 * size.x();
        break;
      case Kind::kCylinder:
      case Kind::kCapsule:
        m.type = Marker::CYLINDER;
        m.scale.x = m.scale.y = 2.0 * size.x();
        m.scale.z = size.y();
        if (ob.shape.kind == Kind::kCapsule)
          for (double end : {-0.5, 0.5}) {
            Marker cap = base_marker("obstacles", id++, Marker::SPHERE, o, stamp);
            cap.color = m.color;
            set_pose(pose * Eigen::Vector3d(0, 0, end * size.y()), q, &cap.pose);
            cap.scale.x = cap.scale.y = cap.scale.z = 2.0 * size.x();
            out->markers.push_back(cap);
          }
        break;
      case Kind::kMesh:
        m.type = Marker::TRIANGLE_LIST;
        m.scale.x = m.scale.y = m.scale.z = 1.0;
        if (ob.shape.mesh)
          for (const Eigen::Vector3i& t : ob.shape.mesh->triangles)
            for (int k = 0; k < 3; ++k) m.points.push_back(point(ob.shape.mesh->vertices[t[k]]));
        break;
    }
    out->markers.push_back(std::move(m));
  }
}

}  // namespace

void TfFrames::layout(const corde::World& world, const std::vector<GraspView>& grasps,
                      const std::string& prefix, const std::string& world_frame, int every_k) {
  every_k_ = std::max(1, every_k);
  laid_out_node_frames_ = node_frames_;
  tfs_.clear();
  geometry_msgs::TransformStamped t;
  t.header.frame_id = world_frame;
  t.transform.rotation.w = 1.0;
  for (const corde::Rod& rod : world.rods()) {
    t.child_frame_id = prefix + rod.name();
    tfs_.push_back(t);
    for (int s = 0; s < rod.num_segments(); s += every_k_) {
      t.child_frame_id = prefix + rod.name() + "/seg_" + std::to_string(s);
      tfs_.push_back(t);
    }
    t.child_frame_id = prefix + rod.name() + "/tip";
    tfs_.push_back(t);
    for (int i = 0; laid_out_node_frames_ && i < rod.num_nodes(); ++i) {
      t.child_frame_id = prefix + rod.name() + "/node_" + std::to_string(i);
      tfs_.push_back(t);
    }
  }
  for (const GraspView& g : grasps) {
    t.child_frame_id = prefix + "grasp/" + g.name;
    tfs_.push_back(t);
  }
}

const std::vector<geometry_msgs::TransformStamped>& TfFrames::update(
    const corde::World& world, const std::vector<GraspView>& grasps, const ros::Time& stamp) {
  size_t i = 0;
  for (const corde::Rod& rod : world.rods()) {
    const auto& x = rod.positions();
    const auto& q = rod.orientations();
    tfs_[i].header.stamp = stamp;
    set_transform(x[0], q[0], &tfs_[i++].transform);
    for (int s = 0; s < rod.num_segments(); s += every_k_) {
      tfs_[i].header.stamp = stamp;
      set_transform(0.5 * (x[s] + x[s + 1]), q[s], &tfs_[i++].transform);
    }
    const int last = rod.num_segments() - 1;
    tfs_[i].header.stamp = stamp;
    set_transform(x[last + 1], q[last], &tfs_[i++].transform);
    for (int n = 0; laid_out_node_frames_ && n <= last + 1; ++n) {
      tfs_[i].header.stamp = stamp;
      set_transform(x[n], q[std::min(n, last)], &tfs_[i++].transform);
    }
  }
  for (const GraspView& g : grasps) {
    tfs_[i].header.stamp = stamp;
    set_transform(g.pose.translation(), Eigen::Quaterniond(g.pose.linear()), &tfs_[i++].transform);
  }
  return tfs_;
}

void segment_strains(const corde::Rod& rod, std::vector<double>* strain) {
  const int n = rod.num_segments();
  strain->assign(n, 0.0);
  if (n < 2) return;
  const double r = rod.section().radius;
  const auto& q = rod.orientations();
  const auto& rest = rod.rest_lengths();
  for (int j = 0; j + 1 < n; ++j) {
    const corde::Vec3 u = corde::darboux(q[j], q[j + 1], 0.5 * (rest[j] + rest[j + 1]));
    const double e = r * (u - rod.rest_strains()[j]).norm();
    (*strain)[j] += 0.5 * e;
    (*strain)[j + 1] += 0.5 * e;
  }
  (*strain)[0] *= 2.0;
  (*strain)[n - 1] *= 2.0;
}

void build_markers(const corde::World& world, const std::vector<GraspView>& grasps,
                   const MarkerOptions& o, const ros::Time& stamp, bool clear_first,
                   visualization_msgs::MarkerArray* out) {
  using visualization_msgs::Marker;
  out->markers.clear();
  if (clear_first) {
    Marker clear;
    clear.header.frame_id = o.world_frame;
    clear.header.stamp = stamp;
    clear.action = 3;  // DELETEALL (constant missing from older message headers)
    out->markers.push_back(clear);
  }
  std::vector<double> strain;
  std::vector<int> clamped;
  double max_diameter = 0.0;
  int node_base = 0;  // index of the rod's node 0 counted over all rods: the clamps' ids
  for (size_t r = 0; r < world.rods().size(); ++r) {
    const corde::Rod& rod = world.rods()[r];
    const int n = rod.num_segments();
    const auto& x = rod.positions();
    const auto& q = rod.orientations();
    const double diameter = std::max(2.0 * rod.section().radius, o.min_diameter);
    max_diameter = std::max(max_diameter, diameter);
    double top = 0.0;
    if (o.color_by_strain) {
      segment_strains(rod, &strain);
      // Scaled by the rod's own largest strain so that any material shows its pattern; the floor
      // keeps a nearly straight rod blue instead of amplifying round-off.
      top = std::max(1e-4, *std::max_element(strain.begin(), strain.end()));
      for (double& e : strain) e /= top;
    }
    const std_msgs::ColorRGBA solid = rod_color(r);
    auto color = [&](int s) { return o.color_by_strain ? strain_color(strain[s]) : solid; };
    if (o.style == MarkerStyle::kCylinders) {
      for (int s = 0; s < n; ++s) {
        Marker m = base_marker(rod.name(), s, Marker::CYLINDER, o, stamp);
        const Eigen::Vector3d d = x[s + 1] - x[s];
        set_pose(0.5 * (x[s] + x[s + 1]), q[s], &m.pose);
        m.scale.x = m.scale.y = diameter;
        // Slightly longer than the chord so that neighbours overlap at bends.
        m.scale.z = d.norm() + 0.5 * diameter;
        m.color = color(s);
        out->markers.push_back(std::move(m));
      }
    } else {
      Marker m = base_marker(rod.name(), 0, Marker::LINE_STRIP, o, stamp);
      m.scale.x = diameter;
      m.points.reserve(n + 1);
      m.colors.reserve(n + 1);
      for (int i = 0; i <= n; ++i) {
        m.points.push_back(point(x[i]));
        m.colors.push_back(color(std::min(i, n - 1)));
      }
      m.color = solid;
      out->markers.push_back(std::move(m));
    }
    if (o.show_frames) {
      Marker m = base_marker(rod.name() + "/frames", 0, Marker::LINE_LIST, o, stamp);
      m.scale.x = 0.25 * diameter;
      m.color = rgba(1, 1, 1);
      for (int s = 0; s < n; s += std::max(1, o.frames_every_k)) {
        const Eigen::Vector3d mid = 0.5 * (x[s] + x[s + 1]);
        const double len = std::max(0.6 * (x[s + 1] - x[s]).norm(), 3.0 * diameter);
        const Eigen::Matrix3d rot = q[s].toRotationMatrix();
        for (int k = 0; k < 3; ++k) {
          m.points.push_back(point(mid));
          m.points.push_back(point(mid + len * rot.col(k)));
          const std_msgs::ColorRGBA c = rgba(k == 0, k == 1, k == 2);
          m.colors.push_back(c);
          m.colors.push_back(c);
        }
      }
      out->markers.push_back(std::move(m));
    }
    // Clamps: every fixed or keyframed node and every ghost-clamped end (a ghost clamp also fixes
    // its node, so each node is drawn once), oriented with the ghost frame or the adjacent segment
    // (frozen too for a natural clamp). A flat box shows the clamp's d1/d2 axes, unlike a disc.
    clamped.clear();
    for (const corde::NodeDrive& d : rod.node_drives())
      if (d.kind == corde::NodeDrive::Kind::kFixed || d.kind == corde::NodeDrive::Kind::kMotion)
        clamped.push_back(d.node);
    if (rod.ghost_start().active) clamped.push_back(0);
    if (rod.ghost_end().active) clamped.push_back(n);
    std::sort(clamped.begin(), clamped.end());
    clamped.erase(std::unique(clamped.begin(), clamped.end()), clamped.end());
    for (int i : clamped) {
      Marker m = base_marker("clamps", node_base + i, Marker::CUBE, o, stamp);
      corde::Quat frame = q[std::min(i, n - 1)];
      if (i == 0 && rod.ghost_start().active) frame = rod.ghost_start().frame;
      if (i == n && rod.ghost_end().active) frame = rod.ghost_end().frame;
      set_pose(x[i], frame, &m.pose);
      m.scale.x = m.scale.y = 2.5 * diameter;
      m.scale.z = 0.8 * diameter;
      m.color = rgba(0.55, 0.55, 0.58);
      out->markers.push_back(std::move(m));
    }
    if (o.color_by_strain) {
      // Above the start, clear of a clamp there.
      Marker m = base_marker("legend", static_cast<int>(r), Marker::TEXT_VIEW_FACING, o, stamp);
      const double height = std::max(0.02, 2.0 * diameter);
      m.pose.position = point(x[0] + Eigen::Vector3d(0, 0, 2.0 * diameter + 1.5 * height));
      m.scale.z = height;
      m.color = rgba(1, 1, 1);
      m.text = strain_legend(rod.name(), top);
      out->markers.push_back(std::move(m));
    }
    node_base += rod.num_nodes();
  }
  const double grasp_size = std::max(0.02, 3.0 * max_diameter);
  for (const GraspView& g : grasps) {
    Marker m = base_marker("grasps", g.id, Marker::SPHERE, o, stamp);
    set_pose(g.pose.translation(), Eigen::Quaterniond(g.pose.linear()), &m.pose);
    m.scale.x = m.scale.y = m.scale.z = grasp_size;
    m.color = rgba(1.0, 0.85, 0.1, 0.8);
    out->markers.push_back(m);
    Marker label = base_marker("grasp_labels", g.id, Marker::TEXT_VIEW_FACING, o, stamp);
    label.pose.position = point(g.pose.translation() + Eigen::Vector3d(0, 0, 1.2 * grasp_size));
    label.scale.z = grasp_size;
    label.color = rgba(1, 1, 1);
    label.text = g.name;
    out->markers.push_back(std::move(label));
  }
  if (world.obstacles) add_obstacle_markers(*world.obstacles, o, stamp, out);
}

int add_contact_markers(const corde::World& world, double force_scale, const MarkerOptions& o,
                        const ros::Time& stamp, int previous,
                        visualization_msgs::MarkerArray* out) {
  using visualization_msgs::Marker;
  const corde::ContactSystem* system = world.contacts();
  const std::vector<corde::Contact> none;
  const std::vector<corde::Contact>& contacts = system ? system->contacts() : none;
  double diameter = o.min_diameter;
  for (const corde::Rod& rod : world.rods())
    diameter = std::max(diameter, 2.0 * rod.section().radius);
  const double h = world.time_step;
  Marker points = base_marker("contacts", 0, Marker::SPHERE_LIST, o, stamp);
  points.scale.x = points.scale.y = points.scale.z = 0.8 * diameter;
  points.color = rgba(0.9, 0.1, 0.1);
  int arrows = 0;
  for (const corde::Contact& c : contacts) {
    const Eigen::Vector3d p = c.point;
    if (!p.allFinite()) continue;
    const bool active = c.pn > 0.0;
    points.points.push_back(point(p));
    points.colors.push_back(active ? rgba(0.9, 0.1, 0.1) : rgba(0.6, 0.6, 0.6, 0.7));
    if (!active || !(h > 0.0)) continue;
    const Eigen::Vector3d force = (c.pn * c.normal + c.pt) / h;  // on rod a
    const double length = std::min(0.5, force_scale * force.norm());
    if (!force.allFinite() || !(length > 1e-6)) continue;
    Marker arrow = base_marker("contact_forces", arrows++, Marker::ARROW, o, stamp);
    arrow.points.push_back(point(p));
    arrow.points.push_back(point(p + length * force.normalized()));
    arrow.scale.x = 0.25 * diameter;                         // shaft diameter
    arrow.scale.y = 0.6 * diameter;                          // head diameter
    arrow.scale.z = std::min(0.3 * length, 1.5 * diameter);  // head length
    arrow.color = rgba(1.0, 0.9, 0.1);
    out->markers.push_back(std::move(arrow));
  }
  if (points.points.empty()) points.action = Marker::DELETE;
  out->markers.push_back(std::move(points));
  for (int id = arrows; id < previous; ++id) {
    Marker gone = base_marker("contact_forces", id, Marker::ARROW, o, stamp);
    gone.action = Marker::DELETE;
    out->markers.push_back(std::move(gone));
  }
  return arrows;
}

std::string strain_legend(const std::string& rod, double top) {
  char scale[64];
  std::snprintf(scale, sizeof(scale), "%.2g", top);
  return rod + ": blue 0 .. red " + scale + " surface strain";
}

void fill_path(const corde::Rod& rod, const std_msgs::Header& header, nav_msgs::Path* out) {
  const auto& x = rod.positions();
  const auto& q = rod.orientations();
  const int last = rod.num_segments() - 1;
  out->header = header;
  out->poses.resize(x.size());
  for (int i = 0; i <= last + 1; ++i) {
    out->poses[i].header = header;
    set_pose(x[i], q[std::min(i, last)], &out->poses[i].pose);
  }
}

void fill_segment_poses(const corde::Rod& rod, const std_msgs::Header& header,
                        geometry_msgs::PoseArray* out) {
  const auto& x = rod.positions();
  const auto& q = rod.orientations();
  out->header = header;
  out->poses.resize(q.size());
  for (size_t s = 0; s < q.size(); ++s) set_pose(0.5 * (x[s] + x[s + 1]), q[s], &out->poses[s]);
}

void RodPaths::publish(ros::NodeHandle& nh, const corde::World& world,
                       const std::string& world_frame, const ros::Time& stamp) {
  // Follow the world's rods (a reset may load another scene): drop topics of rods that went.
  for (auto it = topics_.begin(); it != topics_.end();) {
    const auto& rods = world.rods();
    const bool present = std::any_of(
        rods.begin(), rods.end(), [&](const corde::Rod& rod) { return rod.name() == it->first; });
    it = present ? std::next(it) : topics_.erase(it);
  }
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = world_frame;
  for (const corde::Rod& rod : world.rods()) {
    auto found = topics_.find(rod.name());
    if (found == topics_.end()) {
      Topics t;
      // Rod names are free text in scene files; advertise would throw on one that is no name.
      std::string error;
      t.valid = ros::names::validate("rods/" + rod.name(), error);
      if (t.valid) {
        t.path = nh.advertise<nav_msgs::Path>("rods/" + rod.name() + "/path", 1);
        t.poses = nh.advertise<geometry_msgs::PoseArray>("rods/" + rod.name() + "/poses", 1);
      } else {
        ROS_WARN("corde_sim: rod '%s' gets no path and poses topics: %s", rod.name().c_str(),
                 error.c_str());
      }
      found = topics_.emplace(rod.name(), std::move(t)).first;
    }
    Topics& t = found->second;
    if (!t.valid) continue;
    if (t.path.getNumSubscribers() > 0) {
      auto msg = boost::make_shared<nav_msgs::Path>();
      fill_path(rod, header, msg.get());
      t.path.publish(msg);
    }
    if (t.poses.getNumSubscribers() > 0) {
      auto msg = boost::make_shared<geometry_msgs::PoseArray>();
      fill_segment_poses(rod, header, msg.get());
      t.poses.publish(msg);
    }
  }
}

void fill_rod_states(const corde::World& world, WorldState* msg) {
  msg->rods.resize(world.rods().size());
  for (size_t r = 0; r < world.rods().size(); ++r) {
    const corde::Rod& rod = world.rods()[r];
    RodState& out = msg->rods[r];
    out.name = rod.name();
    const int n = rod.num_segments();
    out.nodes.resize(n + 1);
    out.velocities.resize(n + 1);
    out.orientations.resize(n);
    out.angular_velocities.resize(n);
    out.tension.resize(n);
    for (int i = 0; i <= n; ++i) {
      out.nodes[i] = point(rod.positions()[i]);
      const corde::Vec3& v = rod.velocities()[i];
      out.velocities[i].x = v.x();
      out.velocities[i].y = v.y();
      out.velocities[i].z = v.z();
    }
    for (int s = 0; s < n; ++s) {
      const corde::Quat& q = rod.orientations()[s];
      out.orientations[s].x = q.x();
      out.orientations[s].y = q.y();
      out.orientations[s].z = q.z();
      out.orientations[s].w = q.w();
      const corde::Vec3 w = q * rod.angular_velocities()[s];
      out.angular_velocities[s].x = w.x();
      out.angular_velocities[s].y = w.y();
      out.angular_velocities[s].z = w.z();
      out.tension[s] = rod.tension(s);
    }
    out.max_strain = rod.max_stretch_strain();
    const corde::Energies e = rod.energies(world.gravity_at(world.time()));
    out.kinetic_energy = e.kinetic();
    out.elastic_energy = e.elastic();
  }
}

}  // namespace corde_sim
