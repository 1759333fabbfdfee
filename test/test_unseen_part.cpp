// Mirror completion of objects lying along the table (unseen_part.h, beyond the thesis).
// Expectations come from the analytic shapes, not from the code.
#include "fast_grasp/grasping/unseen_part.h"

#include "synthetic_views.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fast_grasp
{
namespace
{
using namespace synthetic;

constexpr double kXtionMaxIncidenceRad = 70.0 * M_PI / 180.0;  // xtion_renderer.h
const Eigen::Vector4f kTable(0, 0, 1, 0);

/// Extent of `cloud` along the unit vector `direction`.
double extentAlong(const CloudNormal& cloud, const Eigen::Vector3f& direction)
{
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const auto& p : cloud.points)
  {
    low = std::min(low, static_cast<double>(p.getVector3fMap().dot(direction)));
    high = std::max(high, static_cast<double>(p.getVector3fMap().dot(direction)));
  }
  return high - low;
}
}  // namespace

TEST(MirrorCompletion, ALyingBoxsHiddenFarSideIsItsMirroredNearSide)
{
  // A box 7 cm across (x), 20 cm long (y), 6 cm high lying on the table, seen from above -x:
  // the camera sees its top and its -x side. Mirrored across the vertical plane along its
  // length through the middle of its level top (x = 0), the -x side lands on the hidden +x
  // side; no mirrored point leaves the box by more than 5 mm (the plane and the long axis are
  // estimated from a perspective view's points), and the completed width is the box's 7 cm.
  const Eigen::Vector3d eye(-0.45, 0.05, 0.5);
  const Shape box = makeBox(Eigen::Vector3d(0.0, 0.0, 0.03), Eigen::Vector3d(0.07, 0.2, 0.06));
  const CloudNormal::Ptr seen = renderView(box, ViewParams{ eye });
  const MirrorCompletion completion = completeByMirror(*seen, eye.cast<float>(), kTable);
  ASSERT_TRUE(completion.ok()) << completion.failure;
  ASSERT_GT(completion.mirrored.size(), seen->size() / 2);
  EXPECT_GT(std::abs(completion.along.y()), 0.99f);
  std::size_t on_far_side = 0;
  for (const auto& p : completion.mirrored)
  {
    EXPECT_LT(std::abs(p.x), 0.035f + 0.005f) << p.x << " " << p.y << " " << p.z;
    EXPECT_LT(std::abs(p.y), 0.1f + 0.005f);
    EXPECT_LT(p.z, 0.06f + 0.005f);
    if (std::abs(p.x - 0.035f) < 0.005f && p.z < 0.055f)
      ++on_far_side;
  }
  EXPECT_GT(on_far_side, 100u);
  EXPECT_NEAR(completion.width_m, 0.07, 0.005);
  EXPECT_NEAR(completion.length_m, 0.2, 0.01);
}

TEST(MirrorCompletion, ALyingRoundBodySeenShortOfItsFarSideIsCompletedToItsDiameter)
{
  // A 9.8 cm thick round body 25 cm long lying along y (a bleach bottle's size), seen from
  // 45 deg above -x as a depth camera sees it: the far side turns away from the rays and is
  // lost, so the seen points span less than the diameter across the axis. Its top is level
  // over the axis, so the mirror completes it to the full 9.8 cm.
  const double radius = 0.049;
  const Eigen::Vector3d eye(-0.45, 0.0, radius + 0.45);
  const Shape body = makeCylinder(Eigen::Vector3d(0.0, 0.0, radius), Eigen::Vector3d::UnitY(), radius, 0.25);
  ViewParams depth_camera{ eye };
  depth_camera.max_incidence_rad = kXtionMaxIncidenceRad;
  const CloudNormal::Ptr seen = renderView(body, depth_camera);
  ASSERT_LT(extentAlong(*seen, Eigen::Vector3f::UnitX()), 2.0 * radius - 0.01);  // the premise
  const MirrorCompletion completion = completeByMirror(*seen, eye.cast<float>(), kTable);
  ASSERT_TRUE(completion.ok()) << completion.failure;
  EXPECT_NEAR(completion.width_m, 2.0 * radius, 0.006);
}

