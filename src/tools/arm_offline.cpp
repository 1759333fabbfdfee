// arm_offline: one bag frame through the perception core, a grasp planner and the arm
// planner core (planGraspMotion), without a roscore. Prints every grasp, why each one was
// skipped and the grasp the trajectory ends at. Builds the collision scene the way the
// ArmPlanner nodelet does (scene cloud minus the arm at the start state, the object as the
// target, the unseen part behind it as an obstacle), so an arm failure of a pipeline rostest
// can be reproduced and iterated on here. Debugging aid; exit 0 when a motion was planned.
//
//   arm_offline --bag bags/cup.bag [--algorithm principal_axis|cshape|boundary|concavity] [--frame N]
//               [--gripper lacquey_fetch] [--max-grasps N] [--planner NAME] [--verbose]
#include "command_line.h"
#include "offline_arm_scene.h"

#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/core/gripper_model.h"

#include <pcl/console/print.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
const std::string kSource = FAST_GRASP_SOURCE_DIR;

struct Options
{
  std::string bag_path;
  int frame_index = 0;
  std::string algorithm = "principal_axis";
  std::string gripper = "lacquey_fetch";
  std::string arm_config = kSource + "/config/arm.yaml";
  std::string planners_config = kSource + "/config/planners.yaml";
  std::string planner;  // empty: arm.yaml's
  std::string robot = "ur5";  // config/robots/<robot>.yaml
  std::size_t max_grasps = 0;
  bool verbose = false;
  bool first_camera_only = false;  // unseen part from the first camera alone (the nodelet before sensor_frames)
  int explain_grasp = -1;  // >= 0: list every IK solution of this grasp and why it is invalid
};

std::string describePose(const Eigen::Isometry3d& pose)
{
  char text[256];
  const Eigen::Vector3d t = pose.translation(), x = pose.linear().col(0), y = pose.linear().col(1);
  std::snprintf(text, sizeof(text), "at (%.3f %.3f %.3f) approach (%.2f %.2f %.2f) closing (%.2f %.2f %.2f)", t.x(),
                t.y(), t.z(), x.x(), x.y(), x.z(), y.x(), y.y(), y.z());
  return text;
}

