// The perception half of the pipeline for the offline tools (grasp_offline, bench_grasps):
// raw camera cloud(s) -> ObjectView (object with normals in base_link, sensor origins, table
// plane), i.e. what the CloudPreprocess -> TableSegmentation -> NormalEstimation (-> CloudFusion)
// nodelets do online, as one call on the same core functions. ROS-free.
#pragma once

#include "bag_frames.h"

#include "fast_grasp/perception/cloud_preprocess.h"
#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/perception/normal_estimation.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace fast_grasp
{
/// One camera's cloud as recorded. Exactly one of the two cloud pointers is set.
struct SensorCloud
{
  pcl::PointCloud<pcl::PointXYZRGB>::ConstPtr rgb_cloud;
  CloudXYZ::ConstPtr xyz_cloud;
  /// Maps the cloud's coordinates into the base frame (identity for a cloud saved in base_link).
  Eigen::Isometry3f cloud_to_base = Eigen::Isometry3f::Identity();
  /// Optical centre of the camera in the base frame. Unset: the translation of
  /// `cloud_to_base` (true for a cloud in the camera frame). For a cloud already in the base
  /// frame set it, and the camera is then taken to look at the centroid of its points.
  std::optional<Eigen::Vector3f> sensor_origin;
};

/// A bag frame (organised camera cloud + its static camera pose) as a SensorCloud.
SensorCloud sensorCloudFromBagFrame(const BagFrame& frame);

/// The x, y, z fields of a PCD file (any PCL-readable encoding), or null with `error` saying why
/// (unreadable header, no fields, a missing axis, bad data). grasp_offline's --pcd input;
/// test/fuzz/fuzz_pcd_input.cpp feeds it arbitrary files.
CloudXYZ::Ptr readPcdCloud(const std::string& path, std::string& error);

struct ViewPreparationParams
{
  PreprocessParams preprocess;
  TableSegmentationParams segmentation;
  NormalParams normals;
  /// false: the input holds the object only (no table fit, no clustering).
  bool segment_table = true;
  /// Table plane a, b, c, d (base frame) handed to the planner instead of the fitted one
  /// (the only one with segment_table = false). (a, b, c) need not be unit; it is normalised
  /// and turned to point from the table toward the object.
  std::optional<Eigen::Vector4f> table_plane;
  /// > 0: resample the object to exactly this many points before the normals (benchmarks at a
  /// fixed size): a random subset, or every point plus jittered copies when it has fewer.
  std::size_t resample_to = 0;
  /// Also prepare every other cluster as an object view (PreparedView::objects).
  bool all_objects = false;
};

/// The values config/perception.yaml gives the perception nodelets where they differ from the
/// structs' defaults (height band, object distance), so the tools see what the robot sees.
/// Kept in step with that file by hand.
ViewPreparationParams deployedViewPreparationParams();

/// Where preparation stopped.
enum class ViewStage
{
  None,          // usable
  Preprocess,    // reach filter / NaN removal / voxel grid left nothing usable
  Segmentation,  // no table, no cluster, object out of reach, ...
  Normals        // too few points or degenerate neighbourhoods
};
const char* toString(ViewStage stage);

struct PreparedView
{
  ObjectView view;
  std::size_t points = 0;  // object points with normals (view.cloud->size())
  ViewStage failed_stage = ViewStage::None;
  /// Typed failure token for machine consumers: "PreprocessFailed", "NormalsFailed", or the
  /// segmentation failure ("NoPlane", "NoCluster", "ObjectOutOfReach", "InvalidInput").
  std::string status = "ok";
  std::string problem;  // "<stage>: <reason>"; empty when usable
  /// Axis-aligned bounds and centroid of the object points (base frame), valid when usable.
  Eigen::Vector3f object_min = Eigen::Vector3f::Zero();
  Eigen::Vector3f object_max = Eigen::Vector3f::Zero();
  Eigen::Vector3f object_centroid = Eigen::Vector3f::Zero();
  /// all_objects: the target (`view`, first) and every other cluster with normals, each with
  /// the same sensor origins and table plane; empty otherwise.
  std::vector<ObjectView> objects;
  bool ok() const { return failed_stage == ViewStage::None; }
};

/// Perception core on one camera cloud, or on several fused (the first is the reference camera:
/// its pose aims the target-cluster choice). Each normal is oriented toward the camera that
/// saw its point. `rng` is used only for resampling. Never throws on bad input: the failure
/// comes back typed in PreparedView.
PreparedView prepareView(const std::vector<SensorCloud>& clouds, const ViewPreparationParams& params, std::mt19937& rng);

}  // namespace fast_grasp
