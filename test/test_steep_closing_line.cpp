// The hold check's steep-closing-line rule (hold_check.h, closingLineTooSteep): a grasp whose
// closing line tilts more than max_closing_tilt_rad from the table is dropped, unless the object
// is a ball resting on the table. The tilts are set by construction, so the right answer is the
// angle itself.
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <memory>
#include <string>

namespace fast_grasp
{
namespace
{
using hold_check_fixtures::GivenGrasps;
using hold_check_fixtures::graspAt;

constexpr double kDeg = M_PI / 180.0;

/// A grasp centred at `centre` whose closing line rises `tilt_rad` from the table along x; the
/// approach is square to it, coming down from above.
GraspCandidate tiltedGrasp(const Eigen::Vector3d& centre, double tilt_rad)
{
  const Eigen::Vector3d closing(std::cos(tilt_rad), 0.0, std::sin(tilt_rad));
  const Eigen::Vector3d approach(std::sin(tilt_rad), 0.0, -std::cos(tilt_rad));
  return graspAt(centre, approach, closing);
}

HoldCheckParams steepOnly(double max_tilt_rad)
{
  HoldCheckParams params;
  params.max_closing_tilt_rad = max_tilt_rad;
  return params;
}

}  // namespace

TEST(SteepClosingLine, TheTiltIsTheClosingLinesAngleFromTheTable)
{
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const Eigen::Vector3d centre(0.0, 0.0, 0.05);
  const double limit = 27.0 * kDeg;
  for (const double tilt_deg : { 0.0, 10.0, 26.0, -26.0 })
    EXPECT_FALSE(closingLineTooSteep(tiltedGrasp(centre, tilt_deg * kDeg), up, limit)) << tilt_deg;
  for (const double tilt_deg : { 28.0, -28.0, 45.0, 89.0 })
    EXPECT_TRUE(closingLineTooSteep(tiltedGrasp(centre, tilt_deg * kDeg), up, limit)) << tilt_deg;
  // A tilted table: the same grasp is flat against it.
  const Eigen::Vector3f tilted_up(-std::sin(30.0f * static_cast<float>(kDeg)), 0.0f, std::cos(30.0f * static_cast<float>(kDeg)));
  EXPECT_FALSE(closingLineTooSteep(tiltedGrasp(centre, 30.0 * kDeg), tilted_up, limit));
  EXPECT_TRUE(closingLineTooSteep(tiltedGrasp(centre, 0.0), tilted_up, 20.0 * kDeg));
  // 0 = no check.
  EXPECT_FALSE(closingLineTooSteep(tiltedGrasp(centre, 80.0 * kDeg), up, 0.0));
}

TEST(SteepClosingLine, TheHoldCheckDropsASteepGraspOnABoxAndSaysWhy)
{
  // A 5 x 5 x 10 cm box standing on the table; both grasps close through its centre.
  const ObjectView box = hold_check_fixtures::tableView(synthetic::makeBox({ 0.0, 0.0, 0.05 }, { 0.05, 0.05, 0.10 }));
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspResult planned;
  planned.grasps = { tiltedGrasp({ 0.0, 0.0, 0.07 }, 40.0 * kDeg), tiltedGrasp({ 0.0, 0.0, 0.07 }, 5.0 * kDeg) };
  const GraspResult checked =
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), steepOnly(27.0 * kDeg)).plan(box, gripper);
  ASSERT_TRUE(checked.ok()) << checked.message;
  ASSERT_EQ(checked.grasps.size(), 1u);
  EXPECT_NEAR(checked.grasps.front().binormal().z(), std::sin(5.0 * kDeg), 1e-9);
  EXPECT_NE(checked.message.find("dropped 1 grasps whose closing line tilts more than 27 deg from the table"),
            std::string::npos)
      << checked.message;

  // Only the steep one: none left, and the planner says why.
  planned.grasps.pop_back();
  const GraspResult none =
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), steepOnly(27.0 * kDeg)).plan(box, gripper);
  EXPECT_EQ(none.failure, GraspFailure::NoStableGrasp);
  EXPECT_NE(none.message.find("closing line tilts more than 27 deg"), std::string::npos) << none.message;
  EXPECT_NE(none.message.find("none left"), std::string::npos) << none.message;

  // Off: both kept.
  planned.grasps.push_back(tiltedGrasp({ 0.0, 0.0, 0.07 }, 5.0 * kDeg));
  const GraspResult off = HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), steepOnly(0.0)).plan(box, gripper);
  EXPECT_EQ(off.grasps.size(), 2u);
}

TEST(SteepClosingLine, ABallRestingOnTheTableIsJudgedByItsOwnFitNotTheTilt)
{
  // A 6 cm ball: a grasp through its centre closing 40 deg from the table reaches past the
  // centre (the ball's own rule keeps it), and the tilt rule leaves balls alone.
  const ObjectView ball = hold_check_fixtures::tableView(synthetic::makeSphere({ 0.0, 0.0, 0.03 }, 0.03));
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspResult planned;
  planned.grasps = { tiltedGrasp({ 0.0, 0.0, 0.03 }, 40.0 * kDeg) };
  HoldCheckParams params = steepOnly(27.0 * kDeg);
  params.resting_ball.enabled = true;
  ASSERT_TRUE(fitRestingBall(ball, objectExtent(ball), params.resting_ball).found);
  const GraspResult checked = HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), params).plan(ball, gripper);
  ASSERT_TRUE(checked.ok()) << checked.message;
  EXPECT_EQ(checked.grasps.size(), 1u);
  // The same grasp on a box of the ball's size is dropped.
  const ObjectView box = hold_check_fixtures::tableView(synthetic::makeBox({ 0.0, 0.0, 0.03 }, { 0.06, 0.06, 0.06 }));
  ASSERT_FALSE(fitRestingBall(box, objectExtent(box), params.resting_ball).found);
  EXPECT_EQ(HoldCheckedPlanner(std::make_unique<GivenGrasps>(planned), params).plan(box, gripper).failure,
            GraspFailure::NoStableGrasp);
}

TEST(SteepClosingLine, TheShippedConfigChecksAt27DegreesAndBadValuesAreRefused)
{
  const GraspPlannerConfig config =
      loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_EQ(config.hold_check.max_closing_tilt_rad, 0.47);
  EXPECT_EQ(holdCheckConfigFromYaml(YAML::Load("{max_closing_tilt_rad: 0}")).max_closing_tilt_rad, 0.0);
  for (const char* bad : { "{max_closing_tilt_rad: -0.1}", "{max_closing_tilt_rad: 2}" })
    EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
}

}  // namespace fast_grasp
