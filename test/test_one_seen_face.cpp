// A narrow grasp across one face seen from in front (one_seen_face.h), and the hold check and
// the fused planner that drop or rank it last, on a box whose faces, normals and depth follow
// from its construction.
#include "fast_grasp/grasping/one_seen_face.h"

#include "fast_grasp/grasping/fused_grasp.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
using hold_check_fixtures::GivenGrasps;
using hold_check_fixtures::graspAt;

/// A cereal box standing on the table at the origin: 6 cm deep along x, 16 cm wide along y,
/// 21 cm tall. The camera (hold_check_fixtures::kCamera, at x = -0.40 m) sees its front face
/// x = -3 cm, normals (-1, 0, 0), and its top; with `cut_above_m` > 0 only what lies below that
/// height (the rest out of the image, or behind a neighbour), so only the front face's foot.
ObjectView standingBox(double cut_above_m = 0.0, double noise_m = 0.0)
{
  ObjectView view = hold_check_fixtures::tableView(synthetic::makeBox({ 0.0, 0.0, 0.105 }, { 0.06, 0.16, 0.21 }), noise_m);
  if (cut_above_m > 0.0)
  {
    CloudNormal::Ptr low(new CloudNormal);
    for (const auto& p : view.cloud->points)
      if (p.z < cut_above_m)
        low->push_back(p);
    view = synthetic::makeObjectView(low, hold_check_fixtures::kCamera);
    view.has_table_plane = true;
    view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  }
  return view;
}

/// From above, closing along x (the camera's line of sight, horizontally) on the front face at
/// height `height_m`: the fingers 2.5 mm either side of the face for `width_m` = 5 mm, so the
/// far one 2.5 mm inside the box.
GraspCandidate pinchOnTheFrontFace(double height_m, double width_m, double score = 0.0)
{
  GraspCandidate grasp = graspAt({ -0.03, 0.0, height_m }, { 0, 0, -1 }, { 1, 0, 0 }, score);
  grasp.width_m = width_m;
  return grasp;
}

OneSeenFaceParams enabled()
{
  OneSeenFaceParams p;
  p.enabled = true;
  return p;
}
}  // namespace

TEST(OneSeenFace, ANarrowPinchOnAFaceWhoseDepthIsUnseenIsCaughtNotOneThatSeesTheDepth)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  for (const double noise : { 0.0, 0.001 })
  {
    // Only the front face's foot is seen (below 6 cm): between the open fingers (4 cm along the
    // approach, 8.5 cm along x, 2.2 cm along y) there is only that face, all its normals along
    // -x, spanning ~0 (noise: ~2 mm) along the closing line.
    const ObjectView cut = standingBox(0.06, noise);
    EXPECT_TRUE(closesAcrossOneSeenFace(pinchOnTheFrontFace(0.03, 0.005), gripper, cut, enabled())) << noise;
    // A width that assumes the hidden depth is not a pinch on the face.
    EXPECT_FALSE(closesAcrossOneSeenFace(pinchOnTheFrontFace(0.03, 0.06), gripper, cut, enabled())) << noise;
    // Off: nothing judged.
    EXPECT_FALSE(closesAcrossOneSeenFace(pinchOnTheFrontFace(0.03, 0.005), gripper, cut, OneSeenFaceParams{}));
    // With the top in view, the same pinch at its front edge has the top face between the
    // fingers (normals up, across the closing line; 4.25 cm of it along x): the depth is seen.
    const ObjectView whole = standingBox(0.0, noise);
    EXPECT_FALSE(closesAcrossOneSeenFace(pinchOnTheFrontFace(0.20, 0.005), gripper, whole, enabled())) << noise;
  }
  // Closing along y, across the face's width: the face's points span the whole 8.5 cm opening
  // and their normals are square to the closing line. Not a pinch on one face.
  const ObjectView cut = standingBox(0.06);
  GraspCandidate along_face = graspAt({ -0.03, 0.0, 0.03 }, { 0, 0, -1 }, { 0, 1, 0 });
  along_face.width_m = 0.005;
  EXPECT_FALSE(closesAcrossOneSeenFace(along_face, gripper, cut, enabled()));
  // Too few points between the fingers (a grasp beside the box) say nothing.
  EXPECT_FALSE(closesAcrossOneSeenFace(graspAt({ -0.03, 0.3, 0.03 }, { 0, 0, -1 }, { 1, 0, 0 }), gripper, cut, enabled()));
}

