// planGraspMotion's choice of grasp and of how to reach it (as given, flipped 180 deg about
// the approach axis, tilted about the closing axis), its skip reasons, and buildGraspScene's
// table box and unseen part. Hand-made scenes around the UR5 + Lacquey gripper + wrist Xtion of urdf/.
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/arm/table_grasp_motion.h"

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

// A box seen from the front (-x): its face at x = 0.50 m is all the camera saw; the unseen
// part is the 10 cm shadow behind it (UnseenPartParams::extension_m), while the box itself is
// 6 cm deep. A top-down grasp closing across that depth puts its back finger past the box,
// where the shadow still reaches: the grasp planner's hand check (exact points) allowed that,
// so the arm planner must too, while nothing but the hand may enter the shadow.
/// Points every 5 mm filling the box from `lo` to `hi` (a face when one side is 0).
pcl::PointCloud<pcl::PointXYZ> slab(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
{
  pcl::PointCloud<pcl::PointXYZ> points;
  for (float x = lo.x(); x <= hi.x() + 1e-4f; x += 0.005f)
    for (float y = lo.y(); y <= hi.y() + 1e-4f; y += 0.005f)
      for (float z = lo.z(); z <= hi.z() + 1e-4f; z += 0.005f)
        points.push_back(pcl::PointXYZ(x, y, z));
  return points;
}

TEST(GraspScene, TheHandMayEnterTheUnseenPartTheRestOfTheArmMayNot)
{
  Scene s;
  const pcl::PointCloud<pcl::PointXYZ> face = slab({ 0.50f, -0.03f, 0.01f }, { 0.50f, 0.03f, 0.12f });
  const pcl::PointCloud<pcl::PointXYZ> shadow = slab({ 0.505f, -0.03f, 0.01f }, { 0.60f, 0.03f, 0.12f });
  GraspSceneClouds clouds;
  clouds.object = &face;
  clouds.unseen = &shadow;
  const std::string note = buildGraspScene(s.collision, home(), clouds, s.params);
  EXPECT_NE(note.find(std::to_string(face.size()) + " object points"), std::string::npos) << note;
  EXPECT_NE(note.find(std::to_string(shadow.size()) + " unseen-part points"), std::string::npos) << note;
  EXPECT_EQ(s.collision.obstacleVoxelCount(), 0u) << note;

  // Closing line along x through the box's middle (x = 0.53), fingers 9 cm long centred on
  // z = 0.10: the inner faces at 0.53 -+ 0.065 (open 13 cm), so the back finger spans
  // x = 0.595 .. 0.613, 5 mm inside the shadow; the palm (z > 0.145) is above the box (0.12).
  GraspCandidate across;
  across.pose = makeGraspPose(Eigen::Vector3d(0.53, 0.0, 0.10), Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, 0));
  GraspExecutionParams as_given_only = s.params;
  as_given_only.try_flipped_grasp = false;
  as_given_only.max_approach_tilt_deg = 0.0;
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { across }, as_given_only);
  ASSERT_TRUE(r.success) << reasons(r);
  // At the grasp the fingers are in the shadow: a contact only the final approach allows.
  const Eigen::VectorXd& at_grasp = r.points[r.grasp_point_index].positions;
  std::string why;
  EXPECT_TRUE(s.collision.inCollision(at_grasp, CollisionCheckOptions(), &why));
  EXPECT_NE(why.find("target / "), std::string::npos) << why;
  EXPECT_NE(why.find("finger_link"), std::string::npos) << why;
  CollisionCheckOptions final_approach;
  final_approach.allow_finger_target_contact = true;
  EXPECT_FALSE(s.collision.inCollision(at_grasp, final_approach, &why)) << why;

  // The shadow as the bench under a side grasp (TheFlippedHandIsUsedWhenOnlyItFits...): the
  // wrist camera hanging below the hand may not enter it, even in the final approach.
  Scene bench;
  const pcl::PointCloud<pcl::PointXYZ> target = slab({ 0.49f, -0.01f, 0.24f }, { 0.51f, 0.01f, 0.26f });
  const pcl::PointCloud<pcl::PointXYZ> hidden = slab({ 0.30f, -0.20f, 0.10f }, { 0.62f, 0.20f, 0.18f });
  GraspSceneClouds bench_clouds;
  bench_clouds.object = &target;
  bench_clouds.unseen = &hidden;
  buildGraspScene(bench.collision, home(), bench_clouds, bench.params);
  const GraspPlanResult blocked = planGraspMotion(bench.collision, home(), { sideGraspAboveBench() }, as_given_only);
  ASSERT_FALSE(blocked.success) << reasons(blocked);
  ASSERT_EQ(blocked.skipped_reasons.size(), 1u);
  EXPECT_NE(blocked.skipped_reasons[0].find("target / xtion_link"), std::string::npos) << blocked.skipped_reasons[0];
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

