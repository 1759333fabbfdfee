// The resting ball fit, how deep a grasp's fingertips reach into the ball, and the hold check
// that drops grasps stopping high on it, on analytic shapes whose centre, radius and depths
// follow from their construction.
#include "fast_grasp/grasping/resting_ball.h"

#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>

namespace fast_grasp
{
namespace
{
using hold_check_fixtures::GivenGrasps;
using hold_check_fixtures::graspAt;

ObjectView viewOf(const synthetic::Shape& shape, double noise_m = 0.0)
{
  return hold_check_fixtures::tableView(shape, noise_m);
}

RestingBallParams enabled()
{
  RestingBallParams p;
  p.enabled = true;
  return p;
}

RestingBall fit(const ObjectView& view, const RestingBallParams& params = enabled())
{
  return fitRestingBall(view, objectExtent(view), params);
}

/// A found body resting on the table at the origin: half-height `radius_m`, footprint half-axes
/// `major_m` x `minor_m`.
RestingBall restingBody(float radius_m, float major_m, float minor_m)
{
  RestingBall body;
  body.found = true;
  body.centre = Eigen::Vector3f(0.0f, 0.0f, radius_m);
  body.radius_m = radius_m;
  body.horizontal_half_axes_m = Eigen::Vector2f(major_m, minor_m);
  return body;
}

}  // namespace

TEST(RestingBall, ABallOnTheTableIsFoundWithItsCentreAndRadius)
{
  // A 6 cm ball resting on the table: its centre 3 cm up, off the origin; seen from one side
  // only its near cap, yet the centre is where the table puts it.
  const Eigen::Vector3d centre(0.03, -0.02, 0.03);
  for (const double noise : { 0.0, 0.001 })
  {
    const RestingBall ball = fit(viewOf(synthetic::makeSphere(centre, 0.03), noise));
    ASSERT_TRUE(ball.found) << ball.why << " (noise " << noise << ")";
    EXPECT_NEAR(ball.radius_m, 0.03, 0.0015) << noise;
    EXPECT_LT((ball.centre.cast<double>() - centre).norm(), 0.003) << noise;
    EXPECT_LT(ball.median_residual_m, 0.12 * 0.03) << noise;
  }
}

TEST(RestingBall, BoxesCansAndBarsAreNotBalls)
{
  // A cube as high as the ball: its faces lie up to 0.7 of the radius off the sphere and their
  // normals up to 55 deg off the radial direction.
  EXPECT_FALSE(fit(viewOf(synthetic::makeBox({ 0.0, 0.0, 0.03 }, { 0.06, 0.06, 0.06 }))).found);
  // A standing can as wide as it is high: a flat top and a straight side.
  EXPECT_FALSE(fit(viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.03 }, { 0, 0, 1 }, 0.03, 0.06))).found);
  // A lying can 10 cm long: its footprint is longer than it is high.
  const RestingBall lying = fit(viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.03 }, { 0, 1, 0 }, 0.03, 0.10)));
  EXPECT_FALSE(lying.found);
  EXPECT_EQ(lying.why, "footprint not as wide as it is high");
  // Off: nothing is found.
  RestingBallParams off = enabled();
  off.enabled = false;
  EXPECT_FALSE(fit(viewOf(synthetic::makeSphere({ 0.0, 0.0, 0.03 }, 0.03)), off).found);
  // Without a table plane the height says nothing of the radius.
  ObjectView floating = viewOf(synthetic::makeSphere({ 0.0, 0.0, 0.03 }, 0.03));
  floating.has_table_plane = false;
  EXPECT_FALSE(fit(floating).found);
}

