// A rod's `boundary` entries (docs/scene_format.md, "Boundary conditions"): described in pass (a),
// built on the rod in pass (b) (scene_passes.h).
#include <algorithm>

#include "scene_passes.h"

namespace corde {
namespace scene_detail {
namespace {

// The one mode an entry gives among `modes` and a keyframed drive (keyframes, move_by, turns).
std::string entry_mode(const Map& b, const std::vector<std::string>& modes, bool motion_ok) {
  std::vector<std::string> present;
  for (const std::string& k : modes)
    if (b.has(k)) present.push_back(k);
  if (motion_ok && has_motion(b)) present.push_back("motion");
  if (present.size() == 1) return present[0];
  std::string list;
  for (const std::string& k : modes) list += k + ", ";
  list += motion_ok ? "keyframes, move_by or turns" : "";
  b.fail(present.empty() ? "needs one of " + list : "give only one of " + list);
}

// What an entry's keyframes may move.
MotionStart rules(bool translates, bool rotates) {
  MotionStart m;
  m.translates = translates;
  m.rotates = rotates;
  return m;
}

// The item's start on the built rod, with the rules it was described with.
MotionStart start_of(const Rod& rod, int node, int seg, bool translates, bool rotates) {
  MotionStart m = rules(translates, rotates);
  m.position = rod.positions()[node];
  m.orientation = rod.orientations()[seg];
  m.tangent = director3(m.orientation);
  return m;
}

}  // namespace

void Owners::claim(std::map<int, std::string>* owners, int index, const char* what, const Value& v,
                   const std::string& owner) {
  auto it = owners->find(index);
  if (it != owners->end())
    v.fail(std::string(what) + " " + std::to_string(index) + " is already constrained by " +
           it->second);
  (*owners)[index] = owner;
}

BoundaryDescription describe_boundary(const Value& entry, const std::string& base) {
  Map b(entry);
  BoundaryDescription d;
  d.path = entry.path();
  const std::string kind = b.one_of({"node", "segment", "clamp"});
  if (kind == "node") {
    d.kind = BoundaryDescription::Kind::kNode;
    d.at = describe_index(b.get("node"), "node");
    d.mode = entry_mode(b, {"fix", "velocity", "line", "plane"}, true);
    if (d.mode == "line" || d.mode == "plane") {
      d.direction = b.get(d.mode).nonzero_vec3();
    } else if (d.mode == "fix") {
      const Value f = b.get("fix");
      if (!f.boolean()) f.fail("must be true (leave the entry out for a free node)");
    } else if (d.mode == "velocity") {
      d.velocity = b.get("velocity").vec3(SceneBounds::max_speed, "m/s");
      if (auto t = b.find("start_time")) d.start_time = t->non_negative(SceneBounds::max_time, "s");
    } else {
      d.motion = describe_motion(&b, rules(true, false), base);
    }
  } else if (kind == "segment") {
    d.kind = BoundaryDescription::Kind::kSegment;
    d.at = describe_index(b.get("segment"), "segment");
    d.mode = entry_mode(b, {"fix", "spin_rate", "free_axis"}, true);
    if (d.mode == "free_axis") {
      const Value a = b.get("free_axis");
      d.along_tangent = a.is_scalar() && a.node().Scalar() == "tangent";
      if (!d.along_tangent) d.direction = a.nonzero_vec3();
    } else if (d.mode == "fix") {
      const Value f = b.get("fix");
      if (!f.boolean()) f.fail("must be true (leave the entry out for a free segment)");
    } else if (d.mode == "spin_rate") {
      d.rate =
          b.get("spin_rate")
              .within(-SceneBounds::max_angular_speed, SceneBounds::max_angular_speed, "rad/s");
      if (auto t = b.find("start_time")) d.start_time = t->non_negative(SceneBounds::max_time, "s");
    } else {
      d.motion = describe_motion(&b, rules(false, true), base);
    }
  } else {
    d.kind = BoundaryDescription::Kind::kClamp;
    const Value cv = b.get("clamp");
    d.clamp_key = cv;
    d.end = cv.choice({"start", "end"}) == "end";
    if (auto k = b.find("kind")) d.natural = k->choice({"natural", "ghost"}) == "natural";
    std::optional<Value> slide = b.find("slide");
    if (auto t = b.find("twist")) d.twist_free = t->choice({"held", "free"}) == "free";
    if (d.twist_free && !d.natural)
      b.fail("twist: free needs kind: natural (a ghost clamp holds the end frame fully)");
    if (slide && has_motion(b)) slide->fail("a sliding clamp cannot also be moved by keyframes");
    d.motion = describe_motion(&b, rules(true, !d.twist_free), base);
    if (slide && !(slide->is_scalar() && slide->node().Scalar() == "false")) {
      d.slides = true;
      d.along_tangent = slide->is_scalar() && slide->boolean();
      if (!d.along_tangent) d.direction = slide->nonzero_vec3();
    }
  }
  b.finish();
  return d;
}

void build_boundary(const BoundaryDescription& d, Rod* rod, Owners* owners, Support* support) {
  using Kind = BoundaryDescription::Kind;
  const std::string& owner = d.path;
  const int n = rod->num_segments();
  support->rod = rod->name();
  support->name = rod->name() + "/" + owner.substr(owner.rfind('.') + 1);
  if (d.kind == Kind::kNode) {
    const int node = resolve_index(d.at, n + 1, "node");
    support->nodes = {node};
    owners->claim(&owners->node, node, "node", d.at.key, owner);
    if (d.mode == "line" || d.mode == "plane") {
      NodeConstraint c;
      c.kind = d.mode == "line" ? NodeConstraint::Kind::kLine : NodeConstraint::Kind::kPlane;
      c.node = node;
      c.point = rod->positions()[node];
      c.direction = d.direction;
      rod->add_node_constraint(c);
      return;
    }
    NodeDrive nd;
    nd.node = node;
    nd.origin = nd.pivot = rod->positions()[node];
    if (d.mode == "fix") {
      nd.kind = NodeDrive::Kind::kFixed;
    } else if (d.mode == "velocity") {
      nd.kind = NodeDrive::Kind::kVelocity;
      nd.velocity = d.velocity;
      nd.t_start = d.start_time;
    } else {
      nd.kind = NodeDrive::Kind::kMotion;
      nd.motion =
          resolve_motion(*d.motion, start_of(*rod, node, std::min(node, n - 1), true, false));
    }
    rod->add_node_drive(nd);
    return;
  }
  if (d.kind == Kind::kSegment) {
    const int seg = resolve_index(d.at, n, "segment");
    support->segments = {seg};
    owners->claim(&owners->segment, seg, "segment", d.at.key, owner);
    if (d.mode == "free_axis") {
      SegmentConstraint c;
      c.segment = seg;
      c.origin = rod->orientations()[seg];
      c.axis = d.along_tangent ? director3(c.origin) : d.direction;
      rod->add_segment_constraint(c);
      return;
    }
    SegmentDrive sd;
    sd.segment = seg;
    sd.origin = rod->orientations()[seg];
    if (d.mode == "fix") {
      sd.kind = SegmentDrive::Kind::kFixed;
    } else if (d.mode == "spin_rate") {
      sd.kind = SegmentDrive::Kind::kSpin;
      sd.rate = d.rate;
      sd.t_start = d.start_time;
    } else {
      sd.kind = SegmentDrive::Kind::kMotion;
      sd.motion = resolve_motion(*d.motion, start_of(*rod, seg, seg, false, true));
    }
    rod->add_segment_drive(sd);
    return;
  }
  const Value& cv = *d.clamp_key;
  support->name = rod->name() + "/clamp " + (d.end ? "end" : "start");
  const int node = d.end ? n : 0, seg = d.end ? n - 1 : 0;
  support->nodes = {node};
  const Quat frame = rod->orientations()[seg];
  const Vec3 tangent = director3(frame);
  const std::shared_ptr<const Motion> motion =
      d.motion ? resolve_motion(*d.motion, start_of(*rod, node, seg, true, !d.twist_free))
               : nullptr;
  owners->claim(&owners->node, node, "node", cv, owner);
  if (d.slides) {
    NodeConstraint c;
    c.kind = NodeConstraint::Kind::kLine;
    c.node = node;
    c.point = rod->positions()[node];
    c.direction = d.along_tangent ? tangent : d.direction;
    rod->add_node_constraint(c);
  } else {
    NodeDrive nd;
    nd.node = node;
    nd.origin = nd.pivot = rod->positions()[node];
    if (motion) {
      nd.kind = NodeDrive::Kind::kMotion;
      nd.motion = motion;
    }
    rod->add_node_drive(nd);
  }
  if (d.natural) {
    support->segments = {seg};
    owners->claim(&owners->segment, seg, "segment", cv, owner);
    if (d.twist_free) {
      rod->add_segment_constraint(SegmentConstraint{seg, frame, tangent, Vec3::Zero()});
    } else {
      SegmentDrive sd;
      sd.segment = seg;
      sd.origin = frame;
      if (motion) {
        sd.kind = SegmentDrive::Kind::kMotion;
        sd.motion = motion;
      }
      rod->add_segment_drive(sd);
    }
  } else {
    if (!owners->ghost[d.end].empty())
      cv.fail("the " + cv.node().Scalar() + " is already clamped by " + owners->ghost[d.end]);
    owners->ghost[d.end] = owner;
    support->ghost = d.end ? 1 : 0;
    GhostFrame& g = d.end ? rod->ghost_end() : rod->ghost_start();
    g.active = true;
    g.frame = g.origin = frame;
    g.uhat.setZero();
    g.motion = motion;
  }
}

}  // namespace scene_detail
}  // namespace corde
