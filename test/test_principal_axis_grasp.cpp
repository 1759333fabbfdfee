// Principal-axis planner (thesis Ch3): analytic shapes with hand-derivable answers.
#include "fast_grasp/grasping/principal_axis_grasp.h"
#include "fast_grasp/core/gripper_model.h"

#include "synthetic_views.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

using namespace fast_grasp;

namespace
{
constexpr double kDeg = M_PI / 180.0;

GripperModel robotiq() { return synthetic::robotiqLikeGripper(); }

ObjectView viewOf(const CloudNormal::ConstPtr& cloud, const Eigen::Vector3d& sensor)
{
  return synthetic::makeObjectView(cloud, sensor);
}

/// Visible surface of a solid truncated cone (a cup, or a bottle when the radii are equal)
/// standing on z = base_z with its axis along z through (cx, cy): the lateral surface and
/// the top disc, keeping the points whose outward normal faces the camera. The solid is
/// convex, so that back-face test is exact visibility.
CloudNormal::Ptr visibleFrustum(const Eigen::Vector3d& base_centre, double height_m, double bottom_radius_m,
                                double top_radius_m, const Eigen::Vector3d& camera, double spacing_m)
{
  CloudNormal::Ptr cloud(new CloudNormal);
  auto keep = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& outward) {
    if (outward.dot(camera - p) <= 0.0)
      return;
    const Eigen::Vector3d n = outward.normalized();
    PointNormal q;
    q.x = float(p.x());
    q.y = float(p.y());
    q.z = float(p.z());
    q.normal_x = float(n.x());
    q.normal_y = float(n.y());
    q.normal_z = float(n.z());
    cloud->push_back(q);
  };
  const double slope = (top_radius_m - bottom_radius_m) / height_m;
  for (double h = 0.0; h <= height_m + 1e-9; h += spacing_m)
  {
    const double r = bottom_radius_m + slope * h;
    const int around = std::max(8, int(std::ceil(2.0 * M_PI * r / spacing_m)));
    for (int k = 0; k < around; ++k)
    {
      const double phi = 2.0 * M_PI * k / around;
      const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0.0);
      keep(base_centre + r * radial + Eigen::Vector3d(0, 0, h), radial - Eigen::Vector3d(0, 0, slope));
    }
  }
  for (double rho = 0.0; rho <= top_radius_m; rho += spacing_m)
  {
    const int around = std::max(1, int(std::ceil(2.0 * M_PI * rho / spacing_m)));
    for (int k = 0; k < around; ++k)
    {
      const double phi = 2.0 * M_PI * k / around;
      keep(base_centre + Eigen::Vector3d(rho * std::cos(phi), rho * std::sin(phi), height_m), Eigen::Vector3d::UnitZ());
    }
  }
  return cloud;
}

CloudNormal::Ptr fuse(const CloudNormal& a, const CloudNormal& b)
{
  CloudNormal::Ptr fused(new CloudNormal(a));
  *fused += b;
  return fused;
}

Eigen::Vector3d horizontal(const Eigen::Vector3d& v)
{
  return Eigen::Vector3d(v.x(), v.y(), 0.0);
}

Eigen::Vector3d centroidOf(const CloudNormal& cloud)
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud.points)
    sum += Eigen::Vector3d(p.x, p.y, p.z);
  return sum / double(cloud.size());
}

/// True when the horizontal direction `d` lies within the horizontal sector spanned by the
/// directions from `centre` to the two cameras (less than pi wide): the seen side.
bool withinSeenSector(const Eigen::Vector3d& d, const Eigen::Vector3d& centre, const Eigen::Vector3d& camera_a,
                      const Eigen::Vector3d& camera_b, double tolerance_rad)
{
  const Eigen::Vector3d a = horizontal(camera_a - centre).normalized();
  const Eigen::Vector3d b = horizontal(camera_b - centre).normalized();
  const Eigen::Vector3d h = horizontal(d).normalized();
  const double spread = std::atan2(a.cross(b).norm(), a.dot(b));
  const double to_a = std::atan2(a.cross(h).norm(), a.dot(h));
  const double to_b = std::atan2(b.cross(h).norm(), b.dot(h));
  return to_a + to_b <= spread + tolerance_rad;
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Distance from point p to segment ab (2-D).
double segmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}
}  // namespace

// ----------------------------------------------------------------------------------------
// Grid stand-in for the concave hull (steps 4-5).

