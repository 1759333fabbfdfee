// A body whose flat top is wider than the hand in every direction (wide_flat_top.h), and the
// fused planner that refuses it, on boxes and a ball whose tops follow from their construction.
#include "fast_grasp/grasping/wide_flat_top.h"

#include "fast_grasp/grasping/fused_grasp.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
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
using hold_check_fixtures::graspAt;
using hold_check_fixtures::tableView;

WideFlatTopParams enabled()
{
  WideFlatTopParams p;
  p.enabled = true;
  return p;
}

/// A cereal box lying flat on the table at the origin: 16 cm along x, 21 cm along y, 6 cm tall.
/// Its top (z = 6 cm, normals up) is 16 cm wide at its narrowest, across x.
ObjectView boxLyingFlat(double noise_m = 0.0)
{
  return tableView(synthetic::makeBox({ 0.0, 0.0, 0.03 }, { 0.16, 0.21, 0.06 }), noise_m);
}
}  // namespace

TEST(WideFlatTop, ABoxLyingFlatIsWiderThanTheHandStandingOrSmallItIsNot)
{
  constexpr double kOpening = 0.085;
  for (const double noise : { 0.0, 0.001 })
  {
    const ObjectView flat = boxLyingFlat(noise);
    const FlatTop top = measureFlatTop(*flat.cloud, flat.table_plane, enabled());
    EXPECT_TRUE(top.flat) << "share " << top.top_share;
    // Seen from above, the top is most of what the camera sees (the front and a side face are
    // 6 cm tall); its narrowest extent is the 16 cm edge, less the rays' 3 mm spacing.
    EXPECT_GT(top.top_share, 0.5) << noise;
    EXPECT_NEAR(top.min_width_m, 0.16, 0.008) << noise;
    EXPECT_TRUE(isWideFlatTop(top, kOpening, enabled())) << noise;
    // Not judged when off; a hand opening 17 cm would close across it.
    EXPECT_FALSE(isWideFlatTop(top, kOpening, WideFlatTopParams{}));
    EXPECT_FALSE(isWideFlatTop(top, 0.17, enabled()));
  }
  // The same box standing on its 6 x 16 cm end: its top is 6 cm wide at its narrowest.
  const ObjectView standing = tableView(synthetic::makeBox({ 0.0, 0.0, 0.105 }, { 0.06, 0.16, 0.21 }));
  const FlatTop standing_top = measureFlatTop(*standing.cloud, standing.table_plane, enabled());
  EXPECT_FALSE(isWideFlatTop(standing_top, kOpening, enabled())) << standing_top.min_width_m;
  // A tea box lying flat, 7 x 12 cm: the hand closes across its 7 cm.
  const ObjectView tea = tableView(synthetic::makeBox({ 0.0, 0.0, 0.0325 }, { 0.07, 0.12, 0.065 }));
  const FlatTop tea_top = measureFlatTop(*tea.cloud, tea.table_plane, enabled());
  EXPECT_TRUE(tea_top.flat);
  EXPECT_NEAR(tea_top.min_width_m, 0.07, 0.008);
  EXPECT_FALSE(isWideFlatTop(tea_top, kOpening, enabled()));
  // A phone lying flat (7.5 x 14.8 cm, 1 cm tall) with a marker (1.6 cm thick) lying along it,
  // touching, segmented as one cluster: together 9.1 cm across. The top band (5 mm under the
  // marker's top) holds the marker only; a 1 cm band would take the phone's top in too and call
  // the pair one 9.1 cm top, were the pair not lower than min_height_m (3 cm) as well.
  const std::vector<synthetic::Shape> pair = { synthetic::makeBox({ 0.0, 0.0, 0.005 }, { 0.075, 0.148, 0.01 }),
                                               synthetic::makeCylinder({ 0.0455, 0.0, 0.008 }, { 0, 1, 0 }, 0.008, 0.14) };
  const ObjectView touching =
      synthetic::makeObjectView(synthetic::renderView(pair, { hold_check_fixtures::kCamera, 0.003, 0.0, 7 }),
                                hold_check_fixtures::kCamera);
  const Eigen::Vector4f table(0, 0, 1, 0);
  EXPECT_FALSE(isWideFlatTop(measureFlatTop(*touching.cloud, table, enabled()), kOpening, enabled()));
  WideFlatTopParams thick_band = enabled();
  thick_band.top_band_m = 0.01;
  EXPECT_FALSE(isWideFlatTop(measureFlatTop(*touching.cloud, table, thick_band), kOpening, thick_band))
      << "1.6 cm tall: lower than min_height_m, not judged";
  thick_band.min_height_m = 0.0;
  const FlatTop both = measureFlatTop(*touching.cloud, table, thick_band);
  EXPECT_NEAR(both.min_width_m, 0.091, 0.005);
  EXPECT_TRUE(isWideFlatTop(both, kOpening, thick_band)) << both.top_share;
  // A 10 cm ball: within 5 mm of its top lies a cap of radius 2.2 cm (normals within 26 degrees
  // of up), a tenth of the half ball seen: no flat top.
  const ObjectView ball = tableView(synthetic::makeSphere({ 0.0, 0.0, 0.05 }, 0.05));
  const FlatTop ball_top = measureFlatTop(*ball.cloud, ball.table_plane, enabled());
  EXPECT_FALSE(ball_top.flat) << ball_top.top_share;
  EXPECT_FALSE(isWideFlatTop(ball_top, kOpening, enabled()));
  // Empty and non-finite input: nothing judged, no crash.
  pcl::PointCloud<pcl::PointNormal> empty;
  EXPECT_FALSE(measureFlatTop(empty, Eigen::Vector4f(0, 0, 1, 0), enabled()).flat);
  pcl::PointCloud<pcl::PointNormal> nan_only;
  pcl::PointNormal nan_point;
  nan_point.x = nan_point.y = nan_point.z = std::numeric_limits<float>::quiet_NaN();
  nan_only.push_back(nan_point);
  EXPECT_FALSE(measureFlatTop(nan_only, Eigen::Vector4f(0, 0, 1, 0), enabled()).flat);
}