int run(const Options& options)
{
  const BagFramePerception perception = perceiveBagFrame(options.bag_path, options.frame_index);
  const PreparedView& prepared = perception.prepared;

  const GripperModel gripper = loadGripperModel(kSource + "/config/grippers/" + options.gripper + ".yaml");
  const GraspPlannerConfig config = loadGraspPlannerConfig(kSource + "/config/grasp_planners.yaml");
  const std::unique_ptr<GraspPlanner> planner = makeGraspPlanner(options.algorithm, config);
  if (!planner)
    throw std::runtime_error("--algorithm: '" + options.algorithm + "' is none of principal_axis, cshape, boundary, concavity");
  GraspResult grasps = planner->plan(prepared.view, gripper);
  std::cout << options.algorithm << ": " << grasps.grasps.size() << " grasps (" << grasps.message << ")\n";
  if (!grasps.ok())
    return 1;
  if (options.max_grasps > 0 && grasps.grasps.size() > options.max_grasps)
    grasps.grasps.resize(options.max_grasps);

  OfflineArm arm = loadOfflineArm(options.arm_config, options.planners_config, options.planner, options.robot);
  const GraspExecutionParams& params = arm.params;
  const ArmKinematics& kinematics = arm.kinematics;
  const RobotCollision& collision = arm.collision;
  const Eigen::VectorXd& start = arm.start;
  std::cout << "scene: " << buildOfflineArmScene(arm, perception, options.first_camera_only) << "\n";
  if (options.verbose)
    for (std::size_t i = 0; i < grasps.grasps.size(); ++i)
      std::cout << "  grasp " << i << " " << describePose(grasps.grasps[i].pose) << " width "
                << grasps.grasps[i].width_m << "\n";

  if (options.explain_grasp >= 0 && static_cast<std::size_t>(options.explain_grasp) < grasps.grasps.size())
  {
    const GraspCandidate& grasp = grasps.grasps[static_cast<std::size_t>(options.explain_grasp)];
    for (const bool flipped : { false, true })
    {
      Eigen::Isometry3d pose = grasp.pose;
      if (flipped)
        pose.linear() = pose.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
      IkParams ik = params.ik;
      ik.max_solutions = 64;
      ik.timeout_s = 0.5;
      const std::vector<Eigen::VectorXd> solutions = kinematics.ik(pose, start, ik);
      std::cout << "grasp " << options.explain_grasp << (flipped ? " flipped" : "") << ": " << solutions.size()
                << " IK solutions\n";
      CollisionCheckOptions approach;
      approach.allow_finger_target_contact = true;
      for (const Eigen::VectorXd& q : solutions)
      {
        std::string why;
        const bool hit = collision.inCollision(q, approach, &why);
        std::cout << "  q = " << q.transpose() << (hit ? "  COLLISION " + why : "  free") << "\n";
        if (hit && why.rfind("octomap", 0) == 0)
        {
          // Which obstacle voxels does which shape reach (padded shape + half a voxel)?
          std::vector<Eigen::Isometry3d> poses;
          collision.shapePoses(q, poses);
          const double margin = params.link_padding_m + 0.5 * params.octomap_resolution_m;
          for (std::size_t k = 0; k < collision.shapes().size(); ++k)
          {
            const RobotShape& shape = collision.shapes()[k];
            if (shape.type != RobotShape::Type::Box)
              continue;
            int count = 0;
            Eigen::Vector3d example = Eigen::Vector3d::Zero();
            for (const Eigen::Vector3d& c : collision.occupiedVoxelCentres())
            {
              const Eigen::Vector3d local = poses[k].inverse() * c;
              if ((local.cwiseAbs().array() <= 0.5 * shape.size_m.array() + margin).all())
              {
                ++count;
                example = c;
              }
            }
            if (count > 0)
              std::cout << "    " << shape.link << ": " << count << " voxels, e.g. " << example.transpose() << "\n";
          }
        }
      }
    }
  }

  const GraspPlanResult result = planGraspMotion(collision, start, grasps.grasps, params);
  for (const std::string& reason : result.skipped_reasons)
    std::cout << "  skipped " << reason << "\n";
  std::cout << (result.success ? "PLANNED: " : "FAILED: ") << result.status << "\n";
  if (result.success)
    std::cout << "  trajectory ends at " << describePose(kinematics.fk(result.points[result.grasp_point_index].positions))
              << "\n  grasp " << result.grasp_index << " was " << describePose(grasps.grasps[result.grasp_index].pose)
              << "\n";
  return result.success ? 0 : 1;
}

}  // namespace
}  // namespace fast_grasp

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  static const char* const kUsage =
      "usage: arm_offline --bag FILE [--algorithm principal_axis|cshape|boundary|concavity] [--frame N] [--gripper G]\n"
      "                   [--arm-config FILE] [--robot ur5|lwr4|jaco] [--planner NAME] [--max-grasps N] [--explain-grasp N]\n"
      "                   [--first-camera-only] [--verbose]\n"
      "  bag frame -> grasps -> the ArmPlanner's scene -> planGraspMotion, without ROS\n";
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  fast_grasp::Options options;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        fast_grasp::exitWithUsage("arm_offline: " + flag + " needs a value", kUsage);
      return argv[++i];
    };
    if (flag == "--bag")
      options.bag_path = value();
    else if (flag == "--frame")
      options.frame_index = std::stoi(value());
    else if (flag == "--algorithm")
      options.algorithm = value();
    else if (flag == "--gripper")
      options.gripper = value();
    else if (flag == "--arm-config")
      options.arm_config = value();
    else if (flag == "--planner")
      options.planner = value();
    else if (flag == "--robot")
      options.robot = value();
    else if (flag == "--max-grasps")
      options.max_grasps = static_cast<std::size_t>(std::stoul(value()));
    else if (flag == "--explain-grasp")
      options.explain_grasp = std::stoi(value());
    else if (flag == "--first-camera-only")
      options.first_camera_only = true;
    else if (flag == "--verbose")
      options.verbose = true;
    else
      fast_grasp::exitWithUsage("arm_offline: unknown flag " + flag, kUsage);
  }
  if (options.bag_path.empty())
  {
    std::cerr << "arm_offline: --bag is required\n";
    return 2;
  }
  try
  {
    return fast_grasp::run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "arm_offline: " << e.what() << "\n";
    return 1;
  }
}