TEST(RestingBall, AFlatRoundBodyIsFittedAsAnEllipsoidWhenAllowed)
{
  // A flat pebble: an ellipsoid with half-axes 4.5 x 3.5 x 2 cm resting on the table (centre
  // 2 cm up). Made from a rendered 2 cm ball by stretching x and y (an affine map keeps which
  // points a camera sees: the ball is rendered from the camera pulled back by the inverse map),
  // normals by the inverse transpose.
  const Eigen::Vector3d stretch(0.045 / 0.02, 0.035 / 0.02, 1.0);
  const Eigen::Vector3d eye = hold_check_fixtures::kCamera;
  auto cloud = synthetic::renderView(synthetic::makeSphere({ 0.0, 0.0, 0.02 }, 0.02),
                                     { eye.cwiseQuotient(stretch), 0.002, 0.0, 7 });
  for (auto& p : cloud->points)
  {
    p.getVector3fMap() = p.getVector3fMap().cwiseProduct(stretch.cast<float>());
    p.getNormalVector3fMap() = p.getNormalVector3fMap().cwiseQuotient(stretch.cast<float>()).normalized();
  }
  ObjectView view = synthetic::makeObjectView(cloud, eye);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);

  const RestingBall as_ball = fit(view);  // balls only (max_length_to_height 1.25)
  EXPECT_FALSE(as_ball.found);
  RestingBallParams params = enabled();
  params.max_length_to_height = 2.5;
  const RestingBall pebble = fit(view, params);
  ASSERT_TRUE(pebble.found) << pebble.why;
  EXPECT_NEAR(pebble.radius_m, 0.02, 0.0015);
  EXPECT_LT((pebble.centre.cast<double>() - Eigen::Vector3d(0.0, 0.0, 0.02)).norm(), 0.006);
  // Straight down its radius is the vertical half-axis; along its long axis (x) the long one,
  // within what a partial view gives of the footprint.
  EXPECT_NEAR(radiusAlong(pebble, Eigen::Vector3f(0, 0, -1)), 0.02, 0.0015);
  EXPECT_NEAR(radiusAlong(pebble, Eigen::Vector3f(1, 0, 0)), 0.045, 0.006);
  // Top-down grasps (fingertips 2 cm ahead of the centre): tips 1.8 cm above the table, 2.2 cm
  // into it and past its rim at half height, are kept; at 3 cm, 1 cm into it, dropped.
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const Eigen::Vector3d down(0, 0, -1), across(0, 1, 0);
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.038 }, down, across), gripper, pebble, params));
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.05 }, down, across), gripper, pebble, params));
  // It is flat (2 cm high against a 3.5 cm half-breadth): with the shipped extra depth (0.2 of
  // its 2 cm half-height = 4 mm past the centre) the tips 2 mm past it no longer do, 6 mm past do.
  EXPECT_TRUE(isFlatRoundBody(pebble, params));
  params.flat_min_fingertip_past_centre_frac = 0.2;
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.038 }, down, across), gripper, pebble, params));
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.034 }, down, across), gripper, pebble, params));
  // A box of the same footprint is still no round body.
  EXPECT_FALSE(fit(viewOf(synthetic::makeBox({ 0.0, 0.0, 0.02 }, { 0.09, 0.07, 0.04 })), params).found);
}

TEST(RestingBall, AFlatBodysFingertipsMustPassItsCentreABallsNeedNot)
{
  // Hand-placed bodies; fingertips finger_depth_m / 2 = 2 cm ahead of the grasp centre, top-down.
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  RestingBallParams params = enabled();
  params.flat_min_fingertip_past_centre_frac = 0.2;
  const Eigen::Vector3d down(0, 0, -1), across(0, 1, 0);
  // A pebble 9 x 7 x 4 cm lying flat (centre 2 cm up): 0.57 times as high as broad, flat. It
  // needs the tips 0.2 x 2 cm = 4 mm past its centre: at 1.7 cm (3 mm past) dropped, at 1.5 cm kept.
  RestingBall pebble = restingBody(0.02f, 0.045f, 0.035f);
  EXPECT_TRUE(isFlatRoundBody(pebble, params));
  EXPECT_NEAR(fingertipReachPastCentre(graspAt({ 0.0, 0.0, 0.037 }, down, across), gripper, pebble), 0.003, 1e-6);
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.037 }, down, across), gripper, pebble, params));
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.035 }, down, across), gripper, pebble, params));
  // Without the extra depth (0) the old rule alone: reaching the centre is enough.
  RestingBallParams plain = params;
  plain.flat_min_fingertip_past_centre_frac = 0.0;
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.037 }, down, across), gripper, pebble, plain));
  // An 8 cm ball (all half-axes 4 cm) is not flat: tips 1.3 cm short of its centre, 2.7 cm
  // into it, still hold.
  const RestingBall ball = restingBody(0.04f, 0.04f, 0.04f);
  EXPECT_FALSE(isFlatRoundBody(ball, params));
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.073 }, down, across), gripper, ball, params));
  // Nor is a lemon on its side (7.2 x 5.4 x 5.4 cm): as high as it is broad. Tips 2 mm short of
  // its centre, 2.5 cm into it, are kept.
  const RestingBall lemon = restingBody(0.027f, 0.036f, 0.027f);
  EXPECT_FALSE(isFlatRoundBody(lemon, params));
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.049 }, down, across), gripper, lemon, params));
  // A fit without half-axes (zero) says nothing of flatness.
  pebble.horizontal_half_axes_m = Eigen::Vector2f::Zero();
  EXPECT_FALSE(isFlatRoundBody(pebble, params));
}

