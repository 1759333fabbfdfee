#include "fast_grasp/arm/grasp_execution.h"

#include "fast_grasp/core/yaml_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
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

namespace
{
void useRobot(const RobotConfig& robot, GraspExecutionParams& p)
{
  p.robot = robot;
  p.urdf_path = robot.urdf_path;
  p.base_link = robot.base_link;
  p.tip_link = robot.tip_link;
  p.joint_lower_rad = robot.joint_lower_rad;
  p.joint_upper_rad = robot.joint_upper_rad;
  p.velocity_limit_rad_s = robot.velocity_limit_rad_s;
  p.acceleration_limit_rad_s2 = robot.acceleration_limit_rad_s2;
  p.link_padding_m = robot.link_padding_m;
}
}  // namespace

RobotCollision makeRobotCollision(const GraspExecutionParams& params)
{
  if (params.urdf_path.empty())
    throw std::runtime_error("no URDF configured (arm.yaml names no robot)");
  ArmKinematics kinematics = ArmKinematics::fromUrdfFile(params.urdf_path, params.base_link, params.tip_link);
  const std::string limits_problem = applyLimits(params, kinematics);
  if (!limits_problem.empty())
    throw std::runtime_error(limits_problem);
  const std::vector<std::string>& group = params.robot.joints;
  if (!group.empty() && group != kinematics.jointNames())
    throw std::runtime_error("robot '" + params.robot.name + "': the chain " + params.base_link + " -> " +
                             params.tip_link + " has other joints than the configured planning group");
  return params.robot.name.empty() ?
             RobotCollision(kinematics, params.link_padding_m) :
             RobotCollision(kinematics, params.link_padding_m, params.robot.object_contact_links,
                            params.robot.contact_link_padding_m);
}