TEST(SweepProjectedContour, LShapeMatchesHandComputedCrossingsAndOutline)
{
  // L = [0, 0.06] x [0, 0.02]  U  [0, 0.02] x [0, 0.10], filled with a 1 mm lattice whose
  // rows sit half a millimetre off the 2 mm grid rows (plus one anchor point at y = 0), so
  // no point lies on a row edge.
  std::vector<Eigen::Vector3f> points = { { 0.0f, 0.0f, 0.0f } };
  for (int i = 0; i <= 60; ++i)
    for (int j = 0; j < 100; ++j)
      if (j <= 20 || i <= 20)
        points.emplace_back(0.001f * i, 0.0005f + 0.001f * j, 0.0f);
  std::vector<Eigen::Vector2f> boundary;
  const auto lines = sweepProjectedContour(points, 0.002, 0.002, 2, 1, &boundary);
  ASSERT_EQ(lines.size(), 50u);  // y = 0, 0.002, ..., 0.098 up to y_max = 0.0995 (Eq. 3.4)
  for (const SweepLine& line : lines)
  {
    ASSERT_TRUE(line.hit) << line.y_m;
    EXPECT_NEAR(line.left_x_m, 0.0, 1e-6);
    if (line.y_m < 0.017)
    {
      EXPECT_NEAR(line.right_x_m, 0.06, 1e-6) << line.y_m;
    }
    else if (line.y_m > 0.023)
    {
      EXPECT_NEAR(line.right_x_m, 0.02, 1e-6) << line.y_m;
    }
  }
  // Boundary cells hug the L's outline (hand-written vertices) and cover all of it.
  const std::vector<Eigen::Vector2d> outline = { { 0, 0 },      { 0.06, 0 },  { 0.06, 0.02 },
                                                 { 0.02, 0.02 }, { 0.02, 0.1 }, { 0, 0.1 } };
  auto outlineDistance = [&](const Eigen::Vector2d& p) {
    double d = 1e9;
    for (std::size_t k = 0; k < outline.size(); ++k)
      d = std::min(d, segmentDistance(p, outline[k], outline[(k + 1) % outline.size()]));
    return d;
  };
  ASSERT_FALSE(boundary.empty());
  for (const auto& cell : boundary)
    EXPECT_LT(outlineDistance(cell.cast<double>()), 0.0031) << cell.transpose();
  // Closing fills the concave corner's cell, so allow one cell diagonal more there.
  for (std::size_t k = 0; k < outline.size(); ++k)
    for (double t = 0.0; t <= 1.0; t += 0.05)
    {
      const Eigen::Vector2d p = outline[k] + t * (outline[(k + 1) % outline.size()] - outline[k]);
      double nearest = 1e9;
      for (const auto& cell : boundary)
        nearest = std::min(nearest, (cell.cast<double>() - p).norm());
      EXPECT_LT(nearest, (p - outline[3]).norm() < 0.004 ? 0.0036 : 0.0031) << p.transpose();
    }
  // The interior is not boundary: far fewer cells than the L's area in cells (~500).
  EXPECT_LT(boundary.size(), 200u);
}

TEST(SweepProjectedContour, BridgesShortGapsOnly)
{
  // A 0.04 x 0.10 rectangle (1 mm lattice, rows off the grid edges as above) with a 4 mm
  // band of missing points: two empty 2 mm grid rows (a sensor hole).
  std::vector<Eigen::Vector3f> points = { { 0.0f, 0.0f, 0.0f } };
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j < 100; ++j)
      if (j < 50 || j > 53)
        points.emplace_back(0.001f * i, 0.0005f + 0.001f * j, 0.0f);
  const auto bridged = sweepProjectedContour(points, 0.002, 0.002, 2, 0);
  ASSERT_EQ(bridged.size(), 50u);
  for (const SweepLine& line : bridged)
  {
    EXPECT_TRUE(line.hit) << line.y_m;
    EXPECT_NEAR(line.widthM(), 0.04, 1e-6) << line.y_m;
  }
  int misses = 0;
  for (const SweepLine& line : sweepProjectedContour(points, 0.002, 0.002, 1, 0))
    misses += line.hit ? 0 : 1;
  EXPECT_EQ(misses, 2);  // a two-row hole is wider than a one-row closing
}

TEST(VirtualViewpoints, CountIsFloorOfAngleOverStepPlusOne)
{
  const Eigen::Vector3f centroid(0.5f, 0.0f, 0.1f);
  const Eigen::Vector3f axis = Eigen::Vector3f::UnitZ();
  const Eigen::Vector3f a = centroid + Eigen::Vector3f(0.4f, 0.0f, 0.2f);
  auto at = [&](double deg, float height) {
    return Eigen::Vector3f(centroid + Eigen::Vector3f(0.3f * std::cos(deg * kDeg), 0.3f * std::sin(deg * kDeg), height));
  };
  EXPECT_EQ(virtualViewpoints(centroid, axis, a, at(90, 0.3f), 10 * kDeg).size(), 10u);
  EXPECT_EQ(virtualViewpoints(centroid, axis, a, at(95, 0.0f), 10 * kDeg).size(), 10u);
  EXPECT_EQ(virtualViewpoints(centroid, axis, a, at(45, 0.1f), 20 * kDeg).size(), 3u);
  EXPECT_EQ(virtualViewpoints(centroid, axis, a, at(-100, 0.1f), 10 * kDeg).size(), 11u);
  EXPECT_EQ(virtualViewpoints(centroid, axis, a, a, 10 * kDeg).size(), 1u);

  // Each viewpoint is the first origin turned by i * step about the axis, toward the second.
  const auto viewpoints = virtualViewpoints(centroid, axis, a, at(-100, 0.1f), 10 * kDeg);
  for (std::size_t i = 0; i < viewpoints.size(); ++i)
  {
    const Eigen::Vector3d v = (viewpoints[i] - centroid).cast<double>();
    EXPECT_NEAR(v.z(), 0.2, 1e-5);
    EXPECT_NEAR(horizontal(v).norm(), 0.4, 1e-5);
    EXPECT_NEAR(std::atan2(v.y(), v.x()), -double(i) * 10 * kDeg, 1e-5);
  }
  // Degenerate: an origin on the axis, or a non-positive step.
  EXPECT_TRUE(virtualViewpoints(centroid, axis, centroid + Eigen::Vector3f(0, 0, 1), a, 0.1).empty());
  EXPECT_TRUE(virtualViewpoints(centroid, axis, a, at(90, 0.f), 0.0).empty());
}

// ----------------------------------------------------------------------------------------
// Single view (Ch3.2).