TEST(RestingBall, FingertipsMustReachTheGripDepthOrPassTheCentre)
{
  // Hand-placed ball (centre, radius): the fingertips are finger_depth_m / 2 = 2 cm ahead of
  // the grasp centre. Depth into the ball from its near side = radius + reach past the centre.
  RestingBall ball;
  ball.found = true;
  ball.centre = Eigen::Vector3f(0.0f, 0.0f, 0.04f);
  ball.radius_m = 0.04f;
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const RestingBallParams params = enabled();  // 2.5 cm
  const Eigen::Vector3d down(0, 0, -1), across(1, 0, 0);
  // top-down, tips at 5.3 cm: 1.3 cm short of the centre, 2.7 cm into the 8 cm ball (kept)
  const GraspCandidate deep_enough = graspAt({ 0.0, 0.0, 0.073 }, down, across);
  EXPECT_NEAR(fingertipReachPastCentre(deep_enough, gripper, ball), -0.013, 1e-6);
  EXPECT_FALSE(fingertipsStopHighOnBall(deep_enough, gripper, ball, params));
  // tips at 6 cm: 2 cm into it (dropped)
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.08 }, down, across), gripper, ball, params));
  // from the side (approach +x), the grasp centre 5.5 cm before the centre: tips 3.5 cm
  // before it, 5 mm into the ball (dropped); 3.2 cm before it: tips 1.2 cm short, 2.8 cm in (kept)
  const Eigen::Vector3d side(1, 0, 0), vertical(0, 0, 1);
  EXPECT_NEAR(fingertipReachPastCentre(graspAt({ -0.055, 0.0, 0.04 }, side, vertical), gripper, ball), -0.035, 1e-6);
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ -0.055, 0.0, 0.04 }, side, vertical), gripper, ball, params));
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ -0.032, 0.0, 0.04 }, side, vertical), gripper, ball, params));
  // A 3 cm ball (radius 1.5 cm < 2.5 cm): the tips must pass its centre.
  ball.centre = Eigen::Vector3f(0.0f, 0.0f, 0.015f);
  ball.radius_m = 0.015f;
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.033 }, down, across), gripper, ball, params));  // 2 mm past
  EXPECT_TRUE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.037 }, down, across), gripper, ball, params));   // 2 mm short
  // Nothing found: nothing is judged.
  ball.found = false;
  EXPECT_FALSE(fingertipsStopHighOnBall(graspAt({ 0.0, 0.0, 0.2 }, down, across), gripper, ball, params));
}

TEST(RestingBall, TheHoldCheckDropsGraspsHighOnABallAndKeepsTheRestInOrder)
{
  // The 6 cm ball of ABallOnTheTableIsFoundWithItsCentreAndRadius, at the origin: needs the
  // tips 2.5 cm in, at most 3.5 cm above the table.
  const ObjectView view = viewOf(synthetic::makeSphere({ 0.0, 0.0, 0.03 }, 0.03));
  const Eigen::Vector3d down(0, 0, -1), across(1, 0, 0);
  GraspResult given;
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.065 }, down, across, 0.9));  // tips at 4.5 cm: 1.5 cm in
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.048 }, down, across, 0.8));  // tips at 2.8 cm: past the centre
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.053 }, down, across, 0.7));  // tips at 3.3 cm: 2.7 cm in
  HoldCheckParams params;
  params.resting_ball = enabled();
  const GraspResult result = HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), params)
                                 .plan(view, synthetic::robotiqLikeGripper());
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_EQ(result.grasps.size(), 2u) << result.message;
  EXPECT_DOUBLE_EQ(result.grasps[0].score, 0.8);
  EXPECT_DOUBLE_EQ(result.grasps[1].score, 0.7);
  EXPECT_NE(result.message.find("dropped 1 grasps whose fingertips stop high on it"), std::string::npos)
      << result.message;
  // Only the high one: none left, and the planner says why.
  GraspResult high;
  high.grasps.push_back(given.grasps.front());
  const GraspResult none =
      HoldCheckedPlanner(std::make_unique<GivenGrasps>(high), params).plan(view, synthetic::robotiqLikeGripper());
  EXPECT_FALSE(none.ok());
  EXPECT_NE(none.message.find("ball (radius 30 mm)"), std::string::npos) << none.message;
  // On a cube the same grasps all come back.
  const ObjectView cube = viewOf(synthetic::makeBox({ 0.0, 0.0, 0.03 }, { 0.06, 0.06, 0.06 }));
  EXPECT_EQ(HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), params).plan(cube, synthetic::robotiqLikeGripper()).grasps.size(),
            3u);
}

TEST(RestingBall, TheShippedConfigChecksBallsAndBadParametersAreRefused)
{
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_TRUE(config.hold_check.resting_ball.enabled);
  EXPECT_EQ(config.hold_check.resting_ball.validate(), "");
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planners: [cshape]\nresting_ball: {min_fingertip_depth_m: -0.01}")),
               std::runtime_error);
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planners: [cshape]\nresting_ball: {radius: 0.03}")),
               std::runtime_error);
  EXPECT_DOUBLE_EQ(config.hold_check.resting_ball.flat_max_height_to_breadth, 0.75);
  EXPECT_DOUBLE_EQ(config.hold_check.resting_ball.flat_min_fingertip_past_centre_frac, 0.2);
  RestingBallParams p = enabled();
  p.max_median_normal_angle_rad = 0.0;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.flat_max_height_to_breadth = 1.0;  // a ball would be flat
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.flat_min_fingertip_past_centre_frac = 1.5;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.min_points = 2;
  EXPECT_NE(p.validate(), "");
}

}  // namespace fast_grasp
