// The camera's blind zone (grasping/near_range.h). A 30 cm bottle standing 0.5 m in front of a
// camera 0.45 m up is rendered as a depth camera with a 0.5 m minimum range would see it: the
// points nearer than 0.5 m along the optical axis are dropped, so the view ends where the
// bottle's top enters the blind zone. Every expectation follows from that geometry: where the
// cut is, that the blind space lies above it and nearer than the limit, and that no hand the
// fused planner returns for the cut view would come in through the bottle's invisible top.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/near_range.h"
#include "fast_grasp/grasping/table_grasps.h"

#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <yaml-cpp/yaml.h>

namespace fast_grasp
{
namespace
{
const Eigen::Vector3d kCamera(0.0, 0.0, 0.45);
const Eigen::Vector3d kBottleBase(0.42, 0.0, 0.0);
constexpr double kRadius = 0.035;
constexpr double kHeight = 0.30;
constexpr double kMinRange = 0.5;

Eigen::Vector3f opticalAxis()
{
  // The camera looks at the bottle's middle.
  return (kBottleBase + Eigen::Vector3d(0, 0, kHeight / 2) - kCamera).normalized().cast<float>();
}

/// The bottle as the camera sees it, nearer than `min_range_m` dropped, with the camera pose
/// on the cloud as CloudPreprocess leaves it, on a table at z = 0.
ObjectView cutBottleView(double min_range_m)
{
  const synthetic::Shape bottle =
      synthetic::makeCylinder(kBottleBase + Eigen::Vector3d(0, 0, kHeight / 2), Eigen::Vector3d::UnitZ(), kRadius, kHeight);
  synthetic::ViewParams params;
  params.viewpoint = kCamera;
  params.spacing_m = 0.003;
  const CloudNormal::Ptr seen = synthetic::renderView(bottle, params);
  CloudNormal::Ptr cut(new CloudNormal);
  const Eigen::Vector3f axis = opticalAxis();
  for (const auto& p : seen->points)
    if ((p.getVector3fMap() - kCamera.cast<float>()).dot(axis) >= static_cast<float>(min_range_m))
      cut->push_back(p);
  cut->sensor_origin_ = Eigen::Vector4f(kCamera.x(), kCamera.y(), kCamera.z(), 0.0f);
  cut->sensor_orientation_ = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), axis);
  ObjectView view = synthetic::makeObjectView(cut, kCamera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  return view;
}

float topOf(const CloudNormal& cloud)
{
  float top = -1.0f;
  for (const auto& p : cloud.points)
    top = std::max(top, p.z);
  return top;
}

NearRangeParams xtion()
{
  NearRangeParams params;
  params.sensor_min_range_m = kMinRange;
  params.add_blind_space = true;
  params.flag_grasps_on_cut = true;
  return params;
}

/// The camera looks down and forward (+x) along (0.814, 0, -0.581): the 0.5 m plane cuts the
/// bottle's seen front lowest where it is nearest, at its middle (x = 0.385, y = 0):
/// 0.814 * 0.385 + 0.581 * (0.45 - z) = 0.5 gives z = 0.129 m. From above, closing along x (the
/// line of sight) on that front rim, 15 mm wide, as the fused planner pinched the cut faces of
/// standing bottles and boxes in physics: the hand comes down onto the invisible top.
GraspCandidate pinchOnTheCut(double score = 0.0)
{
  GraspCandidate grasp = hold_check_fixtures::graspAt({ 0.39, kBottleBase.y(), 0.125 }, { 0, 0, -1 }, { 1, 0, 0 }, score);
  grasp.width_m = 0.015;
  return grasp;
}

/// From the camera's side, horizontally, closing along y 5 cm above the table: 8 cm below the
/// lowest cut, the whole bottle seen there.
GraspCandidate graspLowOnTheBody(double score = 0.0)
{
  GraspCandidate grasp = hold_check_fixtures::graspAt({ kBottleBase.x(), kBottleBase.y(), 0.05 }, { 1, 0, 0 },
                                                      { 0, 1, 0 }, score);
  grasp.width_m = 0.07;
  return grasp;
}

TEST(NearRange, BlindSpaceStandsOnTheCutAndNearerThanTheLimit)
{
  const ObjectView view = cutBottleView(kMinRange);
  const float cut_top = topOf(*view.cloud);
  // The camera looks down at 0.5 m to the bottle's middle: its top half is nearer than 0.5 m.
  ASSERT_LT(cut_top, 0.25f);
  ASSERT_GT(cut_top, 0.08f);

  const NearRangeBlindSpace blind =
      nearRangeBlindSpace(*view.cloud, kCamera.cast<float>(), opticalAxis(), Eigen::Vector3f::UnitZ(), xtion());
  EXPECT_GE(blind.at_limit, 5u);
  ASSERT_FALSE(blind.points.empty());
  // The 0.5 m plane cuts the bottle aslant (its front, nearer the camera, lower than its sides):
  // the seen points within margin_m of the limit span a band below the top.
  float lowest_at_limit = 1.0f;
  for (const auto& p : view.cloud->points)
    if ((p.getVector3fMap() - kCamera.cast<float>()).dot(opticalAxis()) <= static_cast<float>(kMinRange + 0.02))
      lowest_at_limit = std::min(lowest_at_limit, p.z);
  float blind_top = -1.0f;
  for (const auto& p : blind.points)
  {
    EXPECT_LT((p.getVector3fMap() - kCamera.cast<float>()).dot(opticalAxis()), static_cast<float>(kMinRange));
    blind_top = std::max(blind_top, p.z);
    // Joined to the cut: up and toward the (higher) camera from the points at the limit.
    EXPECT_GE(p.z, lowest_at_limit);
  }
  // Up to extension_m (15 cm) above the cut, where the bottle's invisible top is.
  EXPECT_GT(blind_top, cut_top + 0.12f);
}

TEST(NearRange, NothingAssumedWhenTheObjectIsWithinRangeOrTheRangeIsOff)
{
  // The same bottle with a 0.3 m minimum range is seen whole: no point is near that limit.
  const ObjectView whole = cutBottleView(0.3);
  EXPECT_NEAR(topOf(*whole.cloud), kHeight, 0.01);
  NearRangeParams params = xtion();
  params.sensor_min_range_m = 0.3;
  EXPECT_TRUE(nearRangeBlindSpace(*whole.cloud, kCamera.cast<float>(), opticalAxis(), Eigen::Vector3f::UnitZ(), params)
                  .points.empty());
  params.sensor_min_range_m = 0.0;
  const ObjectView cut = cutBottleView(kMinRange);
  EXPECT_TRUE(nearRangeBlindSpace(*cut.cloud, kCamera.cast<float>(), opticalAxis(), Eigen::Vector3f::UnitZ(), params)
                  .points.empty());
}

TEST(NearRange, AddedToTheObstaclesOnlyWithTheCameraPose)
{
  ObjectView view = cutBottleView(kMinRange);
  auto neighbour = std::make_shared<CloudXYZ>();
  neighbour->push_back(PointXYZ(1.0f, 2.0f, 3.0f));
  view.obstacles = neighbour;
  const std::size_t at_limit = addNearRangeBlindSpace(view, xtion());
  EXPECT_GE(at_limit, 5u);
  ASSERT_TRUE(view.obstacles);
  EXPECT_GT(view.obstacles->size(), 1u);
  EXPECT_EQ(view.obstacles->points.front().getVector3fMap(), neighbour->points.front().getVector3fMap());

  // A cloud without a camera pose (it crossed a process boundary): the blind zone is unknown.
  ObjectView posed_nowhere = cutBottleView(kMinRange);
  auto bare = std::make_shared<CloudNormal>(*posed_nowhere.cloud);
  bare->sensor_orientation_ = Eigen::Quaternionf::Identity();
  posed_nowhere.cloud = bare;
  EXPECT_EQ(addNearRangeBlindSpace(posed_nowhere, xtion()), 0u);
  EXPECT_FALSE(posed_nowhere.obstacles);
}

TEST(NearRange, FusedHandsStayOutOfTheInvisibleTop)
{
  GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  config.near_range.sensor_min_range_m = kMinRange;
  config.near_range.add_blind_space = true;  // opt-in: the shipped file has it off
  // Below the cut every side grasp closes below the 30 cm bottle's centre of mass (a drop risk):
  // judged here are the hands a table's planner returns as a last resort (tablePlannerConfig).
  config = tablePlannerConfig(config);
  const auto planner = makeGraspPlanner("fused", config);
  ASSERT_TRUE(planner);
  const GripperModel gripper = synthetic::robotiqLikeGripper();

  ObjectView view = cutBottleView(kMinRange);
  const float cut_top = topOf(*view.cloud);
  // The bottle's invisible part: its surface above the cut, every 5 mm.
  Eigen::Matrix3Xf invisible(3, 0);
  std::vector<Eigen::Vector3f> samples;
  for (double z = cut_top + 0.005; z <= kHeight; z += 0.005)
    for (int k = 0; k < 72; ++k)
    {
      const double a = 2.0 * M_PI * k / 72.0;
      samples.emplace_back(static_cast<float>(kBottleBase.x() + kRadius * std::cos(a)),
                           static_cast<float>(kBottleBase.y() + kRadius * std::sin(a)), static_cast<float>(z));
    }
  invisible.resize(3, static_cast<Eigen::Index>(samples.size()));
  for (std::size_t i = 0; i < samples.size(); ++i)
    invisible.col(static_cast<Eigen::Index>(i)) = samples[i];

  // What the blind space is for: without it the best grasps pinch the cut's rim from above and
  // the hand closes around the invisible top. (The rim seen from outside is one face whose
  // depth is unseen: fused/one_seen_face already ranks the narrowest of those pinches last, so
  // it is off here, to show the blind space's own effect.)
  // Nor does the flag on grasps closing on the cut (below), for the same reason.
  GraspPlannerConfig without_face_rule = config;
  without_face_rule.fused.one_seen_face.enabled = false;
  without_face_rule.near_range.flag_grasps_on_cut = false;
  const GraspResult unaware = makeGraspPlanner("fused", without_face_rule)->plan(view, gripper);
  ASSERT_TRUE(unaware.ok()) << unaware.message;
  EXPECT_TRUE(handSweepHits(unaware.grasps.front().pose, gripper, invisible, 0.0, 0.0));

  addNearRangeBlindSpace(view, config.near_range);
  const GraspResult result = planner->plan(view, gripper);
  ASSERT_TRUE(result.ok()) << result.message;
  // The open hand at the grasp (no sweep, no clearance): a hand that would close around the
  // invisible top, or land on it, is not returned.
  for (const GraspCandidate& g : result.grasps)
    EXPECT_FALSE(handSweepHits(g.pose, gripper, invisible, 0.0, 0.0))
        << "grasp at z " << g.pose.translation().z() << " (cut at " << cut_top << ") reaches into the bottle's top";
}

TEST(NearRange, AGraspClosingOnTheCutIsFlaggedNotOneBelowIt)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectView cut = cutBottleView(kMinRange);
  // The cut: seen points within margin_m (5 mm) of the 0.5 m limit, none nearer than it.
  const CloudNormal at_cut = nearLimitCut(*cut.cloud, xtion());
  EXPECT_GE(at_cut.size(), 5u);
  for (const auto& p : at_cut.points)
  {
    const float depth = (p.getVector3fMap() - kCamera.cast<float>()).dot(opticalAxis());
    EXPECT_LE(depth, static_cast<float>(kMinRange + 0.005) + 1e-6f);
    EXPECT_GE(depth, static_cast<float>(kMinRange) - 0.003f);  // the renderer drops nearer points
  }
  EXPECT_TRUE(closesOnNearLimitCut(pinchOnTheCut(), gripper, at_cut, xtion()));
  EXPECT_FALSE(closesOnNearLimitCut(graspLowOnTheBody(), gripper, at_cut, xtion()));
  // Off, or no range, or no camera pose on the cloud: nothing judged.
  NearRangeParams off = xtion();
  off.flag_grasps_on_cut = false;
  EXPECT_FALSE(closesOnNearLimitCut(pinchOnTheCut(), gripper, nearLimitCut(*cut.cloud, off), off));
  NearRangeParams unknown_camera = xtion();
  unknown_camera.sensor_min_range_m = 0.0;
  EXPECT_FALSE(closesOnNearLimitCut(pinchOnTheCut(), gripper, nearLimitCut(*cut.cloud, unknown_camera), unknown_camera));
  ObjectView posed_nowhere = cut;
  auto bare = std::make_shared<CloudNormal>(*cut.cloud);
  bare->sensor_origin_.setZero();
  posed_nowhere.cloud = bare;
  EXPECT_FALSE(closesOnNearLimitCut(pinchOnTheCut(), gripper, nearLimitCut(*posed_nowhere.cloud, xtion()), xtion()));
  // Seen whole (a 0.3 m range): its real top is no cut, however near the 0.3 m limit is.
  const ObjectView whole = cutBottleView(0.3);
  NearRangeParams short_range = xtion();
  short_range.sensor_min_range_m = 0.3;
  GraspCandidate on_the_top = hold_check_fixtures::graspAt({ kBottleBase.x(), kBottleBase.y(), kHeight - 0.01 },
                                                           { 0, 0, -1 }, { 0, 1, 0 });
  EXPECT_FALSE(closesOnNearLimitCut(on_the_top, gripper, nearLimitCut(*whole.cloud, short_range), short_range));
}

