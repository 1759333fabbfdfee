// The lying round object fit, the fingertips' reach past its axis and the hold check that drops
// grasps by them, on analytic shapes whose axis, radius and reach follow from their construction.
#include "fast_grasp/grasping/lying_cylinder.h"

#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/hold_check.h"
#include "hold_check_fixtures.h"
#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <vector>

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

LyingCylinderParams enabled()
{
  LyingCylinderParams p;
  p.enabled = true;
  p.max_median_residual_frac = 0.18;
  p.max_median_normal_angle_rad = 0.22;
  return p;
}

LyingCylinder fit(const ObjectView& view, const LyingCylinderParams& params = enabled())
{
  return fitLyingCylinder(view, objectExtent(view), params);
}

/// Distance of `point` from the line through `on` along unit `axis`.
double distanceFromLine(const Eigen::Vector3d& point, const Eigen::Vector3d& on, const Eigen::Vector3d& axis)
{
  const Eigen::Vector3d d = point - on;
  return (d - d.dot(axis) * axis).norm();
}
}  // namespace

TEST(LyingCylinder, ACanOnItsSideIsFoundWithItsAxisAndRadius)
{
  // A 3.4 cm radius, 10 cm long can lying on the table, its axis 30 deg from x, 3.4 cm up.
  const Eigen::Vector3d axis(std::cos(M_PI / 6), std::sin(M_PI / 6), 0.0);
  const Eigen::Vector3d centre(0.02, -0.01, 0.034);
  for (const double noise : { 0.0, 0.001 })
  {
    const LyingCylinder can = fit(viewOf(synthetic::makeCylinder(centre, axis, 0.034, 0.10), noise));
    ASSERT_TRUE(can.found) << can.why << " (noise " << noise << ")";
    EXPECT_NEAR(can.radius_m, 0.034, 0.0015);
    EXPECT_GT(std::abs(can.axis.cast<double>().dot(axis)), std::cos(3.0 * M_PI / 180.0));
    EXPECT_NEAR(can.axis.z(), 0.0, 1e-5);  // horizontal
    EXPECT_LT(distanceFromLine(can.axis_point.cast<double>(), centre, axis), 0.003);
    EXPECT_NEAR(can.axis_point.cast<double>().dot(axis), centre.dot(axis), 0.01);  // the middle of what was seen
  }
}

TEST(LyingCylinder, ACanHalfHiddenInAPileIsFoundFromItsNormals)
{
  // Only 5 cm of a 3.4 cm radius can along x are seen (the rest hidden in a pile): its seen
  // footprint is shorter than it is wide, so the footprint's major axis runs across it. The
  // side's normals still give its axis.
  const Eigen::Vector3d centre(0.0, 0.0, 0.034);
  const LyingCylinder can = fit(viewOf(synthetic::makeCylinder(centre, { 1, 0, 0 }, 0.034, 0.05)));
  ASSERT_TRUE(can.found) << can.why << " axis " << can.axis.transpose() << " res " << can.median_residual_m << " ang " << can.median_normal_angle_rad << " spread " << can.normal_spread_ratio << " pt " << can.axis_point.transpose();
  EXPECT_GT(std::abs(can.axis.x()), std::cos(3.0 * M_PI / 180.0));
  EXPECT_LT(can.normal_spread_ratio, 0.05f);
  EXPECT_LT(distanceFromLine(can.axis_point.cast<double>(), centre, Eigen::Vector3d::UnitX()), 0.003);
}

