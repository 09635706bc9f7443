#include "corde_sim/ros/node_params.h"

#include <ros/console.h>

#include <cmath>
#include <stdexcept>

#include "corde_sim/rod/rod.h"
#include "corde_sim/ros/configure.h"
#include "corde_sim/ros/input_checks.h"
#include "corde_sim/ros/surface_cloud.h"
#include "corde_sim/scene/key_ranges.h"

namespace corde_sim {
namespace {

[[noreturn]] void bad(const std::string& name, const std::string& why) {
  throw std::invalid_argument("parameter ~" + name + ": " + why);
}

bool take(const XmlRpc::XmlRpcValue& x, double& v) {
  if (x.getType() == XmlRpc::XmlRpcValue::TypeInt)
    v = static_cast<int>(x);
  else if (x.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    v = static_cast<double>(x);
  else
    return false;
  return true;
}
bool take(const XmlRpc::XmlRpcValue& x, int& v) {
  if (x.getType() != XmlRpc::XmlRpcValue::TypeInt) return false;  // no silent 2.5 -> 2
  v = static_cast<int>(x);
  return true;
}
bool take(const XmlRpc::XmlRpcValue& x, bool& v) {
  if (x.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return false;
  v = static_cast<bool>(x);
  return true;
}
bool take(const XmlRpc::XmlRpcValue& x, std::string& v) {
  if (x.getType() != XmlRpc::XmlRpcValue::TypeString) return false;
  v = static_cast<std::string>(x);
  return true;
}
const char* type_name(const double&) { return "a number"; }
const char* type_name(const int&) { return "an integer"; }
const char* type_name(const bool&) { return "true or false"; }
const char* type_name(const std::string&) { return "a string"; }

// Like NodeHandle::param, but a value of the wrong type is an error instead of the default
// (roscpp would also cut 2.5 to an integer 2).
template <class T>
void read(const ros::NodeHandle& pnh, const std::string& name, T& value, const T& def) {
  XmlRpc::XmlRpcValue x;
  if (!pnh.getParam(name, x)) {
    value = def;
    return;
  }
  if (!take(x, value)) bad(name, std::string("must be ") + type_name(value));
}

// A number within its entry of the key-range table (scene/key_ranges.h), which ~configure and
// the reconfigure config share: one range and one message for the parameter however it is set.
double read_ranged(const ros::NodeHandle& pnh, const std::string& name, double def) {
  double v = def;
  read(pnh, name, v, def);
  const std::string why = start_up_range_error(name, v);
  if (!why.empty()) throw std::invalid_argument(why);
  return v;
}

// A list of n numbers (integers accepted), or false if the parameter is not set.
bool read_numbers(const ros::NodeHandle& pnh, const std::string& name, size_t n,
                  std::vector<double>* out) {
  XmlRpc::XmlRpcValue x;
  if (!pnh.getParam(name, x)) return false;
  if (x.getType() != XmlRpc::XmlRpcValue::TypeArray || static_cast<size_t>(x.size()) != n)
    bad(name, "must be a list of " + std::to_string(n) + " numbers");
  out->resize(n);
  for (size_t i = 0; i < n; ++i)
    if (!take(x[static_cast<int>(i)], (*out)[i]) || !std::isfinite((*out)[i]))
      bad(name, "must be a list of " + std::to_string(n) + " finite numbers");
  return true;
}

// A positive finite number.
double read_positive(const ros::NodeHandle& pnh, const std::string& name, double def,
                     const char* unit) {
  double v = def;
  read(pnh, name, v, def);
  if (!std::isfinite(v) || !(v > 0.0))
    bad(name, "must be > 0 " + std::string(unit) + ", got " + num(v));
  return v;
}

void check_frame(const std::string& name, const std::string& frame, bool allow_empty) {
  if (frame.empty() && !allow_empty) bad(name, "must not be empty");
  if (!frame.empty() && frame[0] == '/')
    bad(name, "frame ids have no leading slash: '" + frame + "'");
  if (frame.find_first_of(" \t\n") != std::string::npos) bad(name, "frame ids have no spaces");
}

}  // namespace

std::string start_up_range_error(const std::string& name, double value) {
  const corde::KeyRange* range = corde::find_key_range(name);
  if (!range) throw std::logic_error("no key range for parameter ~" + name);
  const std::string why = corde::range_violation(*range, value);
  return why.empty() ? why : "parameter ~" + name + ": " + why;
}

GraspSource parse_grasp_source(const std::string& s) {
  if (s == "topic") return GraspSource::kTopic;
  if (s == "tf") return GraspSource::kTf;
  if (s == "fixed") return GraspSource::kFixed;
  throw std::invalid_argument("grasp source must be topic, tf or fixed, got '" + clip(s) + "'");
}

const char* to_string(GraspSource s) {
  switch (s) {
    case GraspSource::kTopic:
      return "topic";
    case GraspSource::kTf:
      return "tf";
    case GraspSource::kFixed:
      return "fixed";
  }
  return "?";
}

NodeParams load_node_params(const ros::NodeHandle& pnh, const std::string& ns,
                            const std::string& default_scene) {
  NodeParams p;
  read<std::string>(pnh, "scene", p.scene, default_scene);
  if (p.scene.empty()) bad("scene", "no scene file given and the package path is unknown");

  // ~overrides: a list of "key.path=value" strings, or one string with ';' between them.
  XmlRpc::XmlRpcValue ov;
  if (pnh.getParam("overrides", ov)) {
    if (ov.getType() == XmlRpc::XmlRpcValue::TypeString) {
      std::string all = ov, item;
      for (char c : all + ";") {
        if (c != ';') {
          item += c;
        } else if (!item.empty()) {
          p.overrides.push_back(item);
          item.clear();
        }
      }
    } else if (ov.getType() == XmlRpc::XmlRpcValue::TypeArray) {
      for (int i = 0; i < ov.size(); ++i) {
        if (ov[i].getType() != XmlRpc::XmlRpcValue::TypeString)
          bad("overrides", "must be a list of \"key.path=value\" strings");
        p.overrides.push_back(static_cast<std::string>(ov[i]));
      }
    } else {
      bad("overrides", "must be a list of \"key.path=value\" strings");
    }
  }

  // ~integrator: the scene's integrator key, as a last override (so a reset of the start-up
  // file keeps it); "auto" lets the scene loader choose (docs/scene_format.md).
  read<std::string>(pnh, "integrator", p.integrator, "");
  if (!p.integrator.empty()) {
    corde::Integrator parsed;
    if (p.integrator != "auto" && !corde::parse_integrator(p.integrator, &parsed))
      bad("integrator", "unknown integrator '" + p.integrator +
                            "' (integrators: " + integrator_names() + ", auto)");
    p.overrides.push_back("integrator=" + p.integrator);
  }

  read<std::string>(pnh, "world_frame", p.world_frame, "world");
  check_frame("world_frame", p.world_frame, false);

  // Default prefix: the namespace without its leading slash, so /sim1 draws sim1/cable/seg_0.
  std::string def_prefix = ns;
  while (!def_prefix.empty() && def_prefix.front() == '/') def_prefix.erase(0, 1);
  if (!def_prefix.empty() && def_prefix.back() != '/') def_prefix += '/';
  read<std::string>(pnh, "frame_prefix", p.frame_prefix, def_prefix);
  check_frame("frame_prefix", p.frame_prefix, true);
  if (!p.frame_prefix.empty() && p.frame_prefix.back() != '/') p.frame_prefix += '/';

  p.real_time_factor = read_ranged(pnh, "real_time_factor", 1.0);
  read(pnh, "publish_clock", p.publish_clock, false);

  p.tf_rate = read_ranged(pnh, "tf_rate", 50.0);
  p.marker_rate = read_ranged(pnh, "marker_rate", 20.0);
  p.state_rate = read_ranged(pnh, "state_rate", 50.0);
  p.loop_rate = read_ranged(pnh, "loop_rate", 200.0);
  read(pnh, "tf_every_k", p.tf_every_k, 1);
  if (p.tf_every_k < 1)
    bad("tf_every_k", "must be an integer >= 1, got " + std::to_string(p.tf_every_k));
  read(pnh, "node_frames", p.node_frames, false);
  p.cloud_rate = read_ranged(pnh, "cloud_rate", 10.0);
  read(pnh, "cloud_points_per_ring", p.cloud_points_per_ring, 8);
  if (p.cloud_points_per_ring < 3 || p.cloud_points_per_ring > kMaxCloudPointsPerRing)
    bad("cloud_points_per_ring", "must be an integer in [3, " +
                                     std::to_string(kMaxCloudPointsPerRing) + "], got " +
                                     std::to_string(p.cloud_points_per_ring));
  read(pnh, "cloud_rings_per_segment", p.cloud_rings_per_segment, 1);
  if (p.cloud_rings_per_segment < 1 || p.cloud_rings_per_segment > kMaxCloudRingsPerSegment)
    bad("cloud_rings_per_segment", "must be an integer in [1, " +
                                       std::to_string(kMaxCloudRingsPerSegment) + "], got " +
                                       std::to_string(p.cloud_rings_per_segment));

  std::string style;
  read<std::string>(pnh, "marker_style", style, "cylinders");
  if (style == "cylinders")
    p.marker_style = MarkerStyle::kCylinders;
  else if (style == "line_strip")
    p.marker_style = MarkerStyle::kLineStrip;
  else
    bad("marker_style", "must be line_strip or cylinders, got '" + style + "'");
  read(pnh, "show_frames", p.show_frames, false);
  read(pnh, "color_by_strain", p.color_by_strain, true);
  p.marker_min_diameter = read_ranged(pnh, "marker_min_diameter", 0.004);

  read(pnh, "max_pose_age", p.max_pose_age, 1.0);
  if (!std::isfinite(p.max_pose_age) || !(p.max_pose_age > 0.0))
    bad("max_pose_age", "must be > 0 s, got " + num(p.max_pose_age));
  p.max_frame_age = read_positive(pnh, "max_frame_age", 1.0, "s");
  p.max_grasp_distance = read_positive(pnh, "max_grasp_distance", 0.05, "m");
  p.holder_max_speed = read_ranged(pnh, "holder_max_speed", 2.0);
  p.holder_max_acceleration = read_ranged(pnh, "holder_max_acceleration", 50.0);
  p.holder_max_angular_speed = read_positive(pnh, "holder_max_angular_speed", 20.0, "rad/s");
  p.holder_max_angular_acceleration =
      read_positive(pnh, "holder_max_angular_acceleration", 1000.0, "rad/s^2");
  p.max_node_speed = read_positive(pnh, "max_node_speed", 100.0, "m/s");
  p.max_angular_speed = read_positive(pnh, "max_angular_speed", 1e5, "rad/s");
  std::vector<double> v;
  if (read_numbers(pnh, "workspace_min", 3, &v)) p.workspace_min << v[0], v[1], v[2];
  if (read_numbers(pnh, "workspace_max", 3, &v)) p.workspace_max << v[0], v[1], v[2];
  if (!(p.workspace_min.array() < p.workspace_max.array()).all())
    bad("workspace_max", "must be above ~workspace_min in every coordinate");
  std::string strain_action;
  read<std::string>(pnh, "strain_action", strain_action, "warn");
  if (strain_action == "warn")
    p.strain_action = StrainAction::kWarn;
  else if (strain_action == "slip")
    p.strain_action = StrainAction::kSlip;
  else
    bad("strain_action", "must be warn or slip, got '" + strain_action + "'");
  read(pnh, "start_paused", p.start_paused, false);
  read(pnh, "status_period", p.status_period, 10.0);
  if (!std::isfinite(p.status_period) || p.status_period < 0.0)
    bad("status_period", "must be >= 0 s (0 = no status lines), got " + num(p.status_period));
  read(pnh, "benchmark", p.benchmark, 0.0);
  if (!std::isfinite(p.benchmark) || p.benchmark < 0.0) bad("benchmark", "must be >= 0 s");

  XmlRpc::XmlRpcValue grasps;
  if (pnh.getParam("grasps", grasps)) {
    if (grasps.getType() != XmlRpc::XmlRpcValue::TypeStruct)
      bad("grasps", "must be a dictionary of grasp names");
    for (auto it = grasps.begin(); it != grasps.end(); ++it) {
      const std::string key = "grasps/" + it->first;
      GraspSourceParam g;
      std::string source;
      read<std::string>(pnh, key + "/source", source, "topic");
      try {
        g.source = parse_grasp_source(source);
      } catch (const std::invalid_argument& e) {
        bad(key + "/source", e.what());
      }
      read<std::string>(pnh, key + "/frame", g.frame, "");
      if (g.source == GraspSource::kTf) check_frame(key + "/frame", g.frame, false);
      // offset: [x, y, z] or [x, y, z, qx, qy, qz, qw], the segment's pose in the holder frame.
      XmlRpc::XmlRpcValue off;
      if (pnh.getParam(key + "/offset", off)) {
        std::vector<double> o;
        const size_t n = off.getType() == XmlRpc::XmlRpcValue::TypeArray ? off.size() : 0;
        if (n != 3 && n != 7)
          bad(key + "/offset", "must be [x, y, z] or [x, y, z, qx, qy, qz, qw]");
        read_numbers(pnh, key + "/offset", n, &o);
        g.has_offset = true;
        g.offset.translation() << o[0], o[1], o[2];
        if (n == 7) {
          Eigen::Quaterniond q(o[6], o[3], o[4], o[5]);
          if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance)
            bad(key + "/offset",
                "quaternion (qx, qy, qz, qw) must have unit norm, got " + num(q.norm()));
          g.offset.linear() = q.normalized().toRotationMatrix();
        }
      }
      read(pnh, key + "/snap", g.snap, false);
      read(pnh, key + "/start_at_frame", g.start_at_frame, false);
      if (g.start_at_frame) check_frame(key + "/frame", g.frame, false);
      read(pnh, key + "/start_timeout", g.start_timeout, 10.0);
      if (!std::isfinite(g.start_timeout) || g.start_timeout < 0.0)
        bad(key + "/start_timeout", "must be >= 0 s, got " + num(g.start_timeout));
      p.grasps[it->first] = g;
    }
  }

  read(pnh, "robot_collision", p.robot_collision, false);
  read<std::string>(pnh, "robot_description", p.robot_description, "robot_description");
  if (p.robot_description.empty()) bad("robot_description", "must name a parameter");
  read<std::string>(pnh, "robot_urdf_file", p.robot_urdf_file, "");
  read(pnh, "robot_friction", p.robot_friction, 0.5);
  if (!std::isfinite(p.robot_friction) || p.robot_friction < 0.0)
    bad("robot_friction", "must be a friction coefficient >= 0, got " + num(p.robot_friction));
  XmlRpc::XmlRpcValue ignore;
  if (pnh.getParam("robot_ignore_links", ignore)) {
    if (ignore.getType() != XmlRpc::XmlRpcValue::TypeArray)
      bad("robot_ignore_links", "must be a list of link names");
    for (int i = 0; i < ignore.size(); ++i) {
      if (ignore[i].getType() != XmlRpc::XmlRpcValue::TypeString)
        bad("robot_ignore_links", "must be a list of link names");
      p.robot_ignore_links.push_back(static_cast<std::string>(ignore[i]));
    }
  }
  read<std::string>(pnh, "robot_frame_prefix", p.robot_frame_prefix, "");
  check_frame("robot_frame_prefix", p.robot_frame_prefix, true);
  p.robot_max_speed = read_positive(pnh, "robot_max_speed", 5.0, "m/s");
  p.robot_max_angular_speed = read_positive(pnh, "robot_max_angular_speed", 30.0, "rad/s");
  read(pnh, "robot_start_timeout", p.robot_start_timeout, 10.0);
  if (!(p.robot_start_timeout >= 0.0 && p.robot_start_timeout <= 3600.0))
    bad("robot_start_timeout", "must be a time in [0, 3600] s, got " + num(p.robot_start_timeout));
  read(pnh, "contact_markers", p.contact_markers, false);
  p.contact_force_scale = read_positive(pnh, "contact_force_scale", 0.05, "m/N");

  ROS_INFO("corde_sim: ~scene = %s", p.scene.c_str());
  for (const std::string& o : p.overrides) ROS_INFO("corde_sim: ~overrides: %s", o.c_str());
  ROS_INFO("corde_sim: ~world_frame = %s, ~frame_prefix = '%s'", p.world_frame.c_str(),
           p.frame_prefix.c_str());
  ROS_INFO("corde_sim: ~real_time_factor = %g%s, ~publish_clock = %s", p.real_time_factor,
           p.real_time_factor == 0.0 ? " (as fast as possible)" : "",
           p.publish_clock ? "true" : "false");
  ROS_INFO(
      "corde_sim: ~tf_rate = %g Hz, ~tf_every_k = %d, ~node_frames = %s, ~marker_rate = %g Hz, "
      "~state_rate = %g Hz, ~loop_rate = %g Hz",
      p.tf_rate, p.tf_every_k, p.node_frames ? "true" : "false", p.marker_rate, p.state_rate,
      p.loop_rate);
  ROS_INFO(
      "corde_sim: ~marker_style = %s, ~show_frames = %s, ~color_by_strain = %s, "
      "~marker_min_diameter = %g m",
      style.c_str(), p.show_frames ? "true" : "false", p.color_by_strain ? "true" : "false",
      p.marker_min_diameter);
  ROS_INFO("corde_sim: ~max_pose_age = %g s, ~max_frame_age = %g s, ~start_paused = %s",
           p.max_pose_age, p.max_frame_age, p.start_paused ? "true" : "false");
  ROS_INFO(
      "corde_sim: holders: ~holder_max_speed = %g m/s, ~holder_max_acceleration = %g m/s^2, "
      "~holder_max_angular_speed = %g rad/s, ~holder_max_angular_acceleration = %g rad/s^2",
      p.holder_max_speed, p.holder_max_acceleration, p.holder_max_angular_speed,
      p.holder_max_angular_acceleration);
  ROS_INFO(
      "corde_sim: ~workspace_min = [%g, %g, %g], ~workspace_max = [%g, %g, %g] m, "
      "~max_grasp_distance = %g m, ~strain_action = %s, ~max_node_speed = %g m/s, "
      "~max_angular_speed = %g rad/s",
      p.workspace_min.x(), p.workspace_min.y(), p.workspace_min.z(), p.workspace_max.x(),
      p.workspace_max.y(), p.workspace_max.z(), p.max_grasp_distance, strain_action.c_str(),
      p.max_node_speed, p.max_angular_speed);
  if (p.robot_collision || !p.robot_urdf_file.empty()) {
    std::string ignored;
    for (const std::string& l : p.robot_ignore_links) ignored += (ignored.empty() ? "" : ", ") + l;
    ROS_INFO(
        "corde_sim: robot collision from %s, ~robot_friction = %g, ~robot_ignore_links = [%s], "
        "~robot_frame_prefix = '%s', ~robot_max_speed = %g m/s, ~robot_max_angular_speed = %g "
        "rad/s",
        p.robot_urdf_file.empty() ? ("parameter " + p.robot_description).c_str()
                                  : ("file " + p.robot_urdf_file).c_str(),
        p.robot_friction, ignored.c_str(), p.robot_frame_prefix.c_str(), p.robot_max_speed,
        p.robot_max_angular_speed);
  }
  ROS_INFO("corde_sim: ~contact_markers = %s, ~contact_force_scale = %g m/N",
           p.contact_markers ? "true" : "false", p.contact_force_scale);
  for (const auto& g : p.grasps)
    ROS_INFO("corde_sim: ~grasps/%s: source %s%s%s%s%s%s", g.first.c_str(),
             to_string(g.second.source), g.second.frame.empty() ? "" : ", frame ",
             g.second.frame.c_str(), g.second.has_offset ? ", offset given" : "",
             g.second.snap ? ", snap" : "", g.second.start_at_frame ? ", starts at its frame" : "");
  return p;
}

}  // namespace corde_sim
