// Boundary (caging) planner, thesis Ch4: the contour routines on hand-computed polygons and the
// planner on analytic shapes with hand-derived answers.
#include "fast_grasp/grasping/boundary_grasp.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/core/gripper_model.h"

#include "synthetic_views.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <iostream>
#include <random>
#include <stdexcept>

using namespace fast_grasp;

namespace
{
constexpr double kDeg = M_PI / 180.0;

std::vector<Eigen::Vector2d> rectangle(double length_m, double width_m, double vertex_spacing_m = 0.0)
{
  const std::vector<Eigen::Vector2d> corners = { { 0.0, 0.0 }, { length_m, 0.0 }, { length_m, width_m }, { 0.0, width_m } };
  if (!(vertex_spacing_m > 0.0))
    return corners;
  std::vector<Eigen::Vector2d> dense;
  for (std::size_t i = 0; i < corners.size(); ++i)
  {
    const Eigen::Vector2d a = corners[i], b = corners[(i + 1) % corners.size()];
    const int count = static_cast<int>(std::round((b - a).norm() / vertex_spacing_m));
    for (int k = 0; k < count; ++k)
      dense.push_back(a + (b - a) * (double(k) / count));
  }
  return dense;
}

GripperModel lacquey() { return loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/lacquey_fetch.yaml"); }

GripperModel robotiq()
{
  return loadGripperModel(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/robotiq_2f85.yaml");
}

ObjectView viewFromAbove(const std::vector<synthetic::Shape>& shapes, const Eigen::Vector3d& camera, bool with_table)
{
  synthetic::ViewParams params;
  params.viewpoint = camera;
  params.spacing_m = 0.002;
  ObjectView view = synthetic::makeObjectView(synthetic::renderView(shapes, params), camera);
  if (with_table)
  {
    view.table_plane = Eigen::Vector4f(0.0f, 0.0f, 1.0f, 0.0f);
    view.has_table_plane = true;
  }
  return view;
}

/// Angle between the grasp's closing direction and `direction` (either sense).
double closingAngleTo(const GraspCandidate& grasp, const Eigen::Vector3d& direction)
{
  return std::acos(std::min(1.0, std::abs(grasp.binormal().dot(direction.normalized()))));
}
}  // namespace

// ---- contour routines -----------------------------------------------------------------------

// A 0.10 x 0.04 m rectangle has a 0.28 m perimeter; from a corner, step points every 0.01 m land
// on the corners themselves (both sides are whole multiples of r), so there are 28, each 0.01 m
// from the one before, and the 29th would be the first again.
TEST(BoundaryContour, StepPointsOnARectangleFollowThePerimeter)
{
  for (const double vertex_spacing : { 0.0, 0.001, 0.003 })
  {
    const std::vector<Eigen::Vector2d> contour = rectangle(0.10, 0.04, vertex_spacing);
    const std::vector<ContourPoint> steps = contourStepPoints(contour, 0.01);
    ASSERT_EQ(steps.size(), 28u) << "vertex spacing " << vertex_spacing;
    EXPECT_LT(steps.front().point.norm(), 1e-12);
    for (std::size_t i = 1; i < steps.size(); ++i)
      EXPECT_NEAR((steps[i].point - steps[i - 1].point).norm(), 0.01, 1e-9) << i;
    EXPECT_NEAR((steps.back().point - steps.front().point).norm(), 0.01, 1e-9);
    // In serial order: the 11th is the corner (0.10, 0), the 15th (0.10, 0.04).
    EXPECT_LT((steps[10].point - Eigen::Vector2d(0.10, 0.0)).norm(), 1e-9);
    EXPECT_LT((steps[14].point - Eigen::Vector2d(0.10, 0.04)).norm(), 1e-9);
  }
  // r = 0.03 does not divide the sides: the circle cuts the corners (chords), so there are fewer
  // than perimeter / r, but still one every 0.03 m of chord.
  const std::vector<ContourPoint> coarse = contourStepPoints(rectangle(0.10, 0.04), 0.03);
  EXPECT_LE(coarse.size(), 9u);
  EXPECT_GE(coarse.size(), 8u);
}

// Eq. 4.1 across a corner: from (0.095, 0) the 0.01 m circle leaves the bottom side at its end
// (d = 0.005 < r) and crosses the right side where 0.005^2 + y^2 = 0.01^2, y = 0.00866.
TEST(BoundaryContour, CircleSegmentIntersectionAcrossACorner)
{
  const std::vector<Eigen::Vector2d> contour = rectangle(0.10, 0.04);
  const std::optional<ContourPoint> next = nextContourPointAtDistance(contour, { { 0.095, 0.0 }, 0 }, 0.01);
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->segment, 1u);
  EXPECT_NEAR(next->point.x(), 0.10, 1e-12);
  EXPECT_NEAR(next->point.y(), std::sqrt(0.01 * 0.01 - 0.005 * 0.005), 1e-12);
  EXPECT_FALSE(nextContourPointAtDistance(contour, { { 0.0, 0.0 }, 0 }, 1.0).has_value());  // beyond the polygon
}

TEST(BoundaryContour, PointInPolygonByCrossingParity)
{
  // L-shape: the notch (0.05, 0.05) is outside although it is inside the bounding box.
  const std::vector<Eigen::Vector2d> l_shape = { { 0, 0 }, { 0.1, 0 }, { 0.1, 0.03 }, { 0.03, 0.03 }, { 0.03, 0.1 }, { 0, 0.1 } };
  EXPECT_TRUE(insidePolygon(l_shape, { 0.05, 0.01 }));
  EXPECT_TRUE(insidePolygon(l_shape, { 0.01, 0.08 }));
  EXPECT_FALSE(insidePolygon(l_shape, { 0.05, 0.05 }));
  EXPECT_FALSE(insidePolygon(l_shape, { -0.01, 0.01 }));
  // A ray through a vertex (y = 0.03) counts it once.
  EXPECT_TRUE(insidePolygon(l_shape, { 0.01, 0.03 }));
  EXPECT_FALSE(insidePolygon(l_shape, { 0.05, 0.03 + 1e-9 }));
}

// A filled 0.10 x 0.04 m rectangle of points 1 mm apart traced on a 2 mm grid: the outline is
// counter-clockwise, in serial order (neighbours about one cell apart), on the rectangle's edge
// (cell centres moved out by half a cell) and encloses its area.
TEST(BoundaryContour, TracedOutlineIsOrderedAndOnTheEdge)
{
  std::vector<Eigen::Vector3d> points;
  for (double x = 0.0; x <= 0.10 + 1e-9; x += 0.001)
    for (double y = 0.0; y <= 0.04 + 1e-9; y += 0.001)
      points.emplace_back(x, y, -0.5 * y);  // depth falls with y: the outline keeps the deepest
  const OrderedContour contour = traceOrderedContour(points, 0.002, 1);
  ASSERT_GT(contour.points.size(), 100u);
  ASSERT_EQ(contour.depth_m.size(), contour.points.size());
  double area2 = 0.0;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1.0), hi = -lo;
  for (std::size_t i = 0; i < contour.points.size(); ++i)
  {
    const Eigen::Vector2d& a = contour.points[i];
    const Eigen::Vector2d& b = contour.points[(i + 1) % contour.points.size()];
    area2 += a.x() * b.y() - a.y() * b.x();
    EXPECT_LT((b - a).norm(), 1.5 * 0.002 * std::sqrt(2.0)) << i;
    lo = lo.cwiseMin(a);
    hi = hi.cwiseMax(a);
  }
  EXPECT_GT(area2, 0.0);  // counter-clockwise
  // The grid covers [0, 0.102] x [0, 0.042] (51 x 21 cells) and the outline runs on its edge, so
  // it overstates the samples' extent by up to a cell (on a real scan the object's edge lies
  // about half a spacing beyond its outermost samples, which this offsets).
  EXPECT_NEAR(0.5 * area2, 0.102 * 0.042, 0.004 * 0.03);
  EXPECT_NEAR(hi.x() - lo.x(), 0.101, 0.0015);
  EXPECT_NEAR(hi.y() - lo.y(), 0.041, 0.0015);
  // Along the top edge (y ~ 0.04) the deepest point is that row's, -0.02.
  for (std::size_t i = 0; i < contour.points.size(); ++i)
    if (contour.points[i].y() > 0.039 && contour.points[i].x() > 0.01 && contour.points[i].x() < 0.09)
    {
      EXPECT_NEAR(contour.depth_m[i], -0.02, 0.0011);
    }
}