TEST(LyingCylinder, ABottleOnItsSideIsJudgedByItsBodysNormalsWhileABallIsNot)
{
  // A bottle lying along x, its top half as a camera above sees it (rings every 3 mm, 6 deg
  // apart): a 14 cm body of radius 3.3 cm, a shoulder narrowing at 20 deg to a 5 cm neck of
  // radius 1.4 cm. The shoulder's normals lean 20 deg along the axis: over all the points the
  // horizontal parts of the normals spread 0.051 (least over most), over the body's (within
  // 15 % of the radius of the circle) 0.022, by hand. With the spread allowed up to 0.035 the
  // bottle is found only because its body, longer than the bottle is high, is what judges.
  const float r = 0.033f;
  CloudNormal::Ptr cloud(new CloudNormal);
  const auto ring = [&](float x, float radius, float lean) {
    for (int degrees = -90; degrees <= 90; degrees += 6)
    {
      const float angle = static_cast<float>(degrees) * static_cast<float>(M_PI) / 180.0f;
      pcl::PointNormal p;
      p.getVector3fMap() = Eigen::Vector3f(x, radius * std::sin(angle), r + radius * std::cos(angle));
      const float across = std::sqrt(1.0f - lean * lean);
      p.getNormalVector3fMap() = Eigen::Vector3f(lean, across * std::sin(angle), across * std::cos(angle));
      cloud->push_back(p);
    }
  };
  float x = -0.07f;
  for (; x < 0.07f; x += 0.003f)
    ring(x, r, 0.0f);
  const float slope = std::tan(20.0f * static_cast<float>(M_PI) / 180.0f);
  for (const float shoulder_start = x; r - (x - shoulder_start) * slope > 0.014f; x += 0.003f)
    ring(x, r - (x - shoulder_start) * slope, std::sin(20.0f * static_cast<float>(M_PI) / 180.0f));
  for (const float neck_start = x; x < neck_start + 0.05f; x += 0.003f)
    ring(x, 0.014f, 0.0f);
  ObjectView view = synthetic::makeObjectView(cloud, hold_check_fixtures::kCamera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
  LyingCylinderParams params = enabled();
  params.max_normal_spread_ratio = 0.035;
  const LyingCylinder bottle = fit(view, params);
  ASSERT_TRUE(bottle.found) << bottle.why;
  EXPECT_NEAR(bottle.radius_m, r, 0.001);
  EXPECT_GT(std::abs(bottle.axis.x()), 0.99f);
  EXPECT_NEAR(bottle.normal_spread_ratio, 0.022, 0.005);
  // A ball as high as the bottle: the band of its points on a circle round any horizontal axis
  // is half as long as the ball is high, so all its normals judge, and they spread.
  EXPECT_FALSE(fit(viewOf(synthetic::makeSphere({ 0.0, 0.0, r }, r))).found);
}

TEST(LyingCylinder, ASmallObjectTouchingALyingCanWidensTheClusterNotTheCan)
{
  // A pile's cluster: a 14 cm can of radius 3.4 cm lying along x, and a 2.5 cm cube on the
  // table against its camera-side flank (one cluster when touching objects are not cut apart).
  // Across the axis the cluster spans 6.8 + 2.5 = 9.3 cm, more than 1.25 x its 6.8 cm height,
  // the most a lying circle's footprint spans; the can's own points span 6.8 cm at most.
  const double r = 0.034;
  const synthetic::Shape can = synthetic::makeCylinder({ 0.0, 0.0, r }, { 1, 0, 0 }, r, 0.14);
  const synthetic::Shape cube = synthetic::makeBox({ 0.02, -(r + 0.0125), 0.0125 }, { 0.025, 0.025, 0.025 });
  const ObjectView view = hold_check_fixtures::tableView({ can, cube });
  const ObjectExtent extent = objectExtent(view);
  ASSERT_GT(extent.breadth_m, 1.25f * extent.height_m) << "the cube must widen the footprint for this test";
  const LyingCylinder found = fit(view);
  ASSERT_TRUE(found.found) << found.why;
  EXPECT_NEAR(found.radius_m, r, 0.0015);
  EXPECT_GT(std::abs(found.axis.x()), std::cos(3.0 * M_PI / 180.0));
  EXPECT_LT(distanceFromLine(found.axis_point.cast<double>(), { 0.0, 0.0, r }, Eigen::Vector3d::UnitX()), 0.003);
  // A can no longer than it is high is judged by all its points: the cube still refuses it.
  const synthetic::Shape short_can = synthetic::makeCylinder({ 0.0, 0.0, r }, { 1, 0, 0 }, r, 0.06);
  EXPECT_FALSE(fit(hold_check_fixtures::tableView({ short_can, cube })).found);
}

TEST(LyingCylinder, BoxesStandingObjectsAndShortRollsAreNotLyingRoundObjects)
{
  // A box as long as the can, its cross-section square (its height is the can's diameter).
  const Eigen::Vector3d centre(0.0, 0.0, 0.034);
  const LyingCylinder box = fit(viewOf(synthetic::makeBox(centre, { 0.10, 0.068, 0.068 })));
  EXPECT_FALSE(box.found) << "its normals are not radial";
  // A flat box (a book): its top is far off any circle of half its height.
  EXPECT_FALSE(fit(viewOf(synthetic::makeBox({ 0.0, 0.0, 0.015 }, { 0.20, 0.14, 0.03 }))).found);
  // A cereal box on its long side: 6 cm deep, 17 cm high, 21 cm long.
  const LyingCylinder cereal = fit(viewOf(synthetic::makeBox({ 0.0, 0.0, 0.085 }, { 0.21, 0.06, 0.17 })));
  EXPECT_FALSE(cereal.found);
  // The same can standing: its footprint is no longer than it is high.
  const LyingCylinder standing = fit(viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.05 }, { 0, 0, 1 }, 0.034, 0.10)));
  EXPECT_FALSE(standing.found);
  EXPECT_NE(standing.why, "");
  // Off by default, and nothing without a table plane.
  const ObjectView can_view = viewOf(synthetic::makeCylinder(centre, { 1, 0, 0 }, 0.034, 0.10));
  EXPECT_FALSE(fit(can_view, LyingCylinderParams{}).found);
  ObjectView no_table = can_view;
  no_table.has_table_plane = false;
  EXPECT_FALSE(fit(no_table).found);
}

