// OMPL planning, time parameterisation and the grasp execution plan on the benchmark scenes
// and on hand-made bad input.
#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/arm/arm_motion_validator.h"
#include "fast_grasp/arm/batch_validity_checker.h"
#include "fast_grasp/arm/arm_rrt_connect.h"
#include "fast_grasp/arm/joint_nearest_neighbors.h"
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/arm/trajectory_timing.h"
#include "cpu_timed_planner.h"  // src/benchmarks (bench_planners)

#include <gtest/gtest.h>
#include <ompl/base/goals/GoalStates.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>
#include <ompl/tools/benchmark/Benchmark.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstring>
#include <fstream>
#include <map>
#include <random>

namespace
{
using namespace fast_grasp;
constexpr double kPi = 3.14159265358979323846;
// OMPL's per-solve INFO/DEBUG lines would drown the test output.
const bool kQuietOmpl = (ompl::msg::setLogLevel(ompl::msg::LOG_WARN), true);
// One OMPL seed for every run: the planners sample the same states each time, so a plan that
// passes here passes on every machine (unseeded, a time-bounded random search may fail one run in many).
const bool kSeededOmpl = (ompl::RNG::setSeed(20261202), true);

std::string sourcePath(const std::string& relative) { return std::string(FAST_GRASP_SOURCE_DIR) + "/" + relative; }

ArmKinematics ur5() { return ArmKinematics::fromUrdfFile(sourcePath("urdf/ur5_gripper_xtion.urdf")); }

Eigen::VectorXd home()
{
  Eigen::VectorXd q(6);
  q << kPi / 2, -kPi / 2, kPi / 2, -kPi / 2, -kPi / 2, 0.0;
  return q;
}

/// Limits, monotonic time, rest at both ends, finite-difference consistency.
void expectTrajectoryWithinLimits(const std::vector<TrajectoryPoint>& traj, const ArmKinematics& kin,
                                  const TimingLimits& limits)
{
  ASSERT_GE(traj.size(), 2u);
  EXPECT_LT(traj.front().velocities.norm(), 1e-9);
  EXPECT_LT(traj.back().velocities.norm(), 1e-9);
  for (std::size_t i = 0; i < traj.size(); ++i)
  {
    const TrajectoryPoint& p = traj[i];
    EXPECT_TRUE(kin.withinLimits(p.positions, 1e-6)) << i;
    EXPECT_TRUE((p.velocities.cwiseAbs().array() <= limits.velocity_rad_s.array() * (1 + 1e-6)).all()) << i;
    EXPECT_TRUE((p.accelerations.cwiseAbs().array() <= limits.acceleration_rad_s2.array() * (1 + 1e-6)).all()) << i;
    if (i == 0)
      continue;
    const double dt = p.time_from_start_s - traj[i - 1].time_from_start_s;
    if ((p.positions - traj[i - 1].positions).norm() < 1e-12)
      continue;  // a junction repeated point
    ASSERT_GT(dt, 0.0) << i;
    // The velocity change between samples needs at most the acceleration limit (10 % slack
    // for the tangent averaging at gentle turns).
    const Eigen::VectorXd fd_acc = (p.velocities - traj[i - 1].velocities) / dt;
    EXPECT_TRUE((fd_acc.cwiseAbs().array() <= 1.1 * limits.acceleration_rad_s2.array() + 1e-6).all())
        << i << ": " << fd_acc.transpose();
  }
}

/// Re-checks every trajectory segment with joint steps of 0.005 rad (<= 5 mm for the UR5's
/// < 1 m lever arms) against an unpadded model.
void expectCollisionFreeDense(const std::vector<TrajectoryPoint>& traj, const RobotCollision& collision,
                              const CollisionCheckOptions& options = CollisionCheckOptions())
{
  for (std::size_t i = 1; i < traj.size(); ++i)
  {
    const Eigen::VectorXd a = traj[i - 1].positions, b = traj[i].positions;
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).cwiseAbs().maxCoeff() / 0.005)));
    for (int k = 0; k <= steps; ++k)
    {
      std::string why;
      ASSERT_FALSE(collision.inCollision(a + (b - a) * (static_cast<double>(k) / steps), options, &why))
          << "segment " << i << " step " << k << ": " << why;
    }
  }
}

TimingLimits ur5Limits()
{
  TimingLimits limits;
  limits.velocity_rad_s = Eigen::VectorXd::Constant(6, kPi);
  limits.acceleration_rad_s2 = Eigen::VectorXd::Constant(6, 2.0);
  return limits;
}