TEST(PrincipalAxisGrasp, BoxClosesOnItsSideWithParallelContacts)
{
  // Upright 0.05 x 0.07 x 0.15 box; the camera sees the +x face and the top.
  const auto box = synthetic::makeBox({ 0.5, 0.0, 0.075 }, { 0.05, 0.07, 0.15 });
  synthetic::ViewParams camera;
  camera.viewpoint = { 1.0, 0.0, 0.4 };
  const auto cloud = synthetic::renderView(box, camera);
  const GraspResult result = PrincipalAxisGraspPlanner().plan(viewOf(cloud, camera.viewpoint), robotiq());
  ASSERT_TRUE(result.ok()) << result.message;
  const GraspCandidate& best = result.grasps.front();
  EXPECT_EQ(best.algorithm, "principal_axis");
  EXPECT_LT(best.force_balance_rad, 0.02);
  EXPECT_NEAR(best.width_m, 0.07, 0.003);  // closes on the 0.07 side (along y)
  EXPECT_GT(std::abs(best.binormal().dot(Eigen::Vector3d::UnitY())), 0.99);
  EXPECT_GT(best.approach().dot(-Eigen::Vector3d::UnitX()), 0.99);  // from the sensor side
  EXPECT_LT(best.xoz_offset_m, 0.005);
  EXPECT_NEAR((best.contact_a - best.contact_b).norm(), best.width_m, 0.002);
  EXPECT_GE(result.candidates_evaluated, result.grasps.size());
  EXPECT_FALSE(result.hull.empty());
  EXPECT_FALSE(result.graspable_zone.empty());
  EXPECT_FALSE(result.next_view.has_value());
  for (std::size_t i = 1; i < result.grasps.size(); ++i)
    EXPECT_GE(result.grasps[i - 1].score, result.grasps[i].score);
}

TEST(PrincipalAxisGrasp, CylinderClosesAcrossTheDiameterThroughTheAxis)
{
  const Eigen::Vector3d axis_point(0.5, 0.05, 0.07);
  const auto cylinder = synthetic::makeCylinder(axis_point, Eigen::Vector3d::UnitZ(), 0.03, 0.14);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.25, 0.35 };
  const double spacing = 0.001;
  camera.spacing_m = spacing;
  const auto cloud = synthetic::renderView(cylinder, camera);
  PrincipalAxisParams params;
  // The Robotiq's palm stands only 2 cm behind the closing line: with the arm-consistent 1.1 cm
  // clearance the 3 cm radius would need more back-off than the fingers allow.
  params.gripper_fit.palm_clearance_m = 0.003;
  const GraspResult result = PrincipalAxisGraspPlanner(params).plan(viewOf(cloud, camera.viewpoint), robotiq());
  ASSERT_TRUE(result.ok()) << result.message;
  const GraspCandidate& best = result.grasps.front();
  // The outermost ray of a row misses the silhouette by up to one ray spacing measured along
  // the camera's (tilted) grid: up to sqrt(2) * spacing per side, never more than the diameter.
  const double silhouette_gap = std::sqrt(2.0) * spacing;
  EXPECT_LE(best.width_m, 0.06 + 1e-4);
  EXPECT_GE(best.width_m, 0.06 - 2.0 * silhouette_gap);
  EXPECT_LT(best.force_balance_rad, 0.05);
  EXPECT_LT(std::abs(best.binormal().dot(Eigen::Vector3d::UnitZ())), 0.05);  // across the axis
  // The closing line (centre + t * binormal) passes through the cylinder axis: the contacts
  // sit at the silhouette, at the axis' depth, up to the depth of a point a gap g inside the
  // silhouette of a circle of radius r, sqrt(2 r g).
  const double depth_bound = std::sqrt(2.0 * 0.03 * silhouette_gap);
  const Eigen::Vector3d normal = best.binormal().cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d closing_point = 0.5 * (best.contact_a + best.contact_b);
  EXPECT_LT(std::abs((closing_point - axis_point).dot(normal)), depth_bound);
  EXPECT_LT(horizontal(closing_point - axis_point).norm(), depth_bound);
  // The real hand (gripper_volume.h): the Robotiq's palm face is finger_depth / 2 = 0.02 m
  // behind the grasp origin, the cylinder's front about R = 0.03 m in front of the axis, so the
  // hand backs out by at least R + palm_clearance - 0.02 = 0.013 m (more as the approach
  // tilts) and the closing line stays between the fingers.
  const double ahead = (closing_point - best.position()).dot(best.approach());
  EXPECT_GE(ahead, 0.03 + params.gripper_fit.palm_clearance_m - 0.02 - depth_bound);
  EXPECT_LE(ahead, 0.5 * robotiq().finger_depth_m);
}