TEST(LyingCylinder, FingertipReachIsMeasuredAlongTheApproachInTheCrossSection)
{
  // The can along y, its axis 3.4 cm up. The gripper's fingers are 4 cm deep: the tips are
  // 2 cm beyond the grasp centre along the approach.
  const ObjectView view = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  const LyingCylinder can = fit(view);
  ASSERT_TRUE(can.found) << can.why;
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  ASSERT_NEAR(gripper.finger_depth_m, 0.04, 1e-9);
  // Top-down, closing across the axis, centre 5 cm up: the tips at 3 cm, 4 mm past the axis
  // (the fitted axis height is half the seen height: within the render's 1.5 mm).
  GraspCandidate top;
  top.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.01, 0.05), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  ASSERT_TRUE(fingertipReachPastAxis(top, gripper, can).has_value());
  EXPECT_NEAR(*fingertipReachPastAxis(top, gripper, can), 0.004, 0.0015);
  // Oblique: 35 deg from vertical about the axis, the tips stopping 8 mm short of it; and
  // the approach's component along the axis does not count (tilted 20 deg along y as well).
  const Eigen::Vector3d axis_point = can.axis_point.cast<double>();
  for (const double along_rad : { 0.0, 20.0 * M_PI / 180.0 })
  {
    const double tilt = 35.0 * M_PI / 180.0;
    const Eigen::Vector3d in_section(std::sin(tilt), 0.0, -std::cos(tilt));
    const Eigen::Vector3d approach = (std::cos(along_rad) * in_section + std::sin(along_rad) * Eigen::Vector3d::UnitY()).normalized();
    const Eigen::Vector3d closing = Eigen::Vector3d(std::cos(tilt), 0.0, std::sin(tilt));
    // tip = centre + 2 cm approach; put the tip's cross-section position 8 mm before the axis
    const Eigen::Vector3d tip = axis_point - 0.008 * in_section + 0.02 * std::sin(along_rad) * Eigen::Vector3d::UnitY();
    GraspCandidate oblique;
    oblique.pose = makeGraspPose(tip - 0.02 * approach, approach, closing);
    const auto reach = fingertipReachPastAxis(oblique, gripper, can);
    ASSERT_TRUE(reach.has_value());
    EXPECT_NEAR(*reach, -0.008, 5e-4) << "tilted along the axis by " << along_rad;  // the fitted axis: within 3 deg
  }
  // End-on (approach along the axis) and closing along the axis: not across it.
  GraspCandidate end_on;
  end_on.pose = makeGraspPose(Eigen::Vector3d(0.0, -0.06, 0.034), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 0, 0));
  EXPECT_FALSE(fingertipReachPastAxis(end_on, gripper, can).has_value());
  GraspCandidate along;
  along.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.05), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  EXPECT_FALSE(fingertipReachPastAxis(along, gripper, can).has_value());
  EXPECT_FALSE(fingertipReachPastAxis(top, gripper, LyingCylinder{}).has_value());
}

