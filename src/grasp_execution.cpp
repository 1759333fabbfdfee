#include "fast_grasp/grasp_execution.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fast_grasp
{
namespace
{
bool fail(std::string* why, const std::string& message)
{
  if (why)
    *why = message;
  return false;
}

Eigen::VectorXd readVector(const YAML::Node& node, const std::string& key, const std::string& file)
{
  if (!node[key])
    return Eigen::VectorXd();
  if (!node[key].IsSequence())
    throw std::runtime_error("arm config '" + file + "': '" + key + "' must be a list");
  Eigen::VectorXd v(static_cast<Eigen::Index>(node[key].size()));
  for (std::size_t i = 0; i < node[key].size(); ++i)
    v[static_cast<Eigen::Index>(i)] = node[key][i].as<double>();
  return v;
}

template <typename T>
void readScalar(const YAML::Node& node, const std::string& key, T& value)
{
  if (node[key])
    value = node[key].as<T>();
}

std::string describe(const Eigen::VectorXd& q)
{
  std::string s = "[";
  for (Eigen::Index j = 0; j < q.size(); ++j)
    s += (j ? ", " : "") + std::to_string(q[j]);
  return s + "]";
}
}  // namespace

GraspExecutionParams loadGraspExecutionParams(const std::string& arm_yaml, const std::string& planners_yaml)
{
  YAML::Node root;
  try
  {
    root = YAML::LoadFile(arm_yaml);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error("arm config '" + arm_yaml + "': " + e.what());
  }
  GraspExecutionParams p;
  try
  {
    readScalar(root, "urdf_path", p.urdf_path);
    readScalar(root, "base_link", p.base_link);
    readScalar(root, "tip_link", p.tip_link);
    const Eigen::VectorXd limit = readVector(root, "joint_limits_rad", arm_yaml);
    if (limit.size() > 0)
    {
      p.joint_lower_rad = -limit;
      p.joint_upper_rad = limit;
    }
    const Eigen::VectorXd lower = readVector(root, "joint_lower_rad", arm_yaml);
    const Eigen::VectorXd upper = readVector(root, "joint_upper_rad", arm_yaml);
    if (lower.size() > 0)
      p.joint_lower_rad = lower;
    if (upper.size() > 0)
      p.joint_upper_rad = upper;
    p.velocity_limit_rad_s = readVector(root, "velocity_limit_rad_s", arm_yaml);
    p.acceleration_limit_rad_s2 = readVector(root, "acceleration_limit_rad_s2", arm_yaml);
    readScalar(root, "approach_distance_m", p.approach_distance_m);
    readScalar(root, "lift_distance_m", p.lift_distance_m);
    readScalar(root, "cartesian_step_m", p.cartesian_step_m);
    readScalar(root, "max_joint_jump_rad", p.max_joint_jump_rad);
    readScalar(root, "link_padding_m", p.link_padding_m);
    readScalar(root, "octomap_resolution_m", p.octomap_resolution_m);
    readScalar(root, "self_filter_padding_m", p.self_filter_padding_m);
    readScalar(root, "total_time_budget_s", p.total_time_budget_s);
    readScalar(root, "max_ik_solutions", p.max_ik_solutions);
    readScalar(root, "ik_timeout_s", p.ik.timeout_s);
    readScalar(root, "ik_position_tolerance_m", p.ik.position_tolerance_m);
    readScalar(root, "ik_orientation_tolerance_rad", p.ik.orientation_tolerance_rad);
    readScalar(root, "planner", p.motion.planner);
    readScalar(root, "planning_time_s", p.motion.planning_time_s);
    readScalar(root, "simplify", p.motion.simplify);
    readScalar(root, "simplify_time_s", p.motion.simplify_time_s);
    readScalar(root, "longest_valid_segment_fraction", p.motion.longest_valid_segment_fraction);
    readScalar(root, "max_cartesian_step_m", p.motion.max_cartesian_step_m);
    readScalar(root, "lazy_validation", p.motion.lazy_validation);
    readScalar(root, "keep_gripper_horizontal", p.motion.keep_gripper_horizontal);
    readScalar(root, "horizontal_tolerance_rad", p.motion.horizontal_tolerance_rad);
    readScalar(root, "trajectory_step_rad", p.timing.max_step_rad);
    readScalar(root, "corner_angle_rad", p.timing.corner_angle_rad);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("arm config '" + arm_yaml + "': bad value: " + e.what());
  }
  auto positive = [&](double v, const char* key) {
    if (!(v > 0.0))
      throw std::runtime_error("arm config '" + arm_yaml + "': '" + key + "' must be > 0");
  };
  positive(p.approach_distance_m, "approach_distance_m");
  positive(p.lift_distance_m, "lift_distance_m");
  positive(p.cartesian_step_m, "cartesian_step_m");
  positive(p.octomap_resolution_m, "octomap_resolution_m");
  positive(p.motion.planning_time_s, "planning_time_s");
  positive(p.motion.longest_valid_segment_fraction, "longest_valid_segment_fraction");
  positive(p.total_time_budget_s, "total_time_budget_s");
  if ((p.acceleration_limit_rad_s2.array() <= 0.0).any() || (p.velocity_limit_rad_s.array() <= 0.0).any())
    throw std::runtime_error("arm config '" + arm_yaml + "': velocity/acceleration limits must be > 0");
  if (!planners_yaml.empty())
    p.motion.planner_params = loadPlannerParameters(planners_yaml);
  return p;
}

std::string applyLimits(const GraspExecutionParams& params, ArmKinematics& kinematics)
{
  if (params.joint_lower_rad.size() > 0 || params.joint_upper_rad.size() > 0)
  {
    if (!kinematics.setJointLimits(params.joint_lower_rad, params.joint_upper_rad))
      return "joint limits need " + std::to_string(kinematics.dof()) + " entries with lower <= upper";
  }
  if (params.velocity_limit_rad_s.size() > 0 && !kinematics.setVelocityLimits(params.velocity_limit_rad_s))
    return "velocity limits need " + std::to_string(kinematics.dof()) + " positive entries";
  return "";
}

std::vector<Eigen::VectorXd> planCartesianLine(const RobotCollision& collision, const Eigen::VectorXd& from,
                                               const Eigen::Isometry3d& target, const GraspExecutionParams& params,
                                               const CollisionCheckOptions& options, std::string* why)
{
  const ArmKinematics& kin = collision.kinematics();
  std::vector<Eigen::VectorXd> path{ from };
  const Eigen::Isometry3d start = kin.fk(from);
  if (!start.matrix().allFinite() || !target.matrix().allFinite())
  {
    fail(why, "NaN pose");
    return {};
  }
  const double distance = (target.translation() - start.translation()).norm();
  const Eigen::Quaterniond q0(start.linear()), q1(target.linear());
  // Rotation counts as distance at 0.1 m per rad (a point 10 cm from the tip).
  const double angle = q0.angularDistance(q1);
  const int steps = std::max(1, static_cast<int>(std::ceil(std::max(distance, 0.1 * angle) / params.cartesian_step_m)));
  IkParams ik = params.ik;
  ik.max_solutions = 1;
  for (int k = 1; k <= steps; ++k)
  {
    const double t = static_cast<double>(k) / steps;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = q0.slerp(t, q1).toRotationMatrix();
    pose.translation() = start.translation() + t * (target.translation() - start.translation());
    const std::vector<Eigen::VectorXd> sols = kin.ik(pose, path.back(), ik);
    if (sols.empty())
    {
      fail(why, "IK failed at " + std::to_string(100.0 * t) + " % of the straight line");
      return {};
    }
    if ((sols.front() - path.back()).cwiseAbs().maxCoeff() > params.max_joint_jump_rad)
    {
      fail(why, "joint jump (IK branch change) at " + std::to_string(100.0 * t) + " % of the straight line");
      return {};
    }
    std::string contact;
    if (collision.inCollision(sols.front(), options, &contact))
    {
      fail(why, "collision at " + std::to_string(100.0 * t) + " % of the straight line: " + contact);
      return {};
    }
    path.push_back(sols.front());
  }
  return path;
}

GraspPlanResult planGraspMotion(const RobotCollision& collision, const Eigen::VectorXd& start,
                                const std::vector<GraspCandidate>& grasps, const GraspExecutionParams& params)
{
  const Stopwatch clock;
  GraspPlanResult result;
  const ArmKinematics& kin = collision.kinematics();
  result.joint_names = kin.jointNames();
  result.planner = params.motion.planner;
  auto finish = [&](const std::string& status) {
    result.status = status;
    result.planning_time_s = clock.elapsedSeconds();
    return result;
  };
  auto skipAll = [&](const std::string& reason) {
    for (std::size_t i = 0; i < grasps.size(); ++i)
      result.skipped_reasons.push_back("grasp " + std::to_string(i) + ": " + reason);
  };
  if (start.size() != static_cast<Eigen::Index>(kin.dof()) || !start.allFinite())
  {
    skipAll("start state invalid");
    return finish("start state invalid: need " + std::to_string(kin.dof()) + " finite joint positions");
  }
  if (!kin.withinLimits(start, 1e-6))
  {
    skipAll("start state outside the joint limits");
    return finish("start state outside the joint limits: " + describe(start));
  }
  std::string why;
  if (collision.inCollision(start, CollisionCheckOptions(), &why))
  {
    skipAll("start in collision");
    return finish("start in collision: " + why);
  }
  if (grasps.empty())
    return finish("no grasps given");

  TimingLimits timing = params.timing;
  timing.velocity_rad_s = params.velocity_limit_rad_s.size() > 0 ? params.velocity_limit_rad_s : kin.velocityLimits();
  timing.acceleration_rad_s2 = params.acceleration_limit_rad_s2.size() > 0 ?
                                   params.acceleration_limit_rad_s2 :
                                   Eigen::VectorXd::Constant(static_cast<Eigen::Index>(kin.dof()), 2.0);
  const ArmMotionPlanner planner(collision);
  CollisionCheckOptions approach_options;
  approach_options.allow_finger_target_contact = true;
  CollisionCheckOptions lift_options;
  lift_options.ignore_target = true;

  for (std::size_t i = 0; i < grasps.size(); ++i)
  {
    const std::string tag = "grasp " + std::to_string(i) + ": ";
    const double remaining = params.total_time_budget_s - clock.elapsedSeconds();
    if (remaining <= 0.0)
    {
      result.skipped_reasons.push_back(tag + "not tried (time budget spent)");
      continue;
    }
    const GraspCandidate& grasp = grasps[i];
    if (!grasp.pose.matrix().allFinite())
    {
      result.skipped_reasons.push_back(tag + "NaN pose");
      continue;
    }
    Eigen::Isometry3d pregrasp = grasp.pose;
    pregrasp.translation() -= params.approach_distance_m * grasp.approach().normalized();
    Eigen::Isometry3d lifted = grasp.pose;
    lifted.translation().z() += params.lift_distance_m;

    IkParams ik = params.ik;
    ik.max_solutions = std::max(1, params.max_ik_solutions);
    ik.timeout_s = std::max(ik.timeout_s, 0.02);  // several distinct solutions need more restarts
    const std::vector<Eigen::VectorXd> grasp_solutions = kin.ik(grasp.pose, start, ik);
    if (grasp_solutions.empty())
    {
      result.skipped_reasons.push_back(tag + "unreachable (no IK solution)");
      continue;
    }
    // Candidates: grasp configuration, its approach line (pre-grasp first) and its lift line.
    struct Candidate
    {
      std::vector<Eigen::VectorXd> approach, lift;
    };
    std::vector<Candidate> candidates;
    std::string last_reason;
    for (const Eigen::VectorXd& q_grasp : grasp_solutions)
    {
      std::string contact;
      if (collision.inCollision(q_grasp, approach_options, &contact))
      {
        last_reason = "grasp pose in collision (" + contact + ")";
        continue;
      }
      std::vector<Eigen::VectorXd> back = planCartesianLine(collision, q_grasp, pregrasp, params, approach_options, &contact);
      if (back.empty())
      {
        last_reason = "approach blocked (" + contact + ")";
        continue;
      }
      if (!planner.isValid(back.back(), params.motion, &contact))
      {
        last_reason = "pre-grasp invalid (" + contact + ")";
        continue;
      }
      std::vector<Eigen::VectorXd> lift = planCartesianLine(collision, q_grasp, lifted, params, lift_options, &contact);
      if (lift.empty())
      {
        last_reason = "lift blocked (" + contact + ")";
        continue;
      }
      std::reverse(back.begin(), back.end());
      candidates.push_back({ back, lift });
    }
    if (candidates.empty())
    {
      result.skipped_reasons.push_back(tag + (last_reason.empty() ? "unreachable" : last_reason));
      continue;
    }
    std::vector<Eigen::VectorXd> goals;
    for (const Candidate& c : candidates)
      goals.push_back(c.approach.front());
    MotionPlanningParams motion = params.motion;
    motion.planning_time_s = std::min(motion.planning_time_s, params.total_time_budget_s - clock.elapsedSeconds());
    if (motion.planning_time_s <= 0.0)
    {
      result.skipped_reasons.push_back(tag + "not tried (time budget spent)");
      continue;
    }
    const MotionPlanResult plan = planner.plan(start, goals, motion);
    if (!plan.ok())
    {
      result.skipped_reasons.push_back(tag + (plan.status == MotionPlanStatus::NoPath ? "no path in time" : toString(plan.status)) +
                                       " (" + plan.message + ")");
      continue;
    }
    // The goal set was reached at one of the candidates' pre-grasps.
    std::size_t chosen = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < candidates.size(); ++c)
    {
      const double d = (candidates[c].approach.front() - plan.path.back()).norm();
      if (d < best)
      {
        best = d;
        chosen = c;
      }
    }
    const Candidate& cand = candidates[chosen];
    std::vector<TrajectoryPoint> to_pregrasp, approach, lift;
    std::string timing_error;
    std::vector<Eigen::VectorXd> free_path = plan.path;
    free_path.back() = cand.approach.front();  // exact goal state (the planner's copy may round)
    if (!timeParameterize(free_path, timing, to_pregrasp, &timing_error) ||
        !timeParameterize(cand.approach, timing, approach, &timing_error) ||
        !timeParameterize(cand.lift, timing, lift, &timing_error))
    {
      result.skipped_reasons.push_back(tag + "time parameterisation failed (" + timing_error + ")");
      continue;
    }
    result.points = to_pregrasp;
    result.pregrasp_point_index = result.points.size() - 1;
    appendTrajectory(result.points, approach);
    result.grasp_point_index = result.points.size() - 1;
    appendTrajectory(result.points, lift);
    result.waypoints = free_path;
    result.waypoints.insert(result.waypoints.end(), cand.approach.begin() + 1, cand.approach.end());
    result.waypoints.insert(result.waypoints.end(), cand.lift.begin() + 1, cand.lift.end());
    result.success = true;
    result.grasp_index = static_cast<int>(i);
    return finish("grasp " + std::to_string(i) + " planned with " + params.motion.planner + " in " +
                  std::to_string(clock.elapsedSeconds()) + " s, " + std::to_string(result.points.size()) +
                  " trajectory points, duration " + std::to_string(result.points.back().time_from_start_s) + " s");
  }
  return finish("no grasp reachable and plannable (" + std::to_string(result.skipped_reasons.size()) + " skipped)");
}