// Fig. 4.11: whichever way the contour runs, every finger's grasping direction points inside
// and its chord is w_f long; a straight side has no variance.
TEST(BoundaryContour, FingerDirectionsPointInsideForEitherOrientation)
{
  for (const bool reversed : { false, true })
  {
    OrderedContour contour;
    contour.points = rectangle(0.10, 0.04, 0.001);
    if (reversed)
      std::reverse(contour.points.begin(), contour.points.end());
    contour.depth_m.assign(contour.points.size(), 0.0);
    const std::vector<ContourPoint> steps = contourStepPoints(contour.points, 0.005);
    const std::vector<FingerCandidate> fingers = fingerCandidates(contour, steps, 0.022, 0.002, 20);
    ASSERT_EQ(fingers.size(), steps.size());
    for (const FingerCandidate& finger : fingers)
    {
      EXPECT_NEAR((finger.end.point - finger.start.point).norm(), 0.022, 1e-9);
      EXPECT_TRUE(insidePolygon(contour.points, finger.middle + 0.003 * finger.inward)) << finger.middle.transpose();
      // A finger along one side is axis-aligned and its side points lie on its line; one whose
      // chord cuts a corner is diagonal and the corner vertex lies off its line.
      const bool along_a_side = std::min(std::abs(finger.inward.x()), std::abs(finger.inward.y())) < 1e-9;
      if (along_a_side)
      {
        EXPECT_LT(finger.side_variance_m, 1e-9);
      }
      else
      {
        EXPECT_GT(finger.side_variance_m, 1e-4);
      }
    }
  }
}

