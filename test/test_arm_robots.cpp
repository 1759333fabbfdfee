// The robot configs beyond the UR5 (config/robots/*.yaml): FK of each URDF against its DH
// table (computed here from the DH convention, independently of the URDF), IK round trips,
// a known self-collision, and a solved shelf scene per arm.
#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/arm/joint_nearest_neighbors.h"
#include "fast_grasp/arm/robot_config.h"
#include "fast_grasp/arm/trajectory_timing.h"

#include <ompl/util/RandomNumbers.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/base/ScopedState.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
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
  double theta_sign = 1.0, theta_offset = 0.0;  // theta_i = sign * q_i + offset
};

/// Standard DH: T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
Eigen::Isometry3d dhForward(const std::vector<Dh>& table, const Eigen::VectorXd& q)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < table.size(); ++i)
  {
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    const double theta = table[i].theta_sign * q[static_cast<Eigen::Index>(i)] + table[i].theta_offset;
    step.rotate(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()));
    step.translate(Eigen::Vector3d(table[i].a, 0.0, table[i].d));
    step.rotate(Eigen::AngleAxisd(table[i].alpha, Eigen::Vector3d::UnitX()));
    t = t * step;
  }
  return t;
}

std::vector<Eigen::VectorXd> jointVectors(const std::vector<std::vector<double>>& rows)
{
  std::vector<Eigen::VectorXd> out;
  for (const std::vector<double>& r : rows)
    out.push_back(Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size())));
  return out;
}

/// False when the IK found nothing; else checks that its first solution reaches `target`
/// within the limits.
bool expectReaches(const ArmKinematics& kin, const Eigen::Isometry3d& target, const std::vector<Eigen::VectorXd>& sols)
{
  if (sols.empty())
    return false;
  const Eigen::Isometry3d reached = kin.fk(sols.front());
  EXPECT_LT((reached.translation() - target.translation()).norm(), 1e-4);
  EXPECT_LT(Eigen::AngleAxisd(reached.linear().transpose() * target.linear()).angle(), 1e-4);
  EXPECT_TRUE(kin.withinLimits(sols.front(), 1e-9));
  return true;
}

/// The URDF chain's FK equals the DH table's at each q; the table takes q + dh_offset (the
/// arm maker's joint angles where the URDF's zero differs).
void expectMatchesDh(const ArmKinematics& chain, const std::vector<Dh>& table, const std::vector<Eigen::VectorXd>& qs,
                     const Eigen::VectorXd& dh_offset)
{
  for (const Eigen::VectorXd& qi : qs)
  {
    const Eigen::Isometry3d urdf = chain.fk(qi), dh = dhForward(table, qi + dh_offset);
    EXPECT_LT((urdf.translation() - dh.translation()).norm(), 1e-9) << qi.transpose();
    EXPECT_LT((urdf.linear() - dh.linear()).norm(), 1e-9) << qi.transpose();
  }
}

// KUKA LWR 4+ (urdf/lwr4_gripper_xtion.urdf's header).
const std::vector<Dh> kLwr4 = { { 0.3105, 0, kPi / 2 }, { 0, 0, -kPi / 2 }, { 0.40, 0, -kPi / 2 }, { 0, 0, kPi / 2 },
                                { 0.39, 0, kPi / 2 }, { 0, 0, -kPi / 2 }, { 0.078, 0, 0 } };