TEST(WideFlatTop, TheFusedPlannerRefusesABoxLyingFlatAndSaysWhy)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const ObjectView flat = boxLyingFlat();
  // What a planner offers on it: a pinch across its near edge (from above, closing along x,
  // 8 mm wide). Scored high, it would be picked.
  GraspResult planned;
  GraspCandidate pinch = graspAt({ -0.08, 0.0, 0.05 }, { 0, 0, -1 }, { 1, 0, 0 }, 0.9);
  pinch.width_m = 0.008;
  planned.grasps = { pinch };
  const GraspResult refused = hold_check_fixtures::fusedOverGivenGrasps(
      planned, flat, gripper, [](FusedParams& fused) { fused.wide_flat_top = enabled(); });
  EXPECT_EQ(refused.failure, GraspFailure::NoStableGrasp);
  EXPECT_TRUE(refused.grasps.empty());
  EXPECT_NE(refused.message.find("its top is one flat face 16"), std::string::npos) << refused.message;
  EXPECT_NE(refused.message.find("wider than the hand's 85 mm opening"), std::string::npos) << refused.message;

  // Off, the planner's grasp comes through (the rule, not something else, refused it).
  const GraspResult kept = hold_check_fixtures::fusedOverGivenGrasps(planned, flat, gripper, [](FusedParams&) {});
  EXPECT_EQ(kept.message.find("flat face"), std::string::npos) << kept.message;
}

TEST(WideFlatTop, TheShippedConfigJudgesItAndBadValuesAreRefused)
{
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_TRUE(config.fused.wide_flat_top.enabled);
  EXPECT_EQ(config.fused.wide_flat_top.min_top_share, 0.3);
  EXPECT_EQ(config.fused.wide_flat_top.min_excess_over_opening_m, 0.02);
  const FusedParams read = fusedParamsFromYaml(YAML::Load(
      "{wide_flat_top: {enabled: true, top_band_m: 0.02, min_up_cos: 0.8, min_top_share: 0.5, "
      "min_excess_over_opening_m: 0.01}}"));
  EXPECT_TRUE(read.wide_flat_top.enabled);
  EXPECT_EQ(read.wide_flat_top.top_band_m, 0.02);
  EXPECT_EQ(read.wide_flat_top.min_up_cos, 0.8);
  EXPECT_EQ(read.wide_flat_top.min_top_share, 0.5);
  EXPECT_EQ(read.wide_flat_top.min_excess_over_opening_m, 0.01);
  for (const char* bad : { "{wide_flat_top: {top_band_m: 0}}", "{wide_flat_top: {min_up_cos: 1.5}}",
                           "{wide_flat_top: {min_top_share: 0}}", "{wide_flat_top: {min_height_m: 2}}", "{wide_flat_top: {min_excess_over_opening_m: 0.5}}",
                           "{wide_flat_top: {no_such_key: 1}}" })
    EXPECT_THROW(fusedParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

}  // namespace fast_grasp