// ---- the planner on analytic views ----------------------------------------------------------

// A 0.10 x 0.04 x 0.03 m box on the table seen from straight above: the top face is the main
// plane. Both the 0.04 m and the 0.10 m closings fit the Lacquey's 0.13 m and pass through the
// centre of gravity, so the width tie-break takes the narrow side: closing along y, width 0.04,
// parallel sides (force balance ~0), approach from the camera (down), on the box's centre.
TEST(BoundaryGrasp, BoxFromAboveClosesAcrossTheNarrowSide)
{
  const Eigen::Vector3d camera(0.0, 0.0, 0.7);
  const ObjectView view =
      viewFromAbove({ synthetic::makeBox(Eigen::Vector3d(0.0, 0.0, 0.015), Eigen::Vector3d(0.10, 0.04, 0.03)) }, camera, true);
  const GraspResult result = BoundaryGraspPlanner().plan(view, lacquey());
  ASSERT_TRUE(result.ok()) << result.message;
  const GraspCandidate& best = result.grasps.front();
  EXPECT_EQ(best.algorithm, "boundary");
  EXPECT_LT(closingAngleTo(best, Eigen::Vector3d::UnitY()), 3.0 * kDeg);
  EXPECT_NEAR(best.width_m, 0.04, 0.004);
  EXPECT_LT(best.force_balance_rad, 0.05);
  EXPECT_LT(best.torque_offset_m, 0.003);
  EXPECT_LT(best.gravity_offset_m, 0.004);
  EXPECT_GT(best.approach().dot(-Eigen::Vector3d::UnitZ()), std::cos(2.0 * kDeg));
  EXPECT_LT(std::abs(best.position().x()), 0.005);
  EXPECT_LT(std::abs(best.position().y()), 0.003);
  // The hand was raised (backed out) until every corner is 1 cm above the table.
  EXPECT_GT(best.position().z() - 0.5 * lacquey().finger_depth_m, 0.01 - 1e-3);
  EXPECT_FALSE(result.hull.empty());
  EXPECT_FALSE(result.candidates.empty());
  EXPECT_GT(result.compute_time_s, 0.0);
}

