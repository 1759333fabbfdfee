// The ArmPlanner nodelet's inputs for the offline tools (arm_offline, bench_grasp_motions): a
// bag frame through perception as the nodelets run it, the arm as config/arm.yaml configures
// it at the home pose, and the collision scene the nodelet builds from one frame (scene cloud
// minus the arm, the object as the target, the unseen part behind it as an obstacle, the
// table as a box). One implementation, so a benchmark plans against exactly the scene the
// debugging tool shows. ROS-free.
#pragma once

#include "offline_pipeline.h"

#include "fast_grasp/arm/arm_kinematics.h"
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/arm/robot_collision.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace fast_grasp
{
/// One bag frame as the perception nodelets leave it.
struct BagFramePerception
{
  /// The bag camera's frame, plus the head camera's closest frame when the bag has one.
  std::vector<SensorCloud> clouds;
  /// Scene and object clouds (what the ArmPlanner nodelet subscribes to) of the fused clouds.
  TableSegmentationResult segmentation;
  /// The object view the grasp planners get.
  PreparedView prepared;
};

/// Frame `frame_index` of /camera/depth_registered/points (and, in a two-camera bag, the
/// /head_camera frame closest to it in time) preprocessed per camera, concatenated and
/// segmented, plus the prepared object view. Throws std::runtime_error naming the stage that
/// failed (no such frame, preprocess, segmentation, view preparation).
BagFramePerception perceiveBagFrame(const std::string& bag_path, int frame_index);

/// The arm as the ArmPlanner nodelet configures it, at its robot config's home pose.
struct OfflineArm
{
  GraspExecutionParams params;
  ArmKinematics kinematics;  // with params' joint and velocity limits applied
  RobotCollision collision;  // links padded by params.link_padding_m; scene empty until buildOfflineArmScene
  Eigen::VectorXd start;     // home pose, in kinematics.jointNames() order
};

/// Loads arm_yaml and planners_yaml (loadGraspExecutionParams); a non-empty `planner`
/// replaces arm.yaml's OMPL planner, a non-empty `robot` its robot (config/robots/<robot>.yaml).
/// Throws std::runtime_error on a bad file or limit.
OfflineArm loadOfflineArm(const std::string& arm_yaml, const std::string& planners_yaml,
                          const std::string& planner = "", const std::string& robot = "");

/// Fills arm.collision with the nodelet's scene for this frame (buildGraspScene: scene cloud
/// minus the arm at arm.start, the object as the target, the table as a box, the unseen part
/// seen from every camera that saw the object, or from the first only when
/// `first_camera_only`). Returns buildGraspScene's one-line summary.
std::string buildOfflineArmScene(OfflineArm& arm, const BagFramePerception& perception, bool first_camera_only = false);

}  // namespace fast_grasp
