// The standing round section fit, how far a side grasp's fingertips get toward its axis, and
// the hold check that drops side grasps stopping well short of a tall bottle's axis, on analytic
// shapes whose centre, radius and reaches follow from their construction.
#include "fast_grasp/grasping/standing_cylinder.h"

#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

namespace fast_grasp
{
namespace
{
using hold_check_fixtures::GivenGrasps;
using hold_check_fixtures::graspAt;

/// A wine bottle's body: 7.4 cm wide, 30 cm tall, standing at the table's origin.
constexpr double kRadius = 0.037;
constexpr double kHeight = 0.30;

ObjectView standingCylinder(double radius_m, double height_m, double noise_m = 0.0)
{
  return hold_check_fixtures::tableView(
      synthetic::makeCylinder({ 0.0, 0.0, 0.5 * height_m }, { 0, 0, 1 }, radius_m, height_m), noise_m);
}

StandingCylinderParams enabled()
{
  StandingCylinderParams p;
  p.enabled = true;
  return p;
}

/// A side grasp at `height_m`, approaching along +x (from the camera's side) toward the axis,
/// closing along y, its fingertips (finger_depth_m / 2 = 2 cm ahead of its centre) at x = tip_x.
GraspCandidate sideGrasp(double tip_x, double height_m, double score = 0.0)
{
  return graspAt({ tip_x - 0.02, 0.0, height_m }, { 1, 0, 0 }, { 0, 1, 0 }, score);
}

}  // namespace

TEST(StandingCylinder, TheSectionOfAStandingBottleIsFoundWithItsAxisAndRadius)
{
  for (const double noise : { 0.0, 0.001 })
  {
    const ObjectView view = standingCylinder(kRadius, kHeight, noise);
    const StandingSection section = fitStandingSection(view, objectExtent(view), 0.10f, enabled());
    ASSERT_TRUE(section.found) << section.why << " (noise " << noise << ")";
    EXPECT_NEAR(section.radius_m, kRadius, 0.002) << noise;
    // on the axis, at the height asked for
    EXPECT_LT((section.centre.cast<double>() - Eigen::Vector3d(0.0, 0.0, 0.10)).norm(), 0.003) << noise;
    // the camera sees about half of the side
    EXPECT_GT(section.arc_rad, 2.0f) << noise;
  }
}

TEST(StandingCylinder, BoxesAndEmptyBandsAreNoRoundSection)
{
  // A standing box as wide as the bottle: its two seen faces lie off any circle.
  const ObjectView box = hold_check_fixtures::tableView(synthetic::makeBox({ 0.0, 0.0, 0.15 }, { 0.074, 0.074, 0.30 }));
  const StandingSection boxed = fitStandingSection(box, objectExtent(box), 0.10f, enabled());
  EXPECT_FALSE(boxed.found) << boxed.radius_m;
  // A cereal box standing (16 x 6 cm, 21 cm high), turned to show both faces: they bend about
  // a circle far wider than the box.
  for (const double yaw : { 0.3, 0.6, 0.9, 1.2 })
  {
    const ObjectView cereal = hold_check_fixtures::tableView(synthetic::makeBox(
        { 0.0, 0.0, 0.105 }, { 0.16, 0.06, 0.21 }, Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix()));
    const StandingSection section = fitStandingSection(cereal, objectExtent(cereal), 0.10f, enabled());
    EXPECT_FALSE(section.found) << "yaw " << yaw << ": radius " << section.radius_m;
  }
  // Above the object there is nothing to fit.
  const ObjectView bottle = standingCylinder(kRadius, kHeight);
  const StandingSection above = fitStandingSection(bottle, objectExtent(bottle), 0.40f, enabled());
  EXPECT_FALSE(above.found);
  EXPECT_EQ(above.why, "too few side points at that height");
  // Without a table plane there is no height.
  ObjectView floating = bottle;
  floating.has_table_plane = false;
  EXPECT_FALSE(fitStandingSection(floating, objectExtent(floating), 0.10f, enabled()).found);
}

TEST(StandingCylinder, SideGraspsStoppingWellShortOfTheAxisAreMissed)
{
  const ObjectView view = standingCylinder(kRadius, kHeight);
  const ObjectExtent extent = objectExtent(view);
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const StandingCylinderParams params = enabled();
  // Tips 12 mm short of the axis (0.32 radius): missed; the reach is the construction's.
  const auto short_tips = standingSectionMissed(sideGrasp(-0.012, 0.10), gripper, view, extent, params);
  ASSERT_TRUE(short_tips.has_value());
  EXPECT_NEAR(fingertipReachPastStandingAxis(sideGrasp(-0.012, 0.10), gripper, *short_tips, extent.up), -0.012, 0.002);
  // 4 mm short (0.11 radius) or past it: not missed.
  EXPECT_FALSE(standingSectionMissed(sideGrasp(-0.004, 0.10), gripper, view, extent, params).has_value());
  EXPECT_FALSE(standingSectionMissed(sideGrasp(0.006, 0.10), gripper, view, extent, params).has_value());
  // A top-down grasp is no side grasp.
  EXPECT_FALSE(
      standingSectionMissed(graspAt({ 0.0, 0.0, 0.31 }, { 0, 0, -1 }, { 0, 1, 0 }), gripper, view, extent, params)
          .has_value());
  // A 10 cm can is not tall: its chord grasps hold.
  const ObjectView can = standingCylinder(kRadius, 0.10);
  EXPECT_FALSE(standingSectionMissed(sideGrasp(-0.012, 0.05), gripper, can, objectExtent(can), params).has_value());
  // Off: nothing is judged.
  StandingCylinderParams off = params;
  off.enabled = false;
  EXPECT_FALSE(standingSectionMissed(sideGrasp(-0.012, 0.10), gripper, view, extent, off).has_value());
}

TEST(StandingCylinder, TheHoldCheckDropsChordGraspsOnATallBottleAndKeepsTheRestInOrder)
{
  const ObjectView view = standingCylinder(kRadius, kHeight);
  GraspResult given;
  given.grasps.push_back(sideGrasp(-0.015, 0.12, 0.9));                                   // 0.41 radius short
  given.grasps.push_back(sideGrasp(0.004, 0.08, 0.8));                                    // past the axis
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.31 }, { 0, 0, -1 }, { 0, 1, 0 }, 0.7));  // from above
  HoldCheckParams params;
  params.standing_cylinder = enabled();
  const GraspResult result =
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), params).plan(view, synthetic::robotiqLikeGripper());
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_EQ(result.grasps.size(), 2u) << result.message;
  EXPECT_DOUBLE_EQ(result.grasps[0].score, 0.8);
  EXPECT_DOUBLE_EQ(result.grasps[1].score, 0.7);
  EXPECT_NE(result.message.find("dropped 1 side grasps whose fingertips stop short of its axis"), std::string::npos)
      << result.message;
  // Only the chord grasp: none left, and the planner says why.
  GraspResult chord;
  chord.grasps.push_back(given.grasps.front());
  const GraspResult none =
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(chord), params).plan(view, synthetic::robotiqLikeGripper());
  EXPECT_FALSE(none.ok());
  EXPECT_NE(none.message.find("tall round object"), std::string::npos) << none.message;
  // On a standing box of the same size the same grasps all come back.
  const ObjectView box = hold_check_fixtures::tableView(synthetic::makeBox({ 0.0, 0.0, 0.15 }, { 0.074, 0.074, 0.30 }));
  EXPECT_EQ(
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), params).plan(box, synthetic::robotiqLikeGripper()).grasps.size(),
      3u);
}

TEST(StandingCylinder, TheShippedConfigChecksTallRoundObjectsAndBadParametersAreRefused)
{
  const GraspPlannerConfig config =
      loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_TRUE(config.hold_check.standing_cylinder.enabled);
  EXPECT_EQ(config.hold_check.standing_cylinder.validate(), "");
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planners: [cshape]\nstanding_cylinder: {max_shortfall_frac: 2.0}")),
               std::runtime_error);
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planners: [cshape]\nstanding_cylinder: {radius: 0.03}")),
               std::runtime_error);
  StandingCylinderParams p = enabled();
  p.band_half_height_m = 0.0;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.min_points = 2;
  EXPECT_NE(p.validate(), "");
}

}  // namespace fast_grasp