TEST(PrincipalAxisGrasp, DepthNoiseDoesNotNarrowTheWidth)
{
  // Kinect-like axial noise along each ray (1 and 3 mm). The sweep-line crossings take row
  // extremes over neighbouring rows, so noise that moves a row's outermost point elsewhere
  // does not read the object narrow: widths stay those of the noise-free bounds above.
  for (double noise_m : { 0.001, 0.003 })
  {
    synthetic::ViewParams camera;
    camera.noise_stddev_m = noise_m;
    camera.viewpoint = { 0.9, 0.25, 0.35 };
    const double silhouette_gap = std::sqrt(2.0) * camera.spacing_m;
    const auto cylinder = synthetic::makeCylinder({ 0.5, 0.05, 0.07 }, Eigen::Vector3d::UnitZ(), 0.03, 0.14);
    PrincipalAxisParams params;
    params.gripper_fit.enabled = false;  // the Ch3 width under noise, not the Robotiq's short fingers
    const GraspResult round = PrincipalAxisGraspPlanner(params).plan(
        viewOf(synthetic::renderView(cylinder, camera), camera.viewpoint), robotiq());
    ASSERT_TRUE(round.ok()) << noise_m << ": " << round.message;
    EXPECT_GE(round.grasps.front().width_m, 0.06 - 2.0 * silhouette_gap) << noise_m;
    EXPECT_LE(round.grasps.front().width_m, 0.06 + 2.0 * noise_m) << noise_m;

    camera.viewpoint = { 1.0, 0.0, 0.4 };
    const auto box = synthetic::makeBox({ 0.5, 0.0, 0.075 }, { 0.05, 0.07, 0.15 });
    const GraspResult flat =
        PrincipalAxisGraspPlanner().plan(viewOf(synthetic::renderView(box, camera), camera.viewpoint), robotiq());
    ASSERT_TRUE(flat.ok()) << noise_m << ": " << flat.message;
    EXPECT_NEAR(flat.grasps.front().width_m, 0.07, 0.003) << noise_m;
    EXPECT_LT(flat.grasps.front().force_balance_rad, 0.1) << noise_m;
  }
}

TEST(PrincipalAxisGrasp, SphereWiderThanTheOpeningFailsWithoutNextView)
{
  // Diameter 0.12 > 0.085: the only narrow sweep lines are near the poles, where the sides
  // are steep arcs. A sphere looks as wide from every side: no flat face to look along (its
  // seen cap is ~0.15 of its width off its XOZ line), so no view is suggested.
  const auto sphere = synthetic::makeSphere({ 0.5, 0.0, 0.06 }, 0.06);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.1, 0.3 };
  const auto cloud = synthetic::renderView(sphere, camera);
  const GraspResult result = PrincipalAxisGraspPlanner().plan(viewOf(cloud, camera.viewpoint), robotiq());
  EXPECT_FALSE(result.ok());
  EXPECT_TRUE(result.failure == GraspFailure::NoGraspableZone || result.failure == GraspFailure::NoStableGrasp)
      << toString(result.failure) << ": " << result.message;
  EXPECT_TRUE(result.grasps.empty());
  EXPECT_FALSE(result.next_view.has_value());
  EXPECT_FALSE(result.message.empty());
}

TEST(PrincipalAxisGrasp, SameInputSameResult)
{
  const auto cylinder = synthetic::makeCylinder({ 0.5, 0.0, 0.07 }, Eigen::Vector3d::UnitZ(), 0.03, 0.14);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.2, 0.35 };
  camera.noise_stddev_m = 0.001;
  const auto view = viewOf(synthetic::renderView(cylinder, camera), camera.viewpoint);
  const PrincipalAxisGraspPlanner planner;
  const GraspResult first = planner.plan(view, robotiq());
  const GraspResult second = planner.plan(view, robotiq());
  ASSERT_EQ(first.failure, second.failure);
  ASSERT_EQ(first.grasps.size(), second.grasps.size());
  for (std::size_t i = 0; i < first.grasps.size(); ++i)
  {
    EXPECT_TRUE(first.grasps[i].pose.isApprox(second.grasps[i].pose, 0.0));
    EXPECT_EQ(first.grasps[i].width_m, second.grasps[i].width_m);
    EXPECT_EQ(first.grasps[i].score, second.grasps[i].score);
  }
}

