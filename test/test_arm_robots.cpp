// The robot configs beyond the UR5 (config/robots/*.yaml): FK of each URDF against its DH
// table (computed here from the DH convention, independently of the URDF), IK round trips,
// a known self-collision, and a solved shelf scene per arm.
#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/arm/grasp_execution.h"

#include <ompl/util/RandomNumbers.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace
{
using namespace fast_grasp;
const double kPi = 3.14159265358979323846;
std::string sourcePath(const std::string& relative) { return std::string(FAST_GRASP_SOURCE_DIR) + "/" + relative; }

GraspExecutionParams robotParams(const std::string& robot)
{
  return loadGraspExecutionParams(sourcePath("config/arm.yaml"), sourcePath("config/planners.yaml"), robot);
}

struct Dh
{
  double d, a, alpha;
};

/// Standard DH: T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
Eigen::Isometry3d dhForward(const std::vector<Dh>& table, const Eigen::VectorXd& q)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < table.size(); ++i)
  {
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    step.rotate(Eigen::AngleAxisd(q[static_cast<Eigen::Index>(i)], Eigen::Vector3d::UnitZ()));
    step.translate(Eigen::Vector3d(table[i].a, 0.0, table[i].d));
    step.rotate(Eigen::AngleAxisd(table[i].alpha, Eigen::Vector3d::UnitX()));
    t = t * step;
  }
  return t;
}

// KUKA LWR 4+ (urdf/lwr4_gripper_xtion.urdf's header).
const std::vector<Dh> kLwr4 = { { 0.31, 0, kPi / 2 }, { 0, 0, -kPi / 2 }, { 0.40, 0, -kPi / 2 }, { 0, 0, kPi / 2 },
                                { 0.39, 0, kPi / 2 }, { 0, 0, -kPi / 2 }, { 0.078, 0, 0 } };

TEST(Lwr4, ForwardKinematicsMatchesDh)
{
  const GraspExecutionParams p = robotParams("lwr4");
  const ArmKinematics flange = ArmKinematics::fromUrdfFile(p.urdf_path, "base_link", "tool0");
  ASSERT_EQ(flange.dof(), 7u);
  std::vector<Eigen::VectorXd> qs;
  qs.push_back(Eigen::VectorXd::Zero(7));
  Eigen::VectorXd q(7);
  q << 0.3, -0.7, 1.1, 1.5, -0.4, 0.9, 2.0;
  qs.push_back(q);
  q << -2.0, 1.9, -2.5, -1.2, 2.7, -1.8, -0.6;
  qs.push_back(q);
  for (const Eigen::VectorXd& qi : qs)
  {
    const Eigen::Isometry3d urdf = flange.fk(qi), dh = dhForward(kLwr4, qi);
    EXPECT_LT((urdf.translation() - dh.translation()).norm(), 1e-9) << qi.transpose();
    EXPECT_LT((urdf.linear() - dh.linear()).norm(), 1e-9) << qi.transpose();
  }
  // Stretched up: the flange 0.31 + 0.40 + 0.39 + 0.078 = 1.178 m above the base (the
  // appendix's "furthest reach 1178.5 mm").
  EXPECT_NEAR(flange.fk(Eigen::VectorXd::Zero(7)).translation().z(), 1.178, 1e-9);
  // Limits from the robot config: +-170 / +-120 deg.
  ArmKinematics kin = flange;
  ASSERT_TRUE(applyLimits(p, kin).empty());
  EXPECT_NEAR(kin.upperLimits()[0], 170.0 * kPi / 180.0, 1e-6);
  EXPECT_NEAR(kin.upperLimits()[1], 120.0 * kPi / 180.0, 1e-6);
}