TEST(MirrorCompletion, OnlyElongatedFootprintsAndConsistentMirrorsAreCompleted)
{
  const Eigen::Vector3d eye(-0.45, 0.05, 0.5);
  // A cube's footprint is as wide as long: no long axis to mirror across.
  const CloudNormal::Ptr cube = renderView(makeBox(Eigen::Vector3d(0, 0, 0.04), Eigen::Vector3d::Constant(0.08)), ViewParams{ eye });
  EXPECT_EQ(completeByMirror(*cube, eye.cast<float>(), kTable).failure, "footprint not elongated");
  // A long bar with a block as high on its camera side: their level tops put the plane
  // between them, and the mirrored block would stand in the open, where the camera saw the
  // table (outside the silhouette); with no tolerance for that, nothing is mirrored.
  const std::vector<Shape> bar_and_block{ makeBox(Eigen::Vector3d(0.0, 0.0, 0.02), Eigen::Vector3d(0.04, 0.24, 0.04)),
                                          makeBox(Eigen::Vector3d(-0.05, 0.08, 0.02), Eigen::Vector3d(0.06, 0.06, 0.04)) };
  const CloudNormal::Ptr seen = renderView(bar_and_block, ViewParams{ eye });
  MirrorCompletionParams params;
  params.max_free_fraction = 0.0;
  const MirrorCompletion refused = completeByMirror(*seen, eye.cast<float>(), kTable, params);
  EXPECT_FALSE(refused.ok());
  EXPECT_TRUE(refused.mirrored.empty());
  EXPECT_EQ(refused.width_m, 0.0);
  params.max_free_fraction = 1.0;
  EXPECT_TRUE(completeByMirror(*seen, eye.cast<float>(), kTable, params).ok());
}

TEST(MirrorCompletion, AnOpenTraysInsideIsNotATopToMirrorAbout)
{
  // A tray 25 cm long and 12 cm wide: a 1 cm floor and two 4 cm walls along its long sides.
  // Its level part is mostly the floor, in the bottom quarter of its height: it is not a closed
  // body (nor is a pan), and nothing is mirrored.
  const Eigen::Vector3d eye(-0.45, 0.05, 0.5);
  const std::vector<Shape> tray{ makeBox(Eigen::Vector3d(0.0, 0.0, 0.005), Eigen::Vector3d(0.12, 0.25, 0.01)),
                                 makeBox(Eigen::Vector3d(-0.055, 0.0, 0.02), Eigen::Vector3d(0.01, 0.25, 0.04)),
                                 makeBox(Eigen::Vector3d(0.055, 0.0, 0.02), Eigen::Vector3d(0.01, 0.25, 0.04)) };
  const MirrorCompletion completion = completeByMirror(*renderView(tray, ViewParams{ eye }), eye.cast<float>(), kTable);
  EXPECT_EQ(completion.failure, "its level part is not its top (a container's inside, a step)");
  EXPECT_TRUE(completion.mirrored.empty());
}

TEST(MirrorCompletion, BadInputIsAReasonNotACrash)
{
  const Eigen::Vector3d eye(-0.45, 0.05, 0.5);
  const CloudNormal::Ptr seen =
      renderView(makeBox(Eigen::Vector3d(0.0, 0.0, 0.03), Eigen::Vector3d(0.07, 0.2, 0.06)), ViewParams{ eye });
  const float nan = std::numeric_limits<float>::quiet_NaN();
  MirrorCompletionParams params;
  params.max_free_fraction = 1.5;
  EXPECT_FALSE(completeByMirror(*seen, eye.cast<float>(), kTable, params).ok());
  params = MirrorCompletionParams{};
  params.min_elongation = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(completeByMirror(*seen, eye.cast<float>(), kTable, params).ok());
  EXPECT_FALSE(completeByMirror(*seen, eye.cast<float>(), Eigen::Vector4f(0, 0, 0, 0)).ok());
  EXPECT_FALSE(completeByMirror(*seen, eye.cast<float>(), Eigen::Vector4f(nan, 0, 1, 0)).ok());
  EXPECT_FALSE(completeByMirror(*seen, Eigen::Vector3f(nan, 0, 0), kTable).ok());
  EXPECT_FALSE(completeByMirror(CloudNormal{}, eye.cast<float>(), kTable).ok());
  CloudNormal all_nan = *seen;
  for (auto& p : all_nan.points)
    p.x = nan;
  EXPECT_FALSE(completeByMirror(all_nan, eye.cast<float>(), kTable).ok());
}

}  // namespace fast_grasp