TEST(PrincipalAxisGrasp, CupHasAWorseXoyAngleThanBottleAndBox)
{
  // Table 3.1, qualitatively: a tapered cup has no parallel sides. Cup radius 0.025 -> 0.045
  // over 0.14 m, so each side leans atan(0.02 / 0.14) and the angle is twice that.
  // The camera looks down on the open top; the rim's ellipse bends the top of both side lines
  // inward, which end_clearance_m keeps out of the finger bands.
  const Eigen::Vector3d camera(0.5, 0.1, 0.25);
  PrincipalAxisParams params;
  params.force_balance_max_rad = 1.0;  // let the cup through to compare its angle
  params.gripper_fit.enabled = false;  // Table 3.1 compares the XOY angles, not a hand
  const PrincipalAxisGraspPlanner planner(params);
  GripperModel gripper = robotiq();
  gripper.max_opening_m = 0.13;  // Lacquey Fetch opening: the cup's 0.09 m rim fits

  const auto cup = visibleFrustum({ 0.0, 0.0, 0.0 }, 0.14, 0.025, 0.045, camera, 0.002);
  const auto bottle = visibleFrustum({ 0.0, 0.0, 0.0 }, 0.14, 0.03, 0.03, camera, 0.002);
  synthetic::ViewParams box_camera;
  box_camera.viewpoint = camera;
  // The box faces the camera (front and top visible) so its two sides are at one depth.
  const Eigen::Matrix3d facing =
      Eigen::AngleAxisd(std::atan2(camera.y(), camera.x()), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto box =
      synthetic::renderView(synthetic::makeBox({ 0.0, 0.0, 0.07 }, { 0.05, 0.06, 0.14 }, facing), box_camera);

  const GraspResult cup_result = planner.plan(viewOf(cup, camera), gripper);
  const GraspResult bottle_result = planner.plan(viewOf(bottle, camera), gripper);
  const GraspResult box_result = planner.plan(viewOf(box, camera), gripper);
  ASSERT_TRUE(cup_result.ok()) << cup_result.message;
  ASSERT_TRUE(bottle_result.ok()) << bottle_result.message;
  ASSERT_TRUE(box_result.ok()) << box_result.message;
  const double cup_angle = cup_result.grasps.front().force_balance_rad;
  EXPECT_NEAR(cup_angle, 2.0 * std::atan(0.02 / 0.14), 0.05);
  EXPECT_GT(cup_angle, bottle_result.grasps.front().force_balance_rad + 0.15);
  EXPECT_GT(cup_angle, box_result.grasps.front().force_balance_rad + 0.15);
  // With the default threshold (0.35 rad) the cup still passes; with 0.2 rad it does not.
  PrincipalAxisParams strict;
  strict.force_balance_max_rad = 0.2;
  const GraspResult strict_cup = PrincipalAxisGraspPlanner(strict).plan(viewOf(cup, camera), gripper);
  EXPECT_EQ(strict_cup.failure, GraspFailure::NoStableGrasp) << strict_cup.message;
  EXPECT_FALSE(strict_cup.next_view.has_value());
}

// Ch3.2.3: a plank seen at an angle passes XOY (vertical sides) but its left and right contact
// regions lie at very different depths, so XOZ fails and the camera should move.
struct NextViewCase
{
  double plank_width_m;
  double yaw_deg;  // angle between the plank's wide-face normal and the line of sight
};

class NextView : public ::testing::TestWithParam<NextViewCase>
{
};

TEST_P(NextView, IsTheSensorTurnedByBetaAboutThePrincipalAxis)
{
  const NextViewCase c = GetParam();
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(c.yaw_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto plank = synthetic::makeBox({ 0.5, 0.0, 0.09 }, { 0.01, c.plank_width_m, 0.18 }, yaw);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.0, 0.3 };
  const auto cloud = synthetic::renderView(plank, camera);
  const GraspResult result = PrincipalAxisGraspPlanner().plan(viewOf(cloud, camera.viewpoint), robotiq());
  ASSERT_EQ(result.failure, GraspFailure::NoStableGrasp) << result.message;
  ASSERT_TRUE(result.next_view.has_value()) << result.message;

  // The rotation axis is the (vertical) principal axis through the centroid: height and
  // distance to the axis are kept.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : cloud->points)
    centroid += Eigen::Vector3d(p.x, p.y, p.z);
  centroid /= double(cloud->size());
  const Eigen::Vector3d before = camera.viewpoint - centroid;
  const Eigen::Vector3d after = result.next_view->translation() - centroid;
  EXPECT_NEAR(after.z(), before.z(), 0.005);
  EXPECT_NEAR(horizontal(after).norm(), horizontal(before).norm(), 0.005);

  // Hand derivation: alpha (sight line to main plane = wide face) is 90 deg - yaw.
  // W_m < G_r: look perpendicular to the face, beta = pi/2 - alpha = yaw;
  // W_m >= G_r: look along the face, beta = alpha = 90 deg - yaw.
  const Eigen::Vector3d face_normal = yaw * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d face_tangent = yaw * Eigen::Vector3d::UnitY();
  const bool narrow = c.plank_width_m < robotiq().max_opening_m;
  const double beta = narrow ? c.yaw_deg * kDeg : (90.0 - c.yaw_deg) * kDeg;
  EXPECT_NEAR(angleBetween(horizontal(before), horizontal(after)), beta, 3.0 * kDeg);
  const Eigen::Vector3d target = narrow ? face_normal : (face_tangent.dot(before) > 0 ? face_tangent : -face_tangent);
  EXPECT_LT(angleBetween(horizontal(after), target), 3.0 * kDeg);
  // The suggested optical axis (z) looks at the centroid.
  EXPECT_GT(result.next_view->linear().col(2).dot(-after.normalized()), 0.999);
}

INSTANTIATE_TEST_SUITE_P(PlankSeenAtAnAngle, NextView,
                         ::testing::Values(NextViewCase{ 0.06, 40.0 }, NextViewCase{ 0.12, 60.0 }));

// Beyond step 7: the other two failures a camera move resolves, each followed by a second plan
// from the suggested view (the loop an eye-in-hand robot runs).

TEST(NextView, NoGraspableZoneOnAWideFlatFaceLooksAlongTheFaceAndThenGrasps)
{
  // Plank 0.015 x 0.12 x 0.18, wide face turned 20 deg from the line of sight: its projection
  // (0.12 cos 20 + 0.015 sin 20 = 0.118 m) exceeds the Robotiq's 0.085 m at every sweep line.
  // Fig. 3.11 (b): look along the face, beta = alpha = 90 - 20 = 70 deg; from there the hand
  // closes across the 0.015 m thickness.
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(20.0 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto plank = synthetic::makeBox({ 0.5, 0.0, 0.09 }, { 0.015, 0.12, 0.18 }, yaw);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.0, 0.3 };
  const auto cloud = synthetic::renderView(plank, camera);
  const GraspResult first = PrincipalAxisGraspPlanner().plan(viewOf(cloud, camera.viewpoint), robotiq());
  ASSERT_EQ(first.failure, GraspFailure::NoGraspableZone) << first.message;
  ASSERT_TRUE(first.next_view.has_value()) << first.message;
  const Eigen::Vector3d centroid = centroidOf(*cloud);
  const Eigen::Vector3d before = camera.viewpoint - centroid;
  const Eigen::Vector3d after = first.next_view->translation() - centroid;
  EXPECT_NEAR(after.z(), before.z(), 0.005);  // turned about the vertical principal axis
  EXPECT_NEAR(angleBetween(horizontal(before), horizontal(after)), 70.0 * kDeg, 3.0 * kDeg);
  const Eigen::Vector3d tangent = yaw * Eigen::Vector3d::UnitY();
  EXPECT_LT(angleBetween(horizontal(after), tangent.dot(before) > 0 ? tangent : -tangent), 3.0 * kDeg);

  synthetic::ViewParams moved;
  moved.viewpoint = first.next_view->translation();
  const GraspResult second =
      PrincipalAxisGraspPlanner().plan(viewOf(synthetic::renderView(plank, moved), moved.viewpoint), robotiq());
  ASSERT_TRUE(second.ok()) << second.message;
  EXPECT_NEAR(second.grasps.front().width_m, 0.015, 0.003);
  EXPECT_LT(second.grasps.front().force_balance_rad, 0.1);
}

TEST(NextView, LowObjectTheTableKeepsFromTheHandIsLookedAtFromAboveAndThenGrasped)
{
  // A 4 cm bar (cylinder) lying on the table z = 0, seen from 60 deg above the horizon: the
  // hand approaching along the line of sight closes on a line tilted 30 deg, and with the
  // Lacquey's 0.13 m opening its lower finger (0.065 sin 30 = 3.3 cm below the 2 cm high axis,
  // then the fingertips 4.5 cm further along the approach) is below the table at any allowed
  // back-off. The axis is horizontal, so the view from above is a turn to a vertical line of
  // sight at the same distance; from there the hand comes down and closes level.
  const GripperModel lacquey = loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/lacquey_fetch.yaml");
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, 1.0, 0.0).normalized();
  const auto bar = synthetic::makeCylinder({ 0.5, 0.0, 0.02 }, axis, 0.02, 0.2);
  const Eigen::Vector3d side_camera(0.5 - 0.65 * std::cos(60.0 * kDeg), 0.0, 0.02 + 0.65 * std::sin(60.0 * kDeg));
  auto viewOnTable = [&](const Eigen::Vector3d& viewpoint) {
    synthetic::ViewParams camera;
    camera.viewpoint = viewpoint;
    ObjectView view = viewOf(synthetic::renderView(bar, camera), viewpoint);
    view.has_table_plane = true;
    view.table_plane = Eigen::Vector4f(0, 0, 1, 0);
    return view;
  };
  const ObjectView from_side = viewOnTable(side_camera);
  const GraspResult first = PrincipalAxisGraspPlanner().plan(from_side, lacquey);
  ASSERT_EQ(first.failure, GraspFailure::NoStableGrasp) << first.message;
  EXPECT_NE(first.message.find("table"), std::string::npos) << first.message;
  ASSERT_TRUE(first.next_view.has_value()) << first.message;
  // Eq. 3.6 turns the camera about the axis: its offset along the axis (the camera is 8 deg
  // off the plane perpendicular to the bar) stays, the part across the axis becomes vertical.
  const Eigen::Vector3d centroid = centroidOf(*from_side.cloud);
  const Eigen::Vector3d before = side_camera - centroid;
  const Eigen::Vector3d after = first.next_view->translation() - centroid;
  EXPECT_NEAR(after.norm(), before.norm(), 0.005);  // turned, not moved away
  EXPECT_NEAR(after.dot(axis), before.dot(axis), 0.005);
  EXPECT_LT(angleBetween(after - after.dot(axis) * axis, Eigen::Vector3d::UnitZ()), 3.0 * kDeg);
  EXPECT_GT(first.next_view->linear().col(2).dot(-after.normalized()), 0.999);  // looks at the bar

  const GraspResult second = PrincipalAxisGraspPlanner().plan(viewOnTable(first.next_view->translation()), lacquey);
  ASSERT_TRUE(second.ok()) << second.message;
  const GraspCandidate& grasp = second.grasps.front();
  EXPECT_NEAR(grasp.width_m, 0.04, 0.004);
  EXPECT_LT(angleBetween(grasp.approach(), -Eigen::Vector3d::UnitZ()), 5.0 * kDeg);
  EXPECT_LT(std::abs(grasp.binormal().dot(axis)), std::sin(5.0 * kDeg));  // closes across the bar
}