// ---- planTableGraspMotion: the arm's scene holds every object but the one grasped -----------
namespace
{

/// A solid block 4 cm along x, 12 cm along y (the closing line of the grasps below) and 5 cm
/// high standing on z = 0 at (x, y): with 1 cm voxels and the 5 mm padding its sides reach the
/// open fingers (inner faces 6.5 cm from the centre, urdf/), so only as the grasped object,
/// which the fingers may touch, does it not block its own grasp.
void addBlock(pcl::PointCloud<pcl::PointXYZ>& cloud, float x, float y)
{
  for (float dx = -0.02f; dx <= 0.02f; dx += 0.005f)
    for (float dy = -0.06f; dy <= 0.0601f; dy += 0.005f)
      for (float z = 0.01f; z <= 0.06f; z += 0.005f)
        cloud.push_back(pcl::PointXYZ(x + dx, y + dy, z));
}

/// Top grasp over the block at (x, y), fingertips 8 mm above the table (as in
/// TheTableIsABoxTopAtItsPlaneNotVoxelsAboveIt), closing along y, across the block's 12 cm.
GraspCandidate topGraspAt(double x, double y, double padding)
{
  GraspCandidate g;
  g.pose = makeGraspPose(Eigen::Vector3d(x, y, 0.045 + 0.008 + padding), Eigen::Vector3d(0, 0, -1),
                         Eigen::Vector3d(0, 1, 0));
  return g;
}

struct TwoBlocks
{
  // The target block (label 0) at y = -0.2, block 1 at y = 0, a table around both.
  pcl::PointCloud<pcl::PointXYZ> table, target, block, scene;
  pcl::PointCloud<pcl::PointXYZL> objects;
  TableSceneClouds clouds;
  TwoBlocks()
  {
    for (float x = 0.2f; x <= 0.8f; x += 0.01f)
      for (float y = -0.4f; y <= 0.3f; y += 0.01f)
        if (std::abs(x - 0.5f) > 0.03f || (std::abs(y) > 0.07f && std::abs(y + 0.2f) > 0.07f))
          table.push_back(pcl::PointXYZ(x, y, 0.0f));
    addBlock(target, 0.5f, -0.2f);
    addBlock(block, 0.5f, 0.0f);
    scene = table;  // TableSegmentation's ~scene: everything but the target
    scene += block;
    for (const auto& [cloud, label] : { std::make_pair(&target, 0u), std::make_pair(&block, 1u) })
      for (const auto& p : cloud->points)
      {
        pcl::PointXYZL q;
        q.x = p.x;
        q.y = p.y;
        q.z = p.z;
        q.label = label;
        objects.push_back(q);
      }
    clouds.scene = &scene;
    clouds.objects = &objects;
    clouds.table_plane = Eigen::Vector4f(0.0f, 0.0f, 1.0f, 0.0f);
  }
};

TEST(TableGraspMotion, TheSceneForAnObjectIsEverythingButThatObject)
{
  const TwoBlocks t;
  const ObjectSceneClouds for_block = sceneForObject(t.clouds, 1);
  EXPECT_EQ(for_block.object.size(), t.block.size());
  EXPECT_EQ(for_block.scene.size(), t.table.size() + t.target.size());  // the block left, the target came in
  EXPECT_TRUE(for_block.unseen.empty());                                // no camera given
  const ObjectSceneClouds for_target = sceneForObject(t.clouds, 0);
  EXPECT_EQ(for_target.object.size(), t.target.size());
  EXPECT_EQ(for_target.scene.size(), t.table.size() + 2 * t.block.size());  // ~scene's copy and the label's
  // A camera above the table: the hidden space under each block's top joins the scene.
  TableSceneClouds seen = t.clouds;
  seen.sensor_origins = { Eigen::Vector3f(0.2f, 0.0f, 0.8f) };
  const ObjectSceneClouds shadowed = sceneForObject(seen, 1);
  EXPECT_FALSE(shadowed.unseen.empty());
  EXPECT_GT(shadowed.scene.size(), for_block.scene.size());
}

TEST(TableGraspMotion, AGraspOnANeighbourPlansOnlyWithoutThatNeighbourInTheScene)
{
  Scene s;
  const TwoBlocks t;
  const GraspCandidate on_block = topGraspAt(0.5, 0.0, s.params.link_padding_m);
  const GraspCandidate on_target = topGraspAt(0.5, -0.2, s.params.link_padding_m);
  GraspExecutionParams as_given_only = s.params;
  as_given_only.try_flipped_grasp = false;
  as_given_only.max_approach_tilt_deg = 0.0;

  // The single-target scene keeps block 1 as an obstacle: its grasp cannot be planned.
  GraspSceneClouds target_only;
  target_only.scene = &t.scene;
  target_only.object = &t.target;
  target_only.table_plane = t.clouds.table_plane;
  buildGraspScene(s.collision, home(), target_only, s.params);
  const GraspPlanResult blocked = planGraspMotion(s.collision, home(), { on_block }, as_given_only);
  ASSERT_FALSE(blocked.success);
  EXPECT_NE(reasons(blocked).find("octomap"), std::string::npos) << reasons(blocked);

  // Grasping block 1, block 1 leaves the scene and the target joins it: the grasp into the
  // target fails, the one on block 1 plans (index into the whole list).
  const TableGraspPlanResult r = planTableGraspMotion(s.collision, home(), { on_target, on_block }, { 1, 1 }, t.clouds,
                                                      as_given_only);
  ASSERT_TRUE(r.ok()) << r.plan.status;
  EXPECT_EQ(r.object_id, 1);
  EXPECT_EQ(r.plan.grasp_index, 1);
  ASSERT_EQ(r.plan.skipped_reasons.size(), 1u) << reasons(r.plan);
  EXPECT_EQ(r.plan.skipped_reasons[0].rfind("object 1, grasp 0:", 0), 0u) << r.plan.skipped_reasons[0];
  EXPECT_LT((s.endPose(r.plan).translation() - on_block.position()).norm(), 1e-3);

  // Objects in the order the list names them: block 1 first (its only grasp is into the
  // target), then the target's own grasp.
  const TableGraspPlanResult next = planTableGraspMotion(s.collision, home(), { on_target, on_target }, { 1, 0 },
                                                         t.clouds, as_given_only);
  ASSERT_TRUE(next.ok()) << next.plan.status;
  EXPECT_EQ(next.object_id, 0);
  EXPECT_EQ(next.plan.grasp_index, 1);
  ASSERT_EQ(next.objects_tried.size(), 2u);
  EXPECT_EQ(next.objects_tried[0].rfind("object 1:", 0), 0u) << next.objects_tried[0];
  EXPECT_NE(next.plan.status.find("object 0"), std::string::npos) << next.plan.status;

  // Bad input: a status, no plan.
  const TableGraspPlanResult mismatched = planTableGraspMotion(s.collision, home(), { on_block }, {}, t.clouds, s.params);
  EXPECT_FALSE(mismatched.ok());
  EXPECT_NE(mismatched.plan.status.find("differ"), std::string::npos) << mismatched.plan.status;
  TableSceneClouds no_objects = t.clouds;
  no_objects.objects = nullptr;
  const TableGraspPlanResult none = planTableGraspMotion(s.collision, home(), { on_block }, { 1 }, no_objects, s.params);
  EXPECT_FALSE(none.ok());
  EXPECT_EQ(none.object_id, -1);
}
}  // namespace
