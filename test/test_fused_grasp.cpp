// The fused planner and its grasp features on analytic shapes whose right answer is derived by
// hand: a 4 x 6 x 8 cm box standing on the table, seen from 45 deg above.
#include "fast_grasp/grasping/fused_grasp.h"
#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/grasp_planner_params.h"

#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <utility>

namespace fast_grasp
{
namespace
{
// Box: 4 cm along x, 6 cm along y, 8 cm tall, standing on z = 0 (the table), points
// `spacing_m` apart.
ObjectView boxView(double spacing_m = 0.002)
{
  const Eigen::Vector3d camera(-0.35, 0.0, 0.43);
  auto cloud = synthetic::renderView(synthetic::makeBox({ 0.0, 0.0, 0.04 }, { 0.04, 0.06, 0.08 }),
                                     { camera, spacing_m, 0.0, 1 });
  ObjectView view = synthetic::makeObjectView(cloud, camera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  return view;
}

/// A can of `radius_m` and `length_m` lying along y on the table (z = 0), seen from 52 deg above
/// on its -x side (the camera sees its top and near side), points `spacing_m` apart.
ObjectView lyingCanView(double radius_m, double length_m, double spacing_m)
{
  const Eigen::Vector3d camera(-0.35, 0.0, 0.45);
  auto cloud = synthetic::renderView(
      synthetic::makeCylinder({ 0.0, 0.0, radius_m }, { 0.0, 1.0, 0.0 }, radius_m, length_m), { camera, spacing_m, 0.0, 1 });
  ObjectView view = synthetic::makeObjectView(cloud, camera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  return view;
}

constexpr double kXtionMaxIncidenceRad = 70.0 * M_PI / 180.0;  // xtion_renderer.h

std::size_t featureIndex(const std::string& name)
{
  const auto& names = graspFeatureNames();
  return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
}

FusedParams onlyGenerated()
{
  FusedParams p;
  p.planners.clear();
  return p;
}

/// No pooled planners and no candidates of fused's own (each test turns on what it studies);
/// the hand check as config/grasp_planners.yaml's fused section has it.
FusedParams noCandidatesOfItsOwn()
{
  FusedParams p = onlyGenerated();
  p.top_down_directions = 0;
  p.side_directions = 0;
  p.end_grasps = false;
  p.max_grasps = 100;
  p.gripper_fit.palm_clearance_m = 0.005;
  p.gripper_fit.table_clearance_m = 0.006;
  return p;
}
}  // namespace

TEST(GraspFeatures, TopDownGraspAcrossTheBoxReadsAsItsGeometry)
{
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectExtent extent = objectExtent(view);
  EXPECT_NEAR(extent.height_m, 0.08, 0.003);
  // Top-down, closing along x (across the 4 cm side), closing line 2 cm below the top.
  GraspCandidate grasp;
  grasp.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.06), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  const auto f = graspFeatures(grasp, "top_down", view, extent, gripper);
  ASSERT_EQ(f.size(), graspFeatureNames().size());
  EXPECT_EQ(f[featureIndex("from_top_down")], 1.0);
  EXPECT_EQ(f[featureIndex("from_cshape")], 0.0);
  EXPECT_NEAR(f[featureIndex("contact_height_frac")], 0.06 / 0.08, 0.03);
  EXPECT_NEAR(f[featureIndex("approach_down")], 1.0, 1e-6);
  // The seen points between the fingers span the 4 cm across (the camera sees the -x face and
  // the top): width over the 85 mm opening.
  EXPECT_NEAR(f[featureIndex("width_frac")], 0.04 / 0.085, 0.03);
  // The -x face is square to the closing line: inside the friction cone by atan(0.8).
  EXPECT_NEAR(f[featureIndex("cone_margin_rad")], std::atan(0.8), 0.1);
}

TEST(GraspFeatures, FootprintAndWeightTorqueOfTheBox)
{
  const ObjectView view = boxView();
  const ObjectExtent extent = objectExtent(view);
  // The camera looks along +x: it sees the whole 6 cm along y and the top's full 4 cm along x.
  EXPECT_NEAR(std::abs(extent.major_axis.y()), 1.0, 1e-3);
  EXPECT_NEAR(extent.length_m, 0.06, 0.004);
  EXPECT_NEAR(extent.breadth_m, 0.04, 0.004);
  // A top-down grasp closing along x, 2 cm beside the centroid along y: the lever is 2 cm
  // (0.4 in units of 5 cm) times the 4 x 6 x 8 cm box's 0.192 l.
  GraspCandidate grasp;
  grasp.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.02, 0.06), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  const auto f = graspFeatures(grasp, "top_down", view, extent, synthetic::robotiqLikeGripper());
  const double arm = std::hypot(extent.centroid.y() - 0.02, extent.centroid.z() - 0.06) / 0.05;
  EXPECT_NEAR(f[featureIndex("centroid_arm_m")], arm, 1e-3);
  EXPECT_NEAR(f[featureIndex("weight_torque")], arm * 0.192, 0.03);
}

TEST(FusedGrasp, DenseViewsAreThinnedToMaxPooledPoints)
{
  // The box seen at 1 mm spacing: ~10k points. Capped at 1000, the points between the fingers
  // of every candidate come from at most 1000 points; uncapped, from many more.
  const ObjectView view = boxView(0.001);
  ASSERT_GT(view.cloud->size(), 5000u);
  const auto most_between = [&](std::size_t cap) {
    FusedParams p = onlyGenerated();
    p.max_pooled_points = cap;
    p.max_grasps = 100;
    const GraspResult result = FusedGraspPlanner({}, p).plan(view, synthetic::robotiqLikeGripper());
    EXPECT_TRUE(result.ok()) << result.message;
    double most = 0.0;
    for (const GraspCandidate& g : result.grasps)
      most = std::max(most, std::expm1(g.features[featureIndex("points_between_log")] * std::log(1000.0)));
    return most;
  };
  EXPECT_LE(most_between(1000), 1000.5);
  EXPECT_GT(most_between(0), 1500.0);
}

TEST(FusedGrasp, GeneratedCandidatesCloseAcrossTheNarrowSideAndStayOffTheTable)
{
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  std::vector<std::unique_ptr<GraspPlanner>> none;
  FusedGraspPlanner planner(std::move(none), onlyGenerated());
  const GraspResult result = planner.plan(view, gripper);
  ASSERT_TRUE(result.ok()) << result.message;
  for (const GraspCandidate& g : result.grasps)
  {
    // Across 4 cm or 6 cm fits the 85 mm opening, the 8 cm height is never a closing width.
    EXPECT_LT(g.width_m, 0.085);
    EXPECT_GT(g.width_m, 0.035);
    // every corner of the open hand above the table (the fingertips are 2 cm below the line)
    const double fingertip = g.position().z() + 0.02 * g.approach().z() - 0.011 * std::abs(g.axis().z());
    EXPECT_GT(fingertip, 0.0) << g.algorithm;
    EXPECT_EQ(g.features.size(), graspFeatureNames().size());
  }
}

TEST(FusedGrasp, TheModelDecidesTheRanking)
{
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  for (const std::string favoured : { "top_down", "side" })
  {
    FusedParams p = onlyGenerated();
    p.model.weights.assign(graspFeatureNames().size(), 0.0);
    p.model.weights[featureIndex("from_" + favoured)] = 3.0;
    FusedGraspPlanner planner({}, p);
    const GraspResult result = planner.plan(view, gripper);
    ASSERT_TRUE(result.ok()) << result.message;
    EXPECT_EQ(result.grasps.front().algorithm, "fused/" + favoured);
    EXPECT_NEAR(result.grasps.front().score, 1.0 / (1.0 + std::exp(-3.0)), 1e-9);
    for (std::size_t i = 1; i < result.grasps.size(); ++i)
      EXPECT_GE(result.grasps[i - 1].score, result.grasps[i].score);
  }
}

TEST(FusedGrasp, PoolsTheThesisPlannersWithTheirOwnParameters)
{
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspPlannerConfig config;
  config.fused.max_grasps = 200;
  const auto planner = makeGraspPlanner("fused", config);
  ASSERT_TRUE(planner);
  EXPECT_STREQ(planner->name(), "fused");
  const GraspResult result = planner->plan(view, gripper);
  ASSERT_TRUE(result.ok()) << result.message;
  std::set<std::string> sources;
  for (const auto& g : result.grasps)
    sources.insert(g.algorithm);
  EXPECT_TRUE(sources.count("fused/top_down")) << result.message;
  EXPECT_GE(sources.size(), 2u) << result.message;
}

// fused/pooled_max_grasps stops a pooled planner early inside the pool only: the same config's
// standalone C-shape planner still returns its own max_grasps.
TEST(FusedGrasp, PooledMaxGraspsCapsThePlannerOnlyInsideThePool)
{
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspPlannerConfig config;
  config.fused.planners = { "cshape" };
  config.fused.top_down_directions = 0;
  config.fused.side_directions = 0;
  config.fused.end_grasps = false;
  config.fused.deepen_pooled_max_m = 0.0;
  config.fused.max_grasps = 200;
  config.fused.pooled_max_grasps = { { "cshape", 2 } };
  const GraspResult alone = makeGraspPlanner("cshape", config)->plan(view, gripper);
  ASSERT_TRUE(alone.ok()) << alone.message;
  ASSERT_GT(alone.grasps.size(), 2u) << alone.message;
  const GraspResult pooled = makeGraspPlanner("fused", config)->plan(view, gripper);
  ASSERT_TRUE(pooled.ok()) << pooled.message;
  EXPECT_EQ(pooled.grasps.size(), 2u) << pooled.message;

  const FusedParams p = fusedParamsFromYaml(YAML::Load("{pooled_max_grasps: {cshape: 5}}"));
  EXPECT_EQ(p.pooled_max_grasps.at("cshape"), 5u);
  for (const char* bad : { "{pooled_max_grasps: {fused: 5}}", "{planners: [boundary], pooled_max_grasps: {cshape: 5}}",
                           "{pooled_max_grasps: {cshape: 0}}", "{pooled_max_grasps: {cshape: 2.5}}",
                           "{pooled_max_grasps: [5]}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

namespace
{
/// A pooled planner that always proposes one fixed grasp, named like a thesis planner.
class FixedGraspPlanner : public GraspPlanner
{
public:
  explicit FixedGraspPlanner(GraspCandidate grasp) : grasp_(std::move(grasp)) {}
  GraspResult plan(const ObjectView& /*view*/, const GripperModel& /*gripper*/) const override
  {
    GraspResult result;
    result.grasps.push_back(grasp_);
    return result;
  }
  const char* name() const override { return "cshape"; }

private:
  GraspCandidate grasp_;
};
}  // namespace

namespace
{
/// A pooled planner that finds no grasp but reports an unseen part (as the thesis planners do).
class UnseenPartOnlyPlanner : public GraspPlanner
{
public:
  explicit UnseenPartOnlyPlanner(CloudXYZ unseen) : unseen_(std::move(unseen)) {}
  GraspResult plan(const ObjectView& /*view*/, const GripperModel& /*gripper*/) const override
  {
    GraspResult result = GraspResult::fail(GraspFailure::NoStableGrasp, "none");
    result.unseen = unseen_;
    return result;
  }
  const char* name() const override { return "boundary"; }

private:
  CloudXYZ unseen_;
};
}  // namespace

namespace
{
/// The fused planner over one fixed grasp per pooled planner, in this order, with no
/// candidates of its own and every point seen: the lying-object rules alone reorder them.
GraspResult planPooledOnLyingObject(const ObjectView& view, const GripperModel& gripper,
                                    const std::vector<GraspCandidate>& grasps, const LyingCylinderParams& lying,
                                    bool return_drop_risk_grasps = true)
{
  FusedParams p = noCandidatesOfItsOwn();
  p.max_pooled_points = 0;
  p.lying_cylinder = lying;
  p.return_drop_risk_grasps = return_drop_risk_grasps;
  std::vector<std::unique_ptr<GraspPlanner>> planners;
  for (const GraspCandidate& grasp : grasps)
    planners.push_back(std::make_unique<FixedGraspPlanner>(grasp));
  return FusedGraspPlanner(std::move(planners), p).plan(view, gripper);
}
/// On lyingCanView(0.034, 0.10, ...): a grasp closing across the can 35 deg from vertical from
/// the camera's side, its fingertips 8 mm short of the axis, and one from above whose fingertips
/// pass the axis by 4 mm.
constexpr double kShortGraspTiltRad = 35.0 * M_PI / 180.0;
std::pair<GraspCandidate, GraspCandidate> shortAndPassingGraspsOnTheLyingCan()
{
  const double tilt = kShortGraspTiltRad;
  const Eigen::Vector3d approach(std::sin(tilt), 0.0, -std::cos(tilt));
  GraspCandidate oblique;
  oblique.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.034) - (0.008 + 0.02) * approach, approach,
                               Eigen::Vector3d(std::cos(tilt), 0.0, std::sin(tilt)));
  oblique.width_m = 0.068;
  GraspCandidate from_above;
  from_above.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.05), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  from_above.width_m = 0.068;
  return { oblique, from_above };
}
}  // namespace

TEST(FusedGrasp, PooledGraspsAreAlsoOfferedDeeperSoTheFingertipsPassTheEquator)
{
  // A can (radius 2.5 cm, 15 cm long) lying along y on the table: its equator is 2.5 cm up,
  // its top 5 cm. A planner closes across it (along x) from above with the closing line at
  // the top: the fingertips (2 cm below the line) end at 3 cm, above the equator, and the
  // can slips out on the lift. Pushed deeper until the palm (2 cm above the line) is
  // palm_clearance_m = 5 mm over the top, the line is at 3.5 cm, the fingertips at 1.5 cm.
  const ObjectView view = lyingCanView(0.025, 0.15, 0.002);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspCandidate at_top;
  at_top.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.05), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  at_top.width_m = 0.05;