TEST(LyingCylinder, TheOpenHandsDepthInTheCylinderIsTheRadiusLessItsLeastDistanceFromTheAxis)
{
  // A soup can along y (radius 3.3 cm, axis 3.3 cm up, 10 cm long), given, not fitted: every
  // expectation below is the gripper's box geometry worked out by hand.
  LyingCylinder can;
  can.found = true;
  can.axis = Eigen::Vector3f::UnitY();
  can.axis_point = Eigen::Vector3f(0.0f, 0.0f, 0.033f);
  can.radius_m = 0.033f;
  can.half_length_m = 0.05f;
  GripperModel gripper = synthetic::robotiqLikeGripper();
  gripper.finger_depth_m = 0.04;
  gripper.finger_thickness_m = 0.012;
  gripper.palm_thickness_m = 0.09;
  gripper.palm_width_m = 0.044;
  const double opening = 0.085, approach_m = 0.1;

  // Top-down across the axis, centred over it, the palm 1 mm above the can (centre 4.7 cm
  // up, the palm 2 cm above the centre): the palm is the nearest part, 3.4 cm from the axis;
  // the fingers' inner faces are 4.25 cm from it.
  GraspCandidate centred;
  centred.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.047), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  const auto clear = openHandDepthInCylinder(centred, gripper, can, opening, approach_m);
  ASSERT_TRUE(clear.has_value());
  EXPECT_NEAR(*clear, 0.033 - 0.034, 1e-5);

  // 1.5 cm off the axis across it: the far finger's inner face is 2.75 cm from the axis, at
  // the axis's height, so 5.5 mm inside the can.
  GraspCandidate offset = centred;
  offset.pose.translation().x() = 0.015;
  const auto into = openHandDepthInCylinder(offset, gripper, can, opening, approach_m);
  ASSERT_TRUE(into.has_value());
  EXPECT_NEAR(*into, 0.033 - 0.0275, 1e-5);
  // Opened only to 11.5 cm the same hand clears it again (the face 4.25 cm from the axis).
  EXPECT_NEAR(*openHandDepthInCylinder(offset, gripper, can, 0.115, approach_m), 0.033 - 0.034, 1e-5);

  // Beside the can's end (the hand's 4.4 cm palm spans y 5.8 .. 10.2 cm, the can ends at
  // 5 cm): no box is over the can.
  GraspCandidate beyond = offset;
  beyond.pose.translation().y() = 0.08;
  const auto nothing = openHandDepthInCylinder(beyond, gripper, can, opening, approach_m);
  ASSERT_TRUE(nothing.has_value());
  EXPECT_LT(*nothing, -1.0f);

  // The swept approach counts: a hand coming in sideways (+x) at the axis's height, closing
  // vertically, stopped 1 cm short of the can with its fingertips: nothing inside. Swept back
  // along -x it never comes nearer.
  GraspCandidate side;
  side.pose = makeGraspPose(Eigen::Vector3d(-0.033 - 0.01 - 0.02, 0.0, 0.033), Eigen::Vector3d(1, 0, 0),
                            Eigen::Vector3d(0, 0, 1));
  const auto side_depth = openHandDepthInCylinder(side, gripper, can, opening, approach_m);
  ASSERT_TRUE(side_depth.has_value());
  EXPECT_LT(*side_depth, 0.0f);
  // The same fingers' place reached from the other side (approach -x): the palm behind them
  // is then where the can is, and the hand comes through it.
  GraspCandidate through;
  through.pose = makeGraspPose(Eigen::Vector3d(-0.033 - 0.01 - 0.02, 0.0, 0.033), Eigen::Vector3d(-1, 0, 0),
                               Eigen::Vector3d(0, 0, 1));
  const auto through_depth = openHandDepthInCylinder(through, gripper, can, opening, approach_m);
  ASSERT_TRUE(through_depth.has_value());
  EXPECT_NEAR(*through_depth, 0.033, 1e-5);  // the palm box contains the axis

  // Centred over the axis but closing 45 deg off it: across the axis (>= 30 deg), and the
  // chord it must span is 1.4 diameters. Each finger's inner face is 4.25 cm out along the
  // closing line and the finger 2.2 cm wide across it, so its nearest corner lies
  // (4.25 - 1.1) cm x cos 45 deg = 2.23 cm from the axis in the cross-section, at heights the
  // finger spans (2.7-6.7 cm, the axis at 3.3 cm): 1.07 cm inside the can.
  GraspCandidate diagonal;
  const double c45 = std::sqrt(0.5);
  diagonal.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.047), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(c45, c45, 0));
  const auto diagonal_depth = openHandDepthInCylinder(diagonal, gripper, can, opening, approach_m);
  ASSERT_TRUE(diagonal_depth.has_value()) << "45 deg off the axis is across it";
  EXPECT_NEAR(*diagonal_depth, 0.033 - c45 * (0.0425 - 0.011), 1e-4);
  // 20 deg off the axis: along it (the object's length), not across.
  GraspCandidate shallow = diagonal;
  shallow.pose = makeGraspPose(Eigen::Vector3d(0.0, 0.0, 0.047), Eigen::Vector3d(0, 0, -1),
                               Eigen::Vector3d(std::sin(20.0 * M_PI / 180.0), std::cos(20.0 * M_PI / 180.0), 0));
  EXPECT_FALSE(openHandDepthInCylinder(shallow, gripper, can, opening, approach_m).has_value());

  // End-on grasps and no cylinder: not across an axis.
  GraspCandidate end_on;
  end_on.pose = makeGraspPose(Eigen::Vector3d(0.0, -0.08, 0.033), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 0, 0));
  EXPECT_FALSE(openHandDepthInCylinder(end_on, gripper, can, opening, approach_m).has_value());
  EXPECT_FALSE(openHandDepthInCylinder(centred, gripper, LyingCylinder{}, opening, approach_m).has_value());
}

