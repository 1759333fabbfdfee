// Concavity planner (thesis Ch5): analytic shapes with hand-derivable answers.
#include "fast_grasp/grasping/concavity_grasp.h"
#include "fast_grasp/core/gripper_model.h"

#include "synthetic_views.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace fast_grasp;

namespace
{
GripperModel robotiq() { return synthetic::robotiqLikeGripper(); }

ObjectView onTable(const CloudNormal::ConstPtr& cloud, const Eigen::Vector3d& camera)
{
  ObjectView view = synthetic::makeObjectView(cloud, camera);
  view.has_table_plane = true;
  view.table_plane = Eigen::Vector4f(0.0f, 0.0f, 1.0f, 0.0f);  // the table is z = 0
  return view;
}

using synthetic::toXyz;

/// Horseshoe (U) block on the table, opening toward +y: two arms of thickness 2 cm along y at
/// x = +-6 cm (inner walls at x = +-5 cm, a 10 cm gap), joined by a base at y = -6 cm; 4 cm high.
std::vector<synthetic::Shape> horseshoe()
{
  return { synthetic::makeBox({ -0.06, 0.0, 0.02 }, { 0.02, 0.10, 0.04 }),
           synthetic::makeBox({ 0.06, 0.0, 0.02 }, { 0.02, 0.10, 0.04 }),
           synthetic::makeBox({ 0.0, -0.06, 0.02 }, { 0.14, 0.02, 0.04 }) };
}
// Above and to the +x side (and behind the base in y): the camera sees the tops, the outer
// wall of the +x arm, the outer wall of the base and the inner wall of the -x arm (facing +x).
const Eigen::Vector3d kHorseshoeCamera(0.3, -0.1, 0.7);
}  // namespace

// --- Step 1: concavity --------------------------------------------------------------------

TEST(Concavity, PointsOnAConvexSurfaceHaveNone)
{
  // A sphere cap and a box seen obliquely: every seen point is on the convex hull.
  for (const auto& shape : { synthetic::makeSphere({ 0.0, 0.0, 0.05 }, 0.05),
                             synthetic::makeBox({ 0.0, 0.0, 0.05 }, { 0.06, 0.12, 0.10 }) })
  {
    synthetic::ViewParams camera;
    camera.viewpoint = Eigen::Vector3d(0.4, 0.1, 0.6);
    const CloudXYZ points = toXyz(*synthetic::renderView(shape, camera));
    ASSERT_GT(points.size(), 500u);
    std::string why;
    const std::vector<float> concavity = concavityBelowConvexHull(points, { camera.viewpoint.cast<float>() }, &why);
    ASSERT_EQ(concavity.size(), points.size());
    EXPECT_TRUE(why.empty()) << why;
    for (const float c : concavity)
      ASSERT_LT(c, 0.001f);
  }
}

TEST(Concavity, VGrooveBottomIsItsDepthBelowTheHull)
{
  // Top of a block, z = 0.05, with a V groove along y: half-width w = 2 cm, depth d = 1.5 cm.
  // Seen from straight above, each groove point lies d (1 - |x| / w) below the lid z = 0.05
  // the hull spans across the groove (the rays are vertical to 1e-4 within 2 cm of the axis).
  const double w = 0.02, d = 0.015, top = 0.05;
  CloudXYZ points;
  for (double x = -0.05; x <= 0.05 + 1e-9; x += 0.002)
    for (double y = -0.03; y <= 0.03 + 1e-9; y += 0.002)
      points.push_back(PointXYZ(float(x), float(y), float(top - std::max(0.0, d * (1.0 - std::abs(x) / w)))));
  const Eigen::Vector3f camera(0.0f, 0.0f, 1.0f);
  const std::vector<float> concavity = concavityBelowConvexHull(points, { camera });
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const double x = points[i].x, y = points[i].y;
    const double expected = std::max(0.0, d * (1.0 - std::abs(x) / w));
    // The ray to (x, y) is tilted by atan(|(x, y)| / 0.95): depth / cos(tilt) along it.
    const double along_ray = expected * std::sqrt(1.0 + (x * x + y * y) / std::pow(1.0 - top + expected, 2));
    EXPECT_NEAR(concavity[i], along_ray, 2e-4) << "at x " << x << " y " << y;
  }
}