namespace
{
Eigen::Vector3d readVector3(const YAML::Node& node, const std::string& key, const std::string& file)
{
  const Eigen::VectorXd v = readVector(node, key, file);
  if (v.size() != 3)
    throw std::runtime_error("scene '" + file + "': '" + key + "' needs 3 numbers");
  return v;
}

Eigen::Isometry3d readGraspPose(const YAML::Node& node, const std::string& file)
{
  return makeGraspPose(readVector3(node, "position", file), readVector3(node, "approach", file),
                       readVector3(node, "closing", file));
}
}  // namespace

ArmScene loadArmScene(const std::string& yaml_path)
{
  YAML::Node root;
  try
  {
    root = YAML::LoadFile(yaml_path);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error("scene '" + yaml_path + "': " + e.what());
  }
  ArmScene scene;
  try
  {
    readScalar(root, "name", scene.name);
    readScalar(root, "description", scene.description);
    scene.seed_joints = readVector(root, "seed_joints", yaml_path);
    if (scene.seed_joints.size() == 0)
    {
      scene.seed_joints.resize(6);
      scene.seed_joints << 0.0, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0.0;
    }
    scene.start_joints = readVector(root, "start_joints", yaml_path);
    if (root["start_pose"])
    {
      scene.has_start_pose = true;
      scene.start_pose = readGraspPose(root["start_pose"], yaml_path);
    }
    if (root["goal_joints"])
      scene.goal_joints.push_back(readVector(root, "goal_joints", yaml_path));
    if (root["goal_pose"])
    {
      scene.has_goal_pose = true;
      scene.goal_pose = readGraspPose(root["goal_pose"], yaml_path);
    }
    readScalar(root, "keep_gripper_horizontal", scene.keep_gripper_horizontal);
    readScalar(root, "horizontal_tolerance_rad", scene.horizontal_tolerance_rad);
    if (root["boxes"])
    {
      for (const YAML::Node& b : root["boxes"])
      {
        ArmScene::Box box;
        readScalar(b, "name", box.name);
        box.size_m = readVector3(b, "size", yaml_path);
        box.pose.translation() = readVector3(b, "position", yaml_path);
        if (b["rpy"])
        {
          const Eigen::Vector3d rpy = readVector3(b, "rpy", yaml_path);
          box.pose.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
        }
        scene.boxes.push_back(box);
      }
    }
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("scene '" + yaml_path + "': bad value: " + e.what());
  }
  if (scene.start_joints.size() == 0 && !scene.has_start_pose)
    throw std::runtime_error("scene '" + yaml_path + "': needs start_joints or start_pose");
  if (scene.goal_joints.empty() && !scene.has_goal_pose)
    throw std::runtime_error("scene '" + yaml_path + "': needs goal_joints or goal_pose");
  return scene;
}

