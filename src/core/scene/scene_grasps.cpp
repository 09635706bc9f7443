// The `grasps` entries (docs/scene_format.md, "Grasps"): described in pass (a), their rod found by
// name; placed on the built rod in pass (b) (scene_passes.h).
#include "scene_passes.h"

namespace corde {
namespace scene_detail {

GraspDescription describe_grasp(const Value& v, const std::vector<RodDescription>& rods,
                                const std::vector<GraspDescription>& before,
                                const std::string& base) {
  Map m(v);
  GraspDescription d;
  d.entry = v;
  GraspSpec& g = d.spec;
  const Value nv = m.get("name");
  g.name = nv.string();
  if (g.name.empty()) nv.fail("must not be empty");
  for (const GraspDescription& b : before)
    if (b.spec.name == g.name)
      nv.fail("duplicate grasp name " + echo(g.name) + " (also " + b.entry->path() + ")");
  int r = 0;
  if (auto rv = m.find("rod")) {
    g.rod = rv->string();
    while (r < static_cast<int>(rods.size()) && rods[r].spec.name != g.rod) ++r;
    if (r == static_cast<int>(rods.size())) {
      std::string known;
      for (const RodDescription& rod : rods) known += (known.empty() ? "" : ", ") + rod.spec.name;
      rv->fail("no rod named " + echo(g.rod) + " (rods: " + echo(known) + ")");
    }
  } else if (rods.size() == 1) {
    g.rod = rods[0].spec.name;
  } else {
    throw SceneError(v.path() + ".rod: missing (required when the scene has several rods)");
  }
  d.rod = r;
  std::string place = "end";
  if (auto p = m.find("place")) place = p->choice({"start", "end", "node", "arc_length"});
  std::optional<Value> value = m.find("value");
  if (place == "start" || place == "end") {
    g.place = place == "start" ? GraspSpec::Place::kStart : GraspSpec::Place::kEnd;
    if (value) value->fail("only used with place: node or arc_length");
  } else {
    if (!value) throw SceneError(v.path() + ".value: missing (required with place: " + place + ")");
    if (place == "node") {
      g.place = GraspSpec::Place::kNode;
      d.node = describe_index(*value, "node");
    } else {
      g.place = GraspSpec::Place::kArcLength;
      g.value = value->non_negative();
      d.arc_length_key = value;
    }
  }
  if (auto p = m.find("hold_orientation")) g.hold_orientation = p->boolean();
  if (auto p = m.find("grip")) {  // a friction grasp (grasp/friction_grasp.h)
    Map grip(*p);
    g.grip.friction = true;
    g.grip.force = grip.get("force").non_negative(SceneBounds::max_force, "N");
    g.grip.mu = grip.get("mu").non_negative(SceneBounds::max_factor, "");
    grip.finish();
  }
  if (auto p = m.find("grasp_time")) g.grasp_time = p->non_negative(SceneBounds::max_time, "s");
  if (auto p = m.find("release_time")) {
    g.release_time = p->non_negative(SceneBounds::max_time, "s");
    if (!(g.release_time > g.grasp_time))
      p->fail(num(g.release_time) + " s is not after grasp_time " + num(g.grasp_time) +
              " s: a grasp lets go after it takes hold");
  }
  MotionStart rules;
  rules.time = g.grasp_time;
  d.motion = describe_motion(&m, rules, base);
  m.finish();
  return d;
}

GraspSpec build_grasp(const GraspDescription& d, const Rod& rod, Owners* owners) {
  GraspSpec g = d.spec;
  const Value& v = *d.entry;
  if (g.place == GraspSpec::Place::kNode) {
    g.value = resolve_index(d.node, rod.num_nodes(), "node");
  } else if (g.place == GraspSpec::Place::kArcLength) {
    double total = 0.0;
    for (double l : rod.rest_lengths()) total += l;
    if (g.value > total * (1.0 + 1e-12))
      d.arc_length_key->fail("arc length " + num(g.value) + " m beyond the rod's length " +
                             num(total) + " m");
  }
  const int seg = grasp_segment(rod, g);
  if (d.motion) {
    MotionStart start;
    start.position = 0.5 * (rod.positions()[seg] + rod.positions()[seg + 1]);
    start.orientation = rod.orientations()[seg];
    start.tangent = director3(start.orientation);
    start.time = g.grasp_time;
    g.motion = resolve_motion(*d.motion, start);
  }
  g.motion_reference = segment_pose(rod, seg);
  // A grasp drives its segment and both of its nodes: nothing else may.
  const std::string owner = v.path() + " (grasp '" + g.name + "')";
  owners->claim(&owners->node, seg, "node", v, owner);
  owners->claim(&owners->node, seg + 1, "node", v, owner);
  if (g.hold_orientation) owners->claim(&owners->segment, seg, "segment", v, owner);
  return g;
}

}  // namespace scene_detail
}  // namespace corde