// A 0.05 m cylinder lying along x, seen from above: the projected outline is a 0.12 x 0.05 m
// rectangle, and the grasp closes across it through the axis: width = diameter, contacts at the
// widest part (the axis height, up to the depth the outline's rim cells hold: < 1 cm above it).
TEST(BoundaryGrasp, LyingCylinderIsClosedAcrossItsDiameterThroughTheAxis)
{
  const double radius = 0.025, axis_z = 0.025;
  const Eigen::Vector3d camera(0.0, 0.0, 0.7);
  const ObjectView view = viewFromAbove(
      { synthetic::makeCylinder(Eigen::Vector3d(0.0, 0.0, axis_z), Eigen::Vector3d::UnitX(), radius, 0.12) }, camera, true);
  const GraspResult result = BoundaryGraspPlanner().plan(view, lacquey());
  ASSERT_TRUE(result.ok()) << result.message;
  const GraspCandidate& best = result.grasps.front();
  EXPECT_LT(closingAngleTo(best, Eigen::Vector3d::UnitY()), 3.0 * kDeg);
  EXPECT_NEAR(best.width_m, 2.0 * radius, 0.004);
  EXPECT_LT(best.force_balance_rad, 0.05);
  EXPECT_LT(std::abs(best.position().y()), 0.003);
  EXPECT_LT(std::abs(best.position().x()), 0.005);
  const Eigen::Vector3d contact_middle = 0.5 * (best.contact_a + best.contact_b);
  EXPECT_LT(std::abs(contact_middle.y()), 0.003);
  EXPECT_GT(contact_middle.z(), axis_z - 0.002);
  EXPECT_LT(contact_middle.z(), axis_z + 0.01);
}

// A flat L: arm A = [0, 0.14] x [0, 0.03], arm B = [0, 0.03] x [0.03, 0.09], 1 cm thick. Areas
// 42 and 18 cm^2, so the centre of gravity is at x = (42 * 7 + 18 * 1.5) / 60 = 5.35 cm,
// y = (42 * 1.5 + 18 * 6) / 60 = 2.85 cm. Grasps across arm A (closing along y, 3 cm) at x = 5.35
// pass through it (gravity offset 0, far from arm B's edge at x = 3); across arm B (closing along
// x) the finger on arm B's inner side x = 3 starts at the inner corner (3, 3), so with the 1.1 cm
// torque-offset allowance the grasping line is at y >= 3.0 + 1.1 - 1.1 / 2 (the pad's middle on the
// side, the other finger up to one offset lower): offset >= 3.55 - 2.85 = 0.7 cm; the
// Robotiq's 8.5 cm opening rules out the 9 cm and 14 cm closings. So the best grasp closes along y
// through x ~ 5.35 cm and ranks above every arm-B grasp.
TEST(BoundaryGrasp, LShapeIsGraspedThroughItsCentreOfGravity)
{
  const Eigen::Vector3d centre_of_gravity(0.0535, 0.0285, 0.01);
  const Eigen::Vector3d camera(0.05, 0.04, 0.7);
  const ObjectView view = viewFromAbove({ synthetic::makeBox(Eigen::Vector3d(0.07, 0.015, 0.005), Eigen::Vector3d(0.14, 0.03, 0.01)),
                                          synthetic::makeBox(Eigen::Vector3d(0.015, 0.06, 0.005), Eigen::Vector3d(0.03, 0.06, 0.01)) },
                                        camera, false);
  const GraspResult result = BoundaryGraspPlanner().plan(view, robotiq());
  ASSERT_TRUE(result.ok()) << result.message;
  const GraspCandidate& best = result.grasps.front();
  EXPECT_LT(closingAngleTo(best, Eigen::Vector3d::UnitY()), 3.0 * kDeg);
  EXPECT_NEAR(best.width_m, 0.03, 0.004);
  EXPECT_NEAR(best.position().x(), centre_of_gravity.x(), 0.005);
  EXPECT_LT(best.gravity_offset_m, 0.005);
  bool saw_arm_b = false;
  for (const GraspCandidate& candidate : result.candidates)
    if (closingAngleTo(candidate, Eigen::Vector3d::UnitX()) < 10.0 * kDeg && candidate.position().y() > 0.035)
    {
      saw_arm_b = true;
      EXPECT_GT(candidate.gravity_offset_m, 0.007);
      EXPECT_LT(candidate.score, best.score);
    }
  EXPECT_TRUE(saw_arm_b) << "no arm-B candidate was evaluated";
}

// A 0.20 x 0.16 m slab seen from above is wider than the Robotiq's 0.085 m both ways.
TEST(BoundaryGrasp, ObjectWiderThanTheOpeningHasNoGraspableZone)
{
  const Eigen::Vector3d camera(0.0, 0.0, 0.8);
  const ObjectView view =
      viewFromAbove({ synthetic::makeBox(Eigen::Vector3d(0.0, 0.0, 0.02), Eigen::Vector3d(0.20, 0.16, 0.04)) }, camera, true);
  const GraspResult result = BoundaryGraspPlanner().plan(view, robotiq());
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(result.failure, GraspFailure::NoGraspableZone) << result.message;
  EXPECT_NE(result.message.find("wider than"), std::string::npos) << result.message;
  EXPECT_TRUE(result.grasps.empty());
  EXPECT_FALSE(result.hull.empty());
}