TEST(Lwr4, ForwardKinematicsMatchesDh)
{
  const GraspExecutionParams p = robotParams("lwr4");
  const ArmKinematics flange = ArmKinematics::fromUrdfFile(p.urdf_path, "base_link", "tool0");
  ASSERT_EQ(flange.dof(), 7u);
  const std::vector<Eigen::VectorXd> qs = jointVectors(
      { { 0, 0, 0, 0, 0, 0, 0 }, { 0.3, -0.7, 1.1, 1.5, -0.4, 0.9, 2.0 }, { -2.0, 1.9, -2.5, -1.2, 2.7, -1.8, -0.6 } });
  expectMatchesDh(flange, kLwr4, qs, Eigen::VectorXd::Zero(7));
  // Stretched up: the flange 0.3105 + 0.40 + 0.39 + 0.078 = 1.1785 m above the base (the
  // appendix's "furthest reach 1178.5 mm").
  EXPECT_NEAR(flange.fk(Eigen::VectorXd::Zero(7)).translation().z(), 1.1785, 1e-9);
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
    if (!expectReaches(kin, target, sols))
      continue;
    ++solved;
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

/// The shelf pick (config/benchmarks/shelf_pick.yaml) from the robot's home pose: solved, ending
/// at the goal pose, every state along the path clear of the unpadded robot.
void expectShelfPickSolved(const std::string& robot)
{
  ompl::RNG::setSeed(11);
  const GraspExecutionParams p = robotParams(robot);
  RobotCollision collision = makeRobotCollision(p);
  // Placed for this robot (benchmark_base_m), from its home pose (the file's joints are the UR5's).
  const ArmScene scene =
      sceneForRobot(loadArmScene(sourcePath("config/benchmarks/shelf_pick.yaml")), p.robot, collision.kinematics().jointNames());
  EXPECT_EQ(scene.start_joints, p.robot.homePose(collision.kinematics().jointNames()));
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


TEST(Lwr4, ShelfPickIsSolved) { expectShelfPickSolved("lwr4"); }

// Kinova JACO (j2n6), Kinova's DH table (urdf/jaco_gripper_xtion.urdf's header), in Kinova's
// joint angles Q = q + (0, pi, pi, 0, 0, 0).
const double kJacoK = std::sin(kPi / 6.0) / std::sin(kPi / 3.0);
const std::vector<Dh> kJaco = { { 0.2755, 0, kPi / 2, -1, 0 },
                                { 0, 0.41, kPi, 1, -kPi / 2 },
                                { -0.0098, 0, kPi / 2, 1, kPi / 2 },
                                { -(0.2073 + kJacoK * 0.0741), 0, kPi / 3, 1, 0 },
                                { -(kJacoK * 0.0741 + kJacoK * 0.0741), 0, kPi / 3, 1, -kPi },
                                { -(kJacoK * 0.0741 + 0.16), 0, kPi, 1, kPi / 2 } };

const Eigen::VectorXd kKinovaAngleOffset = (Eigen::VectorXd(6) << 0.0, kPi, kPi, 0.0, 0.0, 0.0).finished();

TEST(Jaco, ForwardKinematicsMatchesKinovaDh)
{
  const GraspExecutionParams p = robotParams("jaco");
  const ArmKinematics hand = ArmKinematics::fromUrdfFile(p.urdf_path, "base_link", "jaco_end_effector");
  ASSERT_EQ(hand.dof(), 6u);
  const std::vector<Eigen::VectorXd> qs = jointVectors({ { 0, 0, 0, 0, 0, 0 },
                                                         { 0.3, -0.7, 1.1, 1.5, -0.4, 0.9 },
                                                         { -2.0, 1.9, -2.5, -1.2, 2.7, -3.0 },
                                                         { 3.1, 0.2, 0.4, 2.9, 1.6, -1.3 } });
  expectMatchesDh(hand, kJaco, qs, kKinovaAngleOffset);
  // Stretched up (q = 0): the wrist's two 60 deg segments each climb D4 cos 30 deg and step
  // D4 sin 30 deg sideways, so the hand centre is D1 + D2 + D3 + 2 D4 cos 30 + D6 up and
  // 2 D4 sin 30 - e2 off the base axis, pointing up.
  const Eigen::Isometry3d up = hand.fk(Eigen::VectorXd::Zero(6));
  EXPECT_NEAR(up.translation().z(), 0.2755 + 0.41 + 0.2073 + 2 * 0.0741 * std::cos(kPi / 6) + 0.16, 1e-9);
  EXPECT_NEAR(up.translation().y(), 2 * 0.0741 * std::sin(kPi / 6) - 0.0098, 1e-9);
  EXPECT_NEAR(up.translation().x(), 0.0, 1e-9);
  EXPECT_NEAR(up.linear().col(2).z(), 1.0, 1e-9);
  // tool0 (the flange) is D6 = 0.16 m before the hand centre, on the same axis.
  const ArmKinematics flange = ArmKinematics::fromUrdfFile(p.urdf_path, "base_link", "tool0");
  for (const Eigen::VectorXd& qi : qs)
  {
    const Eigen::Isometry3d f = flange.fk(qi), h = hand.fk(qi);
    EXPECT_LT((f.translation() + 0.16 * f.linear().col(2) - h.translation()).norm(), 1e-9);
    EXPECT_LT((f.linear() - h.linear()).norm(), 1e-9);
  }
  // Limits from the robot config: continuous joints +-pi, joint 2 +-130 deg, joint 3 +-145 deg.
  ArmKinematics kin = flange;
  ASSERT_TRUE(applyLimits(p, kin).empty());
  EXPECT_NEAR(kin.upperLimits()[0], kPi, 1e-9);
  EXPECT_NEAR(kin.upperLimits()[1], 130.0 * kPi / 180.0, 1e-6);
  EXPECT_NEAR(kin.lowerLimits()[2], -145.0 * kPi / 180.0, 1e-6);
  EXPECT_NEAR(kin.velocityLimits()[0], 36.0 * kPi / 180.0, 1e-6);
  EXPECT_NEAR(kin.velocityLimits()[5], 48.0 * kPi / 180.0, 1e-6);
}

TEST(Jaco, IkRoundTripsThroughTheOffsetWrist)
{
  // The JACO's wrist axes do not meet in a point: no closed-form wrist decoupling, the
  // numerical solver must handle it. Random reachable poses, seeded at the home pose (far
  // from the answer): every solution reaches the pose, within the limits.
  const GraspExecutionParams p = robotParams("jaco");
  const RobotCollision collision = makeRobotCollision(p);
  const ArmKinematics& kin = collision.kinematics();
  const Eigen::VectorXd home = p.robot.homePose(kin.jointNames());
  std::mt19937 rng(5);
  int solved = 0;
  const int poses = 100;
  for (int i = 0; i < poses; ++i)
  {
    const Eigen::Isometry3d target = kin.fk(kin.randomConfiguration(rng));
    solved += expectReaches(kin, target, kin.ik(target, home)) ? 1 : 0;
  }
  EXPECT_GE(solved, 99);
}

TEST(Jaco, FoldedElbowPutsTheHandOnTheShoulder)
{
  const GraspExecutionParams p = robotParams("jaco");
  const RobotCollision collision = makeRobotCollision(p);
  // Every non-adjacent pair is checked (none touches in the stretched pose).
  EXPECT_TRUE(collision.defaultAllowedPairs().empty());
  Eigen::VectorXd folded(6);
  // Elbow folded to its limit (145 deg) and the forearm turned a quarter turn: the wrist
  // bends the hand back down past the upper arm onto the shoulder.
  folded << 0.0, 0.0, 2.53, 1.57, 1.5, 0.0;
  std::string why;
  EXPECT_TRUE(collision.inSelfCollision(folded, &why));
  EXPECT_EQ(why.rfind("self:", 0), 0u) << why;
  EXPECT_FALSE(collision.inSelfCollision(Eigen::VectorXd::Zero(6), &why)) << why;
  EXPECT_FALSE(collision.inSelfCollision(p.robot.homePose(collision.kinematics().jointNames()), &why)) << why;
}

TEST(Jaco, ShelfPickIsSolved) { expectShelfPickSolved("jaco"); }

TEST(Jaco, ContinuousJointsTurnTheShortWay)
{
  // The URDF declares joints 1, 4, 5, 6 continuous; jaco.yaml gives them a full turn.
  const GraspExecutionParams p = robotParams("jaco");
  const RobotCollision collision = makeRobotCollision(p);
  const ArmKinematics& kin = collision.kinematics();
  const std::vector<bool> continuous = { true, false, false, true, true, true };
  for (std::size_t j = 0; j < 6; ++j)
    EXPECT_EQ(kin.isContinuous(j), continuous[j]) << j;
  // Start and goal 350 deg apart on joint 1 (and 345 deg on joint 6, the start given past
  // +pi): the short way is 10 deg (15 deg) the other way round.
  const double deg = kPi / 180.0;
  Eigen::VectorXd start = p.robot.homePose(kin.jointNames()), goal = start;
  start[0] = -175.0 * deg;
  goal[0] = 175.0 * deg;
  start[5] = 190.0 * deg;
  goal[5] = -155.0 * deg;
  const ArmMotionPlanner planner(collision);
  MotionPlanningParams motion = p.motion;
  motion.planner = "RRTConnect";
  const MotionPlanResult plan = planner.plan(start, { goal }, motion);
  ASSERT_TRUE(plan.ok()) << plan.message;
  EXPECT_LT((plan.path.front() - start).norm(), 1e-12);
  double travel_1 = 0.0, travel_6 = 0.0;
  for (std::size_t k = 0; k < plan.path.size(); ++k)
  {
    const Eigen::VectorXd& q = plan.path[k];
    EXPECT_TRUE(kin.withinLimits(q));
    for (const Eigen::Index j : { 1, 2 })  // the bounded joints stay within their limits
      EXPECT_TRUE(q[j] >= kin.lowerLimits()[j] && q[j] <= kin.upperLimits()[j]) << k;
    if (k == 0)
      continue;
    EXPECT_LT((q - plan.path[k - 1]).cwiseAbs().maxCoeff(), 1.0) << "jump at waypoint " << k;
    travel_1 += std::abs(q[0] - plan.path[k - 1][0]);
    travel_6 += std::abs(q[5] - plan.path[k - 1][5]);
  }
  EXPECT_NEAR(travel_1, 10.0 * deg, 1.0 * deg);
  EXPECT_NEAR(travel_6, 15.0 * deg, 1.0 * deg);
  // The path ends at the goal's pose, at the angles reached the short way (-185, 205 deg).
  EXPECT_NEAR(plan.path.back()[0], -185.0 * deg, 1e-6);
  EXPECT_NEAR(plan.path.back()[5], 205.0 * deg, 1e-6);
  EXPECT_LT((kin.fk(plan.path.back()).matrix() - kin.fk(goal).matrix()).norm(), 1e-6);
  EXPECT_NEAR(plan.path_length_rad, std::hypot(10.0, 15.0) * deg, 0.05);

  // Timing follows the 10 / 15 deg, not a 350 deg swing: at 36 deg/s (48 deg/s on joint 6)
  // and 2 rad/s^2, well under a second; no sample jumps.
  TimingLimits limits;
  limits.velocity_rad_s = p.velocity_limit_rad_s;
  limits.acceleration_rad_s2 = p.acceleration_limit_rad_s2;
  std::vector<TrajectoryPoint> traj;
  std::string why;
  ASSERT_TRUE(timeParameterize(plan.path, limits, traj, &why)) << why;
  EXPECT_LT(traj.back().time_from_start_s, 1.0);
  for (std::size_t i = 1; i < traj.size(); ++i)
    EXPECT_LT((traj[i].positions - traj[i - 1].positions).cwiseAbs().maxCoeff(), 0.05) << i;

  // Sampling near a state moves every joint up to the given distance, as on a flat joint
  // space (OMPL's compound sampler would scale it by each of the five components' weight
  // share: at most 0.1 rad per joint, 0.25 rad in all, for 0.5).
  const auto setup = planner.makeSetup(start, { goal }, motion);
  const ompl::base::StateSpacePtr& space = setup->getStateSpace();
  const ompl::base::StateSamplerPtr sampler = space->allocDefaultStateSampler();
  ompl::base::ScopedState<> near_state(space), sample(space);
  near_state = setup->getProblemDefinition()->getStartState(0);
  double farthest = 0.0;
  for (int i = 0; i < 1000; ++i)
  {
    sampler->sampleUniformNear(sample.get(), near_state.get(), 0.5);
    farthest = std::max(farthest, space->distance(sample.get(), near_state.get()));
  }
  EXPECT_GT(farthest, 0.8);
  EXPECT_LE(farthest, 0.5 * std::sqrt(6.0) + 1e-9);

  // IK agrees: a pose whose joint 6 is past +pi, seeded near it, comes back past +pi (not
  // 2 pi away at -155 deg), and that counts as within the limits.
  const std::vector<Eigen::VectorXd> sols = kin.ik(kin.fk(plan.path.back()), start);
  ASSERT_FALSE(sols.empty());
  EXPECT_NEAR(sols.front()[5], 205.0 * deg, 1e-3);
  EXPECT_NEAR(sols.front()[0], -185.0 * deg, 1e-3);
  EXPECT_TRUE(kin.withinLimits(sols.front()));
}

TEST(Jaco, JointNearestNeighborsFindWhatTheSpaceDistanceFinds)
{
  // RRTConnect's trees (JointNearestNeighbors) must return the states the planner's own
  // state-space distance ranks nearest, continuous joints (the JACO's 1, 4, 5, 6) included:
  // brute force over that distance on random states, with ties impossible in practice.
  const GraspExecutionParams p = robotParams("jaco");
  const RobotCollision collision = makeRobotCollision(p);
  const ArmKinematics& kin = collision.kinematics();
  const ArmMotionPlanner planner(collision);
  const Eigen::VectorXd home = p.robot.homePose(kin.jointNames());
  const auto setup = planner.makeSetup(home, { home }, p.motion);
  const ompl::base::StateSpacePtr& space = setup->getStateSpace();
  const std::size_t dof = kin.dof();
  std::vector<bool> continuous(dof);
  for (std::size_t j = 0; j < dof; ++j)
    continuous[j] = kin.isContinuous(j);
  auto joints_of = [&space, dof](const ompl::base::State* const& s, double* q) {
    for (std::size_t j = 0; j < dof; ++j)
      q[j] = *space->getValueAddressAtIndex(s, static_cast<unsigned>(j));
  };
  JointNearestNeighbors<const ompl::base::State*> nn(continuous, joints_of);
  // The same past 100 elements: those move into GNAT (the planner's distance function).
  JointNearestNeighbors<const ompl::base::State*> handed_over(continuous, joints_of, 100);
  handed_over.setDistanceFunction(
      [&space](const ompl::base::State* const& a, const ompl::base::State* const& b) { return space->distance(a, b); });
  const ompl::base::StateSamplerPtr sampler = space->allocDefaultStateSampler();
  std::vector<ompl::base::State*> states;
  for (int i = 0; i < 500; ++i)
  {
    states.push_back(space->allocState());
    sampler->sampleUniform(states.back());
    nn.add(states.back());
    handed_over.add(states.back());
    EXPECT_EQ(handed_over.usesGnat(), i + 1 >= 100) << i;
  }
  ASSERT_EQ(nn.size(), states.size());
  ASSERT_EQ(handed_over.size(), states.size());
  EXPECT_FALSE(nn.usesGnat());
  ompl::base::State* query = space->allocState();
  int wrapped_wins = 0;  // queries whose nearest state is nearer the short way round
  for (int k = 0; k < 200; ++k)
  {
    sampler->sampleUniform(query);
    std::vector<double> d;
    for (const ompl::base::State* s : states)
      d.push_back(space->distance(query, s));
    const std::size_t best = static_cast<std::size_t>(std::min_element(d.begin(), d.end()) - d.begin());
    EXPECT_EQ(nn.nearest(query), states[best]) << k;
    EXPECT_EQ(handed_over.nearest(query), states[best]) << k;
    std::vector<double> qa(dof), qb(dof);
    joints_of(query, qa.data());
    joints_of(states[best], qb.data());
    EXPECT_DOUBLE_EQ(nn.distance(qa.data(), qb.data()), d[best]);
    double unwrapped = 0.0;
    for (std::size_t j = 0; j < dof; ++j)
      unwrapped += (qa[j] - qb[j]) * (qa[j] - qb[j]);
    wrapped_wins += std::sqrt(unwrapped) > d[best] + 1e-9 ? 1 : 0;
    std::vector<const ompl::base::State*> five;
    nn.nearestK(query, 5, five);
    ASSERT_EQ(five.size(), 5u);
    std::vector<double> sorted = d;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < 5; ++i)
      EXPECT_DOUBLE_EQ(space->distance(query, five[i]), sorted[i]) << k << " " << i;
    std::vector<const ompl::base::State*> within;
    nn.nearestR(query, sorted[9], within);
    EXPECT_EQ(within.size(), 10u);
  }
  EXPECT_GT(wrapped_wins, 0);  // the wrap mattered for some queries
  EXPECT_TRUE(nn.remove(states[3]));
  EXPECT_FALSE(nn.remove(states[3]));
  EXPECT_EQ(nn.size(), states.size() - 1);
  EXPECT_NE(nn.nearest(states[3]), states[3]);
  nn.clear();
  EXPECT_EQ(nn.size(), 0u);
  EXPECT_THROW(nn.nearest(query), ompl::Exception);
  space->freeState(query);
  for (ompl::base::State* s : states)
    space->freeState(s);
}

TEST(RobotConfig, BodyFramesPlaceLinksAndShapesLikeTheChainWalk)
{
  // Collision checking places its shapes from the body frames (one product per moving joint);
  // they must land where the segment-by-segment walk (linkPoses) puts their links.
  for (const std::string robot : { "ur5", "lwr4", "jaco" })
  {
    const RobotCollision collision = makeRobotCollision(robotParams(robot));
    const ArmKinematics& kin = collision.kinematics();
    std::mt19937 rng(11);
    std::vector<Eigen::Isometry3d> links, bodies, shapes;
    for (int n = 0; n < 100; ++n)
    {
      const Eigen::VectorXd q = kin.randomConfiguration(rng);
      kin.linkPoses(q, links);
      kin.bodyFrames(q, bodies);
      ASSERT_EQ(bodies.size(), kin.dof() + 1) << robot;
      EXPECT_TRUE(bodies[0].isApprox(Eigen::Isometry3d::Identity())) << robot;
      for (std::size_t l = 0; l < links.size(); ++l)
      {
        const Eigen::Isometry3d placed =
            bodies[static_cast<std::size_t>(kin.movingJointsBefore(l))] * kin.linkInBodyFrame(l);
        EXPECT_LT((placed.matrix() - links[l].matrix()).cwiseAbs().maxCoeff(), 1e-12) << robot << " link " << l;
      }
      collision.shapePoses(q, shapes);
      ASSERT_EQ(shapes.size(), collision.shapes().size());
      for (std::size_t i = 0; i < shapes.size(); ++i)
      {
        const RobotShape& shape = collision.shapes()[i];
        const Eigen::Isometry3d expected = links[shape.chain_link] * shape.offset;
        EXPECT_LT((shapes[i].matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-12) << robot << " " << shape.link;
      }
    }
    kin.bodyFrames(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(kin.dof() + 1)), bodies);
    EXPECT_FALSE(bodies.back().matrix().allFinite()) << robot << ": a q of the wrong size gives NaN";
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
  // The object-contact links (fingers, palm) are padded 2 mm, the other links 5 mm
  // (RobotCollision.FingersArePaddedByTheirOwnPadding); the collision model knows all three.
  EXPECT_NEAR(p.robot.contact_link_padding_m, 0.002, 1e-12);
  const fast_grasp::RobotCollision collision = fast_grasp::makeRobotCollision(p);
  int contact_links = 0;
  for (const fast_grasp::RobotShape& s : collision.shapes())
    contact_links += s.finger ? 1 : 0;
  EXPECT_EQ(contact_links, 3);  // two fingers and the palm
}

TEST(RobotConfig, AHomePoseThatIsAFolderIsABadFileNotALeak)
{
  // Fuzzed config (test/fuzz/corpus/robot_config/leak_home_pose_is_a_folder): home_pose "."
  // names the config's own folder. yaml-cpp reading a folder leaked its buffer (LeakSanitizer);
  // now it is refused before reading, naming the path, as a missing file is.
  const std::string folder = ::testing::TempDir() + "/robot_config_home_folder";
  std::filesystem::create_directories(folder);
  const std::string path = folder + "/bot.yaml";
  std::ofstream(path) << "urdf: " << sourcePath("urdf/ur5_gripper_xtion.urdf") << "\nhome_pose: .\n";
  try
  {
    loadRobotConfig(path);
    FAIL() << "a home_pose folder was accepted";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("bad file"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(folder), std::string::npos) << e.what();
  }
}

TEST(RobotConfig, RobotPlannerParametersOverridePlannersYaml)
{
  // planners.yaml holds the UR5's RRTConnect range (Table 6.2); the LWR's file the appendix's
  // Table II value, laid over it; untouched parameters stay planners.yaml's.
  const GraspExecutionParams ur5 = robotParams(""), lwr = robotParams("lwr4");
  EXPECT_EQ(ur5.motion.planner_params.at("RRTConnect").at("range"), "0.3125");
  EXPECT_EQ(lwr.motion.planner_params.at("RRTConnect").at("range"), "0.6");
  EXPECT_EQ(lwr.motion.planner_params.at("KPIECE").at("failed_expansion_score_factor"),
            ur5.motion.planner_params.at("KPIECE").at("failed_expansion_score_factor"));
  // The LWR stands 0.2 m further back in the benchmark scenes: the shelf is 0.2 m further away.
  const ArmScene scene = loadArmScene(sourcePath("config/benchmarks/shelf_place.yaml"));
  const RobotCollision collision = makeRobotCollision(lwr);
  const ArmScene placed = sceneForRobot(scene, lwr.robot, collision.kinematics().jointNames());
  EXPECT_NEAR(placed.start_pose.translation().x() - scene.start_pose.translation().x(), 0.2, 1e-12);
  EXPECT_NEAR(placed.boxes.back().pose.translation().x() - scene.boxes.back().pose.translation().x(), 0.2, 1e-12);
  EXPECT_EQ(placed.seed_joints, lwr.robot.homePose(collision.kinematics().jointNames()));
}

}  // namespace