// ----------------------------------------------------------------------------------------
// Two cameras (Ch3.5).

TEST(PrincipalAxisGraspTwoCameras, FusedPlankFoundFromTheNarrowSideOnTheSeenPart)
{
  // Box 0.04 (x) x 0.12 (y) x 0.18 (z). Camera 0 faces the 0.12 m wide +x face: too wide
  // for the gripper from there. Camera 1 faces the narrow +y face, 90 degrees away.
  const auto box = synthetic::makeBox({ 0.5, 0.0, 0.09 }, { 0.04, 0.12, 0.18 });
  const Eigen::Vector3d hand(0.9, 0.0, 0.35), head(0.5, 0.4, 0.35);
  synthetic::ViewParams hand_camera, head_camera;
  hand_camera.viewpoint = hand;
  head_camera.viewpoint = head;
  const auto hand_cloud = synthetic::renderView(box, hand_camera);
  const auto head_cloud = synthetic::renderView(box, head_camera);

  const GraspResult single = PrincipalAxisGraspPlanner().plan(viewOf(hand_cloud, hand), robotiq());
  EXPECT_EQ(single.failure, GraspFailure::NoGraspableZone) << single.message;

  ObjectView fused;
  fused.cloud = fuse(*hand_cloud, *head_cloud);
  fused.sensor_origins = { hand.cast<float>(), head.cast<float>() };
  PrincipalAxisParams params;
  params.xoz_max_offset_m = 0.1;  // compare the geometry; Eq. 3.10 still ranks the viewpoints
  // The Robotiq's 4 cm fingers cannot reach the middle of the 12 cm deep plank without the palm
  // hitting its end; this test is about the Ch3.5 geometry, not the hand.
  params.gripper_fit.enabled = false;
  const GraspResult result = PrincipalAxisGraspPlanner(params).plan(fused, robotiq());
  ASSERT_TRUE(result.ok()) << result.message;
  ASSERT_FALSE(result.candidates.empty());
  // Every per-viewpoint best grasp: approaches from between the two cameras (the seen part),
  // and its width is the fused L-section's extent across the sight line,
  // 0.12 cos(theta) + 0.04 sin(theta), theta measured from camera 0 toward camera 1.
  const Eigen::Vector3d centroid = centroidOf(*fused.cloud);
  for (const GraspCandidate& grasp : result.candidates)
  {
    const Eigen::Vector3d toward_sensor = -grasp.approach();
    const double theta = std::atan2(toward_sensor.y(), toward_sensor.x());
    EXPECT_TRUE(withinSeenSector(toward_sensor, centroid, hand, head, 1e-3)) << theta;
    EXPECT_NEAR(grasp.width_m, 0.12 * std::cos(theta) + 0.04 * std::sin(theta), 0.004) << theta;
    EXPECT_LE(grasp.width_m, robotiq().max_opening_m);
  }
  // The final grasp is the viewpoint with the smallest XOZ offset (Eq. 3.10).
  for (const GraspCandidate& grasp : result.candidates)
    EXPECT_LE(result.grasps.front().xoz_offset_m, grasp.xoz_offset_m + 1e-12);
}