TEST(Concavity, CupBottomSeenFromAboveIsTheCupDepth)
{
  // A cup seen from straight above: the rim annulus at z = 0.10 (radii 3.5-4 cm) and the inner
  // bottom disc at z = 0.02 (radius < 3.5 cm). The hull's lid is the rim plane, so the inner
  // bottom lies 8 cm below it along the (near vertical) rays; the rim is on the hull.
  CloudXYZ points;
  const double rim = 0.10, bottom = 0.02, inner = 0.035, outer = 0.04;
  for (double x = -outer; x <= outer + 1e-9; x += 0.002)
    for (double y = -outer; y <= outer + 1e-9; y += 0.002)
    {
      const double r = std::hypot(x, y);
      if (r <= outer && r >= inner)
        points.push_back(PointXYZ(float(x), float(y), float(rim)));
      else if (r < inner - 0.002)
        points.push_back(PointXYZ(float(x), float(y), float(bottom)));
    }
  const Eigen::Vector3f camera(0.0f, 0.0f, 0.8f);
  const std::vector<float> concavity = concavityBelowConvexHull(points, { camera });
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const double r = std::hypot(points[i].x, points[i].y);
    if (points[i].z > 0.05f)
      EXPECT_LT(concavity[i], 1e-4f);
    else
    {
      // depth 0.08 along a ray tilted by atan(r / 0.78).
      const double along_ray = (rim - bottom) * std::sqrt(1.0 + r * r / std::pow(0.8 - bottom, 2));
      EXPECT_NEAR(concavity[i], along_ray, 2e-4) << "at r " << r;
    }
  }
}

TEST(Concavity, FlatOrTinyInputHasNoneAndSaysWhy)
{
  CloudXYZ flat;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      flat.push_back(PointXYZ(0.01f * i, 0.01f * j, 0.3f));
  std::string why;
  const std::vector<float> concavity = concavityBelowConvexHull(flat, { Eigen::Vector3f(0, 0, 1) }, &why);
  ASSERT_EQ(concavity.size(), flat.size());
  EXPECT_FALSE(why.empty());
  for (const float c : concavity)
    EXPECT_EQ(c, 0.0f);
  CloudXYZ three;
  three.push_back(PointXYZ(0, 0, 0));
  three.push_back(PointXYZ(1, 0, 0));
  three.push_back(PointXYZ(0, 1, 0));
  EXPECT_EQ(concavityBelowConvexHull(three, { Eigen::Vector3f(0, 0, 1) }, &why).size(), 3u);
  EXPECT_FALSE(why.empty());
}

// --- Step 5: step points (Eqs. 5.2-5.3) ---------------------------------------------------

TEST(StepPoints, StraightBoundaryIsSteppedEveryR)
{
  // 10 cm of boundary sampled every mm; r = 1 cm; stop when the rest is within 2.2 cm (hand
  // width): step points at 0, 1, ..., 8 cm (at 8 cm the rest reaches 2 cm < 2.2 cm).
  std::vector<Eigen::Vector2f> chain;
  for (int i = 0; i <= 100; ++i)
    chain.emplace_back(0.001f * i, 0.0f);
  std::vector<std::size_t> segments;
  const std::vector<Eigen::Vector2f> steps = boundaryStepPoints(chain, 0.01, 0.022, &segments);
  ASSERT_EQ(steps.size(), 9u);
  ASSERT_EQ(segments.size(), steps.size());
  for (std::size_t k = 0; k < steps.size(); ++k)
  {
    EXPECT_NEAR(steps[k].x(), 0.01 * k, 1e-5);
    EXPECT_NEAR(steps[k].y(), 0.0, 1e-7);
  }
}

TEST(StepPoints, CircleCrossingsAreExactlyRApart)
{
  // Boundary on a circle of radius 5 cm, coarse (5 degree chords): each step point lies on the
  // chain at straight-line distance r = 1.3 cm from the previous one (Eq. 5.3 solved exactly).
  std::vector<Eigen::Vector2f> chain;
  for (int k = 0; k <= 72; ++k)
    chain.emplace_back(0.05f * std::cos(k * 5.0 * M_PI / 180.0), 0.05f * std::sin(k * 5.0 * M_PI / 180.0));
  const std::vector<Eigen::Vector2f> steps = boundaryStepPoints(chain, 0.013, 0.022);
  ASSERT_GT(steps.size(), 10u);
  for (std::size_t k = 1; k < steps.size(); ++k)
  {
    EXPECT_NEAR((steps[k] - steps[k - 1]).norm(), 0.013, 1e-5);
    EXPECT_NEAR(steps[k].norm(), 0.05, 0.05 * (1.0 - std::cos(2.5 * M_PI / 180.0)) + 1e-6);  // on a chord
  }
  EXPECT_TRUE(boundaryStepPoints({}, 0.01, 0.02).empty());
  EXPECT_EQ(boundaryStepPoints(chain, 0.0, 0.02).size(), 0u);
}