TEST(NearRange, TheHoldCheckDropsAGraspOnTheCutTheFusedPlannerRanksItLast)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectView cut = cutBottleView(kMinRange);
  GraspResult planned;
  planned.grasps = { pinchOnTheCut(0.9), graspLowOnTheBody(0.5) };
  HoldCheckParams params;
  params.near_range = xtion();
  const GraspResult checked =
      HoldCheckedPlanner(std::make_unique<hold_check_fixtures::GivenGrasps>(planned), params).plan(cut, gripper);
  ASSERT_TRUE(checked.ok()) << checked.message;
  ASSERT_EQ(checked.grasps.size(), 1u);
  EXPECT_NEAR(checked.grasps.front().pose.translation().z(), 0.05, 1e-9);
  EXPECT_NE(checked.message.find("dropped 1 grasps closing where the camera's near limit cut the object"),
            std::string::npos)
      << checked.message;

  const GraspResult ranked = hold_check_fixtures::fusedOverGivenGrasps(
      planned, cut, gripper, [](FusedParams& fused) { fused.near_range = xtion(); });
  ASSERT_TRUE(ranked.ok()) << ranked.message;
  ASSERT_EQ(ranked.grasps.size(), 2u);
  EXPECT_FALSE(ranked.grasps.front().drop_risk);
  EXPECT_NEAR(ranked.grasps.front().pose.translation().z(), 0.05, 0.01);
  EXPECT_TRUE(ranked.grasps.back().drop_risk);
  EXPECT_NE(ranked.message.find("near limit cut the object, ranked last: 1"), std::string::npos) << ranked.message;
}