TEST(PrincipalAxisGraspTwoCameras, FusedCylinderOneGraspPerVirtualViewpoint)
{
  const Eigen::Vector3d axis_point(0.5, 0.0, 0.08);
  const auto cylinder = synthetic::makeCylinder(axis_point, Eigen::Vector3d::UnitZ(), 0.03, 0.16);
  const Eigen::Vector3d hand(0.9, 0.0, 0.3), head(0.5, -0.4, 0.3);  // 90 degrees apart
  synthetic::ViewParams hand_camera, head_camera;
  hand_camera.viewpoint = hand;
  head_camera.viewpoint = head;
  ObjectView fused;
  fused.cloud = fuse(*synthetic::renderView(cylinder, hand_camera), *synthetic::renderView(cylinder, head_camera));
  fused.sensor_origins = { hand.cast<float>(), head.cast<float>() };
  PrincipalAxisParams params;
  params.virtual_view_step_rad = 10 * kDeg;
  params.gripper_fit.enabled = false;  // one grasp per viewpoint (Ch3.5), not the Robotiq's reach
  const GraspResult result = PrincipalAxisGraspPlanner(params).plan(fused, robotiq());
  ASSERT_TRUE(result.ok()) << result.message;
  // floor(90 / 10) + 1 = 10 virtual viewpoints, each with its best XOY grasp.
  EXPECT_EQ(result.candidates.size(), 10u);
  const Eigen::Vector3d centroid = centroidOf(*fused.cloud);
  const double silhouette_gap = std::sqrt(2.0) * hand_camera.spacing_m;  // see the single-view test
  for (const GraspCandidate& grasp : result.candidates)
  {
    EXPECT_NEAR(grasp.width_m, 0.06 - silhouette_gap, silhouette_gap + 1e-4);
    EXPECT_TRUE(withinSeenSector(-grasp.approach(), centroid, hand, head, 1e-3));
    const Eigen::Vector3d normal = grasp.binormal().cross(Eigen::Vector3d::UnitZ()).normalized();
    EXPECT_LT(std::abs((grasp.position() - axis_point).dot(normal)), std::sqrt(2.0 * 0.03 * silhouette_gap));
  }
  // Two origins but two-camera mode off: the hand camera's object frame only, so every
  // candidate approaches along the hand's line of sight (the fused cloud then looks lopsided
  // from there, and the thesis's XOZ check may well reject it).
  params.two_camera_mode = false;
  const GraspResult hand_only = PrincipalAxisGraspPlanner(params).plan(fused, robotiq());
  ASSERT_FALSE(hand_only.candidates.empty()) << hand_only.message;
  const Eigen::Vector3d hand_sight = horizontal(centroid - hand).normalized();
  for (const GraspCandidate& grasp : hand_only.candidates)
    EXPECT_GT(grasp.approach().dot(hand_sight), 0.999);
}

// ----------------------------------------------------------------------------------------
// Bad input: a typed failure and a reason, never a crash.