GraspExecutionParams loadGraspExecutionParams(const std::string& arm_yaml, const std::string& planners_yaml,
                                              const std::string& robot)
{
  YAML::Node root;
  try
  {
    root = loadYamlFile(arm_yaml);
  }
  catch (const std::exception& e)
  {
    throw std::runtime_error("arm config '" + arm_yaml + "': " + e.what());
  }
  GraspExecutionParams p;
  try
  {
    std::string robot_name = robot;
    if (robot_name.empty())
      readScalar(root, "robot", robot_name);
    if (!robot_name.empty())
    {
      const std::size_t slash = arm_yaml.find_last_of('/');
      const std::string config_dir = slash == std::string::npos ? "." : arm_yaml.substr(0, slash);
      useRobot(loadRobotConfig(robotConfigPath(config_dir, robot_name)), p);
    }
    readScalar(root, "approach_distance_m", p.approach_distance_m);
    readScalar(root, "lift_distance_m", p.lift_distance_m);
    readScalar(root, "cartesian_step_m", p.cartesian_step_m);
    readScalar(root, "max_joint_jump_rad", p.max_joint_jump_rad);
    readScalar(root, "octomap_resolution_m", p.octomap_resolution_m);
    readScalar(root, "self_filter_padding_m", p.self_filter_padding_m);
    readScalar(root, "table_band_m", p.table_band_m);
    readScalar(root, "table_thickness_m", p.table_thickness_m);
    readScalar(root, "total_time_budget_s", p.total_time_budget_s);
    readScalar(root, "max_ik_solutions", p.max_ik_solutions);
    readScalar(root, "try_flipped_grasp", p.try_flipped_grasp);
    readScalar(root, "max_approach_tilt_deg", p.max_approach_tilt_deg);
    readScalar(root, "approach_tilt_step_deg", p.approach_tilt_step_deg);
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
    readScalar(root, "max_trajectory_samples", p.timing.max_samples);
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
  positive(p.table_thickness_m, "table_thickness_m");
  if (!(p.max_approach_tilt_deg >= 0.0 && p.max_approach_tilt_deg <= 90.0))
    throw std::runtime_error("arm config '" + arm_yaml + "': 'max_approach_tilt_deg' must be in [0, 90]");
  if (p.max_approach_tilt_deg > 0.0)
    positive(p.approach_tilt_step_deg, "approach_tilt_step_deg");
  if (p.timing.max_samples < 2)
    throw std::runtime_error("arm config '" + arm_yaml + "': 'max_trajectory_samples' must be >= 2");
  if (!(p.table_band_m >= 0.0))
    throw std::runtime_error("arm config '" + arm_yaml + "': 'table_band_m' must be >= 0");
  if ((p.acceleration_limit_rad_s2.array() <= 0.0).any() || (p.velocity_limit_rad_s.array() <= 0.0).any())
    throw std::runtime_error("arm config '" + arm_yaml + "': velocity/acceleration limits must be > 0");
  if (!planners_yaml.empty())
    p.motion.planner_params = loadPlannerParameters(planners_yaml);
  for (const auto& planner : p.robot.planner_parameters)
    for (const auto& kv : planner.second)
      p.motion.planner_params[planner.first][kv.first] = kv.second;
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

std::string buildGraspScene(RobotCollision& collision, const Eigen::VectorXd& robot_state,
                            const GraspSceneClouds& clouds, const GraspExecutionParams& params)
{
  collision.resetScene(params.octomap_resolution_m);
  std::string note;
  pcl::PointCloud<pcl::PointXYZ> obstacles;
  if (clouds.scene)
    obstacles = *clouds.scene;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double offset = 0.0;
  if (clouds.table_plane && clouds.table_plane->allFinite() && clouds.table_plane->head<3>().norm() > 1e-6f)
  {
    const Eigen::Vector4d plane = clouds.table_plane->cast<double>() / clouds.table_plane->head<3>().cast<double>().norm();
    normal = plane.head<3>();
    offset = plane.w();
  }
  if (normal.squaredNorm() > 0.0 && !obstacles.empty())
  {
    // In-plane axes u, v; the table's extent is that of its points along them.
    const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    pcl::PointCloud<pcl::PointXYZ> rest;
    rest.reserve(obstacles.size());
    std::size_t table_points = 0;
    for (const pcl::PointXYZ& p : obstacles.points)
    {
      const Eigen::Vector3d x(p.x, p.y, p.z);
      const double height = normal.dot(x) + offset;
      if (std::isfinite(height) && height <= params.table_band_m && height >= -params.table_thickness_m)
      {
        const Eigen::Vector2d uv(u.dot(x), v.dot(x));
        lo = lo.cwiseMin(uv);
        hi = hi.cwiseMax(uv);
        ++table_points;
      }
      else
        rest.push_back(p);
    }
    if (table_points > 0 && (hi - lo).minCoeff() > 0.0)
    {
      const Eigen::Vector2d centre = 0.5 * (lo + hi);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear().col(0) = u;
      pose.linear().col(1) = v;
      pose.linear().col(2) = normal;
      // On the plane: x = centre.u u + centre.v v - offset n; the box centre half its thickness lower.
      pose.translation() = centre.x() * u + centre.y() * v - (offset + 0.5 * params.table_thickness_m) * normal;
      collision.addBox("table", Eigen::Vector3d(hi.x() - lo.x(), hi.y() - lo.y(), params.table_thickness_m), pose);
      obstacles = rest;
      note = std::to_string(table_points) + " table points as a " + std::to_string(hi.x() - lo.x()).substr(0, 4) +
             " x " + std::to_string(hi.y() - lo.y()).substr(0, 4) + " m box, ";
    }
  }
  if (clouds.scene)
    note += std::to_string(collision.addObstacleCloud(obstacles, robot_state, params.self_filter_padding_m)) +
            " scene points";
  else
    note += "no scene cloud";
  // The unseen part joins the target, not the obstacles: it is where the object's hidden side
  // is, and the grasp planner has already fitted its hand against it at finer than voxel
  // resolution (gripper_volume.h). As a target, the arm and the wrist camera keep out of it
  // and only the object_contact_links may enter it in the final approach; as 5 mm obstacle
  // voxels it rejected every finger the grasp planner had placed beside it (session 21:
  // cracker_box's second frame, every C-shape grasp "octomap / finger_link").
  pcl::PointCloud<pcl::PointXYZ> target;
  if (clouds.object)
    target = *clouds.object;
  std::size_t unseen_points = 0;
  if (clouds.unseen && !clouds.unseen->empty())
  {
    const pcl::PointCloud<pcl::PointXYZ> unseen =
        collision.removeRobotPoints(*clouds.unseen, robot_state, params.self_filter_padding_m);
    unseen_points = unseen.size();
    target += unseen;
  }
  // removeRobotPoints keeps finite points only, so what setTargetCloud counts beyond them is the object's.
  const std::size_t inserted = target.empty() ? 0 : collision.setTargetCloud(target);
  if (clouds.object && !clouds.object->empty())
    note += ", " + std::to_string(inserted - std::min(inserted, unseen_points)) + " object points";
  if (unseen_points > 0)
    note += ", " + std::to_string(unseen_points) + " unseen-part points";
  return note;
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

namespace
{
/// Counts the reasons the IK solutions of one pose failed, for one readable line per grasp.
class ReasonTally
{
public:
  void add(const std::string& reason) { ++counts_[reason]; }
  bool empty() const { return counts_.empty(); }
  std::string summary() const
  {
    std::vector<std::pair<int, std::string>> sorted;
    for (const auto& entry : counts_)
      sorted.emplace_back(-entry.second, entry.first);
    std::sort(sorted.begin(), sorted.end());
    std::string text;
    for (const auto& entry : sorted)
      text += (text.empty() ? "" : "; ") + entry.second + (entry.first < -1 ? " (x" + std::to_string(-entry.first) + ")" : "");
    return text;
  }

private:
  std::map<std::string, int> counts_;
};

/// One way to execute a grasp that puts the fingers on the same contacts (see GraspPlanResult).
struct GraspVariant
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  bool flipped = false;
  double tilt_rad = 0.0;
};

std::string describeVariant(const GraspVariant& v)
{
  std::string text;
  if (v.flipped)
    text = "flipped 180 deg about the approach axis";
  if (v.tilt_rad != 0.0)
  {
    char tilt[96];
    std::snprintf(tilt, sizeof(tilt), "tilted %+.0f deg about the closing axis", v.tilt_rad * 180.0 / M_PI);
    text += (text.empty() ? "" : ", ") + std::string(tilt);
  }
  return text.empty() ? "as given" : text;
}

/// The variants of `pose` other than itself, in the order they are tried: flipped, then tilts
/// of growing size (the one that points the approach further down first), each unflipped and
/// flipped. A tilt rotates about the closing axis through the grasp centre, so the closing line
/// (and with it the contacts) stays where the grasp planner put it.
std::vector<GraspVariant> graspVariants(const Eigen::Isometry3d& pose, const GraspExecutionParams& params)
{
  auto make = [&pose](bool flipped, double tilt) {
    GraspVariant v;
    v.flipped = flipped;
    v.tilt_rad = tilt;
    v.pose = pose;
    v.pose.linear() = pose.linear() * Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitY()).toRotationMatrix();
    if (flipped)
      v.pose.linear() = v.pose.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    return v;
  };
  std::vector<GraspVariant> variants;
  if (params.try_flipped_grasp)
    variants.push_back(make(true, 0.0));
  const double max_tilt = params.max_approach_tilt_deg * M_PI / 180.0;
  const double step = params.approach_tilt_step_deg * M_PI / 180.0;
  if (!(max_tilt > 0.0) || !(step > 0.0))
    return variants;
  // X rotated by +t about Y gains -sin(t) Z: "down" is the sign that lowers X's z component.
  const double down = pose.linear().col(2).z() >= 0.0 ? 1.0 : -1.0;
  for (int k = 1; k * step <= max_tilt + 1e-9; ++k)
    for (const double sign : { down, -down })
      for (const bool flipped : { false, true })
        if (!flipped || params.try_flipped_grasp)
          variants.push_back(make(flipped, sign * k * step));
  return variants;
}

struct GoalCandidate
{
  std::vector<Eigen::VectorXd> approach;  // pre-grasp ... grasp
  std::vector<Eigen::VectorXd> lift;      // grasp ... lifted
};

/// Context shared by the attempts on every pose.
struct PoseAttempt
{
  const RobotCollision& collision;
  const ArmMotionPlanner& planner;
  const GraspExecutionParams& params;
  const Eigen::VectorXd& start;
  std::vector<std::string> hand_links;  // links rigidly attached to the tip (no joint between)
  CollisionCheckOptions approach_options, lift_options;

  PoseAttempt(const RobotCollision& c, const ArmMotionPlanner& p, const GraspExecutionParams& pa,
              const Eigen::VectorXd& s)
    : collision(c), planner(p), params(pa), start(s)
  {
    for (const RobotShape& shape : c.shapes())
      if (shape.body == static_cast<int>(c.kinematics().dof()))
        hand_links.push_back(shape.link);
    approach_options.allow_finger_target_contact = true;
    lift_options.ignore_target = true;
  }

  /// "box table / left_finger_link", "octomap / gripper_palm_link", ...: the hand itself hits
  /// the environment. Its pose is fixed by the tip pose, so every IK solution would too.
  bool handHitsEnvironment(const std::string& contact) const
  {
    if (contact.rfind("self:", 0) == 0)
      return false;
    const std::size_t slash = contact.rfind(" / ");
    return slash != std::string::npos &&
           std::find(hand_links.begin(), hand_links.end(), contact.substr(slash + 3)) != hand_links.end();
  }

  /// Every IK solution of `pose` whose approach and lift lines are clear becomes a goal
  /// candidate; the failures are tallied.
  std::vector<GoalCandidate> candidates(const Eigen::Isometry3d& pose, ReasonTally& tally) const
  {
    const ArmKinematics& kin = collision.kinematics();
    std::vector<GoalCandidate> found;
    Eigen::Isometry3d pregrasp = pose;
    pregrasp.translation() -= params.approach_distance_m * pose.linear().col(0);
    Eigen::Isometry3d lifted = pose;
    lifted.translation().z() += params.lift_distance_m;

    IkParams ik = params.ik;
    ik.max_solutions = std::max(1, params.max_ik_solutions);
    ik.timeout_s = std::max(ik.timeout_s, 0.02);  // several distinct solutions need more restarts
    const std::vector<Eigen::VectorXd> grasp_solutions = kin.ik(pose, start, ik);
    if (grasp_solutions.empty())
    {
      tally.add("unreachable (no IK solution)");
      return found;
    }
    std::vector<Eigen::VectorXd> free_grasp_solutions;
    for (const Eigen::VectorXd& q_grasp : grasp_solutions)
    {
      std::string contact;
      if (collision.inCollision(q_grasp, approach_options, &contact))
      {
        if (handHitsEnvironment(contact))
        {
          tally.add("hand in collision at the grasp pose whatever the arm does (" + contact + ")");
          return found;
        }
        tally.add("grasp pose in collision (" + contact + ")");
        continue;
      }
      free_grasp_solutions.push_back(q_grasp);
      std::vector<Eigen::VectorXd> back = planCartesianLine(collision, q_grasp, pregrasp, params, approach_options, &contact);
      if (back.empty())
      {
        tally.add("approach blocked (" + contact + ")");
        continue;
      }
      std::reverse(back.begin(), back.end());
      addIfLiftable(std::move(back), lifted, found, tally);
    }
    if (!found.empty() || free_grasp_solutions.empty())
      return found;
    // Every clear grasp configuration lost its way back to the pre-grasp (IK branch flips near
    // a singularity, a wrist turning through the table): start from the pre-grasp's own IK
    // solutions instead and keep the straight lines that end at a clear grasp configuration.
    for (const Eigen::VectorXd& q_pre : kin.ik(pregrasp, start, ik))
    {
      std::string contact;
      if (!planner.isValid(q_pre, params.motion, &contact))
        continue;
      std::vector<Eigen::VectorXd> forward = planCartesianLine(collision, q_pre, pose, params, approach_options, &contact);
      if (forward.empty())
      {
        tally.add("approach from the pre-grasp blocked (" + contact + ")");
        continue;
      }
      addIfLiftable(std::move(forward), lifted, found, tally);
    }
    return found;
  }

  void addIfLiftable(std::vector<Eigen::VectorXd> approach, const Eigen::Isometry3d& lifted,
                     std::vector<GoalCandidate>& found, ReasonTally& tally) const
  {
    std::string contact;
    if (!planner.isValid(approach.front(), params.motion, &contact))
    {
      tally.add("pre-grasp invalid (" + contact + ")");
      return;
    }
    for (const GoalCandidate& other : found)
      if ((other.approach.back() - approach.back()).cwiseAbs().maxCoeff() < 1e-3 &&
          (other.approach.front() - approach.front()).cwiseAbs().maxCoeff() < 1e-3)
        return;  // the same configurations, reached from the other end
    std::vector<Eigen::VectorXd> lift = planCartesianLine(collision, approach.back(), lifted, params, lift_options, &contact);
    if (lift.empty())
    {
      tally.add("lift blocked (" + contact + ")");
      return;
    }
    found.push_back({ std::move(approach), std::move(lift) });
  }
};
}  // namespace

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
  const PoseAttempt attempt(collision, planner, params, start);

  // Why each grasp was not used: as given (first pass), then its variants (second pass).
  std::vector<std::string> as_given(grasps.size()), variants_note(grasps.size());

  // Plans from the start to one of `candidates` and fills the result; false with a reason.
  auto planTo = [&](std::size_t i, const GraspVariant& variant, const std::vector<GoalCandidate>& candidates,
                    std::string& failure) {
    std::vector<Eigen::VectorXd> goals;
    for (const GoalCandidate& c : candidates)
      goals.push_back(c.approach.front());
    MotionPlanningParams motion = params.motion;
    motion.planning_time_s = std::min(motion.planning_time_s, params.total_time_budget_s - clock.elapsedSeconds());
    if (motion.planning_time_s <= 0.0)
    {
      failure = "not tried (time budget spent)";
      return false;
    }
    const MotionPlanResult plan = planner.plan(start, goals, motion);
    if (!plan.ok())
    {
      failure = (plan.status == MotionPlanStatus::NoPath ? std::string("no path in time") : toString(plan.status)) +
                " (" + plan.message + ")";
      return false;
    }
    // The goal set was reached at one of the candidates' pre-grasps (on a continuous joint
    // possibly a full turn away from the candidate's angle: the path went the short way).
    std::size_t chosen = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < candidates.size(); ++c)
    {
      const double d = (kin.nearestEquivalent(candidates[c].approach.front(), plan.path.back()) - plan.path.back()).norm();
      if (d < best)
      {
        best = d;
        chosen = c;
      }
    }
    // The approach and lift continue from where the path ends: shifted by those full turns.
    GoalCandidate cand = candidates[chosen];
    const Eigen::VectorXd turns =
        kin.nearestEquivalent(cand.approach.front(), plan.path.back()) - cand.approach.front();
    for (Eigen::VectorXd& q : cand.approach)
      q += turns;
    for (Eigen::VectorXd& q : cand.lift)
      q += turns;
    std::vector<TrajectoryPoint> to_pregrasp, approach, lift;
    std::string timing_error;
    std::vector<Eigen::VectorXd> free_path = plan.path;
    free_path.back() = cand.approach.front();  // exact goal state (the planner's copy may round)
    if (!timeParameterize(free_path, timing, to_pregrasp, &timing_error) ||
        !timeParameterize(cand.approach, timing, approach, &timing_error) ||
        !timeParameterize(cand.lift, timing, lift, &timing_error))
    {
      failure = "time parameterisation failed (" + timing_error + ")";
      return false;
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
    result.flipped = variant.flipped;
    result.tilt_rad = variant.tilt_rad;
    result.executed_pose = variant.pose;
    result.variant = variant.flipped || variant.tilt_rad != 0.0 ? describeVariant(variant) : "";
    return true;
  };
  // One line per grasp not used; near-identical grasps (a planner's neighbours) fail alike,
  // so a repeated reason refers back instead of being spelled out again.
  auto collectSkipped = [&]() {
    std::map<std::string, std::size_t> first_with;
    for (std::size_t k = 0; k < grasps.size(); ++k)
    {
      if (as_given[k].empty())
        continue;
      const std::string reason = as_given[k] + (variants_note[k].empty() ? "" : "; " + variants_note[k]);
      const auto seen = first_with.find(reason);
      if (seen != first_with.end())
        result.skipped_reasons.push_back("grasp " + std::to_string(k) + ": as grasp " + std::to_string(seen->second));
      else
      {
        first_with[reason] = k;
        result.skipped_reasons.push_back("grasp " + std::to_string(k) + ": " + reason);
      }
    }
  };
  auto finishPlanned = [&](std::size_t i) {
    collectSkipped();
    return finish("grasp " + std::to_string(i) + (result.variant.empty() ? "" : " (" + result.variant + ")") +
                  " planned with " + params.motion.planner + " in " + std::to_string(clock.elapsedSeconds()) + " s, " +
                  std::to_string(result.points.size()) + " trajectory points, duration " +
                  std::to_string(result.points.back().time_from_start_s) + " s");
  };

  // First pass: every grasp as the grasp planner gave it, best first. A variant of a better
  // grasp is not preferred to a worse grasp as given: the planner's ranking holds first.
  std::vector<bool> worth_varying(grasps.size(), false);
  for (std::size_t i = 0; i < grasps.size(); ++i)
  {
    if (params.total_time_budget_s - clock.elapsedSeconds() <= 0.0)
    {
      as_given[i] = "not tried (time budget spent)";
      continue;
    }
    const GraspCandidate& grasp = grasps[i];
    if (!grasp.pose.matrix().allFinite())
    {
      as_given[i] = "NaN pose";
      continue;
    }
    GraspVariant given;
    given.pose = grasp.pose;
    ReasonTally tally;
    const std::vector<GoalCandidate> candidates = attempt.candidates(given.pose, tally);
    worth_varying[i] = true;
    if (candidates.empty())
    {
      as_given[i] = tally.empty() ? "unreachable" : tally.summary();
      continue;
    }
    std::string failure;
    if (planTo(i, given, candidates, failure))
      return finishPlanned(i);
    as_given[i] = failure;
  }
  // Second pass: the same contacts reached differently (flipped hand, tilted approach).
  for (std::size_t i = 0; i < grasps.size(); ++i)
  {
    if (!worth_varying[i])
      continue;
    const std::vector<GraspVariant> variants = graspVariants(grasps[i].pose, params);
    if (variants.empty())
      continue;
    ReasonTally tally;
    std::size_t tried = 0;
    for (const GraspVariant& variant : variants)
    {
      if (params.total_time_budget_s - clock.elapsedSeconds() <= 0.0)
        break;
      ++tried;
      const std::vector<GoalCandidate> candidates = attempt.candidates(variant.pose, tally);
      if (candidates.empty())
        continue;
      std::string failure;
      if (planTo(i, variant, candidates, failure))
        return finishPlanned(i);
      tally.add(failure);
    }
    variants_note[i] = "flipped/tilted variants: " + std::to_string(tried) + " of " + std::to_string(variants.size()) +
                       " tried" + (tally.empty() ? "" : " (" + tally.summary() + ")");
  }
  collectSkipped();
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
    root = loadYamlFile(yaml_path);
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
    readScalar(root, "joints_robot", scene.joints_robot);
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

ArmScene sceneForRobot(const ArmScene& scene, const RobotConfig& robot, const std::vector<std::string>& joint_names)
{
  ArmScene out = scene;
  for (ArmScene::Box& box : out.boxes)
    box.pose.translation() -= robot.benchmark_base_m;
  out.start_pose.translation() -= robot.benchmark_base_m;
  out.goal_pose.translation() -= robot.benchmark_base_m;
  if (scene.joints_robot != robot.name && !robot.home_pose_rad.empty())
  {
    const Eigen::VectorXd home = robot.homePose(joint_names);
    out.joints_robot = robot.name;
    out.seed_joints = home;
    if (!out.has_start_pose)
      out.start_joints = home;
    out.goal_joints.clear();
  }
  return out;
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
