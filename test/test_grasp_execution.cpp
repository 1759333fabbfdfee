// planGraspMotion's choice of grasp and of how to reach it (as given, flipped 180 deg about
// the approach axis, tilted about the closing axis), its skip reasons, and buildGraspScene's
// table box. Hand-made scenes around the UR5 + Lacquey gripper + wrist Xtion of urdf/.
#include "fast_grasp/arm/grasp_execution.h"

#include <gtest/gtest.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <cmath>
#include <random>

namespace
{
using namespace fast_grasp;
constexpr double kPi = 3.14159265358979323846;
const bool kQuietOmpl = (ompl::msg::setLogLevel(ompl::msg::LOG_WARN), true);
// One OMPL seed for every run: the planners sample the same states each time, so a plan that
// passes here passes on every machine (unseeded, a time-bounded random search may fail one run in many).
const bool kSeededOmpl = (ompl::RNG::setSeed(20261202), true);

std::string sourcePath(const std::string& relative) { return std::string(FAST_GRASP_SOURCE_DIR) + "/" + relative; }

Eigen::VectorXd home()
{
  Eigen::VectorXd q(6);
  q << kPi / 2, -kPi / 2, kPi / 2, -kPi / 2, -kPi / 2, 0.0;
  return q;
}

std::string reasons(const GraspPlanResult& r)
{
  std::string text = r.status;
  for (const auto& s : r.skipped_reasons)
    text += "\n  " + s;
  return text;
}

double angleBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b)
{
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

struct Scene
{
  GraspExecutionParams params;
  RobotCollision collision;
  Scene()
    : params(loadGraspExecutionParams(sourcePath("config/arm.yaml"), sourcePath("config/planners.yaml")))
    , collision(ArmKinematics::fromUrdfFile(sourcePath("urdf/ur5_gripper_xtion.urdf")), params.link_padding_m)
  {
    collision.resetScene(params.octomap_resolution_m);
  }
  /// Box from its lower and upper corners (base_link).
  void addBox(const std::string& name, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
  {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = 0.5 * (lo + hi);
    collision.addBox(name, hi - lo, pose);
  }
  Eigen::Isometry3d endPose(const GraspPlanResult& r) const
  {
    return collision.kinematics().fk(r.points[r.grasp_point_index].positions);
  }
};

// A side grasp 0.25 m up, approach +x, closing +y: the grasp frame's Z points up, so the
// wrist camera (6 cm off the approach axis on the -Z side, urdf/) hangs below the hand, into
// a bench whose top is at 0.18 m. Fingers and palm (3.5 cm half height) clear the bench.
GraspCandidate sideGraspAboveBench()
{
  GraspCandidate grasp;
  grasp.pose = makeGraspPose(Eigen::Vector3d(0.5, 0.0, 0.25), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
  return grasp;
}

TEST(GraspVariants, TheFlippedHandIsUsedWhenOnlyItFitsAndTheStatusSaysSo)
{
  Scene s;
  s.addBox("bench", Eigen::Vector3d(0.3, -0.4, 0.0), Eigen::Vector3d(0.8, 0.4, 0.18));
  const GraspCandidate grasp = sideGraspAboveBench();
  ASSERT_GT(grasp.axis().z(), 0.99);  // camera side down, as the scene intends

  // Without variants: every IK solution has the camera in the bench, and the reason says the
  // hand itself (not the arm) is the problem.
  GraspExecutionParams as_given_only = s.params;
  as_given_only.try_flipped_grasp = false;
  as_given_only.max_approach_tilt_deg = 0.0;
  const GraspPlanResult blocked = planGraspMotion(s.collision, home(), { grasp }, as_given_only);
  ASSERT_FALSE(blocked.success) << reasons(blocked);
  ASSERT_EQ(blocked.skipped_reasons.size(), 1u);
  EXPECT_NE(blocked.skipped_reasons[0].find("xtion_link"), std::string::npos) << blocked.skipped_reasons[0];
  EXPECT_NE(blocked.skipped_reasons[0].find("whatever the arm does"), std::string::npos) << blocked.skipped_reasons[0];

  const GraspPlanResult r = planGraspMotion(s.collision, home(), { grasp }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_EQ(r.grasp_index, 0);  // still the planner's grasp 0
  EXPECT_TRUE(r.flipped);
  EXPECT_EQ(r.tilt_rad, 0.0);
  EXPECT_NE(r.status.find("flipped"), std::string::npos) << r.status;
  EXPECT_NE(r.variant.find("flipped"), std::string::npos) << r.variant;
  // The trajectory ends at the flipped pose: same centre, approach and closing line, closing
  // direction and Z reversed (the camera now above).
  const Eigen::Isometry3d end = s.endPose(r);
  EXPECT_LT((end.translation() - grasp.position()).norm(), 1e-3);
  EXPECT_GT(end.linear().col(0).dot(grasp.approach()), 0.9999);
  EXPECT_LT(end.linear().col(1).dot(grasp.binormal()), -0.9999);
  EXPECT_LT(angleBetween(end.linear(), r.executed_pose.linear()), 0.01);
  EXPECT_LT((end.translation() - r.executed_pose.translation()).norm(), 1e-3);
}

TEST(GraspVariants, AGraspThatWorksAsGivenIsNotVaried)
{
  Scene s;
  GraspCandidate grasp = sideGraspAboveBench();
  grasp.pose = makeGraspPose(grasp.position(), grasp.approach(), -grasp.binormal());  // camera up
  s.addBox("bench", Eigen::Vector3d(0.3, -0.4, 0.0), Eigen::Vector3d(0.8, 0.4, 0.18));
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { grasp }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_FALSE(r.flipped);
  EXPECT_EQ(r.tilt_rad, 0.0);
  EXPECT_TRUE(r.variant.empty()) << r.variant;
  EXPECT_LT(angleBetween(s.endPose(r).linear(), grasp.pose.linear()), 0.01);
}

TEST(GraspVariants, ALowSideGraspIsTiltedDownAboutItsClosingLine)
{
  Scene s;
  // Horizontal approach, horizontal closing line, camera side up. A ledge just behind the
  // object reaches 3 cm above the palm's underside (the palm spans 4.5-11.5 cm behind the
  // centre): neither the grasp as given nor the flipped hand (camera then below) clears it;
  // tilting the approach down about the closing line lifts everything behind the centre.
  GraspCandidate grasp;
  grasp.pose = makeGraspPose(Eigen::Vector3d(0.5, 0.0, 0.3), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0));
  s.addBox("ledge", Eigen::Vector3d(0.36, -0.2, 0.0), Eigen::Vector3d(0.43, 0.2, 0.27));
  GraspExecutionParams no_tilt = s.params;
  no_tilt.max_approach_tilt_deg = 0.0;
  const GraspPlanResult blocked = planGraspMotion(s.collision, home(), { grasp }, no_tilt);
  ASSERT_FALSE(blocked.success) << reasons(blocked);

  const GraspPlanResult r = planGraspMotion(s.collision, home(), { grasp }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_EQ(r.grasp_index, 0);
  EXPECT_NE(r.tilt_rad, 0.0);
  EXPECT_LE(std::abs(r.tilt_rad), s.params.max_approach_tilt_deg * kPi / 180.0 + 1e-9);
  EXPECT_NE(r.status.find("tilted"), std::string::npos) << r.status;
  // Same centre and closing line; the approach now points down.
  const Eigen::Isometry3d end = s.endPose(r);
  EXPECT_LT((end.translation() - grasp.position()).norm(), 1e-3);
  EXPECT_GT(std::abs(end.linear().col(1).dot(grasp.binormal())), 0.9999);
  EXPECT_LT(end.linear().col(0).z(), -0.1);
  EXPECT_LT(angleBetween(end.linear(), r.executed_pose.linear()), 0.01);
}

TEST(GraspVariants, AnUnreachableGraspIsSkippedWithItsReasonAndTheNextIsUsedAsGiven)
{
  Scene s;
  GraspCandidate far;
  far.pose = makeGraspPose(Eigen::Vector3d(2.0, 0.0, 0.3), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  GraspCandidate top;
  top.pose = makeGraspPose(Eigen::Vector3d(0.45, 0.1, 0.2), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { far, top }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_EQ(r.grasp_index, 1);
  EXPECT_TRUE(r.variant.empty()) << r.variant;  // grasp 1 as given beats any variant of grasp 0
  ASSERT_EQ(r.skipped_reasons.size(), 1u);
  EXPECT_EQ(r.skipped_reasons[0], "grasp 0: unreachable (no IK solution)");
  EXPECT_LT(angleBetween(s.endPose(r).linear(), top.pose.linear()), 0.01);
}

TEST(GraspVariants, NoVariantEitherGivesOneReasonLinePerGraspAndRepeatsNone)
{
  Scene s;
  GraspCandidate far;
  far.pose = makeGraspPose(Eigen::Vector3d(2.0, 0.0, 0.3), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { far, far }, s.params);
  ASSERT_FALSE(r.success);
  ASSERT_EQ(r.skipped_reasons.size(), 2u) << reasons(r);
  EXPECT_EQ(r.skipped_reasons[0].rfind("grasp 0: unreachable (no IK solution); flipped/tilted variants:", 0), 0u)
      << r.skipped_reasons[0];
  EXPECT_EQ(r.skipped_reasons[1], "grasp 1: as grasp 0");  // the same reason is not spelled out twice
  EXPECT_NE(r.status.find("no grasp reachable"), std::string::npos) << r.status;
}

TEST(GraspScene, TheTableIsABoxTopAtItsPlaneNotVoxelsAboveIt)
{
  Scene s;
  // A table at z = 0 seen with up to 7 mm of noise, a cube on it, and a grasp whose padded
  // fingertips end 8 mm above the table: voxelised, the noise (a voxel up to 1 cm) would reach
  // them; as a box it must not.
  pcl::PointCloud<pcl::PointXYZ> scene, object;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.004f, 0.007f);
  for (float x = 0.2f; x <= 0.8f; x += 0.005f)
    for (float y = -0.3f; y <= 0.3f; y += 0.005f)
      if (std::abs(x - 0.5f) > 0.03f || std::abs(y) > 0.03f)
        scene.push_back(pcl::PointXYZ(x, y, noise(rng)));
  for (float x = 0.48f; x <= 0.52f; x += 0.005f)
    for (float y = -0.02f; y <= 0.02f; y += 0.005f)
      for (float z = 0.01f; z <= 0.06f; z += 0.005f)
        object.push_back(pcl::PointXYZ(x, y, z));
  GraspSceneClouds clouds;
  clouds.scene = &scene;
  clouds.object = &object;
  clouds.table_plane = Eigen::Vector4f(0.0f, 0.0f, 1.0f, 0.0f);
  const std::string note = buildGraspScene(s.collision, home(), clouds, s.params);
  EXPECT_NE(note.find("table points as a"), std::string::npos) << note;
  EXPECT_EQ(s.collision.obstacleVoxelCount(), 0u) << note;
  EXPECT_GT(s.collision.targetVoxelCount(), 0u);

  // Top grasp; the finger boxes reach 4.5 cm past the grasp centre (urdf: 9 cm long, centred).
  GraspCandidate low;
  low.pose = makeGraspPose(Eigen::Vector3d(0.5, 0.0, 0.045 + 0.008 + s.params.link_padding_m),
                           Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, 1, 0));
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { low }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_TRUE(r.variant.empty()) << r.variant;

  // Fingertips 6 mm above the table, the fused planner's gripper_fit/table_clearance_m for its
  // own candidates (config/grasp_planners.yaml): 1 mm beyond the links' padding still plans.
  GraspCandidate lowest = low;
  lowest.pose.translation().z() = 0.045 + 0.006;
  const GraspPlanResult at_clearance = planGraspMotion(s.collision, home(), { lowest }, s.params);
  EXPECT_TRUE(at_clearance.success) << reasons(at_clearance);

  // The table still blocks: fingertips 5 mm into it.
  GraspCandidate into = low;
  into.pose.translation().z() = 0.045 - 0.005;
  GraspExecutionParams as_given_only = s.params;
  as_given_only.try_flipped_grasp = false;
  as_given_only.max_approach_tilt_deg = 0.0;
  const GraspPlanResult blocked = planGraspMotion(s.collision, home(), { into }, as_given_only);
  ASSERT_FALSE(blocked.success);
  EXPECT_NE(blocked.skipped_reasons[0].find("box table"), std::string::npos) << reasons(blocked);
}

TEST(GraspScene, WithoutAPlaneEveryScenePointIsAnObstacle)
{
  Scene s;
  pcl::PointCloud<pcl::PointXYZ> scene;
  for (float x = 0.4f; x <= 0.6f; x += 0.01f)
    scene.push_back(pcl::PointXYZ(x, 0.0f, 0.0f));
  GraspSceneClouds clouds;
  clouds.scene = &scene;
  const std::string note = buildGraspScene(s.collision, home(), clouds, s.params);
  EXPECT_EQ(note.find("table"), std::string::npos) << note;
  EXPECT_GT(s.collision.obstacleVoxelCount(), 0u);
}

TEST(GraspVariants, ConfigReadsTheVariantParameters)
{
  const GraspExecutionParams p = loadGraspExecutionParams(sourcePath("config/arm.yaml"));
  EXPECT_TRUE(p.try_flipped_grasp);
  EXPECT_GT(p.max_approach_tilt_deg, 0.0);
  EXPECT_LE(p.max_approach_tilt_deg, 30.0);
  EXPECT_GT(p.approach_tilt_step_deg, 0.0);
  EXPECT_GT(p.table_thickness_m, 0.0);
}

}  // namespace