TEST(OneSeenFace, TheHoldCheckDropsThePinchAndSaysWhyTheFusedPlannerRanksItLast)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectView cut = standingBox(0.06);
  GraspResult planned;
  planned.grasps = { pinchOnTheFrontFace(0.03, 0.005, 0.9), pinchOnTheFrontFace(0.03, 0.06, 0.5) };
  HoldCheckParams params;
  params.one_seen_face = enabled();
  const GraspResult checked = HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), params).plan(cut, gripper);
  ASSERT_TRUE(checked.ok()) << checked.message;
  ASSERT_EQ(checked.grasps.size(), 1u);
  EXPECT_EQ(checked.grasps.front().width_m, 0.06);
  EXPECT_NE(checked.message.find("dropped 1 narrow grasps across one seen face"), std::string::npos) << checked.message;
  // Only the pinch: no grasp, and why.
  GraspResult only_pinch;
  only_pinch.grasps = { pinchOnTheFrontFace(0.03, 0.005, 0.9) };
  const GraspResult none = HoldCheckedPlanner(std::make_unique<GivenGrasps>(only_pinch), params).plan(cut, gripper);
  EXPECT_EQ(none.failure, GraspFailure::NoStableGrasp);
  EXPECT_NE(none.message.find("one seen face"), std::string::npos) << none.message;

  // The fused planner keeps it, last, flagged: planned first by its own planner, scored alike
  // (no model weights), it comes after the wide grasp, and the table's object choice sees it.
  const GraspResult ranked = hold_check_fixtures::fusedOverGivenGrasps(
      planned, cut, gripper, [](FusedParams& fused) { fused.one_seen_face = enabled(); });
  ASSERT_TRUE(ranked.ok()) << ranked.message;
  ASSERT_EQ(ranked.grasps.size(), 2u);
  EXPECT_EQ(ranked.grasps.front().width_m, 0.06);
  EXPECT_FALSE(ranked.grasps.front().drop_risk);
  EXPECT_EQ(ranked.grasps.back().width_m, 0.005);
  EXPECT_TRUE(ranked.grasps.back().drop_risk);
  EXPECT_NE(ranked.message.find("narrow across one seen face (its depth unseen), ranked last: 1"), std::string::npos)
      << ranked.message;
}

TEST(OneSeenFace, TheShippedConfigJudgesItAndBadValuesAreRefused)
{
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_TRUE(config.fused.one_seen_face.enabled);
  EXPECT_EQ(config.fused.one_seen_face.max_width_m, 0.012);
  const FusedParams read = fusedParamsFromYaml(
      YAML::Load("{one_seen_face: {enabled: true, max_width_m: 0.01, min_facing_cos: 0.9, min_facing_share: 0.7}}"));
  EXPECT_TRUE(read.one_seen_face.enabled);
  EXPECT_EQ(read.one_seen_face.max_width_m, 0.01);
  EXPECT_EQ(read.one_seen_face.min_facing_cos, 0.9);
  EXPECT_EQ(read.one_seen_face.min_facing_share, 0.7);
  for (const char* bad : { "{one_seen_face: {max_width_m: 0.5}}", "{one_seen_face: {min_facing_cos: 1.5}}",
                           "{one_seen_face: {min_facing_share: 0}}", "{one_seen_face: {no_such_key: 1}}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

}  // namespace fast_grasp