TEST(TrajectoryTiming, StraightMoveIsTheAnalyticTrapezoid)
{
  TimingLimits limits = ur5Limits();
  // One joint moves 6 rad: accelerate at 2 rad/s^2 to pi rad/s (pi^2/4 = 2.47 rad each way),
  // cruise, brake: T = L / v + v / a. The grid costs at most 0.1 % (the switch point falls
  // between samples).
  std::vector<Eigen::VectorXd> path = { Eigen::VectorXd::Zero(6), Eigen::VectorXd::Zero(6) };
  path[1][0] = 6.0;
  std::vector<TrajectoryPoint> traj;
  ASSERT_TRUE(timeParameterize(path, limits, traj));
  EXPECT_NEAR(traj.back().time_from_start_s, 6.0 / kPi + kPi / 2.0, 1e-3 * (6.0 / kPi + kPi / 2.0));
  // Short move (never reaches pi rad/s): T = 2 sqrt(L / a).
  path[1][0] = 0.5;
  ASSERT_TRUE(timeParameterize(path, limits, traj));
  EXPECT_NEAR(traj.back().time_from_start_s, 2.0 * std::sqrt(0.5 / 2.0), 1e-3);
  // Two joints: the one with the longer move sets the pace, both arrive together.
  path[1] << 1.0, 0.5, 0, 0, 0, 0;
  ASSERT_TRUE(timeParameterize(path, limits, traj));
  EXPECT_NEAR(traj.back().time_from_start_s, 2.0 * std::sqrt(1.0 / 2.0), 1e-3);
  expectTrajectoryWithinLimits(traj, ur5(), limits);
}

TEST(TrajectoryTiming, CornersStopAndBadInputIsRejected)
{
  const TimingLimits limits = ur5Limits();
  std::vector<Eigen::VectorXd> path(3, Eigen::VectorXd::Zero(6));
  path[1][0] = 0.5;
  path[2] << 0.5, 0.5, 0, 0, 0, 0;  // 90 degree corner
  std::vector<TrajectoryPoint> traj;
  ASSERT_TRUE(timeParameterize(path, limits, traj));
  EXPECT_NEAR(traj.back().time_from_start_s, 2 * 2.0 * std::sqrt(0.5 / 2.0), 2e-3);
  bool stopped_at_corner = false;
  for (const TrajectoryPoint& p : traj)
    if ((p.positions - path[1]).norm() < 1e-12)
      stopped_at_corner = p.velocities.norm() < 1e-12;
  EXPECT_TRUE(stopped_at_corner);
  std::string why;
  EXPECT_FALSE(timeParameterize({}, limits, traj, &why));
  EXPECT_FALSE(timeParameterize({ Eigen::VectorXd::Zero(5) }, limits, traj, &why));
  std::vector<Eigen::VectorXd> nan_path = { Eigen::VectorXd::Zero(6), Eigen::VectorXd::Constant(6, std::nan("")) };
  EXPECT_FALSE(timeParameterize(nan_path, limits, traj, &why));
  TimingLimits zero = limits;
  zero.acceleration_rad_s2.setZero();
  EXPECT_FALSE(timeParameterize(path, zero, traj, &why));
  // Limits of 1e306 made every segment last ~1e-152 s and the accelerations NaN (fuzzing:
  // test/fuzz/corpus/trajectory_timing/crash_limits_1e306): no arm's limits, refused.
  TimingLimits absurd = limits;
  absurd.velocity_rad_s.setConstant(1e306);
  absurd.acceleration_rad_s2.setConstant(1e306);
  EXPECT_FALSE(timeParameterize(path, absurd, traj, &why));
  EXPECT_NE(why.find("no arm's"), std::string::npos) << why;
  EXPECT_TRUE(traj.empty());
  // A step count beyond int (a tiny max_step_rad) or a segment whose length overflows was an
  // undefined cast and an unbounded grid (UBSan while fuzzing;
  // test/fuzz/corpus/trajectory_timing/crash_*): refused with a reason.
  TimingLimits tiny_step = limits;
  tiny_step.max_step_rad = 1e-300;
  EXPECT_FALSE(timeParameterize(path, tiny_step, traj, &why));
  EXPECT_NE(why.find("too long"), std::string::npos) << why;
  const std::vector<Eigen::VectorXd> huge_path = { Eigen::VectorXd::Constant(6, -1e308),
                                                   Eigen::VectorXd::Constant(6, 1e308) };
  EXPECT_FALSE(timeParameterize(huge_path, limits, traj, &why));
  EXPECT_TRUE(traj.empty());
  // max_samples bounds the work: 6 rad at 0.02 rad is 300 steps, 301 samples.
  std::vector<Eigen::VectorXd> long_move = { Eigen::VectorXd::Zero(6), Eigen::VectorXd::Zero(6) };
  long_move[1][0] = 6.0;
  TimingLimits bounded = limits;
  bounded.max_samples = 301;
  ASSERT_TRUE(timeParameterize(long_move, bounded, traj, &why)) << why;
  EXPECT_EQ(traj.size(), 301u);
  bounded.max_samples = 300;
  EXPECT_FALSE(timeParameterize(long_move, bounded, traj, &why));
  EXPECT_NE(why.find("more than max_samples 300"), std::string::npos) << why;
}