  const auto pooled_heights = [&](double deepen_m) {
    FusedParams p = noCandidatesOfItsOwn();
    p.deepen_pooled_max_m = deepen_m;
    std::vector<std::unique_ptr<GraspPlanner>> planners;
    planners.push_back(std::make_unique<FixedGraspPlanner>(at_top));
    const GraspResult result = FusedGraspPlanner(std::move(planners), p).plan(view, gripper);
    EXPECT_TRUE(result.ok()) << result.message;
    std::vector<double> heights;
    for (const GraspCandidate& g : result.grasps)
    {
      EXPECT_EQ(g.algorithm, "fused/cshape");
      EXPECT_NEAR(g.approach().z(), -1.0, 1e-9);  // deeper along the same approach, not turned
      heights.push_back(g.position().z());
    }
    std::sort(heights.begin(), heights.end());
    return heights;
  };
  const std::vector<double> planner_only = pooled_heights(0.0);
  ASSERT_EQ(planner_only.size(), 1u);
  EXPECT_NEAR(planner_only.front(), 0.05, 1e-9);

  const std::vector<double> with_deeper = pooled_heights(0.04);
  ASSERT_EQ(with_deeper.size(), 2u);
  EXPECT_NEAR(with_deeper.back(), 0.05, 1e-9);  // the planner's own grasp stays in the pool
  const double fingertips = with_deeper.front() - 0.5 * gripper.finger_depth_m;
  EXPECT_LT(fingertips, 0.025 - 0.005);  // past the equator
  EXPECT_GT(fingertips, 0.006 - 1e-6);    // and above the table by table_clearance_m
  // the palm stays palm_clearance_m (5 mm, one 5 mm step of resolution) above the top
  const double palm = with_deeper.front() + 0.5 * gripper.finger_depth_m;
  EXPECT_GE(palm, 0.05 + 0.005 - 1e-3);
  EXPECT_LE(palm, 0.05 + 0.005 + 0.005 + 1e-3);
}

