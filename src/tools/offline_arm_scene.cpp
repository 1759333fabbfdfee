#include "offline_arm_scene.h"

#include "bag_frames.h"

#include "fast_grasp/perception/cloud_preprocess.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <yaml-cpp/yaml.h>

#include <map>
#include <random>
#include <stdexcept>

namespace fast_grasp
{
namespace
{
const std::string kSource = FAST_GRASP_SOURCE_DIR;

std::vector<SensorCloud> readFrameClouds(const std::string& bag_path, int frame_index)
{
  const std::vector<BagFrame> frames = readBagFrames(bag_path, "/camera/depth_registered/points");
  if (frame_index < 0 || static_cast<std::size_t>(frame_index) >= frames.size())
    throw std::runtime_error("bag has " + std::to_string(frames.size()) + " frames");
  const BagFrame& frame = frames[static_cast<std::size_t>(frame_index)];
  std::vector<SensorCloud> clouds{ sensorCloudFromBagFrame(frame) };
  const std::string head_topic = "/head_camera/depth_registered/points";
  if (bagHasTopic(bag_path, head_topic))
  {
    const std::vector<BagFrame> head = readBagFrames(bag_path, head_topic);
    clouds.push_back(sensorCloudFromBagFrame(closestFrame(head, frame.stamp_s)));
  }
  return clouds;
}

}  // namespace

BagFramePerception perceiveBagFrame(const std::string& bag_path, int frame_index)
{
  BagFramePerception perception;
  perception.clouds = readFrameClouds(bag_path, frame_index);

  // Perception as the nodelets run it: preprocess each camera, concatenate (CloudFusion),
  // segment; the scene and object clouds are what the ArmPlanner nodelet subscribes to.
  const ViewPreparationParams params = deployedViewPreparationParams();
  CloudXYZ::Ptr merged;
  for (const SensorCloud& sensor : perception.clouds)
  {
    const PreprocessResult pre = preprocessCloud(*sensor.rgb_cloud, sensor.cloud_to_base, params.preprocess);
    if (!pre.ok)
      throw std::runtime_error("preprocess: " + pre.reason);
    if (!merged)
      merged = pre.cloud;
    else
      *merged += *pre.cloud;
  }
  perception.segmentation = segmentTable(merged, params.segmentation);
  if (!perception.segmentation.ok())
    throw std::runtime_error("segmentation: " + perception.segmentation.reason);
  std::mt19937 rng(0);
  perception.prepared = prepareView(perception.clouds, params, rng);
  if (!perception.prepared.ok())
    throw std::runtime_error(perception.prepared.problem);
  return perception;
}

OfflineArm loadOfflineArm(const std::string& arm_yaml, const std::string& planners_yaml, const std::string& planner,
                          const std::string& robot)
{
  GraspExecutionParams params = loadGraspExecutionParams(arm_yaml, planners_yaml, robot);
  if (!planner.empty())
    params.motion.planner = planner;
  RobotCollision collision = makeRobotCollision(params);
  ArmKinematics kinematics = collision.kinematics();
  Eigen::VectorXd start = params.robot.homePose(kinematics.jointNames());
  return OfflineArm{ std::move(params), std::move(kinematics), std::move(collision), std::move(start) };
}

std::string buildOfflineArmScene(OfflineArm& arm, const BagFramePerception& perception, bool first_camera_only)
{
  // The ArmPlanner nodelet's scene (src/nodelets/arm_planner_nodelet.cpp, plan()).
  const TableSegmentationResult& seg = perception.segmentation;
  GraspSceneClouds scene_clouds;
  scene_clouds.scene = seg.scene.get();
  scene_clouds.object = seg.object.get();
  scene_clouds.table_plane = seg.plane;
  // Every camera that saw the object (the nodelet's sensor_frames): space one of them saw is
  // not unseen.
  std::vector<Eigen::Vector3f> origins = perception.prepared.view.sensor_origins;
  if (first_camera_only)
    origins.resize(1);
  UnseenPartParams unseen_params;  // as the nodelet sets them
  unseen_params.step_m = arm.params.octomap_resolution_m;
  const UnseenPart unseen = buildUnseenPart(*seg.object, origins, unseen_params, scene_clouds.table_plane);
  if (unseen.ok())
    scene_clouds.unseen = &unseen.points;
  return buildGraspScene(arm.collision, arm.start, scene_clouds, arm.params);
}

}  // namespace fast_grasp