TEST(LyingCylinder, ParametersAreValidated)
{
  EXPECT_EQ(enabled().validate(), "");
  LyingCylinderParams p = enabled();
  p.max_median_residual_frac = 0.0;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.max_median_normal_angle_rad = 4.0;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.min_fingertip_reach_m = 0.5;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.min_points = 2;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.max_open_hand_depth_m = -0.001;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.open_hand_approach_m = 2.0;
  EXPECT_NE(p.validate(), "");
  p = enabled();
  p.max_normal_spread_ratio = 0.0;
  EXPECT_NE(p.validate(), "");
}

}  // namespace fast_grasp

namespace fast_grasp
{
namespace
{
HoldCheckParams holdCheck()
{
  HoldCheckParams p;
  p.lying_cylinder = enabled();
  p.lying_cylinder.min_fingertip_reach_m = 0.002;
  p.lying_cylinder.max_open_hand_depth_m = 0.003;
  return p;
}
}  // namespace

TEST(HoldCheck, GraspsThatWouldDropALyingCanAreDroppedTheRestKeepTheirOrder)
{
  // The can of FingertipReachIsMeasuredAlongTheApproachInTheCrossSection: along y, radius
  // 3.4 cm, axis 3.4 cm up; the fingers 4 cm deep, so the tips are 2 cm beyond the centre.
  const ObjectView view = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  const Eigen::Vector3d down(0, 0, -1), across(1, 0, 0);
  GraspResult given;
  // centred over the axis, the tips at 3 cm: 4 mm past it (kept)
  given.grasps.push_back(graspAt({ 0.0, 0.01, 0.05 }, down, across, 0.9));
  // the same 1 cm higher: the tips 6 mm short of the axis (dropped)
  given.grasps.push_back(graspAt({ 0.0, 0.01, 0.06 }, down, across, 0.8));
  // end-on, closing across the diameter at the axis's height: not across the axis (kept)
  given.grasps.push_back(graspAt({ 0.0, -0.06, 0.034 }, { 0, 1, 0 }, across, 0.7));
  // 1.5 cm off the axis: the tips pass it, but the far finger's inner face (4.25 cm from the
  // hand's centre line when open) comes 2.75 cm from the axis, 6.5 mm inside the can (dropped)
  given.grasps.push_back(graspAt({ 0.015, 0.01, 0.05 }, down, across, 0.6));
  const HoldCheckedPlanner checked(std::make_unique<GivenGrasps>(given), holdCheck());
  EXPECT_STREQ(checked.name(), "concavity");
  const GraspResult result = checked.plan(view, gripper);
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_EQ(result.grasps.size(), 2u) << result.message;
  EXPECT_DOUBLE_EQ(result.grasps[0].score, 0.9);
  EXPECT_DOUBLE_EQ(result.grasps[1].score, 0.7);
  EXPECT_NE(result.message.find("dropped 1 grasps whose fingertips stop short of its axis"), std::string::npos)
      << result.message;
  EXPECT_NE(result.message.find("and 1 whose open hand lands on its hidden side"), std::string::npos) << result.message;
}

TEST(HoldCheck, ADiagonalGraspOverALyingCanIsDroppedASquareOneKept)
{
  // The can along y (radius 3.4 cm, axis 3.4 cm up), both hands centred over its axis, the tips
  // 4 mm past it. Closing square to the axis the open fingers (4.25 cm out) clear the can;
  // closing 45 deg off it they come down 2.2 cm from the axis, on the can (a chord of 1.4
  // diameters to span). Until session 24 the diagonal one counted as end-on and was kept.
  const ObjectView view = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  const double c45 = std::sqrt(0.5);
  GraspResult given;
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.05 }, { 0, 0, -1 }, { c45, c45, 0 }, 0.9));
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.05 }, { 0, 0, -1 }, { 1, 0, 0 }, 0.8));
  const HoldCheckedPlanner checked(std::make_unique<GivenGrasps>(given), holdCheck());
  const GraspResult result = checked.plan(view, synthetic::robotiqLikeGripper());
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_EQ(result.grasps.size(), 1u) << result.message;
  EXPECT_DOUBLE_EQ(result.grasps[0].score, 0.8);
  EXPECT_NE(result.message.find("and 1 whose open hand lands on its hidden side"), std::string::npos) << result.message;
}