// --- The planner --------------------------------------------------------------------------

TEST(ConcavityPlanner, HorseshoeIsGraspedAcrossOneArmFromItsInnerWall)
{
  synthetic::ViewParams camera;
  camera.viewpoint = kHorseshoeCamera;
  const CloudNormal::Ptr cloud = synthetic::renderView(horseshoe(), camera);
  ASSERT_GT(cloud->size(), 1000u);
  const ConcavityGraspPlanner planner;
  const GraspResult result = planner.plan(onTable(cloud, camera.viewpoint), robotiq());
  ASSERT_TRUE(result.ok()) << toString(result.failure) << ": " << result.message;
  EXPECT_NE(result.message.find("salient concave region"), std::string::npos) << result.message;
  // The salient concavity is the inside of the U: the seen inner wall of the -x arm (x = -5 cm).
  ASSERT_GT(result.graspable_zone.size(), 10u);
  for (const auto& p : result.graspable_zone)
  {
    EXPECT_NEAR(p.x, -0.05, 0.006);
    EXPECT_LT(p.z, 0.04f);
  }
  // The grasp closes across that arm (along x), from above, with the arm's thickness between
  // the fingers.
  const GraspCandidate& best = result.grasps.front();
  EXPECT_NEAR(best.width_m, 0.02, 0.005);
  EXPECT_GT(std::abs(best.binormal().x()), 0.95) << best.binormal().transpose();
  EXPECT_NEAR(best.position().x(), -0.06, 0.006);
  EXPECT_LT(best.approach().z(), -0.9);
  EXPECT_LT(best.force_balance_rad, 0.15);
  EXPECT_EQ(best.algorithm, "concavity");
  EXPECT_FALSE(result.hull.empty());
  EXPECT_FALSE(result.candidates.empty());
  for (std::size_t i = 1; i < result.grasps.size(); ++i)
    EXPECT_GE(result.grasps[i - 1].score, result.grasps[i].score);
}

TEST(ConcavityPlanner, SameInputSameResult)
{
  synthetic::ViewParams camera;
  camera.viewpoint = kHorseshoeCamera;
  const ObjectView view = onTable(synthetic::renderView(horseshoe(), camera), camera.viewpoint);
  const ConcavityGraspPlanner planner;
  const GraspResult a = planner.plan(view, robotiq());
  const GraspResult b = planner.plan(view, robotiq());
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  ASSERT_EQ(a.message, b.message);
  for (std::size_t i = 0; i < a.grasps.size(); ++i)
  {
    EXPECT_TRUE(a.grasps[i].pose.isApprox(b.grasps[i].pose, 0.0)) << i;
    EXPECT_EQ(a.grasps[i].score, b.grasps[i].score);
    EXPECT_EQ(a.grasps[i].width_m, b.grasps[i].width_m);
  }
}

