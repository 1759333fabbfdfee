// FCL collision of the UR5 model: self, table, OctoMap obstacles, self filter, finger/target rule.
#include "fast_grasp/arm/robot_collision.h"
#include "fast_grasp/arm/sphere_aabb.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>

namespace
{
using fast_grasp::ArmKinematics;
using fast_grasp::CollisionCheckOptions;
using fast_grasp::RobotCollision;
constexpr double kPi = 3.14159265358979323846;

ArmKinematics ur5()
{
  return ArmKinematics::fromUrdfFile(std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/ur5_gripper_xtion.urdf");
}

Eigen::VectorXd joints(double a, double b, double c, double d, double e, double f)
{
  Eigen::VectorXd q(6);
  q << a, b, c, d, e, f;
  return q;
}

/// Points filling an axis-aligned box on a grid (spacing 1 cm).
pcl::PointCloud<pcl::PointXYZ> boxCloud(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double step = 0.01)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (double x = lo.x(); x <= hi.x() + 1e-9; x += step)
    for (double y = lo.y(); y <= hi.y() + 1e-9; y += step)
      for (double z = lo.z(); z <= hi.z() + 1e-9; z += step)
        cloud.push_back(pcl::PointXYZ(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  return cloud;
}

const Eigen::VectorXd kHome = joints(0.0, -kPi / 2, kPi / 2, -kPi / 2, -kPi / 2, 0.0);

TEST(RobotCollision, ReadsTheUrdfShapes)
{
  const RobotCollision collision(ur5());
  EXPECT_GE(collision.shapes().size(), 12u);
  EXPECT_EQ(collision.skippedMeshes(), 0u);
  int fingers = 0;
  for (const auto& s : collision.shapes())
    fingers += s.finger ? 1 : 0;
  EXPECT_EQ(fingers, 2);
  // Unpadded, no non-adjacent pair touches at the zero pose; padded by 1 cm only the base
  // and the shoulder-lift motor (1.5 cm apart by design) do, and they are then not checked.
  EXPECT_TRUE(collision.defaultAllowedPairs().empty());
  const RobotCollision padded(ur5(), 0.01);  // more than the 0.005 default
  ASSERT_EQ(padded.defaultAllowedPairs().size(), 1u);
  EXPECT_EQ(padded.defaultAllowedPairs()[0], "base_link / upper_arm_link");
  // Lever arms: the pan joint reaches the stretched arm's fingertips, a2 + a3 + d6 + 0.16 m
  // of gripper ~ 1.06 m (plus shape radii); each later joint reaches less.
  const Eigen::VectorXd& lever = collision.jointLeverArms();
  ASSERT_EQ(lever.size(), 6);
  EXPECT_GT(lever[0], 1.0);
  EXPECT_LT(lever[0], 1.5);
  for (int j = 1; j < 6; ++j)
    EXPECT_LE(lever[j], lever[j - 1] + 1e-9);
  EXPECT_GT(lever[5], 0.16);  // wrist 3 still carries the fingertips
}

TEST(RobotCollision, FreePosesAreFree)
{
  const RobotCollision collision(ur5());
  std::string why;
  EXPECT_FALSE(collision.inCollision(kHome, CollisionCheckOptions(), &why)) << why;
  EXPECT_FALSE(collision.inCollision(joints(0, -kPi / 2, 0, -kPi / 2, 0, 0), CollisionCheckOptions(), &why)) << why;
  EXPECT_FALSE(collision.inCollision(joints(0, 0, 0, 0, 0, 0), CollisionCheckOptions(), &why)) << why;
}

TEST(RobotCollision, SelfCollisionIsCaught)
{
  const RobotCollision collision(ur5());
  // Elbow folded back (3.1 rad): the wrist lands on the shoulder / upper-arm motor.
  std::string why;
  EXPECT_TRUE(collision.inSelfCollision(joints(0, -kPi / 2, 3.1, 0, 0, 0), &why));
  EXPECT_NE(why.find("self"), std::string::npos) << why;
  // Bad joint vectors are collisions, not crashes.
  EXPECT_TRUE(collision.inCollision(Eigen::VectorXd::Zero(3)));
  EXPECT_TRUE(collision.inCollision(joints(std::nan(""), 0, 0, 0, 0, 0)));
}

TEST(RobotCollision, TableCollisionIsCaught)
{
  RobotCollision collision(ur5());
  Eigen::Isometry3d table = Eigen::Isometry3d::Identity();
  table.translation() << 0.0, 0.0, -0.05;  // top face at z = 0, where the base stands
  collision.addBox("table", Eigen::Vector3d(2.0, 2.0, 0.1), table);
  std::string why;
  EXPECT_FALSE(collision.inCollision(kHome, CollisionCheckOptions(), &why)) << why;
  // Arm stretched 0.5 rad below horizontal: the hand is ~0.4 m under the table top.
  EXPECT_TRUE(collision.inCollision(joints(0, 0.5, 0, 0, 0, 0), CollisionCheckOptions(), &why));
  EXPECT_NE(why.find("table"), std::string::npos) << why;
}

TEST(RobotCollision, OctomapBoxBlocksAPathThroughIt)
{
  RobotCollision collision(ur5());
  ASSERT_TRUE(collision.resetScene(0.02));
  const ArmKinematics& kin = collision.kinematics();
  // Path: the pan joint sweeps the stretched arm (grasp frame ~1 m out) from -1 to +1 rad.
  const Eigen::VectorXd from = joints(-1.0, 0.0, 0.0, 0.0, 0.0, 0.0), to = joints(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  // A 10 cm box of points right on the sweep at pan = 0.
  const Eigen::Vector3d hand = kin.fk(joints(0, 0, 0, 0, 0, 0)).translation();
  const Eigen::Vector3d half(0.05, 0.05, 0.05);
  const std::size_t inserted = collision.addObstacleCloud(boxCloud(hand - half, hand + half), from);
  EXPECT_GT(inserted, 1000u);
  EXPECT_GT(collision.obstacleVoxelCount(), 0u);
  std::string why;
  EXPECT_FALSE(collision.inCollision(from, CollisionCheckOptions(), &why)) << why;
  EXPECT_FALSE(collision.inCollision(to, CollisionCheckOptions(), &why)) << why;
  bool blocked = false;
  for (int i = 0; i <= 200 && !blocked; ++i)
    blocked = collision.inCollision(from + (to - from) * (i / 200.0), CollisionCheckOptions(), &why);
  EXPECT_TRUE(blocked);
  EXPECT_NE(why.find("octomap"), std::string::npos) << why;
}

TEST(RobotCollision, PointsOnTheArmAreFilteredOut)
{
  RobotCollision collision(ur5());
  ASSERT_TRUE(collision.resetScene(0.01));
  const ArmKinematics& kin = collision.kinematics();
  // A cloud of the arm itself (points on the grasp frame axis inside the palm and wrist)
  // plus a far box: only the box survives, and the arm is not its own obstacle.
  pcl::PointCloud<pcl::PointXYZ> cloud;
  const Eigen::Isometry3d tool = kin.fk(kHome);
  for (double s = -0.15; s <= -0.06; s += 0.005)
  {
    const Eigen::Vector3d p = tool * Eigen::Vector3d(s, 0, 0);
    cloud.push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  const std::size_t arm_points = cloud.size();
  const pcl::PointCloud<pcl::PointXYZ> far = boxCloud(Eigen::Vector3d(-0.9, -0.9, 0.0), Eigen::Vector3d(-0.8, -0.8, 0.1));
  cloud += far;
  const std::size_t inserted = collision.addObstacleCloud(cloud, kHome);
  EXPECT_EQ(inserted, far.size());
  EXPECT_LT(inserted, far.size() + arm_points);
  std::string why;
  EXPECT_FALSE(collision.inCollision(kHome, CollisionCheckOptions(), &why)) << why;
}

TEST(RobotCollision, OnlyFingersMayTouchTheTargetDuringApproach)
{
  RobotCollision collision(ur5());
  ASSERT_TRUE(collision.resetScene(0.01));
  std::vector<Eigen::Isometry3d> poses;
  collision.shapePoses(kHome, poses);
  std::size_t finger = 0, palm = 0;
  for (std::size_t i = 0; i < collision.shapes().size(); ++i)
  {
    if (collision.shapes()[i].link == "left_finger_link")
      finger = i;
    if (collision.shapes()[i].link == "gripper_palm_link")
      palm = i;
  }
  auto cloudAt = [](const Eigen::Vector3d& c) {
    return boxCloud(c - Eigen::Vector3d::Constant(0.005), c + Eigen::Vector3d::Constant(0.005), 0.005);
  };
  CollisionCheckOptions approach;
  approach.allow_finger_target_contact = true;
  collision.setTargetCloud(cloudAt(poses[finger].translation()));
  EXPECT_TRUE(collision.inCollision(kHome));
  std::string why;
  EXPECT_FALSE(collision.inCollision(kHome, approach, &why)) << why;
  collision.setTargetCloud(cloudAt(poses[palm].translation()));
  EXPECT_TRUE(collision.inCollision(kHome, approach, &why));
  EXPECT_NE(why.find("target"), std::string::npos) << why;
  // An empty target is no obstacle.
  collision.setTargetCloud(pcl::PointCloud<pcl::PointXYZ>());
  EXPECT_FALSE(collision.inCollision(kHome));
}

/// Lowest z of a box shape placed at `pose` (its corners' extreme along world z).
double lowestZ(const fast_grasp::RobotShape& shape, const Eigen::Isometry3d& pose)
{
  double reach = 0.0;
  for (int k = 0; k < 3; ++k)
    reach += 0.5 * shape.size_m[k] * std::abs(pose.linear()(2, k));
  return pose.translation().z() - reach;
}

TEST(RobotCollision, FingersArePaddedByTheirOwnPadding)
{
  // Links padded 5 mm, fingers 2 mm: a table 3 mm under the fingertips (the hand points down
  // at home) blocks the hand only when the fingers carry the links' 5 mm.
  const RobotCollision uniform(ur5(), 0.005);
  const RobotCollision fingers_tight(ur5(), 0.005, { "left_finger_link", "right_finger_link" }, 0.002);
  std::vector<Eigen::Isometry3d> poses;
  uniform.shapePoses(kHome, poses);
  double tips = std::numeric_limits<double>::infinity();
  std::size_t palm = uniform.shapes().size();
  for (std::size_t i = 0; i < uniform.shapes().size(); ++i)
  {
    const auto& s = uniform.shapes()[i];
    if (s.finger)
    {
      ASSERT_EQ(s.type, fast_grasp::RobotShape::Type::Box);
      tips = std::min(tips, lowestZ(s, poses[i]));
    }
    if (s.link == "gripper_palm_link")
      palm = i;
  }
  ASSERT_TRUE(std::isfinite(tips));
  ASSERT_LT(palm, uniform.shapes().size());
  // A table top 30 cm square under the hand (the rest of the arm is elsewhere)
  const Eigen::Vector3d hand = poses[palm].translation();
  const auto withTableAt = [&hand](RobotCollision collision, double top_z) {
    Eigen::Isometry3d table = Eigen::Isometry3d::Identity();
    table.translation() << hand.x(), hand.y(), top_z - 0.05;
    collision.addBox("table", Eigen::Vector3d(0.3, 0.3, 0.1), table);
    return collision;
  };
  std::string why;
  EXPECT_TRUE(withTableAt(uniform, tips - 0.003).inCollision(kHome, CollisionCheckOptions(), &why));
  EXPECT_NE(why.find("finger"), std::string::npos) << why;
  EXPECT_FALSE(withTableAt(fingers_tight, tips - 0.003).inCollision(kHome, CollisionCheckOptions(), &why)) << why;
  EXPECT_TRUE(withTableAt(fingers_tight, tips - 0.001).inCollision(kHome));
  // The palm is no finger here: 3 mm under it is still a collision (a thin board across the
  // hand between the fingers, which hang lower and would otherwise hit it first).
  RobotCollision board = fingers_tight;
  const double palm_bottom = lowestZ(uniform.shapes()[palm], poses[palm]);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = poses[palm].translation();
  pose.translation().z() = palm_bottom - 0.003 - 0.001;
  board.addBox("board", Eigen::Vector3d(0.02, 0.02, 0.002), pose);
  EXPECT_TRUE(board.inCollision(kHome, CollisionCheckOptions(), &why));
  EXPECT_NE(why.find("gripper_palm_link"), std::string::npos) << why;
}

}  // namespace

namespace
{
/// A scene with every obstacle kind: axis-aligned and rotated boxes (the narrow-passage slot, a
/// tilted board), an OctoMap block and a target.
RobotCollision clutteredScene(const RobotCollision& robot)
{
  RobotCollision collision = robot;
  collision.resetScene(0.02);
  auto box = [&](const std::string& name, const Eigen::Vector3d& size, const Eigen::Vector3d& centre,
                 const Eigen::AngleAxisd& rotation) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = centre;
    pose.linear() = rotation.toRotationMatrix();
    collision.addBox(name, size, pose);
  };
  const Eigen::AngleAxisd level(0.0, Eigen::Vector3d::UnitZ());
  box("table", Eigen::Vector3d(1.6, 1.6, 0.1), Eigen::Vector3d(0.3, 0.0, -0.05), level);
  box("left_wall", Eigen::Vector3d(0.3, 0.1, 0.4), Eigen::Vector3d(0.55, 0.19, 0.2), level);
  box("right_wall", Eigen::Vector3d(0.3, 0.1, 0.4), Eigen::Vector3d(0.55, -0.19, 0.2), level);
  box("roof", Eigen::Vector3d(0.3, 0.48, 0.06), Eigen::Vector3d(0.55, 0.0, 0.43), level);
  box("tilted_board", Eigen::Vector3d(0.4, 0.3, 0.02), Eigen::Vector3d(-0.3, 0.4, 0.5),
      Eigen::AngleAxisd(0.6, Eigen::Vector3d(1.0, 1.0, 0.3).normalized()));
  collision.addObstacleCloud(boxCloud(Eigen::Vector3d(-0.5, -0.5, 0.1), Eigen::Vector3d(-0.35, -0.3, 0.3), 0.02),
                             Eigen::VectorXd());
  collision.setTargetCloud(boxCloud(Eigen::Vector3d(0.5, -0.03, 0.0), Eigen::Vector3d(0.56, 0.03, 0.15), 0.01));
  return collision;
}
}  // namespace

// The culling tests in front of FCL (bounding spheres and boxes, separating axes) may only
// skip pairs that are apart; the culled check must answer like FCL alone, also next to contacts.
TEST(RobotCollision, CulledCheckAgreesWithFclAlone)
{
  const RobotCollision robot(ur5(), 0.005);
  const RobotCollision scene = clutteredScene(robot);
  CollisionCheckOptions culled, fcl_only;
  fcl_only.conservative_culling = false;
  std::mt19937 rng(7);
  const ArmKinematics& kin = robot.kinematics();
  std::vector<Eigen::VectorXd> free_states, colliding_states;
  int disagreements = 0;
  std::string first_disagreement;
  auto compare = [&](const RobotCollision& collision, const Eigen::VectorXd& q) {
    std::string why_culled, why_fcl;
    const bool hit_culled = collision.inCollision(q, culled, &why_culled);
    const bool hit_fcl = collision.inCollision(q, fcl_only, &why_fcl);
    if (hit_culled != hit_fcl && disagreements++ == 0)
    {
      std::ostringstream out;
      out << "q = " << q.transpose() << ": culled says " << (hit_culled ? why_culled : "free") << ", FCL alone "
          << (hit_fcl ? why_fcl : "free");
      first_disagreement = out.str();
    }
    return hit_fcl;
  };
  for (int i = 0; i < 20000; ++i)
  {
    const Eigen::VectorXd q = kin.randomConfiguration(rng);
    (compare(scene, q) ? colliding_states : free_states).push_back(q);
    compare(robot, q);  // empty scene: self-collision alone
  }
  EXPECT_EQ(disagreements, 0) << first_disagreement;
  ASSERT_GT(free_states.size(), 1000u);
  ASSERT_GT(colliding_states.size(), 1000u);
  // Near contacts, where culling could go wrong: bisect free -> colliding segments down to a
  // step of 1e-6 rad (about a micrometre at the hand) and compare on both sides.
  int near_contact = 0;
  for (std::size_t k = 0; k < 1000; ++k)
  {
    Eigen::VectorXd a = free_states[k % free_states.size()], b = colliding_states[k % colliding_states.size()];
    while ((b - a).cwiseAbs().maxCoeff() > 1e-6)
    {
      const Eigen::VectorXd mid = 0.5 * (a + b);
      (compare(scene, mid) ? b : a) = mid;
    }
    compare(scene, a);
    compare(scene, b);
    ++near_contact;
  }
  EXPECT_EQ(near_contact, 1000);
  EXPECT_EQ(disagreements, 0) << first_disagreement;
  // inSelfCollision culls too.
  for (int i = 0; i < 2000; ++i)
  {
    const Eigen::VectorXd q = kin.randomConfiguration(rng);
    EXPECT_EQ(robot.inSelfCollision(q), robot.inCollision(q, fcl_only)) << q.transpose();
  }
}

TEST(SphereAabb, MaskGivesTheOneBoxVerdicts)
{
  // sphereAabbMasks must answer sphereMayTouchAabb for every box, bit for bit: random boxes and
  // spheres, and spheres exactly touching a face, an edge or a corner (radius squared equal to
  // the squared gap), inside a box, of radius 0; 70 boxes, so masks of several calls and a
  // last group with padding lanes.
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0), size(0.0, 0.5);
  std::vector<Eigen::Vector3d> lo, hi;
  for (int k = 0; k < 70; ++k)
  {
    const Eigen::Vector3d a(coordinate(rng), coordinate(rng), coordinate(rng));
    lo.push_back(a);
    hi.push_back(a + Eigen::Vector3d(size(rng), size(rng), size(rng)));
  }
  hi[5] = lo[5];  // a degenerate (point) box
  fast_grasp::AabbLanes lanes;
  lanes.assign(lo, hi);
  ASSERT_EQ(lanes.size(), 70u);
  int reached = 0, missed = 0;
  for (int trial = 0; trial < 20000; ++trial)
  {
    Eigen::Vector3d centre(coordinate(rng), coordinate(rng), coordinate(rng));
    double radius = size(rng);
    const std::size_t near = rng() % 70;
    switch (trial % 5)
    {
      case 1:  // on a face, edge or corner of a box, radius 0
        for (int axis = 0; axis < 3; ++axis)
          if (rng() % 2)
            centre[axis] = rng() % 2 ? lo[near][axis] : hi[near][axis];
        radius = 0.0;
        break;
      case 2:  // exactly touching a box: radius squared = the squared gap (below)
        break;
      case 3:  // inside a box
        centre = 0.5 * (lo[near] + hi[near]);
        break;
      default:
        break;
    }
    const double radius2 = trial % 5 == 2 ? [&] {
      Eigen::Vector3d gap;
      for (int axis = 0; axis < 3; ++axis)
        gap[axis] = std::max(0.0, std::max(lo[near][axis] - centre[axis], centre[axis] - hi[near][axis]));
      return (gap.x() * gap.x() + gap.y() * gap.y()) + gap.z() * gap.z();
    }()
                                          : radius * radius;
    // Three spheres per call: this one, one that is no sphere (negative radius squared:
    // mask 0) and this one again.
    const Eigen::Vector3d centres[3] = { centre, centre, centre };
    const double radii2[3] = { radius2, -1.0, radius2 };
    for (std::size_t first = 0; first < 70; first += 64)
    {
      std::uint64_t masks[3] = { 1, 1, 1 }, sse2[3] = { 1, 1, 1 };
      fast_grasp::sphereAabbMasks(lanes, first, 64, centres, radii2, 3, masks);
      fast_grasp::sphereAabbMasks(lanes, first, 64, centres, radii2, 3, sse2, false);
      const std::uint64_t mask = masks[0];
      EXPECT_EQ(masks[1], 0u);
      EXPECT_EQ(masks[2], mask);
      ASSERT_EQ(sse2[0], mask);  // the SSE2 kernel too
      EXPECT_EQ(sse2[1], 0u);
      for (std::size_t k = first; k < 70 && k < first + 64; ++k)
      {
        const bool expected = fast_grasp::sphereMayTouchAabb(centre, radius2, lo[k], hi[k]);
        ASSERT_EQ(((mask >> (k - first)) & 1u) != 0, expected) << "trial " << trial << " box " << k;
        (expected ? reached : missed) += 1;
      }
      // No bits past the boxes.
      if (first + 64 > 70)
        EXPECT_EQ(mask >> (70 - first), 0u);
    }
  }
  EXPECT_GT(reached, 20000);
  EXPECT_GT(missed, 20000);
  // Fewer boxes than asked for, and none at all; the corners read back.
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const double everything = 100.0;
  std::uint64_t mask = 0;
  fast_grasp::sphereAabbMasks(lanes, 68, 64, &origin, &everything, 1, &mask);
  EXPECT_EQ(mask, 3u);
  fast_grasp::sphereAabbMasks(fast_grasp::AabbLanes(), 0, 64, &origin, &everything, 1, &mask);
  EXPECT_EQ(mask, 0u);
  EXPECT_EQ(lanes.lo(69), lo[69]);
  EXPECT_EQ(lanes.hi(42), hi[42]);
}