TEST(PrincipalAxisGrasp, BadInputGivesTypedFailures)
{
  const PrincipalAxisGraspPlanner planner;
  const GripperModel gripper = robotiq();
  const Eigen::Vector3d sensor(1.0, 0.0, 0.5);
  auto planOn = [&](const CloudNormal::Ptr& cloud) { return planner.plan(viewOf(cloud, sensor), gripper); };
  auto pointAt = [](float x, float y, float z) {
    PointNormal p;
    p.x = x;
    p.y = y;
    p.z = z;
    return p;
  };
  auto expectFailure = [](const GraspResult& result, GraspFailure expected, const char* what) {
    EXPECT_EQ(result.failure, expected) << what << ": " << result.message;
    EXPECT_FALSE(result.ok()) << what;
    EXPECT_TRUE(result.grasps.empty()) << what;
    EXPECT_FALSE(result.message.empty()) << what;
    EXPECT_FALSE(result.next_view.has_value()) << what;
  };

  ObjectView null_view;
  null_view.sensor_origins = { sensor.cast<float>() };
  expectFailure(planner.plan(null_view, gripper), GraspFailure::EmptyInput, "null");
  expectFailure(planOn(CloudNormal::Ptr(new CloudNormal)), GraspFailure::EmptyInput, "empty");

  CloudNormal::Ptr nan_only(new CloudNormal);
  for (int i = 0; i < 100; ++i)
    nan_only->push_back(pointAt(NAN, NAN, NAN));
  nan_only->push_back(pointAt(INFINITY, 0, 0));
  expectFailure(planOn(nan_only), GraspFailure::EmptyInput, "NaN only");

  for (int n = 1; n <= 3; ++n)
  {
    CloudNormal::Ptr few(new CloudNormal);
    for (int i = 0; i < n; ++i)
      few->push_back(pointAt(0.5f + 0.01f * i, 0.02f * (i % 2), 0.1f * i));
    expectFailure(planOn(few), GraspFailure::DegenerateInput, "few points");
  }

  CloudNormal::Ptr collinear(new CloudNormal);
  for (int i = 0; i < 200; ++i)
    collinear->push_back(pointAt(0.5f, 0.0f, 0.001f * i));
  expectFailure(planOn(collinear), GraspFailure::DegenerateInput, "collinear");

  CloudNormal::Ptr sheet(new CloudNormal);  // 0.05 x 0.15 sheet facing the sensor, zero thickness
  for (int i = 0; i <= 25; ++i)
    for (int j = 0; j <= 75; ++j)
      sheet->push_back(pointAt(0.5f, -0.025f + 0.002f * i, 0.002f * j));
  expectFailure(planOn(sheet), GraspFailure::DegenerateInput, "flat sheet");

  const auto box = synthetic::renderView(synthetic::makeBox({ 0.5, 0.0, 0.075 }, { 0.05, 0.07, 0.15 }),
                                         synthetic::ViewParams{ sensor, 0.002, 0.0, 1 });
  ObjectView no_origin;
  no_origin.cloud = box;
  expectFailure(planner.plan(no_origin, gripper), GraspFailure::DegenerateInput, "no sensor origin");
  ObjectView nan_origin = viewOf(box, sensor);
  nan_origin.sensor_origins[0] = Eigen::Vector3f::Constant(NAN);
  expectFailure(planner.plan(nan_origin, gripper), GraspFailure::DegenerateInput, "NaN sensor origin");
  // Looking straight down the principal axis: no object frame.
  expectFailure(planner.plan(viewOf(box, Eigen::Vector3d(0.5, 0.0, 1.0)), gripper), GraspFailure::DegenerateInput,
                "axis at the sensor");

  GripperModel broken = gripper;
  broken.max_opening_m = -1.0;
  expectFailure(planner.plan(viewOf(box, sensor), broken), GraspFailure::InvalidParameters, "bad gripper");
  PrincipalAxisParams bad_params;
  bad_params.sweep_step_m = 0.0;
  expectFailure(PrincipalAxisGraspPlanner(bad_params).plan(viewOf(box, sensor), gripper),
                GraspFailure::InvalidParameters, "zero sweep step");

  // Two origins, the second looking down the (vertical) principal axis: no virtual viewpoints.
  ObjectView two = viewOf(box, sensor);
  two.sensor_origins.push_back((centroidOf(*box) + Eigen::Vector3d(0.0, 0.0, 0.5)).cast<float>());
  expectFailure(planner.plan(two, gripper), GraspFailure::DegenerateInput, "head camera on the axis");
}

// Not a timing assertion: prints the plan time at ~10k points for the report.
TEST(PrincipalAxisGrasp, ReportsComputeTimeAtTenThousandPoints)
{
  const auto cylinder = synthetic::makeCylinder({ 0.5, 0.0, 0.1 }, Eigen::Vector3d::UnitZ(), 0.035, 0.2);
  synthetic::ViewParams camera;
  camera.viewpoint = { 0.9, 0.1, 0.35 };
  camera.spacing_m = 0.0012;
  const auto view = viewOf(synthetic::renderView(cylinder, camera), camera.viewpoint);
  const PrincipalAxisGraspPlanner planner;
  // The Lacquey: the Robotiq's 4 cm fingers cannot reach the 7 cm cylinder's axis past its front.
  const GripperModel gripper =
      loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/lacquey_fetch.yaml");
  // Mean plan time over 20 plans of `input`, printed; the last result must be a grasp.
  auto report = [&](const ObjectView& input, const char* label) {
    GraspResult result;
    double total = 0.0;
    for (int i = 0; i < 20; ++i)
    {
      result = planner.plan(input, gripper);
      total += result.compute_time_s;
    }
    EXPECT_TRUE(result.ok()) << result.message;
    std::cout << "[ timing ] principal_axis " << label << ", " << input.cloud->size() << " points: " << 1e3 * total / 20
              << " ms per plan" << std::endl;
  };
  report(view, "single view");

  // Two cameras 90 degrees apart, about 10k fused points, 10 virtual viewpoints.
  synthetic::ViewParams head_camera = camera;
  head_camera.viewpoint = { 0.4, -0.4, 0.35 };
  head_camera.spacing_m = 0.0017;
  camera.spacing_m = 0.0017;
  ObjectView fused;
  fused.cloud = fuse(*synthetic::renderView(cylinder, camera), *synthetic::renderView(cylinder, head_camera));
  fused.sensor_origins = { camera.viewpoint.cast<float>(), head_camera.viewpoint.cast<float>() };
  report(fused, "two cameras");
}