TEST(ArmMotionPlanner, EveryThesisPlannerAllocates)
{
  const RobotCollision collision(ur5());
  const ArmMotionPlanner planner(collision);
  const PlannerParameterTable table = loadPlannerParameters(sourcePath("config/planners.yaml"));
  MotionPlanningParams params;
  const auto setup = planner.makeSetup(home(), { home() }, params);
  EXPECT_EQ(ArmMotionPlanner::plannerNames().size(), 23u);
  for (const std::string& name : ArmMotionPlanner::plannerNames())
  {
    std::vector<std::string> unknown;
    EXPECT_TRUE(ArmMotionPlanner::allocatePlanner(name, setup->getSpaceInformation(), table, &unknown)) << name;
    EXPECT_TRUE(unknown.empty()) << name << ": " << (unknown.empty() ? "" : unknown.front());
  }
  params.planner = "NoSuchPlanner";
  EXPECT_EQ(planner.plan(home(), { home() }, params).status, MotionPlanStatus::UnknownPlanner);
}

/// Plans a benchmark scene with RRTConnect and checks the timed result.
void planScene(const std::string& scene_name)
{
  const ArmScene scene = loadArmScene(sourcePath("config/benchmarks/" + scene_name + ".yaml"));
  RobotCollision padded(ur5(), 0.005), exact(ur5(), 0.0);
  addSceneBoxes(scene, padded);
  addSceneBoxes(scene, exact);
  const ArmMotionPlanner planner(padded);
  MotionPlanningParams params;
  params.planner_params = loadPlannerParameters(sourcePath("config/planners.yaml"));
  params.planning_time_s = 10.0;
  params.keep_gripper_horizontal = scene.keep_gripper_horizontal;
  params.horizontal_tolerance_rad = scene.horizontal_tolerance_rad;
  Eigen::VectorXd start;
  std::vector<Eigen::VectorXd> goals;
  std::string why;
  ASSERT_TRUE(resolveScene(scene, planner, params, start, goals, &why)) << why;
  const MotionPlanResult plan = planner.plan(start, goals, params);
  ASSERT_TRUE(plan.ok()) << plan.message;
  EXPECT_LT((plan.path.front() - start).norm(), 1e-9);
  bool at_goal = false;
  for (const Eigen::VectorXd& g : goals)
    at_goal = at_goal || (plan.path.back() - g).norm() < 1e-6;
  EXPECT_TRUE(at_goal);
  const TimingLimits limits = ur5Limits();
  std::vector<TrajectoryPoint> traj;
  ASSERT_TRUE(timeParameterize(plan.path, limits, traj, &why)) << why;
  expectTrajectoryWithinLimits(traj, padded.kinematics(), limits);
  expectCollisionFreeDense(traj, exact);
  if (scene.keep_gripper_horizontal)
  {
    for (std::size_t i = 1; i < traj.size(); ++i)
      for (int k = 0; k <= 10; ++k)
      {
        const Eigen::VectorXd q = traj[i - 1].positions + (traj[i].positions - traj[i - 1].positions) * (k / 10.0);
        EXPECT_LE(planner.gripperTiltRad(q), scene.horizontal_tolerance_rad + 1e-9);
      }
  }
}

TEST(ArmMotionPlanner, LongMotionSceneIsSolved) { planScene("long_motion"); }
TEST(ArmMotionPlanner, NarrowPassageSceneIsSolved) { planScene("narrow_passage"); }
TEST(ArmMotionPlanner, HorizontalShelfPlaceKeepsTheGripperLevel) { planScene("shelf_place_horizontal"); }

/// The UR5 in the narrow passage scene, padded as the benchmark plans it.
struct NarrowPassage
{
  NarrowPassage() : collision(ur5(), 0.005)
  {
    scene = loadArmScene(sourcePath("config/benchmarks/narrow_passage.yaml"));
    addSceneBoxes(scene, collision);
    planner = std::make_unique<ArmMotionPlanner>(collision);
    params.planner_params = loadPlannerParameters(sourcePath("config/planners.yaml"));
  }
  ArmScene scene;
  RobotCollision collision;
  std::unique_ptr<ArmMotionPlanner> planner;
  MotionPlanningParams params;
};

/// The narrow passage resolved to its start and IK goals (ASSERTs that it resolves).
struct ResolvedNarrowPassage : NarrowPassage
{
  void resolve()
  {
    std::string why;
    ASSERT_TRUE(resolveScene(scene, *planner, params, start, goals, &why)) << why;
  }
  std::shared_ptr<ompl::geometric::SimpleSetup> makeSetup() const { return planner->makeSetup(start, goals, params); }
  Eigen::VectorXd start;
  std::vector<Eigen::VectorXd> goals;
};

