// Grasps on a resampled rod keep their named places (issue 24, item 5): an end grasp holds the
// new last segment, a start grasp the first, an arc-length grasp the segment nearest the arc
// length it asked for, not the old segment's midpoint.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "corde_sim/grasp/grasp_set.h"
#include "corde_sim/rod/rod_edit.h"
#include "dynamics_util.h"

namespace corde {
namespace {

GraspSpec spec(const std::string& name, GraspSpec::Place place, double value = 0.0) {
  GraspSpec s;
  s.name = name;
  s.rod = "rod";
  s.place = place;
  s.value = value;
  return s;
}

// The example rod (1 m along x) at `elements` elements, held at its start, at arc length 0.5 m
// and at its end.
World held_world(int elements, GraspSet* grasps) {
  World w;
  w.add_rod(dyn::straight_rod(dyn::example_material(), 0.01, 1.0, elements));
  for (const GraspSpec& s :
       {spec("a", GraspSpec::Place::kStart), spec("m", GraspSpec::Place::kArcLength, 0.5),
        spec("z", GraspSpec::Place::kEnd)}) {
    int rod = -1, seg = -1;
    EXPECT_EQ(grasps->check(w, s, &rod, &seg), "");
    EXPECT_EQ(grasps->add(w, s, segment_pose(w.rods()[rod], seg), nullptr, 0.0), "");
  }
  return w;
}

// As ~configure does: the grasps' drives off, the rod resampled, the grasps made again.
void resample(World* w, GraspSet* grasps, int elements) {
  for (const auto& kv : grasps->grasps()) release(w->rods()[0], kv.second.grasp);
  w->rods()[0] = resample_rod(w->rods()[0], elements);
  grasps->remake_on(*w, 0);
}

TEST(ResampleGrasp, NamedPlacesStayWhereTheyAre) {
  GraspSet grasps;
  World w = held_world(40, &grasps);
  ASSERT_EQ(grasps.find("z")->grasp.segment, 39);
  resample(&w, &grasps, 2000);
  EXPECT_EQ(grasps.find("a")->grasp.segment, 0);
  EXPECT_EQ(grasps.find("z")->grasp.segment, 1999);
  // 0.5 m on 2000 segments of 0.5 mm: the midpoints at 0.49975 and 0.50025 are equally near;
  // either is the asked-for place (the old segment's midpoint, 0.4875 m, would be segment 975).
  const int m = grasps.find("m")->grasp.segment;
  EXPECT_TRUE(m == 999 || m == 1000) << m;
  // And back down: still the ends, and the middle.
  resample(&w, &grasps, 10);
  EXPECT_EQ(grasps.find("a")->grasp.segment, 0);
  EXPECT_EQ(grasps.find("z")->grasp.segment, 9);
  const int m10 = grasps.find("m")->grasp.segment;
  EXPECT_TRUE(m10 == 4 || m10 == 5) << m10;
  // Each is held: both nodes of its segment have a target drive.
  for (const auto& kv : grasps.grasps())
    for (int k = 0; k < 2; ++k) {
      const NodeDrive* d = w.rods()[0].node_drive(kv.second.grasp.segment + k);
      ASSERT_NE(d, nullptr) << kv.first;
      EXPECT_EQ(d->kind, NodeDrive::Kind::kTarget) << kv.first;
    }
}

// Resampling moves nothing: the held segments' new poses are where the rod is.
TEST(ResampleGrasp, TheEndGraspHoldsTheRodsEnd) {
  GraspSet grasps;
  World w = held_world(40, &grasps);
  const Vec3 end = w.rods()[0].positions().back();
  resample(&w, &grasps, 2000);
  const Rod& rod = w.rods()[0];
  const int s = grasps.find("z")->grasp.segment;
  EXPECT_LT((rod.positions()[s + 1] - end).norm(), 1e-12);
  const NodeDrive* d = rod.node_drive(s + 1);
  ASSERT_NE(d, nullptr);
  EXPECT_LT((d->target - end).norm(), 1e-9);
}

}  // namespace
}  // namespace corde