TEST(BoundaryGrasp, BadInputGivesTypedFailures)
{
  const BoundaryGraspPlanner planner;
  const GripperModel gripper = lacquey();
  const Eigen::Vector3f camera(0.0f, 0.0f, 1.0f);
  auto viewOf = [&](const CloudNormal::Ptr& cloud) {
    ObjectView view;
    view.cloud = cloud;
    view.sensor_origins = { camera };
    return view;
  };
  auto point = [](float x, float y, float z) {
    PointNormal p;
    p.x = x;
    p.y = y;
    p.z = z;
    p.normal_x = p.normal_y = 0.0f;
    p.normal_z = 1.0f;
    return p;
  };
  ObjectView null_view;
  EXPECT_EQ(planner.plan(null_view, gripper).failure, GraspFailure::EmptyInput);
  CloudNormal::Ptr empty(new CloudNormal);
  EXPECT_EQ(planner.plan(viewOf(empty), gripper).failure, GraspFailure::EmptyInput);
  CloudNormal::Ptr nans(new CloudNormal);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 50; ++i)
    nans->push_back(point(nan, nan, nan));
  const GraspResult nan_result = planner.plan(viewOf(nans), gripper);
  EXPECT_EQ(nan_result.failure, GraspFailure::EmptyInput);  // grasp_types.h: no finite point
  EXPECT_NE(nan_result.message.find("finite"), std::string::npos);
  for (int count : { 1, 2, 3, 9 })
  {
    CloudNormal::Ptr few(new CloudNormal);
    for (int i = 0; i < count; ++i)
      few->push_back(point(0.01f * i, 0.02f * (i % 2), 0.0f));
    const GraspResult r = planner.plan(viewOf(few), gripper);
    EXPECT_EQ(r.failure, GraspFailure::DegenerateInput) << count;
    EXPECT_NE(r.message.find("finite points"), std::string::npos) << r.message;
  }
  CloudNormal::Ptr line(new CloudNormal);
  for (int i = 0; i < 100; ++i)
    line->push_back(point(0.001f * i, 0.002f * i, 0.5f));
  line->push_back(point(nan, 0.0f, 0.0f));
  const GraspResult collinear = planner.plan(viewOf(line), gripper);
  EXPECT_EQ(collinear.failure, GraspFailure::DegenerateInput);
  EXPECT_NE(collinear.message.find("collinear"), std::string::npos) << collinear.message;
  // A tight cluster (1 mm across): too small for two fingers.
  CloudNormal::Ptr speck(new CloudNormal);
  for (int i = 0; i < 30; ++i)
    speck->push_back(point(0.0001f * (i % 6), 0.0002f * (i / 6), 0.5f));
  const GraspResult tiny = planner.plan(viewOf(speck), gripper);
  EXPECT_FALSE(tiny.ok());
  EXPECT_EQ(tiny.failure, GraspFailure::DegenerateInput) << tiny.message;
  // No sensor origin: the approach side is unknown.
  ObjectView blind = viewOf(speck);
  blind.sensor_origins.clear();
  EXPECT_EQ(planner.plan(blind, gripper).failure, GraspFailure::DegenerateInput);
  // Invalid parameters.
  BoundaryParams bad;
  bad.step_m = 0.0;
  EXPECT_EQ(BoundaryGraspPlanner(bad).plan(viewOf(speck), gripper).failure, GraspFailure::InvalidParameters);
}