TEST(JointNearestNeighbors, VectorisedScanGivesTheScalarDistancesAndEigensFirstMinimum)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  const std::vector<bool> continuous = { false, true, false, false, true, false };
  const std::vector<char> continuous_chars(continuous.begin(), continuous.end());
  JointNearestNeighbors<int> reference(continuous, [](const int&, double*) {});
  for (std::size_t n : { 0u, 1u, 3u, 4u, 5u, 17u, 64u, 301u })
  {
    std::vector<std::vector<double>> columns(6, std::vector<double>(n));
    for (auto& column : columns)
      for (double& v : column)
        v = angle(rng);
    std::vector<const double*> data;
    for (const auto& column : columns)
      data.push_back(column.data());
    const double query[6] = { angle(rng), angle(rng), angle(rng), angle(rng), angle(rng), angle(rng) };
    std::vector<double> squared(n, -1.0);
    jointSquaredDistances(data.data(), query, continuous_chars.data(), 6, n, squared.data());
    for (std::size_t i = 0; i < n; ++i)
    {
      double state[6];
      for (int j = 0; j < 6; ++j)
        state[j] = columns[static_cast<std::size_t>(j)][i];
      const double d = reference.distance(state, query);
      EXPECT_EQ(std::sqrt(squared[i]), d) << n << " " << i;  // bit for bit
    }
    // Ties and NaNs: the first index of the smallest value, NaN never smaller (Eigen's minCoeff).
    for (int trial = 0; trial < 20 && n > 0; ++trial)
    {
      std::vector<double> values(n);
      std::uniform_int_distribution<int> small(0, 5);
      for (double& v : values)
        v = small(rng) == 0 ? std::nan("") : static_cast<double>(small(rng));
      Eigen::Index expected = 0;
      Eigen::Map<const Eigen::ArrayXd>(values.data(), static_cast<Eigen::Index>(n)).minCoeff(&expected);
      EXPECT_EQ(firstMinimumIndex(values.data(), n), static_cast<std::size_t>(expected)) << n << " " << trial;
    }
  }
  EXPECT_EQ(firstMinimumIndex(nullptr, 0), 0u);
}

TEST(ArmRRTConnect, PathEndsExactlyAndEverySegmentIsAValidMotion)
{
  ResolvedNarrowPassage np;
  ASSERT_NO_FATAL_FAILURE(np.resolve());
  for (int run = 0; run < 5; ++run)
  {
    const auto setup = np.makeSetup();
    const ompl::base::PlannerPtr planner =
        ArmMotionPlanner::allocatePlanner("RRTConnect", setup->getSpaceInformation(), np.params.planner_params);
    ASSERT_TRUE(std::dynamic_pointer_cast<ArmRRTConnect>(planner));
    EXPECT_DOUBLE_EQ(planner->as<ArmRRTConnect>()->getRange(), 0.3125);  // config/planners.yaml
    setup->setPlanner(planner);
    ASSERT_EQ(setup->solve(10.0), ompl::base::PlannerStatus::EXACT_SOLUTION) << run;
    const auto& path = setup->getSolutionPath();
    const ompl::base::SpaceInformationPtr& si = setup->getSpaceInformation();
    ASSERT_GE(path.getStateCount(), 2u);
    // The start and one of the goal states, bit for bit.
    EXPECT_TRUE(si->equalStates(path.getState(0), setup->getProblemDefinition()->getStartState(0)));
    const auto* goal_states = setup->getGoal()->as<ompl::base::GoalStates>();
    bool at_goal = false;
    for (std::size_t g = 0; g < goal_states->getStateCount(); ++g)
      at_goal = at_goal || si->equalStates(path.getState(path.getStateCount() - 1), goal_states->getState(g));
    EXPECT_TRUE(at_goal) << run;
    // Every state valid and every segment valid at the space's resolution, in the path's
    // direction (OMPL's DiscreteMotionValidator; goal-tree edges included).
    for (std::size_t k = 0; k < path.getStateCount(); ++k)
      EXPECT_TRUE(si->isValid(path.getState(k))) << run << " state " << k;
    for (std::size_t k = 0; k + 1 < path.getStateCount(); ++k)
      EXPECT_TRUE(si->checkMotion(path.getState(k), path.getState(k + 1))) << run << " segment " << k;
    // The planner data hold both trees and the connecting edge.
    ompl::base::PlannerData data(si);
    planner->getPlannerData(data);
    EXPECT_GE(data.numVertices(), path.getStateCount());
    EXPECT_EQ(data.numStartVertices(), 1u);
    EXPECT_GE(data.numGoalVertices(), 1u);
    EXPECT_EQ(data.numEdges() + data.numStartVertices() + data.numGoalVertices(), data.numVertices() + 1);
  }
}