/// The suggested camera: the cut view's camera 15 cm farther back along its optical axis,
/// looking the same way. From there the bottle's middle is 0.5 + 0.15 m away along the axis.
void expectCameraSteppedBack(const GraspResult& none)
{
  EXPECT_EQ(none.failure, GraspFailure::NoStableGrasp);
  ASSERT_TRUE(none.next_view) << none.message;
  const Eigen::Vector3d axis = opticalAxis().cast<double>();
  EXPECT_LT((none.next_view->translation() - (kCamera - 0.15 * axis)).norm(), 1e-5);
  EXPECT_LT((none.next_view->linear().col(2) - axis).norm(), 1e-5);
  EXPECT_NE(none.message.find("next view: the camera 15 cm farther back"), std::string::npos) << none.message;
}

TEST(NearRange, NothingLeftButGraspsOnTheCutSuggestsTheCameraFartherBack)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectView cut = cutBottleView(kMinRange);
  GraspResult planned;
  planned.grasps = { pinchOnTheCut(0.9) };
  HoldCheckParams params;
  params.near_range = xtion();
  expectCameraSteppedBack(
      HoldCheckedPlanner(std::make_unique<hold_check_fixtures::GivenGrasps>(planned), params).plan(cut, gripper));
  // The fused planner, asked for one object, does not return a grasp it expects to drop.
  expectCameraSteppedBack(hold_check_fixtures::fusedOverGivenGrasps(planned, cut, gripper, [](FusedParams& fused) {
    fused.near_range = xtion();
    fused.return_drop_risk_grasps = false;
  }));
  // No step back: no suggestion (the planner's own, none here). A grasp left: none either.
  const GraspResult unsuggested = hold_check_fixtures::fusedOverGivenGrasps(planned, cut, gripper, [](FusedParams& fused) {
    fused.near_range = xtion();
    fused.near_range.next_view_step_back_m = 0.0;
    fused.return_drop_risk_grasps = false;
  });
  EXPECT_FALSE(unsuggested.ok());
  EXPECT_FALSE(unsuggested.next_view);
  planned.grasps.push_back(graspLowOnTheBody(0.5));
  const GraspResult kept =
      HoldCheckedPlanner(std::make_unique<hold_check_fixtures::GivenGrasps>(planned), params).plan(cut, gripper);
  ASSERT_TRUE(kept.ok()) << kept.message;
  EXPECT_FALSE(kept.next_view);
  // Without the camera's pose on the cloud there is nothing to step back from.
  CloudNormal bare = *cut.cloud;
  bare.sensor_orientation_ = Eigen::Quaternionf::Identity();
  EXPECT_FALSE(nextViewBackFromNearLimit(bare, xtion()));
}