TEST(Lwr4, IkRoundTripsStayNearTheSeed)
{
  const RobotCollision collision = makeRobotCollision(robotParams("lwr4"));
  const ArmKinematics& kin = collision.kinematics();
  std::mt19937 rng(7);
  int solved = 0;
  for (int i = 0; i < 50; ++i)
  {
    const Eigen::VectorXd q = kin.randomConfiguration(rng);
    const Eigen::Isometry3d target = kin.fk(q);
    // Seed near the answer: a redundant arm has a family of solutions; the solver returns
    // the one its damped least-squares steps reach from the seed (closest to the seed first).
    Eigen::VectorXd seed = q;
    for (Eigen::Index j = 0; j < seed.size(); ++j)
      seed[j] += 0.05 * ((j % 2) ? 1.0 : -1.0);
    kin.wrapIntoLimits(seed);
    seed = seed.cwiseMax(kin.lowerLimits()).cwiseMin(kin.upperLimits());
    const std::vector<Eigen::VectorXd> sols = kin.ik(target, seed);
    if (sols.empty())
      continue;
    ++solved;
    const Eigen::Isometry3d reached = kin.fk(sols.front());
    EXPECT_LT((reached.translation() - target.translation()).norm(), 1e-4);
    EXPECT_LT(Eigen::AngleAxisd(reached.linear().transpose() * target.linear()).angle(), 1e-4);
    EXPECT_TRUE(kin.withinLimits(sols.front(), 1e-9));
    EXPECT_LT((sols.front() - seed).cwiseAbs().maxCoeff(), 0.5);  // the nearby branch, not another
  }
  EXPECT_GE(solved, 49);
}

TEST(Lwr4, FoldedWristHitsTheUpperArm)
{
  const RobotCollision collision = makeRobotCollision(robotParams("lwr4"));
  Eigen::VectorXd folded(7);
  // Forearm 120 deg down-forward (A4 about +y), wrist 120 deg further (A6 about -y): the
  // hand comes back onto the upper arm, 0.4 m above the shoulder.
  folded << 0.0, 0.0, 0.0, 2.09, 0.0, -2.09, 0.0;
  std::string why;
  EXPECT_TRUE(collision.inSelfCollision(folded, &why));
  EXPECT_EQ(why.rfind("self:", 0), 0u) << why;
  EXPECT_FALSE(collision.inSelfCollision(Eigen::VectorXd::Zero(7), &why)) << why;
  const GraspExecutionParams p = robotParams("lwr4");
  EXPECT_FALSE(collision.inSelfCollision(p.robot.homePose(collision.kinematics().jointNames()), &why)) << why;
}

TEST(Lwr4, ShelfPickIsSolved)
{
  ompl::RNG::setSeed(11);
  const GraspExecutionParams p = robotParams("lwr4");
  RobotCollision collision = makeRobotCollision(p);
  ArmScene scene = loadArmScene(sourcePath("config/benchmarks/shelf_pick.yaml"));
  const Eigen::VectorXd home = p.robot.homePose(collision.kinematics().jointNames());
  scene.start_joints = home;  // the scene's joint vectors are the UR5's
  scene.seed_joints = home;
  addSceneBoxes(scene, collision);
  const ArmMotionPlanner planner(collision);
  MotionPlanningParams motion = p.motion;
  Eigen::VectorXd start;
  std::vector<Eigen::VectorXd> goals;
  std::string why;
  ASSERT_TRUE(resolveScene(scene, planner, motion, start, goals, &why)) << why;
  const MotionPlanResult plan = planner.plan(start, goals, motion);
  ASSERT_TRUE(plan.ok()) << plan.message;
  const Eigen::Isometry3d reached = collision.kinematics().fk(plan.path.back());
  EXPECT_LT((reached.translation() - scene.goal_pose.translation()).norm(), 1e-3);
  // Every state along the path (0.01 rad steps) is clear of the unpadded robot: the planner
  // validates with padded links and bounded Cartesian steps (max_cartesian_step_m).
  GraspExecutionParams unpadded = p;
  unpadded.link_padding_m = 0.0;
  RobotCollision exact = makeRobotCollision(unpadded);
  addSceneBoxes(scene, exact);
  for (std::size_t k = 1; k < plan.path.size(); ++k)
  {
    const Eigen::VectorXd& a = plan.path[k - 1];
    const Eigen::VectorXd& b = plan.path[k];
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).cwiseAbs().maxCoeff() / 0.01)));
    for (int s = 0; s <= steps; ++s)
      EXPECT_FALSE(exact.inCollision(a + (b - a) * (static_cast<double>(s) / steps)));
  }
}

TEST(RobotConfig, Ur5ConfigKeepsTheUr5Values)
{
  const GraspExecutionParams p = robotParams("");
  EXPECT_EQ(p.robot.name, "ur5");
  EXPECT_EQ(p.robot.joints.size(), 6u);
  EXPECT_NEAR(p.joint_upper_rad[2], kPi, 1e-9);
  EXPECT_NEAR(p.link_padding_m, 0.005, 1e-12);
  EXPECT_NEAR(p.robot.home_pose_rad.at("shoulder_lift_joint"), -1.5708, 1e-9);
  EXPECT_THROW(robotParams("no_such_robot"), std::runtime_error);
}

}  // namespace