/// States of the narrow passage: random ones (about half in collision) and pairs bisected
/// down to 1e-6 rad across a contact (where a different rounding would flip a verdict).
std::vector<Eigen::VectorXd> randomAndNearContactStates(const NarrowPassage& np, std::mt19937& rng)
{
  const ArmKinematics& kin = np.collision.kinematics();
  std::vector<Eigen::VectorXd> states, free_states, hit_states;
  for (int i = 0; i < 3000; ++i)
  {
    states.push_back(kin.randomConfiguration(rng));
    (np.collision.inCollision(states.back()) ? hit_states : free_states).push_back(states.back());
  }
  for (std::size_t k = 0; k < 300 && !free_states.empty() && !hit_states.empty(); ++k)
  {
    Eigen::VectorXd a = free_states[k % free_states.size()], b = hit_states[k % hit_states.size()];
    while ((b - a).cwiseAbs().maxCoeff() > 1e-6)
    {
      const Eigen::VectorXd mid = 0.5 * (a + b);
      (np.collision.inCollision(mid) ? b : a) = mid;
    }
    states.push_back(a);
    states.push_back(b);
  }
  std::shuffle(states.begin(), states.end(), rng);
  return states;
}

TEST(RobotCollision, FirstInCollisionGivesInCollisionsVerdictsInOrder)
{
  const NarrowPassage np;
  std::mt19937 rng(5);
  std::vector<Eigen::VectorXd> states = randomAndNearContactStates(np, rng);
  // Bad vectors count as collisions, as in inCollision.
  Eigen::VectorXd nan_state = states[0];
  nan_state[2] = std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd short_state = states[1].head(5);
  int collisions = 0, groups = 0;
  for (std::size_t first = 0; first + 9 < states.size(); first += 1 + rng() % 9, ++groups)
  {
    const std::size_t count = 1 + rng() % 9;  // more than one batch of four too
    std::vector<const Eigen::VectorXd*> group;
    for (std::size_t k = 0; k < count; ++k)
      group.push_back(&states[first + k]);
    if (groups % 50 == 0)
      group[rng() % count] = groups % 100 == 0 ? &nan_state : &short_state;
    std::size_t expected = count;
    for (std::size_t k = 0; k < count && expected == count; ++k)
      if (np.collision.inCollision(*group[k]))
        expected = k;
    collisions += expected < count ? 1 : 0;
    ASSERT_EQ(np.collision.firstInCollision(group.data(), count), expected) << "group at " << first;
  }
  EXPECT_GT(groups, 500);
  EXPECT_GT(collisions, 100);
  EXPECT_EQ(np.collision.firstInCollision(nullptr, 0), 0u);
}

TEST(ArmMotionPlanner, BatchedCheckerAndMotionValidatorGiveTheOneByOneVerdicts)
{
  ResolvedNarrowPassage np;
  ASSERT_NO_FATAL_FAILURE(np.resolve());
  const auto setup = np.makeSetup();
  const ompl::base::SpaceInformationPtr& si = setup->getSpaceInformation();
  si->setup();
  const auto* checker = dynamic_cast<const BatchValidityChecker*>(si->getStateValidityChecker().get());
  ASSERT_NE(checker, nullptr);
  ASSERT_NE(dynamic_cast<const ArmMotionValidator*>(si->getMotionValidator().get()), nullptr);
  std::mt19937 rng(9);
  const std::vector<Eigen::VectorXd> qs = randomAndNearContactStates(np, rng);
  std::vector<ompl::base::State*> states;
  for (const Eigen::VectorXd& q : qs)
  {
    states.push_back(si->allocState());
    si->getStateSpace()->copyFromReals(states.back(), std::vector<double>(q.data(), q.data() + q.size()));
  }
  // firstInvalid against the planner's isValid, state by state (groups overlap).
  int groups = 0, invalid = 0;
  for (std::size_t first = 0; first + 9 < states.size(); first += 1 + rng() % 5, ++groups)
  {
    const std::size_t count = 1 + rng() % 9;
    std::size_t expected = count;
    for (std::size_t k = 0; k < count && expected == count; ++k)
      if (!np.planner->isValid(qs[first + k], np.params))
        expected = k;
    invalid += expected < count ? 1 : 0;
    ASSERT_EQ(checker->firstInvalid(states.data() + first, count), expected) << "group at " << first;
  }
  EXPECT_GT(invalid, 100);
  // ArmMotionValidator against OMPL's DiscreteMotionValidator on the same space: motions
  // from valid states to all kinds of states, short and long.
  ompl::base::DiscreteMotionValidator reference(si);
  const auto& validator = *si->getMotionValidator();
  int motions = 0, valid_motions = 0;
  for (std::size_t k = 0; k + 1 < states.size() && motions < 1500; ++k)
  {
    if (!np.planner->isValid(qs[k], np.params))
      continue;
    ompl::base::State* to = states[k + 1];
    if (k % 2 == 0)  // a short motion: a few states between the ends
      si->getStateSpace()->interpolate(states[k], states[k + 1], 0.1, to = si->allocState());
    const bool expected = reference.checkMotion(states[k], to);
    ASSERT_EQ(validator.checkMotion(states[k], to), expected) << "motion " << k;
    valid_motions += expected ? 1 : 0;
    ++motions;
    if (to != states[k + 1])
      si->freeState(to);
  }
  EXPECT_GT(motions, 500);
  EXPECT_GT(valid_motions, 50);
  EXPECT_LT(valid_motions, motions - 50);
  EXPECT_EQ(validator.getValidMotionCount(), reference.getValidMotionCount());
  EXPECT_EQ(validator.getInvalidMotionCount(), reference.getInvalidMotionCount());
  for (ompl::base::State* state : states)
    si->freeState(state);
}