// Random clouds of any size and scale, with infinities, outliers and duplicates: a typed result,
// never a crash, and grasps only with a consistent frame.
TEST(BoundaryGrasp, RandomCloudsGiveTypedResults)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const BoundaryGraspPlanner planner;
  const GripperModel gripper = lacquey();
  for (int trial = 0; trial < 150; ++trial)
  {
    CloudNormal::Ptr cloud(new CloudNormal);
    const int count = std::uniform_int_distribution<int>(0, 400)(rng);
    const float scale = std::pow(10.0f, std::uniform_real_distribution<float>(-4.0f, 1.0f)(rng));
    for (int i = 0; i < count; ++i)
    {
      PointNormal p;
      p.x = scale * unit(rng);
      p.y = scale * unit(rng);
      p.z = 0.3f * scale * unit(rng) + 0.5f;
      p.normal_x = p.normal_y = 0.0f;
      p.normal_z = 1.0f;
      if (i % 97 == 5)
        p.x = std::numeric_limits<float>::infinity();
      if (i % 131 == 7)
        p.y = 1e4f;  // a far outlier
      cloud->push_back(p);
      if (i % 50 == 3)
        cloud->push_back(p);  // duplicate
    }
    ObjectView view;
    view.cloud = cloud;
    view.sensor_origins = { Eigen::Vector3f(0.0f, 0.0f, 2.0f) };
    const GraspResult result = planner.plan(view, gripper);
    EXPECT_EQ(result.ok(), result.failure == GraspFailure::None) << result.message;
    EXPECT_FALSE(result.message.empty());
    for (const GraspCandidate& g : result.grasps)
    {
      EXPECT_TRUE(g.pose.matrix().allFinite());
      EXPECT_NEAR(g.pose.linear().determinant(), 1.0, 1e-6);
    }
  }
}

TEST(BoundaryGrasp, SameInputSameResult)
{
  const Eigen::Vector3d camera(0.1, -0.05, 0.6);
  synthetic::ViewParams params;
  params.viewpoint = camera;
  params.noise_stddev_m = 0.001;
  const ObjectView view = synthetic::makeObjectView(
      synthetic::renderView(synthetic::makeCylinder(Eigen::Vector3d(0.0, 0.0, 0.03), Eigen::Vector3d(1.0, 0.3, 0.0), 0.03, 0.15),
                            params),
      camera);
  const BoundaryGraspPlanner planner;
  const GraspResult a = planner.plan(view, lacquey());
  const GraspResult b = planner.plan(view, lacquey());
  ASSERT_EQ(a.failure, b.failure);
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  ASSERT_TRUE(a.ok()) << a.message;
  for (std::size_t i = 0; i < a.grasps.size(); ++i)
  {
    EXPECT_TRUE(a.grasps[i].pose.isApprox(b.grasps[i].pose, 0.0)) << i;
    EXPECT_EQ(a.grasps[i].score, b.grasps[i].score);
  }
  EXPECT_EQ(a.message, b.message);
}

// Grasp frame convention (DESIGN.md) and the named metrics are filled on every grasp.
TEST(BoundaryGrasp, GraspsAreRightHandedWithTheirMetrics)
{
  const Eigen::Vector3d camera(0.0, 0.0, 0.7);
  const ObjectView view =
      viewFromAbove({ synthetic::makeBox(Eigen::Vector3d(0.0, 0.0, 0.015), Eigen::Vector3d(0.10, 0.04, 0.03)) }, camera, true);
  const GraspResult result = BoundaryGraspPlanner().plan(view, lacquey());
  ASSERT_TRUE(result.ok()) << result.message;
  for (std::size_t i = 1; i < result.grasps.size(); ++i)
    EXPECT_GE(result.grasps[i - 1].score, result.grasps[i].score);
  for (const GraspCandidate& g : result.grasps)
  {
    EXPECT_NEAR(g.pose.linear().determinant(), 1.0, 1e-9);
    EXPECT_NEAR(g.axis().dot(g.approach().cross(g.binormal())), 1.0, 1e-9);
    EXPECT_LE(g.width_m, lacquey().max_opening_m);
    for (double metric : { g.force_balance_rad, g.torque_offset_m, g.variance_m, g.gravity_offset_m })
      EXPECT_TRUE(std::isfinite(metric));
    EXPECT_TRUE(std::isnan(g.xoz_offset_m));  // a Ch3 metric
  }
}

// The main plane at 10k points: the timing is reported, the bound is loose (shared machine).
TEST(BoundaryGrasp, ReportsComputeTimeAtTenThousandPoints)
{
  const Eigen::Vector3d camera(0.3, 0.0, 0.6);
  synthetic::ViewParams params;
  params.viewpoint = camera;
  params.spacing_m = 0.0009;
  const ObjectView view = synthetic::makeObjectView(
      synthetic::renderView(synthetic::makeCylinder(Eigen::Vector3d(0.0, 0.0, 0.1), Eigen::Vector3d::UnitZ(), 0.035, 0.2),
                            params),
      camera);
  ASSERT_GT(view.cloud->size(), 8000u);
  const BoundaryGraspPlanner planner;
  GraspResult result;
  double best_s = 1e9;
  for (int i = 0; i < 5; ++i)
  {
    result = planner.plan(view, lacquey());
    best_s = std::min(best_s, result.compute_time_s);
  }
  ASSERT_TRUE(result.ok()) << result.message;
  std::cout << "boundary: " << view.cloud->size() << " points, best of 5 " << best_s * 1e3 << " ms\n";
  EXPECT_LT(best_s, 0.1);
  // A standing bottle seen from the side: closing across its diameter, horizontally.
  EXPECT_NEAR(result.grasps.front().width_m, 0.07, 0.006);
  EXPECT_LT(std::abs(result.grasps.front().binormal().z()), std::sin(10.0 * kDeg));
}