TEST(HoldCheck, WhenEveryGraspWouldDropTheCanThePlannerSaysWhyAndKeepsItsNextView)
{
  const ObjectView view = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  GraspResult given;
  given.grasps.push_back(graspAt({ 0.0, 0.01, 0.06 }, { 0, 0, -1 }, { 1, 0, 0 }, 0.8));
  given.message = "concavity: 1 grasp";
  given.next_view = Eigen::Isometry3d(Eigen::Translation3d(0.1, 0.2, 0.3));
  const HoldCheckedPlanner checked(std::make_unique<GivenGrasps>(given), holdCheck());
  const GraspResult result = checked.plan(view, synthetic::robotiqLikeGripper());
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(result.failure, GraspFailure::NoStableGrasp);
  EXPECT_NE(result.message.find("lying round object (radius 34 mm)"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("none left (concavity: 1 grasp)"), std::string::npos) << result.message;
  ASSERT_TRUE(result.next_view.has_value());
  EXPECT_TRUE(result.next_view->translation().isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
}

TEST(HoldCheck, GraspsOnAStandingCanOrWithTheCheckOffAreReturnedAsPlanned)
{
  const GripperModel gripper = synthetic::robotiqLikeGripper();
  GraspResult given;
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.09 }, { 0, 0, -1 }, { 1, 0, 0 }, 0.8));
  // A standing can (axis vertical): no lying round object, the same grasp comes back.
  const ObjectView standing = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.05 }, { 0, 0, 1 }, 0.034, 0.10));
  const GraspResult kept = HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), holdCheck()).plan(standing, gripper);
  ASSERT_EQ(kept.grasps.size(), 1u) << kept.message;
  // The lying can with the fit disabled: nothing is judged.
  const ObjectView lying = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  given.grasps.front().pose.translation() = Eigen::Vector3d(0.0, 0.01, 0.06);  // short of the axis
  HoldCheckParams off = holdCheck();
  off.lying_cylinder.enabled = false;
  EXPECT_EQ(HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), off).plan(lying, gripper).grasps.size(), 1u);
}