TEST(ConcavityPlanner, ConvexBoxIsGraspedAcrossItsNarrowSideAsOneRegion)
{
  // 12 x 5 x 10 cm box on the table, seen obliquely from its symmetry plane y = 0: no
  // concavity; the only extent within the 8.5 cm opening is the 5 cm side (along y), whose two
  // faces are parallel (force balance 0). (Seen from off that plane one of the two faces is
  // hidden, and the unseen part behind its silhouette rightly keeps the far finger out.)
  synthetic::ViewParams camera;
  camera.viewpoint = Eigen::Vector3d(0.4, 0.0, 0.6);
  const CloudNormal::Ptr cloud = synthetic::renderView(synthetic::makeBox({ 0.0, 0.0, 0.05 }, { 0.12, 0.05, 0.10 }), camera);
  const GraspResult result = ConcavityGraspPlanner().plan(onTable(cloud, camera.viewpoint), robotiq());
  ASSERT_TRUE(result.ok()) << toString(result.failure) << ": " << result.message;
  EXPECT_NE(result.message.find("no salient concavity"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("whole object"), std::string::npos) << result.message;
  EXPECT_TRUE(result.graspable_zone.empty());
  for (const GraspCandidate& grasp : result.grasps)
  {
    EXPECT_NEAR(grasp.width_m, 0.05, 0.005);
    EXPECT_GT(std::abs(grasp.binormal().y()), 0.95) << grasp.binormal().transpose();
    EXPECT_LE(grasp.force_balance_rad, ConcavityParams().force_balance_max_rad);
    // From the seen side.
    EXPECT_GT(grasp.approach().dot(grasp.position() - camera.viewpoint), 0.0);
  }
  // The best has parallel sides (the rest include slices near the box's ends and corners,
  // where the down-sampled extremes scatter by a voxel).
  EXPECT_LT(result.grasps.front().force_balance_rad, 0.05) << result.message;
}

TEST(ConcavityPlanner, ObjectWiderThanTheOpeningIsNoGraspableZone)
{
  synthetic::ViewParams camera;
  camera.viewpoint = Eigen::Vector3d(0.4, 0.1, 0.6);
  const CloudNormal::Ptr cloud = synthetic::renderView(synthetic::makeBox({ 0.0, 0.0, 0.075 }, { 0.2, 0.2, 0.15 }), camera);
  const GraspResult result = ConcavityGraspPlanner().plan(onTable(cloud, camera.viewpoint), robotiq());
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(result.failure, GraspFailure::NoGraspableZone) << result.message;
  EXPECT_TRUE(result.grasps.empty());
  EXPECT_NE(result.message.find("opening"), std::string::npos) << result.message;
}

TEST(ConcavityPlanner, BadInputsGiveTypedFailures)
{
  const ConcavityGraspPlanner planner;
  const GripperModel gripper = robotiq();
  const Eigen::Vector3d camera(0.0, 0.0, 1.0);
  ObjectView null_view;
  EXPECT_EQ(planner.plan(null_view, gripper).failure, GraspFailure::EmptyInput);

  CloudNormal::Ptr empty(new CloudNormal);
  EXPECT_EQ(planner.plan(synthetic::makeObjectView(empty, camera), gripper).failure, GraspFailure::EmptyInput);

  CloudNormal::Ptr nans(new CloudNormal);
  PointNormal nan_point;
  nan_point.x = nan_point.y = nan_point.z = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 100; ++i)
    nans->push_back(nan_point);
  EXPECT_EQ(planner.plan(synthetic::makeObjectView(nans, camera), gripper).failure, GraspFailure::EmptyInput);

  for (int count = 1; count <= 3; ++count)
  {
    CloudNormal::Ptr few(new CloudNormal);
    for (int i = 0; i < count; ++i)
    {
      PointNormal p;
      p.x = 0.01f * i;
      p.y = 0.02f * (i % 2);
      p.z = 0.1f;
      few->push_back(p);
    }
    const GraspResult result = planner.plan(synthetic::makeObjectView(few, camera), gripper);
    EXPECT_EQ(result.failure, GraspFailure::DegenerateInput) << count << " points: " << result.message;
    EXPECT_FALSE(result.message.empty());
  }

  CloudNormal::Ptr line(new CloudNormal);
  for (int i = 0; i < 200; ++i)
  {
    PointNormal p;
    p.x = 0.001f * i;
    p.y = 0.0005f * i;
    p.z = 0.1f;
    line->push_back(p);
  }
  EXPECT_EQ(planner.plan(synthetic::makeObjectView(line, camera), gripper).failure, GraspFailure::DegenerateInput);

  synthetic::ViewParams view_params;
  view_params.viewpoint = kHorseshoeCamera;
  ObjectView no_sensor = synthetic::makeObjectView(synthetic::renderView(horseshoe(), view_params), kHorseshoeCamera);
  no_sensor.sensor_origins.clear();
  EXPECT_EQ(planner.plan(no_sensor, gripper).failure, GraspFailure::DegenerateInput);

  ConcavityParams bad;
  bad.step_m = 0.0;
  EXPECT_EQ(ConcavityGraspPlanner(bad).plan(no_sensor, gripper).failure, GraspFailure::InvalidParameters);
}