TEST(NearRange, TheShippedConfigFlagsGraspsOnTheCutAndAddsNoBlindSpace)
{
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_EQ(config.near_range.sensor_min_range_m, 0.5);
  EXPECT_TRUE(config.near_range.flag_grasps_on_cut);
  EXPECT_FALSE(config.near_range.add_blind_space);
  ObjectView view = cutBottleView(kMinRange);
  EXPECT_EQ(addNearRangeBlindSpace(view, config.near_range), 0u);
  EXPECT_FALSE(view.obstacles);
  const NearRangeParams read =
      nearRangeParamsFromYaml(YAML::Load("{sensor_min_range_m: 0.45, add_blind_space: true, flag_grasps_on_cut: false}"));
  EXPECT_EQ(read.sensor_min_range_m, 0.45);
  EXPECT_TRUE(read.add_blind_space);
  EXPECT_FALSE(read.flag_grasps_on_cut);
  EXPECT_EQ(config.near_range.next_view_step_back_m, 0.15);
  EXPECT_EQ(nearRangeParamsFromYaml(YAML::Load("{next_view_step_back_m: 0.2}")).next_view_step_back_m, 0.2);
  for (const char* bad : { "{flag_grasps_on_cut: 3}", "{no_such_key: 1}", "{next_view_step_back_m: -0.1}" })
    EXPECT_THROW(nearRangeParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

}  // namespace
}  // namespace fast_grasp