TEST(HoldCheck, SideGraspsBelowATallObjectsCentreOfMassAreDroppedWhenAsked)
{
  // A 20 cm can standing on the table (radius 3 cm): a side grasp at 8 cm (0.4 of its height)
  // holds it as an inverted pendulum, one at 17 cm (0.85) from above its centre of mass, and a
  // top-down grasp is no side grasp at all.
  const ObjectView standing = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.10 }, { 0, 0, 1 }, 0.03, 0.20));
  const Eigen::Vector3d side(1, 0, 0), across(0, 1, 0);
  GraspResult given;
  given.grasps.push_back(graspAt({ -0.01, 0.0, 0.08 }, side, across, 0.9));
  given.grasps.push_back(graspAt({ -0.01, 0.0, 0.17 }, side, across, 0.8));
  given.grasps.push_back(graspAt({ 0.0, 0.0, 0.20 }, { 0, 0, -1 }, across, 0.7));
  HoldCheckParams tall = holdCheck();
  tall.tall_object_min_height_m = 0.15;
  tall.tall_side_min_height_frac = 0.75;
  const GraspResult checked = HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), tall).plan(standing, synthetic::robotiqLikeGripper());
  ASSERT_EQ(checked.grasps.size(), 2u) << checked.message;
  EXPECT_DOUBLE_EQ(checked.grasps[0].score, 0.8);
  EXPECT_DOUBLE_EQ(checked.grasps[1].score, 0.7);
  EXPECT_NE(checked.message.find("tall object (200 mm): dropped 1 side grasps below its centre of mass"), std::string::npos)
      << checked.message;
  // A 12 cm can is not tall: nothing dropped; nor with the tall test off (the default).
  const ObjectView short_can = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.06 }, { 0, 0, 1 }, 0.03, 0.12));
  EXPECT_EQ(HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), tall).plan(short_can, synthetic::robotiqLikeGripper()).grasps.size(), 3u);
  EXPECT_EQ(HoldCheckedPlanner(std::make_unique<GivenGrasps>(given), holdCheck()).plan(standing, synthetic::robotiqLikeGripper()).grasps.size(), 3u);
}

TEST(HoldCheck, TheShippedConfigChecksEveryThesisPlannerButNotFusedsPool)
{
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_EQ(config.hold_check.planners, (std::vector<std::string>{ "principal_axis", "cshape", "boundary", "concavity" }));
  for (const std::string& name : config.hold_check.planners)
  {
    const auto planner = makeGraspPlanner(name, config);
    EXPECT_NE(dynamic_cast<const HoldCheckedPlanner*>(planner.get()), nullptr) << name;
    EXPECT_EQ(planner->name(), name);
  }
  GraspPlannerConfig unchecked = config;
  unchecked.hold_check.planners.clear();
  EXPECT_EQ(dynamic_cast<const HoldCheckedPlanner*>(makeGraspPlanner("cshape", unchecked).get()), nullptr);
  // The fused planner pools the planners unchecked (it judges those grasps itself: for one
  // object it does not return them, fused/return_drop_risk_grasps): on a lying can its grasps
  // are the same with and without the check.
  const ObjectView lying = viewOf(synthetic::makeCylinder({ 0.0, 0.0, 0.034 }, { 0, 1, 0 }, 0.034, 0.10));
  const GraspResult fused = makeGraspPlanner("fused", config)->plan(lying, synthetic::robotiqLikeGripper());
  const GraspResult fused_unchecked = makeGraspPlanner("fused", unchecked)->plan(lying, synthetic::robotiqLikeGripper());
  ASSERT_TRUE(fused.ok()) << fused.message;
  ASSERT_EQ(fused.grasps.size(), fused_unchecked.grasps.size());
  for (std::size_t i = 0; i < fused.grasps.size(); ++i)
    EXPECT_TRUE(fused.grasps[i].pose.isApprox(fused_unchecked.grasps[i].pose)) << i;
  EXPECT_NE(fused.message.find("fingertips short of its axis, not returned"), std::string::npos) << fused.message;
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planners: [cshape, fused]")), std::runtime_error);
  EXPECT_THROW(holdCheckConfigFromYaml(YAML::Load("planers: [cshape]")), std::runtime_error);
}

}  // namespace fast_grasp