TEST(CpuTimedPlanner, RunsThePlannerInOmplsBenchmarkAsIfItRanAlone)
{
  // bench_planners hands OMPL's Benchmark this wrapper: the benchmark must see the wrapped
  // planner's name, parameters and planner data, and the clock must be read when solve() ends.
  ResolvedNarrowPassage np;
  ASSERT_NO_FATAL_FAILURE(np.resolve());
  const auto setup = np.makeSetup();
  const ompl::base::PlannerPtr inner =
      ArmMotionPlanner::allocatePlanner("RRTConnect", setup->getSpaceInformation(), np.params.planner_params);
  inner->setName("RRTConnect");
  const auto timed = std::make_shared<CpuTimedPlanner>(inner);
  EXPECT_EQ(timed->getName(), "RRTConnect");
  std::map<std::string, std::string> inner_params, timed_params;
  inner->params().getParams(inner_params);
  timed->params().getParams(timed_params);
  EXPECT_EQ(timed_params, inner_params);
  EXPECT_EQ(timed_params.at("range"), "0.3125");
  timed->params().setParam("range", "0.25");  // the wrapper's parameters are the planner's
  EXPECT_DOUBLE_EQ(inner->as<ArmRRTConnect>()->getRange(), 0.25);
  timed->params().setParam("range", "0.3125");

  ompl::tools::Benchmark benchmark(*setup, "narrow_passage");
  benchmark.addPlanner(timed);
  std::vector<double> cpu_before, cpu_at_end;
  benchmark.setPreRunEvent([&](const ompl::base::PlannerPtr& p) {
    EXPECT_EQ(p.get(), timed.get());
    cpu_before.push_back(processCpuSeconds());
  });
  benchmark.setPostRunEvent([&](const ompl::base::PlannerPtr&, ompl::tools::Benchmark::RunProperties&) {
    cpu_at_end.push_back(timed->cpuSecondsAtSolveEnd());
    // The end of solve() lies between the pre-run event and now.
    EXPECT_GE(cpu_at_end.back(), cpu_before.back());
    EXPECT_LE(cpu_at_end.back(), processCpuSeconds());
    // The solution is the wrapped planner's: exact, every segment a valid motion.
    ASSERT_TRUE(setup->haveExactSolutionPath());
    EXPECT_TRUE(setup->getSolutionPath().check());
  });
  ompl::tools::Benchmark::Request request(10.0, 4096.0, 3, 0.5, false, false, false);
  benchmark.benchmark(request);
  ASSERT_EQ(cpu_at_end.size(), 3u);
  const auto& experiment = benchmark.getRecordedExperimentData();
  ASSERT_EQ(experiment.planners.size(), 1u);
  EXPECT_EQ(experiment.planners[0].name, "geometric_RRTConnect");
  EXPECT_EQ(experiment.planners[0].common.at("range"), "0.3125");
  for (const auto& run : experiment.planners[0].runs)
  {
    EXPECT_EQ(run.at("solved BOOLEAN"), "1");
    EXPECT_EQ(run.at("correct solution BOOLEAN"), "1");
    // The planner data came through: both trees, at least the path's states.
    EXPECT_GE(std::stoi(run.at("graph states INTEGER")), std::stoi(run.at("solution segments INTEGER")) + 1);
    EXPECT_GE(std::stoi(run.at("graph motions INTEGER")), 1);
  }
  // clear() reaches the wrapped planner: no tree left.
  timed->clear();
  ompl::base::PlannerData data(setup->getSpaceInformation());
  inner->getPlannerData(data);
  EXPECT_EQ(data.numVertices(), 0u);
}

