// Scene YAML (config/scenes/*.yaml, format in docs/renderer.md) -> posed triangle parts, objects
// and cameras for the Xtion renderer. Shared by render_bag (scene -> bag) and grasp_offline
// (--scene: render, plan, follow the planner's next view). ROS-free.
#pragma once

#include "fast_grasp/render/xtion_renderer.h"

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace fast_grasp
{
/// part_label of the table and floor, and of the target object's parts.
constexpr int kSceneBackgroundLabel = 0;
constexpr int kSceneTargetLabel = 1;

struct SceneCamera
{
  std::string prefix = "camera";
  Eigen::Isometry3d optical_pose = Eigen::Isometry3d::Identity();  // in base_link
};

struct SceneObject
{
  std::string name;
  std::string source;
  bool target = false;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // base of the object, in base_link
  double height_m = 0.0;
  int label = kSceneTargetLabel;  // part_label of its parts: the target 1, distractors 2, 3, ... in scene order
};

struct SceneDescription
{
  std::string name;
  uint64_t seed = 1;
  int frames = 1;
  std::string compression = "lz4";
  Eigen::Vector4d table_plane{ 0.0, 0.0, 1.0, 0.0 };
  std::vector<ScenePart> parts;
  std::vector<SceneObject> objects;
  std::vector<SceneCamera> cameras;
};

/// Loads a scene YAML. `ycb_dir` holds the YCB STL files that "ycb:NAME" meshes refer to;
/// relative mesh paths are taken from the scene file's folder. Throws std::runtime_error (or
/// YAML::Exception) with the reason on any problem.
SceneDescription loadSceneDescription(const std::string& scene_path, const std::string& ycb_dir);

/// Noise seed of frame `frame` of camera `camera`: render_bag's scheme, so a live or offline
/// render of view 0 is the bundled bag; `view` > 0 (the hand camera moved to a next view) gets
/// seeds of its own.
std::uint64_t renderSeed(const SceneDescription& scene, std::size_t camera, int frame, int view = 0);

/// The fixed <prefix>_link -> <prefix>_rgb_optical_frame transform (REP 103 optical axes); the
/// link's pose in base_link is optical_pose * linkFromOptical().inverse().
Eigen::Isometry3d linkFromOptical();

/// One point per occupied leaf_m voxel: the centroid of its points (pcl::VoxelGrid).
pcl::PointCloud<pcl::PointXYZ> voxelCentroids(const pcl::PointCloud<pcl::PointXYZ>& points, float leaf_m);

/// The whole surface of the parts labelled `label` (posed, base_link; seen by the camera or not):
/// every triangle sampled on a barycentric grid at most spacing_m apart (deterministic, no
/// seed), then reduced to voxel centroids of leaf_m. render_bag's truth (whether a finger enters
/// an object, including the side the camera cannot see) and scene_camera's picks use it.
pcl::PointCloud<pcl::PointXYZ> surfacePoints(const std::vector<ScenePart>& parts, int label, float spacing_m,
                                             float leaf_m);

/// A rendered frame as the organised x y z rgb cloud a registered Xtion gives (camera optical
/// frame, NaN where there is no depth): what render_bag writes into its bags.
pcl::PointCloud<pcl::PointXYZRGB>::Ptr organisedCloud(const RenderedFrame& frame);

}  // namespace fast_grasp