TEST(FusedGrasp, GraspsWhoseFingertipsStopShortOfALyingCansAxisRankLast)
{
  // A can (radius 3.4 cm, 10 cm long) lying along y, its axis 3.4 cm up. Two planners propose
  // one grasp each, closing across it; the model (no weights) scores them alike, so the pool's
  // order decides. The first comes 35 deg from vertical from the camera's side with its
  // fingertips 8 mm short of the axis (they touch above the widest section: in physics it
  // squeezes out); the second from above with its fingertips at 3 cm, 4 mm past the axis.
  const ObjectView view = lyingCanView(0.034, 0.10, 0.003);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const double tilt = kShortGraspTiltRad;
  const auto grasps = shortAndPassingGraspsOnTheLyingCan();  // (no structured binding: lambdas capture these)
  const GraspCandidate& oblique = grasps.first;
  const GraspCandidate& from_above = grasps.second;

  const auto plan = [&](bool lying_cylinder) {
    LyingCylinderParams lying;
    lying.enabled = lying_cylinder;
    return planPooledOnLyingObject(view, gripper, { oblique, from_above }, lying);
  };
  const GraspResult off = plan(false);
  ASSERT_TRUE(off.ok()) << off.message;
  ASSERT_EQ(off.grasps.size(), 2u);
  EXPECT_NEAR(off.grasps.front().approach().z(), -std::cos(tilt), 1e-9) << "pool order without the fit";
  const GraspResult on = plan(true);
  ASSERT_TRUE(on.ok()) << on.message;
  ASSERT_EQ(on.grasps.size(), 2u) << "the short grasp is kept, as a last resort";
  EXPECT_NEAR(on.grasps.front().approach().z(), -1.0, 1e-9);
  EXPECT_NEAR(on.grasps.back().approach().z(), -std::cos(tilt), 1e-9);
  EXPECT_NE(on.message.find("lying round object (radius 34 mm), fingertips short of its axis, ranked last: 1"),
            std::string::npos)
      << on.message;

  // The YAML keys (config/grasp_planners.yaml fused/lying_cylinder), and bad values refused.
  const FusedParams read = fusedParamsFromYaml(YAML::Load(
      "{lying_cylinder: {enabled: true, min_length_to_height: 1.5, max_normal_spread_ratio: 0.3, max_median_residual_frac: 0.1, "
      "max_median_normal_angle_rad: 0.2, min_points: 40, min_fingertip_reach_m: -0.002}}"));
  EXPECT_TRUE(read.lying_cylinder.enabled);
  EXPECT_EQ(read.lying_cylinder.min_length_to_height, 1.5);
  EXPECT_EQ(read.lying_cylinder.max_normal_spread_ratio, 0.3);
  EXPECT_EQ(read.lying_cylinder.max_median_residual_frac, 0.1);
  EXPECT_EQ(read.lying_cylinder.max_median_normal_angle_rad, 0.2);
  EXPECT_EQ(read.lying_cylinder.min_points, 40u);
  EXPECT_EQ(read.lying_cylinder.min_fingertip_reach_m, -0.002);
  for (const char* bad : { "{lying_cylinder: {min_fingertip_reach_m: 0.5}}", "{lying_cylinder: {max_median_residual_frac: 0}}",
                           "{lying_cylinder: {no_such_key: 1}}", "{lying_cylinder: {min_points: 1}}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

TEST(FusedGrasp, GraspsWithADropRiskAreNotReturnedWhenConfiguredSo)
{
  // The can and the two grasps of the test above: the oblique one stops 8 mm short of the axis
  // (a drop risk), the one from above passes it. With return_drop_risk_grasps false the short
  // one is never returned; proposed alone, it leaves no grasp, and the answer says why.
  const ObjectView view = lyingCanView(0.034, 0.10, 0.003);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const auto grasps = shortAndPassingGraspsOnTheLyingCan();  // (no structured binding: lambdas capture these)
  const GraspCandidate& oblique = grasps.first;
  const GraspCandidate& from_above = grasps.second;
  LyingCylinderParams lying;
  lying.enabled = true;

  const GraspResult both = planPooledOnLyingObject(view, gripper, { oblique, from_above }, lying, false);
  ASSERT_TRUE(both.ok()) << both.message;
  ASSERT_EQ(both.grasps.size(), 1u);
  EXPECT_NEAR(both.grasps.front().approach().z(), -1.0, 1e-9);
  EXPECT_NE(both.message.find("fingertips short of its axis, not returned: 1"), std::string::npos) << both.message;

  const GraspResult alone = planPooledOnLyingObject(view, gripper, { oblique }, lying, false);
  EXPECT_FALSE(alone.ok());
  EXPECT_EQ(alone.failure, GraspFailure::NoStableGrasp);
  EXPECT_NE(alone.message.find("fingertips short of its axis, not returned: 1"), std::string::npos) << alone.message;
  // ... while the default keeps it as a last resort.
  const GraspResult kept = planPooledOnLyingObject(view, gripper, { oblique }, lying);
  ASSERT_TRUE(kept.ok()) << kept.message;
  EXPECT_TRUE(kept.grasps.front().drop_risk);

  EXPECT_FALSE(fusedParamsFromYaml(YAML::Load("{return_drop_risk_grasps: false}")).return_drop_risk_grasps);
  EXPECT_EQ(fusedParamsFromYaml(YAML::Load("{finger_graze_penalty: 0.2}")).finger_graze_penalty, 0.2);
  EXPECT_THROW(fusedParamsFromYaml(YAML::Load("{finger_graze_penalty: 2}")), std::runtime_error);
  EXPECT_EQ(fusedParamsFromYaml(YAML::Load("{gripper_fit: {finger_graze_margin_m: 0.003}}")).gripper_fit.finger_graze_margin_m,
            0.003);
}

TEST(FusedGrasp, GraspsWhoseOpenHandLandsOnALyingCansHiddenSideRankLast)
{
  // The can of the test above (radius 3.4 cm along y, axis 3.4 cm up), two top-down grasps
  // closing across it with the fingertips 4 mm past the axis (centre 5 cm up; the palm then
  // clears the top by 2 mm). The first is 1.5 cm off the axis across it: its far finger's inner
  // face, 4.25 cm from the centre, comes down 2.75 cm from the axis, 6.5 mm into the can's
  // far side, which the camera never saw. The second is centred over the axis.
  const ObjectView view = lyingCanView(0.034, 0.10, 0.003);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspCandidate offset;
  offset.pose = makeGraspPose(Eigen::Vector3d(0.015, 0.0, 0.05), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  offset.width_m = 0.068;
  GraspCandidate centred = offset;
  centred.pose.translation().x() = 0.0;

  const auto plan = [&](double max_open_hand_depth_m) {
    LyingCylinderParams lying;
    lying.enabled = true;
    lying.max_open_hand_depth_m = max_open_hand_depth_m;
    return planPooledOnLyingObject(view, gripper, { offset, centred }, lying);
  };
  const GraspResult off = plan(std::numeric_limits<double>::infinity());
  ASSERT_TRUE(off.ok()) << off.message;
  ASSERT_EQ(off.grasps.size(), 2u);
  EXPECT_NEAR(off.grasps.front().position().x(), 0.015, 1e-9) << "pool order without the check";
  const GraspResult on = plan(0.003);
  ASSERT_TRUE(on.ok()) << on.message;
  ASSERT_EQ(on.grasps.size(), 2u) << "the offset grasp is kept, as a last resort";
  EXPECT_NEAR(on.grasps.front().position().x(), 0.0, 1e-9);
  EXPECT_NEAR(on.grasps.back().position().x(), 0.015, 1e-9);
  EXPECT_NE(on.message.find("open hand onto its hidden side, ranked last: 1"), std::string::npos) << on.message;

  const FusedParams read = fusedParamsFromYaml(
      YAML::Load("{lying_cylinder: {max_open_hand_depth_m: 0.002, open_hand_approach_m: 0.05}}"));
  EXPECT_EQ(read.lying_cylinder.max_open_hand_depth_m, 0.002);
  EXPECT_EQ(read.lying_cylinder.open_hand_approach_m, 0.05);
  for (const char* bad : { "{lying_cylinder: {max_open_hand_depth_m: -0.001}}", "{lying_cylinder: {open_hand_approach_m: 3}}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

TEST(FusedGrasp, EndGraspsCloseAcrossALyingCansDiameterAtItsEquator)
{
  // A can (radius 3.3 cm, 12 cm long: longer than the 85 mm opening) lying along y, seen from
  // 52 deg above on its -x side: the camera sees its top and near side, not its far side.
  // From either end, horizontally along y, the fingers close along x across its diameter: the
  // closing line at the equator (half the 6.6 cm height; the palm, 4.4 cm wide, then stays 1.1
  // cm off the table) through the axis (x = 0; the seen near edge at x = -3.3 cm plus the
  // height), width 6.6 cm; the palm palm_clearance_m before the end, the fingers around it.
  const double radius = 0.033, length = 0.12;
  // 4 mm spacing: below max_pooled_points, so no full-resolution re-check (no pooled planner
  // gives an unseen part here; with one, the far finger must stay out of it as well)
  const ObjectView view = lyingCanView(radius, length, 0.004);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  FusedParams p = noCandidatesOfItsOwn();
  p.gripper_fit.max_table_tilt_rad = 0.0;
  EXPECT_FALSE(FusedGraspPlanner({}, p).plan(view, gripper).ok());  // off: nothing generated

  p.end_grasps = true;
  const GraspResult result = FusedGraspPlanner({}, p).plan(view, gripper);
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_EQ(result.grasps.size(), 2u);
  std::set<int> ends;
  for (const GraspCandidate& g : result.grasps)
  {
    EXPECT_NEAR(std::abs(g.approach().y()), 1.0, 1e-3);
    EXPECT_NEAR(std::abs(g.binormal().x()), 1.0, 1e-3);
    EXPECT_NEAR(g.position().z(), radius, 0.004);
    EXPECT_NEAR(g.position().x(), 0.0, 0.005);
    EXPECT_NEAR(g.width_m, 2.0 * radius, 0.005);
    const double end = -0.5 * length * (g.approach().y() > 0.0 ? 1.0 : -1.0);  // the end it comes from
    const double palm = g.approach().y() * (g.position().y() - end) - 0.5 * gripper.finger_depth_m;
    EXPECT_NEAR(palm, -0.005, 0.003);  // the palm 5 mm before the end (+-1 mm points, 1 mm margin)
    ends.insert(g.approach().y() > 0.0 ? 1 : -1);
  }
  EXPECT_EQ(ends.size(), 2u);
  // A pooled planner's unseen part fills the space beyond the +y end (what the can would hide
  // there seen from that side: a bottle's neck). The grasp from that end would put its palm
  // into it: dropped; the one from the -y end stays.
  CloudXYZ hidden_neck;
  for (double y = 0.062; y < 0.11; y += 0.004)
    for (double x = -0.014; x <= 0.014; x += 0.004)
      for (double z = 0.02; z <= 0.047; z += 0.004)
        hidden_neck.push_back(pcl::PointXYZ(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  std::vector<std::unique_ptr<GraspPlanner>> with_unseen;
  with_unseen.push_back(std::make_unique<UnseenPartOnlyPlanner>(hidden_neck));
  const GraspResult beside_hidden = FusedGraspPlanner(std::move(with_unseen), p).plan(view, gripper);
  ASSERT_TRUE(beside_hidden.ok()) << beside_hidden.message;
  ASSERT_EQ(beside_hidden.grasps.size(), 1u);
  EXPECT_GT(beside_hidden.grasps.front().approach().y(), 0.99) << "from the -y end, away from the hidden part";
  EXPECT_NE(beside_hidden.message.find("end-on with the palm in the unseen part: 1"), std::string::npos)
      << beside_hidden.message;
  // Standing up, 12 cm tall: higher than the opening, so nothing says how far its hidden back
  // reaches (an upright cracker box's is 6 cm behind its front, not 12): no end grasps.
  const Eigen::Vector3d camera(-0.35, 0.0, 0.45);  // lyingCanView's
  auto standing = synthetic::renderView(synthetic::makeCylinder({ 0.0, 0.0, 0.5 * length }, { 0.0, 0.0, 1.0 }, radius, length),
                                        { camera, 0.004, 0.0, 1 });
  ObjectView upright = synthetic::makeObjectView(standing, camera);
  upright.has_table_plane = true;
  upright.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  EXPECT_FALSE(FusedGraspPlanner({}, p).plan(upright, gripper).ok());
}

TEST(FusedGrasp, ABodyLyingWiderThanTheOpeningGetsNoGraspANarrowerOneDoes)
{
  // A body lying along y, 9.8 cm wide, 25 cm long and 6.5 cm high (a bleach bottle on its broad
  // face), seen from 52 deg above on its -x side by a depth camera (no return beyond 70 deg
  // incidence, as the Xtion): no grasp can close across it with the 85 mm hand. Mirror
  // completion reads its width from its seen near side and its level top, and the planner says
  // why it has no grasp. A 7 cm one fits the hand and gets its grasps; so does the wide one when
  // the refusal allows 2 cm more than the opening.
  const auto lyingBody = [](double width_m) {
    const Eigen::Vector3d camera(-0.35, 0.0, 0.45);
    synthetic::ViewParams depth_camera{ camera, 0.002 };
    depth_camera.max_incidence_rad = kXtionMaxIncidenceRad;
    ObjectView view = synthetic::makeObjectView(
        synthetic::renderView(synthetic::makeBox({ 0.0, 0.0, 0.0325 }, { width_m, 0.25, 0.065 }), depth_camera), camera);
    view.has_table_plane = true;
    view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
    return view;
  };
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  ASSERT_NEAR(gripper.max_opening_m, 0.085, 1e-9);
  FusedParams p = onlyGenerated();
  p.wide_lying_body.enabled = true;
  const GraspResult wide = FusedGraspPlanner({}, p).plan(lyingBody(0.098), gripper);
  ASSERT_FALSE(wide.ok()) << wide.message;
  EXPECT_EQ(wide.failure, GraspFailure::NoStableGrasp);
  EXPECT_NE(wide.message.find("wider than the hand's 85 mm opening"), std::string::npos) << wide.message;

  const GraspResult narrow = FusedGraspPlanner({}, p).plan(lyingBody(0.07), gripper);
  ASSERT_TRUE(narrow.ok()) << narrow.message;
  const std::size_t said = narrow.message.find("lying body ");
  ASSERT_NE(said, std::string::npos) << narrow.message;
  EXPECT_NEAR(std::stoi(narrow.message.substr(said + 11)), 70, 3) << narrow.message;  // mm, as completed

  const FusedParams read = fusedParamsFromYaml(
      YAML::Load("{planners: [], wide_lying_body: {enabled: true, min_elongation: 1.5, max_free_fraction: 0.1, "
                 "min_excess_over_opening_m: 0.02}}"));
  ASSERT_TRUE(read.wide_lying_body.enabled);
  const GraspResult allowed = FusedGraspPlanner({}, read).plan(lyingBody(0.098), gripper);
  EXPECT_EQ(allowed.message.find("wider than the hand"), std::string::npos) << allowed.message;
  EXPECT_THROW(fusedParamsFromYaml(YAML::Load("{wide_lying_body: {enabled: true, min_elongation: 0.5}}")),
               std::runtime_error);
  EXPECT_THROW(fusedParamsFromYaml(YAML::Load("{wide_lying_body: {widht: 1}}")), std::runtime_error);
}

TEST(FusedGrasp, TallObjectsAreHeldAboveTheirCentreOfMass)
{
  // A bottle: a 16 cm body of radius 3.3 cm under a 9 cm neck of radius 1.3 cm (25 cm tall),
  // standing, seen from the side and 40 cm above the table. One side direction (the view's).
  // Tall handling off: the one side grasp closes at the seen points' centroid, in the body's
  // lower half. On (tall from 15 cm, sides also at 0.75 and 0.9 of the height): two more side
  // grasps close on the neck at 18.75 and 22.5 cm, about 2.6 cm wide (the neck seen across
  // the closing direction, square to the view); the centroid one, below 0.6 of the height, ranks last.
  const double height = 0.25;
  const Eigen::Vector3d camera(-0.5, 0.0, 0.4);
  auto cloud = synthetic::renderView({ synthetic::makeCylinder({ 0.0, 0.0, 0.08 }, { 0.0, 0.0, 1.0 }, 0.033, 0.16),
                                       synthetic::makeCylinder({ 0.0, 0.0, 0.205 }, { 0.0, 0.0, 1.0 }, 0.013, 0.09) },
                                     { camera, 0.003, 0.0, 1 });
  ObjectView view = synthetic::makeObjectView(cloud, camera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  ASSERT_NEAR(objectExtent(view).height_m, height, 0.004);
  FusedParams p = noCandidatesOfItsOwn();
  p.side_directions = 1;
  const GraspResult off = FusedGraspPlanner({}, p).plan(view, gripper);
  ASSERT_TRUE(off.ok()) << off.message;
  ASSERT_EQ(off.grasps.size(), 1u);
  EXPECT_LT(off.grasps.front().position().z(), 0.6 * height);

  p.tall_object_min_height_m = 0.15;
  p.side_high_fracs = { 0.75, 0.9 };
  p.tall_side_min_height_frac = 0.6;
  const GraspResult on = FusedGraspPlanner({}, p).plan(view, gripper);
  ASSERT_TRUE(on.ok()) << on.message;
  ASSERT_EQ(on.grasps.size(), 3u);
  std::set<int> neck_heights_mm;
  for (std::size_t i = 0; i < 2; ++i)
  {
    const GraspCandidate& g = on.grasps[i];
    EXPECT_NEAR(std::abs(g.approach().x()), 1.0, 1e-3);  // horizontal, from the camera's side
    EXPECT_NEAR(g.width_m, 0.025, 0.005);  // the neck's 2.6 cm as seen (grazing points sparse), not the body's 6.6
    EXPECT_NEAR(g.position().y(), 0.0, 0.003);
    neck_heights_mm.insert(static_cast<int>(std::lround(g.position().z() * 1000.0)));
  }
  EXPECT_EQ(neck_heights_mm, (std::set<int>{ 188, 225 }));  // 0.75 and 0.9 of the 25 cm (+-1 mm)
  EXPECT_NEAR(on.grasps.back().position().z(), off.grasps.front().position().z(), 1e-6) << "the pendulum grasp ranks last";
  EXPECT_NE(on.message.find("centre of mass"), std::string::npos) << on.message;

  // The YAML keys (config/grasp_planners.yaml fused section), and bad values refused.
  const FusedParams read =
      fusedParamsFromYaml(YAML::Load("{tall_object_min_height_m: 0.15, side_high_fracs: [0.75, 0.9], tall_side_min_height_frac: 0.6}"));
  EXPECT_EQ(read.tall_object_min_height_m, 0.15);
  EXPECT_EQ(read.side_high_fracs, (std::vector<double>{ 0.75, 0.9 }));
  EXPECT_EQ(read.tall_side_min_height_frac, 0.6);
  for (const char* bad : { "{side_high_fracs: [1.2]}", "{side_high_fracs: [0.0]}", "{tall_side_min_height_frac: 1.5}",
                           "{tall_object_min_height_m: 3.0}", "{tall_object_min_height_m: -0.1}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;

  // A 12 cm can is not tall at 15 cm: nothing changes.
  auto can = synthetic::renderView(synthetic::makeCylinder({ 0.0, 0.0, 0.06 }, { 0.0, 0.0, 1.0 }, 0.033, 0.12),
                                   { camera, 0.003, 0.0, 1 });
  ObjectView can_view = synthetic::makeObjectView(can, camera);
  can_view.has_table_plane = true;
  can_view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  EXPECT_EQ(FusedGraspPlanner({}, p).plan(can_view, gripper).grasps.size(), 1u);
}

TEST(FusedGrasp, GraspsPlannedOnAThinnedViewAreCheckedAgainstTheFullViewsUnseenPart)
{
  // The box seen densely (1 mm: ~7000 points). Its unseen back lies behind it along the camera
  // rays: behind the +x face (x = 2 cm) the shadow of the top back edge drops ~43 deg, so at
  // x = 4.5 cm it covers everything below z ~ 5.6 cm. A top-down grasp closing along x at
  // z = 6 cm puts its +x finger (x 4.25-5.45 cm, z 4-8 cm) into that shadow; one closing along
  // y keeps both fingers beside the box, clear of it.
  const ObjectView view = boxView(0.001);
  ASSERT_GT(view.cloud->size(), 5000u);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspCandidate into_back;
  into_back.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.06), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  into_back.width_m = 0.04;
  GraspCandidate beside = into_back;
  beside.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.06), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  beside.width_m = 0.06;

  const auto plan = [&](const GraspCandidate& proposed, std::size_t max_pooled_points) {
    FusedParams p = onlyGenerated();
    p.top_down_directions = 0;
    p.side_directions = 0;
    p.end_grasps = false;
    p.deepen_pooled_max_m = 0.0;
    p.max_pooled_points = max_pooled_points;
    std::vector<std::unique_ptr<GraspPlanner>> planners;
    planners.push_back(std::make_unique<FixedGraspPlanner>(proposed));
    return FusedGraspPlanner(std::move(planners), p).plan(view, gripper);
  };
  // Not thinned: the pool trusts what its planners checked on the same points.
  const GraspResult full = plan(into_back, 0);
  ASSERT_TRUE(full.ok()) << full.message;
  EXPECT_EQ(full.grasps.size(), 1u);
  // Thinned to 500 points: the grasp is checked once more with every point and the full view's
  // unseen part, and dropped.
  const GraspResult thinned = plan(into_back, 500);
  EXPECT_FALSE(thinned.ok());
  EXPECT_NE(thinned.message.find("dropped at full resolution: 1"), std::string::npos) << thinned.message;
  const GraspResult kept = plan(beside, 500);
  ASSERT_TRUE(kept.ok()) << kept.message;
  ASSERT_EQ(kept.grasps.size(), 1u);
  EXPECT_LT((kept.grasps.front().position() - beside.position()).norm(), 0.011);  // at most a back-off
}

TEST(PlannerInput, AnObjectSpanningKilometresIsDegenerateForEveryPlanner)
{
  // Found by the random views below: principal_axis sized its sweep by the extent and threw
  // std::bad_alloc on a cloud spanning 2000 km. Every planner now answers with a typed failure.
  ObjectView view = boxView();
  CloudNormal::Ptr far(new CloudNormal(*view.cloud));
  PointNormal p = far->points.front();
  p.x = 2.0e6f;
  far->push_back(p);
  view.cloud = far;
  GraspPlannerConfig config;
  for (const std::string& name : graspAlgorithmNames())
  {
    GraspResult result;
    ASSERT_NO_THROW(result = makeGraspPlanner(name, config)->plan(view, synthetic::robotiqLikeGripper())) << name;
    EXPECT_EQ(result.failure, GraspFailure::DegenerateInput) << name << ": " << result.message;
    EXPECT_NE(result.message.find("span"), std::string::npos) << result.message;
  }
}

TEST(PlannerInput, AViewWiderThanMaxObjectExtentIsDegenerateForEveryPlanner)
{
  // A box plus one point 1.2 m away: wider than the deployed max_object_extent_m (1 m).
  ObjectView view = boxView();
  CloudNormal::Ptr wide(new CloudNormal(*view.cloud));
  PointNormal p = wide->points.front();
  p.x += 1.2f;
  wide->push_back(p);
  view.cloud = wide;
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspPlannerConfig config;
  for (const std::string& name : graspAlgorithmNames())
  {
    const GraspResult result = makeGraspPlanner(name, config)->plan(view, gripper);
    EXPECT_EQ(result.failure, GraspFailure::DegenerateInput) << name << ": " << result.message;
    EXPECT_NE(result.message.find("more than max_object_extent_m 1 m"), std::string::npos) << result.message;
  }
  // A larger limit lets the same view through the input check; an unusable one is a parameter error.
  PlannerInputLimits wider;
  wider.max_object_extent_m = 2.0;
  setInputLimits(config, wider);
  PlannerInputLimits unusable;
  unusable.max_object_extent_m = 0.0;
  GraspPlannerConfig bad_config;
  setInputLimits(bad_config, unusable);
  for (const std::string& name : graspAlgorithmNames())
  {
    const GraspResult result = makeGraspPlanner(name, config)->plan(view, gripper);
    EXPECT_EQ(result.message.find("max_object_extent_m"), std::string::npos) << name << ": " << result.message;
    const GraspResult refused = makeGraspPlanner(name, bad_config)->plan(boxView(), gripper);
    EXPECT_EQ(refused.failure, GraspFailure::InvalidParameters) << name << ": " << refused.message;
  }
}

TEST(PlannerInput, MaxObjectExtentIsOneTopLevelKeyForEveryPlanner)
{
  const GraspPlannerConfig deployed =
      loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  for (const double limit : { deployed.principal_axis.input_limits.max_object_extent_m,
                              deployed.cshape.input_limits.max_object_extent_m,
                              deployed.boundary.input_limits.max_object_extent_m,
                              deployed.concavity.input_limits.max_object_extent_m,
                              deployed.fused.input_limits.max_object_extent_m })
    EXPECT_EQ(limit, 1.0);
  YAML::Node root;
  root["max_object_extent_m"] = 0.5;
  EXPECT_EQ(plannerInputLimitsFromYaml(root).max_object_extent_m, 0.5);
  root["max_object_extent_m"] = -1.0;
  EXPECT_THROW(plannerInputLimitsFromYaml(root), std::runtime_error);
  root["max_object_extent_m"] = "wide";
  EXPECT_THROW(plannerInputLimitsFromYaml(root), std::runtime_error);
  EXPECT_EQ(plannerInputLimitsFromYaml(YAML::Node()).max_object_extent_m, PlannerInputLimits().max_object_extent_m);
}

TEST(FusedGrasp, BadInputAndBadModelAreTypedFailures)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  FusedGraspPlanner planner({}, onlyGenerated());
  ObjectView empty;
  empty.cloud.reset(new CloudNormal);
  EXPECT_EQ(planner.plan(empty, gripper).failure, GraspFailure::EmptyInput);
  FusedParams bad = onlyGenerated();
  bad.model.weights = { 1.0, 2.0 };  // not one per feature
  FusedGraspPlanner wrong({}, bad);
  EXPECT_EQ(wrong.plan(boxView(), gripper).failure, GraspFailure::InvalidParameters);
}

// Random views, seeded: clouds of 0-1500 points from blobs, lines, a single repeated point, huge
// coordinates, with NaN / inf / denormal coordinates and normals sprinkled in, random or
// non-finite sensor origins and table planes. Whatever comes in, plan() must return (no throw, no
// crash), and every grasp it returns must be finite with a probability score.
TEST(FusedGrasp, RandomAndBrokenViewsNeverCrashAndGiveFiniteGrasps)
{
  GraspPlannerConfig config;
  const auto planner = makeGraspPlanner("fused", config);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  std::mt19937 rng(20261202);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float weird[] = { nan, inf, -inf, 1e-40f, 1e30f, 0.0f };
  int planned = 0;
  for (int trial = 0; trial < 120; ++trial)
  {
    CloudNormal::Ptr cloud(new CloudNormal);
    const int n = static_cast<int>(rng() % 1500);
    const int shape = static_cast<int>(rng() % 5);
    const Eigen::Vector3f centre(0.5f + 0.1f * unit(rng), 0.1f * unit(rng), 0.05f + 0.05f * unit(rng));
    for (int i = 0; i < n; ++i)
    {
      PointNormal p;
      Eigen::Vector3f q;
      if (shape == 0)
        q = centre + 0.04f * Eigen::Vector3f(unit(rng), unit(rng), unit(rng));
      else if (shape == 1)
        q = centre + 0.1f * unit(rng) * Eigen::Vector3f(1.0f, 0.3f, 0.0f);  // a line
      else if (shape == 2)
        q = centre;  // one point, repeated
      else if (shape == 3)
        q = 1e6f * Eigen::Vector3f(unit(rng), unit(rng), unit(rng));  // huge
      else
        q = centre + Eigen::Vector3f(0.05f * unit(rng), 0.05f * unit(rng), 0.0f);  // flat on the table
      p.getVector3fMap() = q;
      p.getNormalVector3fMap() = Eigen::Vector3f(unit(rng), unit(rng), unit(rng)).normalized();
      if (rng() % 20 == 0)
        p.x = weird[rng() % 6];
      if (rng() % 20 == 0)
        p.normal_z = weird[rng() % 6];
      cloud->push_back(p);
    }
    ObjectView view;
    view.cloud = cloud;
    if (rng() % 4 != 0)
      view.sensor_origins.push_back(centre + Eigen::Vector3f(-0.4f, 0.1f * unit(rng), 0.4f));
    if (rng() % 6 == 0)
      view.sensor_origins.push_back(Eigen::Vector3f(weird[rng() % 6], 0.0f, 0.5f));
    view.has_table_plane = rng() % 3 != 0;
    view.table_plane = rng() % 5 == 0 ? Eigen::Vector4f(weird[rng() % 6], 0.0f, 0.0f, 0.0f)
                                      : Eigen::Vector4f(0.05f * unit(rng), 0.05f * unit(rng), 1.0f, 0.01f * unit(rng));
    GraspResult result;
    ASSERT_NO_THROW(result = planner->plan(view, gripper)) << "trial " << trial;
    if (!result.ok())
    {
      EXPECT_NE(result.failure, GraspFailure::None) << "trial " << trial;
      EXPECT_FALSE(result.message.empty()) << "trial " << trial;
      continue;
    }
    ++planned;
    for (const GraspCandidate& g : result.grasps)
    {
      EXPECT_TRUE(g.pose.matrix().allFinite()) << "trial " << trial << " " << g.algorithm;
      EXPECT_GE(g.score, 0.0);
      EXPECT_LE(g.score, 1.0);
      for (const double f : g.features)
        EXPECT_TRUE(std::isfinite(f)) << "trial " << trial << " " << g.algorithm;
    }
  }
  EXPECT_GT(planned, 0);  // the blobs on a table do get grasps
}

TEST(FusedGrasp, YamlModelNamesFeatures)
{
  const YAML::Node node = YAML::Load("{model: {bias: 0.5, weights: {from_side: 2.0, approach_down: -1.0}}}");
  const FusedParams p = fusedParamsFromYaml(node);
  ASSERT_EQ(p.model.weights.size(), graspFeatureNames().size());
  EXPECT_EQ(p.model.weights[featureIndex("from_side")], 2.0);
  EXPECT_EQ(p.model.weights[featureIndex("approach_down")], -1.0);
  EXPECT_EQ(p.model.bias, 0.5);
  EXPECT_THROW(fusedParamsFromYaml(YAML::Load("{model: {weights: {no_such_feature: 1.0}}}")), std::runtime_error);
  EXPECT_THROW(fusedParamsFromYaml(YAML::Load("{planners: [fused]}")), std::runtime_error);
}

TEST(FusedGrasp, AGraspWhoseOpenFingerGrazesTheObjectRanksLower)
{
  // Two top-down grasps across the box's 6 cm side (y in +-0.03), equal in the model's eyes
  // (all weights 0), the first 1 cm off centre: its -y finger's inner face (0.0425 from the
  // hand's centre, the 85 mm opening) is then 2.5 mm from the box's -y face, the centred
  // one's 12.5 mm. With a 4 mm graze margin and a penalty the off-centre grasp is returned
  // second; it is not dropped. Without either the pool's order stands.
  const ObjectView view = boxView();
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspCandidate off_centre;
  off_centre.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.01, 0.065), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  off_centre.width_m = 0.06;
  GraspCandidate centred = off_centre;
  centred.pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.065);

  const auto plan = [&](double graze_margin_m, double penalty) {
    FusedParams p = noCandidatesOfItsOwn();
    p.deepen_pooled_max_m = 0.0;
    p.max_pooled_points = 0;
    p.model.weights.assign(graspFeatureNames().size(), 0.0);
    p.gripper_fit.finger_graze_margin_m = graze_margin_m;
    p.finger_graze_penalty = penalty;
    std::vector<std::unique_ptr<GraspPlanner>> planners;
    planners.push_back(std::make_unique<FixedGraspPlanner>(off_centre));
    planners.push_back(std::make_unique<FixedGraspPlanner>(centred));
    return FusedGraspPlanner(std::move(planners), p).plan(view, gripper);
  };
  const GraspResult plain = plan(0.0, 0.05);
  ASSERT_TRUE(plain.ok()) << plain.message;
  ASSERT_EQ(plain.grasps.size(), 2u);
  EXPECT_NEAR(plain.grasps[0].position().y(), 0.01, 1e-6);

  const GraspResult margin = plan(0.004, 0.05);
  ASSERT_TRUE(margin.ok()) << margin.message;
  ASSERT_EQ(margin.grasps.size(), 2u);
  EXPECT_NEAR(margin.grasps[0].position().y(), 0.0, 1e-6);
  EXPECT_NEAR(margin.grasps[1].position().y(), 0.01, 1e-6);
  EXPECT_NE(margin.message.find("ranked 0.05 lower: 1"), std::string::npos) << margin.message;

  // A margin of 2 mm leaves the 2.5 mm gap alone; without a penalty grazing changes nothing.
  const GraspResult small = plan(0.002, 0.05);
  ASSERT_TRUE(small.ok()) << small.message;
  EXPECT_NEAR(small.grasps[0].position().y(), 0.01, 1e-6);
  const GraspResult no_penalty = plan(0.004, 0.0);
  ASSERT_TRUE(no_penalty.ok()) << no_penalty.message;
  EXPECT_NEAR(no_penalty.grasps[0].position().y(), 0.01, 1e-6);
}

}  // namespace fast_grasp