TEST(ArmMotionPlanner, OctomapBoxForcesADetour)
{
  // Straight joint-space line between two poses would sweep the hand through a box of points.
  RobotCollision collision(ur5(), 0.005);
  ASSERT_TRUE(collision.resetScene(0.02));
  Eigen::VectorXd from(6), to(6);
  from << -0.8, -1.2, 1.6, -1.97, -1.57, 0.0;
  to << 0.8, -1.2, 1.6, -1.97, -1.57, 0.0;
  Eigen::VectorXd mid = 0.5 * (from + to);
  const Eigen::Vector3d hand = collision.kinematics().fk(mid).translation();
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (double x = -0.06; x <= 0.06; x += 0.01)
    for (double y = -0.06; y <= 0.06; y += 0.01)
      for (double z = -0.06; z <= 0.06; z += 0.01)
        cloud.push_back(pcl::PointXYZ(hand.x() + x, hand.y() + y, hand.z() + z));
  collision.addObstacleCloud(cloud, from);
  ASSERT_TRUE(collision.inCollision(mid));
  const ArmMotionPlanner planner(collision);
  MotionPlanningParams params;
  params.planning_time_s = 5.0;
  const MotionPlanResult plan = planner.plan(from, { to }, params);
  ASSERT_TRUE(plan.ok()) << plan.message;
  EXPECT_GT(plan.path.size(), 2u);  // not the straight line
  std::vector<TrajectoryPoint> traj;
  ASSERT_TRUE(timeParameterize(plan.path, ur5Limits(), traj));
  RobotCollision exact(ur5(), 0.0);
  ASSERT_TRUE(exact.resetScene(0.02));
  exact.addObstacleCloud(cloud, from);
  expectCollisionFreeDense(traj, exact);
}

std::string reasons(const GraspPlanResult& r)
{
  std::string all = r.status;
  for (const std::string& s : r.skipped_reasons)
    all += "\n  " + s;
  return all;
}

/// Scene with a table and a 4 x 4 x 10 cm target on it at (0.5, 0, 0.05..0.15).
struct GraspScene
{
  RobotCollision collision;
  GraspExecutionParams params;
  std::vector<GraspCandidate> grasps;
  GraspCandidate good;
  explicit GraspScene(bool with_table = true, bool with_target = true, double link_padding_m = 0.005)
    : collision(ur5(), link_padding_m)
  {
    params = loadGraspExecutionParams(sourcePath("config/arm.yaml"), sourcePath("config/planners.yaml"));
    collision.resetScene(params.octomap_resolution_m);
    if (with_table)
    {
      Eigen::Isometry3d table = Eigen::Isometry3d::Identity();
      table.translation() << 0.3, 0.0, -0.05;
      collision.addBox("table", Eigen::Vector3d(1.6, 1.6, 0.1), table);
    }
    if (with_target)
    {
      pcl::PointCloud<pcl::PointXYZ> object;
      for (double x = 0.48; x <= 0.52 + 1e-9; x += 0.005)
        for (double y = -0.02; y <= 0.02 + 1e-9; y += 0.005)
          for (double z = 0.05; z <= 0.15 + 1e-9; z += 0.005)
            object.push_back(pcl::PointXYZ(x, y, z));
      collision.setTargetCloud(object);
    }
    good.pose = makeGraspPose(Eigen::Vector3d(0.5, 0.0, 0.1), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0));
  }
};

TEST(GraspExecution, PlansApproachAndLiftForAReachableGrasp)
{
  GraspScene s;
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { s.good }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_EQ(r.grasp_index, 0);
  EXPECT_EQ(r.joint_names.size(), 6u);
  const ArmKinematics& kin = s.collision.kinematics();
  // Pre-grasp: approach_distance_m back along the approach; grasp: the grasp pose; then lifted.
  const Eigen::Isometry3d pre = kin.fk(r.points[r.pregrasp_point_index].positions);
  const Eigen::Isometry3d at = kin.fk(r.points[r.grasp_point_index].positions);
  const Eigen::Isometry3d lifted = kin.fk(r.points.back().positions);
  EXPECT_LT((at.translation() - s.good.pose.translation()).norm(), 1e-3);
  EXPECT_LT(Eigen::AngleAxisd(at.linear().transpose() * s.good.pose.linear()).angle(), 0.01);
  EXPECT_LT((pre.translation() - (s.good.position() - s.params.approach_distance_m * s.good.approach())).norm(), 1e-3);
  EXPECT_LT((lifted.translation() - (s.good.position() + Eigen::Vector3d(0, 0, s.params.lift_distance_m))).norm(), 1e-3);
  TimingLimits limits = ur5Limits();
  limits.acceleration_rad_s2 = s.params.acceleration_limit_rad_s2;
  expectTrajectoryWithinLimits(r.points, kin, limits);
  // Free motion to the pre-grasp never touches the target; the approach only with fingers.
  // The planner checks the free motion at states where no robot point moves more than
  // max_cartesian_step_m (1 cm) apart, with links padded by 5 mm: what that proves is the
  // unpadded arm clear in between (a point is never more than 5 mm from where it was
  // checked), so the dense re-check uses the unpadded arm (as planScene does). The padded
  // one may graze the target between checks (main at a902f1c with OMPL seed 25 instead of
  // kSeededOmpl's did; so does this seed with RRTConnect's trees in JointNearestNeighbors).
  const GraspScene unpadded(true, true, 0.0);
  std::vector<TrajectoryPoint> free(r.points.begin(), r.points.begin() + r.pregrasp_point_index + 1);
  expectCollisionFreeDense(free, unpadded.collision);
  std::vector<TrajectoryPoint> approach(r.points.begin() + r.pregrasp_point_index,
                                        r.points.begin() + r.grasp_point_index + 1);
  CollisionCheckOptions fingers;
  fingers.allow_finger_target_contact = true;
  expectCollisionFreeDense(approach, s.collision, fingers);
}