void addSceneBoxes(const ArmScene& scene, RobotCollision& collision)
{
  for (const ArmScene::Box& box : scene.boxes)
    collision.addBox(box.name, box.size_m, box.pose);
}

bool resolveScene(const ArmScene& scene, const ArmMotionPlanner& planner, const MotionPlanningParams& motion,
                  Eigen::VectorXd& start, std::vector<Eigen::VectorXd>& goals, std::string* why)
{
  const ArmKinematics& kin = planner.collision().kinematics();
  IkParams ik;
  ik.max_solutions = 16;
  ik.timeout_s = 0.05;
  std::string reason;
  if (scene.has_start_pose)
  {
    start.resize(0);
    for (const Eigen::VectorXd& q : kin.ik(scene.start_pose, scene.seed_joints, ik))
      if (planner.isValid(q, motion, &reason))
      {
        start = q;
        break;
      }
    if (start.size() == 0)
      return fail(why, "no valid IK solution for the start pose" + (reason.empty() ? "" : " (" + reason + ")"));
  }
  else
    start = scene.start_joints;
  if (!planner.isValid(start, motion, &reason))
    return fail(why, "start invalid: " + reason);
  goals.clear();
  for (const Eigen::VectorXd& q : scene.goal_joints)
    if (planner.isValid(q, motion, &reason))
      goals.push_back(q);
  if (scene.has_goal_pose)
    for (const Eigen::VectorXd& q : kin.ik(scene.goal_pose, start, ik))
      if (planner.isValid(q, motion, &reason))
        goals.push_back(q);
  if (goals.empty())
    return fail(why, "no valid goal" + (reason.empty() ? "" : " (" + reason + ")"));
  return true;
}

}  // namespace fast_grasp