TEST(BoundaryParamsYaml, KeysTypesAndTyposAreChecked)
{
  const BoundaryParams p = boundaryParamsFromYaml(YAML::Load("{step_m: 0.004, close_cells: 2, use_unseen_part: false, "
                                                             "unseen_depth_jump_m: 0.03, gripper_fit: {enabled: false}}"));
  EXPECT_DOUBLE_EQ(p.step_m, 0.004);
  EXPECT_EQ(p.close_cells, 2);
  EXPECT_FALSE(p.use_unseen_part);
  EXPECT_DOUBLE_EQ(p.unseen.depth_jump_m, 0.03);
  EXPECT_FALSE(p.gripper_fit.enabled);
  EXPECT_DOUBLE_EQ(p.grid_cell_m, BoundaryParams().grid_cell_m);
  try
  {
    boundaryParamsFromYaml(YAML::Load("{step: 0.005}"));
    ADD_FAILURE() << "unknown key accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("boundary/step"), std::string::npos) << e.what();
  }
  for (const char* bad : { "{step_m: 0}", "{step_m: far}", "{max_grasps: 0}", "{gripper_fit: {palm_clearance: 1}}", "[1]" })
    EXPECT_THROW(boundaryParamsFromYaml(YAML::Load(bad)), std::runtime_error) << bad;
  const GraspPlannerConfig config = loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  const YAML::Node file = YAML::LoadFile(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  EXPECT_DOUBLE_EQ(config.boundary.step_m, file["boundary"]["step_m"].as<double>());
  EXPECT_DOUBLE_EQ(config.boundary.variance_max_m, file["boundary"]["variance_max_m"].as<double>());
}

// A box narrower across the view (0.04 m along y) than deep along it (0.12 m along x), 0.15 m
// tall, seen from the front and above: the seen front and top faces spread least along y, so the
// OBB plane's normal (the minor axis) is y, across the line of sight, and the thesis's
// perpendicular approach would come from the side nobody saw. With the default
// max_normal_sight_angle_rad the plane facing the camera is used instead: the hand comes from the
// camera's side and closes across the 0.04 m.
TEST(BoundaryGrasp, MainPlaneFacesTheCameraWhenTheObbNormalLiesAcrossTheView)
{
  const Eigen::Vector3d camera(-0.45, 0.0, 0.55);
  const Eigen::Vector3d centre(0.0, 0.0, 0.075);
  synthetic::ViewParams params;
  params.viewpoint = camera;
  const ObjectView view = synthetic::makeObjectView(
      synthetic::renderView(synthetic::makeBox(centre, Eigen::Vector3d(0.12, 0.04, 0.15)), params), camera);
  const Eigen::Vector3d sight = (camera - centre).normalized();

  BoundaryParams thesis_plane;
  thesis_plane.max_normal_sight_angle_rad = M_PI / 2.0;
  // Seen along y, both seen faces are edge-on: the outline is an L of lines a cell or two thick,
  // nothing the fingers can close on.
  const GraspResult side = BoundaryGraspPlanner(thesis_plane).plan(view, lacquey());
  EXPECT_EQ(side.failure, GraspFailure::NoGraspableZone) << side.message;
  EXPECT_NE(side.message.find("min_opening_m"), std::string::npos) << side.message;

  const GraspResult facing = BoundaryGraspPlanner().plan(view, lacquey());
  ASSERT_TRUE(facing.ok()) << facing.message;
  const GraspCandidate& best = facing.grasps.front();
  EXPECT_GT(best.approach().dot(-sight), std::cos(60.0 * kDeg));
  EXPECT_LT(closingAngleTo(best, Eigen::Vector3d::UnitY()), 5.0 * kDeg);
  EXPECT_NEAR(best.width_m, 0.04, 0.005);
}