TEST(GraspExecution, BadGraspsAreSkippedWithReasonsAndTheNextIsTried)
{
  GraspScene s;
  GraspCandidate nan_grasp;
  nan_grasp.pose.translation().x() = std::nan("");
  GraspCandidate far = s.good;
  far.pose.translation() << 2.0, 0.0, 0.1;  // beyond reach
  GraspCandidate into_table = s.good;
  into_table.pose.translation().z() = -0.2;  // reachable, but the hand would be in the table
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { nan_grasp, far, into_table, s.good }, s.params);
  ASSERT_TRUE(r.success) << reasons(r);
  EXPECT_EQ(r.grasp_index, 3);
  ASSERT_EQ(r.skipped_reasons.size(), 3u);
  EXPECT_NE(r.skipped_reasons[0].find("NaN pose"), std::string::npos) << r.skipped_reasons[0];
  EXPECT_NE(r.skipped_reasons[1].find("unreachable"), std::string::npos) << r.skipped_reasons[1];
  EXPECT_NE(r.skipped_reasons[2].find("collision"), std::string::npos) << r.skipped_reasons[2];
}

TEST(GraspExecution, StartInCollisionFailsClearly)
{
  GraspScene s;
  Eigen::VectorXd below_table(6);
  below_table << 0, 0.5, 0, 0, 0, 0;
  const GraspPlanResult r = planGraspMotion(s.collision, below_table, { s.good, s.good }, s.params);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.status.find("start in collision"), std::string::npos) << r.status;
  EXPECT_EQ(r.skipped_reasons.size(), 2u);
  EXPECT_TRUE(r.points.empty());
  const GraspPlanResult wrong = planGraspMotion(s.collision, Eigen::VectorXd::Zero(4), { s.good }, s.params);
  EXPECT_FALSE(wrong.success);
  EXPECT_NE(wrong.status.find("start state invalid"), std::string::npos) << wrong.status;
  const GraspPlanResult none = planGraspMotion(s.collision, home(), {}, s.params);
  EXPECT_FALSE(none.success);
  EXPECT_EQ(none.grasp_index, -1);
}

TEST(GraspExecution, EmptySceneStillPlans)
{
  GraspScene s(false, false);
  const GraspPlanResult r = planGraspMotion(s.collision, home(), { s.good }, s.params);
  EXPECT_TRUE(r.success) << reasons(r);
}

TEST(GraspExecution, ConfigLoadsAndRejectsBadValues)
{
  const GraspExecutionParams p = loadGraspExecutionParams(sourcePath("config/arm.yaml"), sourcePath("config/planners.yaml"));
  EXPECT_EQ(p.joint_upper_rad.size(), 6);
  EXPECT_NEAR(p.joint_upper_rad[0], kPi, 1e-9);
  EXPECT_NEAR(p.velocity_limit_rad_s[0], kPi, 1e-9);
  EXPECT_EQ(p.motion.planner_params.size(), 23u);
  EXPECT_THROW(loadGraspExecutionParams("/nonexistent/arm.yaml"), std::runtime_error);
  const std::string bad = ::testing::TempDir() + "/bad_arm.yaml";
  std::ofstream(bad) << "approach_distance_m: -1\n";
  EXPECT_THROW(loadGraspExecutionParams(bad), std::runtime_error);
  ArmKinematics kin = ur5();
  GraspExecutionParams wrong = p;
  wrong.joint_lower_rad = Eigen::VectorXd::Zero(3);
  EXPECT_FALSE(applyLimits(wrong, kin).empty());
  EXPECT_TRUE(applyLimits(p, kin).empty());
}

}  // namespace
