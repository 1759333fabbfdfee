// fast_grasp/TableSegmentation: RANSAC table, clusters above it, target object choice
// (thesis Ch3.2 step 1 / Ch6.2 step 1). Thin wrapper around segmentTable().
#include "fast_grasp/perception/cloud_checks.h"
#include "fast_grasp/nodelets/cloud_nodelet.h"
#include "fast_grasp/nodelets/shared_cloud.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <fast_grasp/SegmentedScene.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
bool readVector3(ros::NodeHandle& pnh, const std::string& name, Eigen::Vector3f& value, std::string& bad)
{
  std::vector<double> v{ value.x(), value.y(), value.z() };
  pnh.param(name, v, v);
  if (v.size() != 3)
  {
    bad = name + " must have 3 elements";
    return false;
  }
  value = Eigen::Vector3d(v[0], v[1], v[2]).cast<float>();
  return true;
}
}  // namespace

class TableSegmentationNodelet : public CloudNodelet<CloudXYZ>
{
public:
  ~TableSegmentationNodelet() override { stopInputs(); }  // before the members below go (CloudNodeletBase::stopInputs)

private:
  std::string readParameters(ros::NodeHandle& pnh) override;
  void advertiseOutputs(ros::NodeHandle& pnh) override;
  void process(const InputConstPtr& msg) override;
  void publishScene(const CloudXYZ& input, const TableSegmentationResult& result, const std::string& status);

  TableSegmentationParams params_;
  int max_input_points_ = 2000000;

  ros::Publisher object_pub_;
  ros::Publisher scene_pub_;
  ros::Publisher table_pub_;
  ros::Publisher segmented_scene_pub_;
  ros::Publisher objects_pub_;  // every cluster, labelled (a planner with ~all_objects)
};

std::string TableSegmentationNodelet::readParameters(ros::NodeHandle& pnh)
{
  pnh.param("plane_distance_m", params_.plane_distance_m, params_.plane_distance_m);
  pnh.param("ransac_max_iterations", params_.ransac_max_iterations, params_.ransac_max_iterations);
  pnh.param("max_table_tilt_rad", params_.max_table_tilt_rad, params_.max_table_tilt_rad);
  pnh.param("min_table_points", params_.min_table_points, params_.min_table_points);
  pnh.param("min_height_above_table_m", params_.min_height_above_table_m, params_.min_height_above_table_m);
  pnh.param("cluster_tolerance_m", params_.cluster_tolerance_m, params_.cluster_tolerance_m);
  pnh.param("min_cluster_points", params_.min_cluster_points, params_.min_cluster_points);
  pnh.param("max_cluster_points", params_.max_cluster_points, params_.max_cluster_points);
  pnh.param("max_object_distance_m", params_.max_object_distance_m, params_.max_object_distance_m);
  pnh.param("split_concave_creases", params_.split_concave_creases, params_.split_concave_creases);
  pnh.param("concave_k_neighbours", params_.concave_split.k_neighbours, params_.concave_split.k_neighbours);
  pnh.param("concave_link_radius_m", params_.concave_split.link_radius_m, params_.concave_split.link_radius_m);
  pnh.param("concave_tolerance_rad", params_.concave_split.concave_tolerance_rad, params_.concave_split.concave_tolerance_rad);
  pnh.param("concave_min_piece_points", params_.concave_split.min_piece_points, params_.concave_split.min_piece_points);
  pnh.param("concave_min_standing_piece_points", params_.concave_split.min_standing_piece_points,
            params_.concave_split.min_standing_piece_points);
  pnh.param("inside_concave_fraction", params_.concave_split.concave_piece_fraction, params_.concave_split.concave_piece_fraction);
  pnh.param("inside_bent_pair_rad", params_.concave_split.bent_pair_rad, params_.concave_split.bent_pair_rad);
  pnh.param("inside_pair_min_distance_m", params_.concave_split.bend_min_distance_m, params_.concave_split.bend_min_distance_m);
  pnh.param("inside_pair_max_distance_m", params_.concave_split.bend_max_distance_m, params_.concave_split.bend_max_distance_m);
  pnh.param("inside_pair_samples", params_.concave_split.bend_samples, params_.concave_split.bend_samples);
  pnh.param("standing_height_m", params_.concave_split.standing_height_m, params_.concave_split.standing_height_m);
  pnh.param("bottom_band_m", params_.concave_split.bottom_band_m, params_.concave_split.bottom_band_m);
  pnh.param("floating_seen_fraction", params_.concave_split.floating_seen_fraction, params_.concave_split.floating_seen_fraction);
  pnh.param("table_cell_m", params_.concave_split.table_cell_m, params_.concave_split.table_cell_m);
  pnh.param("join_occluded_pieces", params_.join_occluded_pieces, params_.join_occluded_pieces);
  pnh.param("occlusion_max_gap_m", params_.occlusion_join.max_gap_m, params_.occlusion_join.max_gap_m);
  pnh.param("occlusion_max_top_difference_m", params_.occlusion_join.max_top_difference_m,
            params_.occlusion_join.max_top_difference_m);
  pnh.param("occlusion_sample_step_m", params_.occlusion_join.sample_step_m, params_.occlusion_join.sample_step_m);
  pnh.param("occlusion_hidden_margin_m", params_.occlusion_join.hidden_margin_m, params_.occlusion_join.hidden_margin_m);
  pnh.param("occlusion_angular_cell", params_.occlusion_join.angular_cell, params_.occlusion_join.angular_cell);
  pnh.param("join_container_insides", params_.join_container_insides, params_.join_container_insides);
  pnh.param("container_min_across_overlap", params_.container_join.min_across_overlap, params_.container_join.min_across_overlap);
  pnh.param("container_max_top_difference_m", params_.container_join.max_top_difference_m, params_.container_join.max_top_difference_m);
  pnh.param("container_max_depth_to_width", params_.container_join.max_depth_to_width, params_.container_join.max_depth_to_width);
  pnh.param("join_lying_necks", params_.join_lying_necks, params_.join_lying_necks);
  pnh.param("neck_min_elongation", params_.neck_join.min_elongation, params_.neck_join.min_elongation);
  pnh.param("neck_max_gap_m", params_.neck_join.max_gap_m, params_.neck_join.max_gap_m);
  pnh.param("neck_standing_height_m", params_.neck_join.standing_height_m, params_.neck_join.standing_height_m);
  pnh.param("merge_stacked_clusters", params_.merge_stacked_clusters, params_.merge_stacked_clusters);
  pnh.param("stacked_overlap_fraction", params_.stacked_overlap_fraction, params_.stacked_overlap_fraction);
  pnh.param("max_input_points", max_input_points_, max_input_points_);
  std::string target = toString(params_.target);
  pnh.param("target_cluster", target, target);

  std::string bad;
  if (!parseTargetCluster(target, params_.target))
    bad = "target_cluster '" + target + "' is not one of nearest | largest | closest_to_point";
  else if (max_input_points_ < 1)
    bad = "max_input_points must be >= 1";
  for (const auto& [name, value] : { std::make_pair("up_axis", &params_.up_axis),
                                      std::make_pair("reference_point_m", &params_.reference_point_m),
                                      std::make_pair("target_point_m", &params_.target_point_m) })
  {
    if (bad.empty())
      readVector3(pnh, name, *value, bad);
  }
  if (bad.empty())
  {
    // The core validates the numbers; probe it with an empty cloud.
    const TableSegmentationResult probe = segmentTable(std::make_shared<CloudXYZ>(), params_);
    if (probe.reason.rfind("invalid parameters", 0) == 0)
      bad = probe.reason;
  }
  if (!bad.empty())
    return bad;
  NODELET_DEBUG("plane_distance_m %.4f, cluster_tolerance_m %.3f, target %s", params_.plane_distance_m,
                params_.cluster_tolerance_m, toString(params_.target));
  return {};
}

void TableSegmentationNodelet::advertiseOutputs(ros::NodeHandle& pnh)
{
  object_pub_ = advertise<CloudXYZ>(pnh, "object", kOutputQueueSize);
  scene_pub_ = advertise<CloudXYZ>(pnh, "scene", kOutputQueueSize);
  table_pub_ = advertise<CloudXYZ>(pnh, "table", kOutputQueueSize);
  segmented_scene_pub_ = advertise<fast_grasp::SegmentedScene>(pnh, "segmented_scene", kOutputQueueSize);
  objects_pub_ = advertise<pcl::PointCloud<pcl::PointXYZL>>(pnh, "objects", kOutputQueueSize);
}

void TableSegmentationNodelet::process(const InputConstPtr& msg)
{
  // Zero-copy view for the core: the std::shared_ptr keeps the boost one alive.
  const CloudXYZ::ConstPtr cloud = toStd(msg);
  const CloudCheck check = checkCloud<PointXYZ>(cloud, static_cast<std::size_t>(max_input_points_));
  if (!check.ok)
  {
    NODELET_ERROR_THROTTLE(5.0, "rejected input: %s", check.reason.c_str());
    status_.error(check.reason);
    TableSegmentationResult nothing;
    nothing.failure = SegmentationFailure::InvalidInput;
    publishScene(*msg, nothing, check.reason);
    return;
  }
  const TableSegmentationResult result = segmentTable(cloud, params_);
  const std::string status = result.ok() ? "ok" : std::string(toString(result.failure)) + ": " + result.reason;
  // Publish what exists even on failure: the scene (for collision) and the table are still
  // meaningful when no object was found.
  for (auto* cloud_out : { result.table.get(), result.scene.get(), result.object.get() })
    cloud_out->header = msg->header;
  // The scene summary (with the table plane) goes first: in one manager a subscriber's callbacks
  // run in arrival order, so a grasp planner has this frame's plane before its object cloud
  // (which reaches it later still, through NormalEstimation).
  publishScene(*msg, result, status);
  if (result.has_plane)
    table_pub_.publish(toBoost(result.table));
  if (result.has_plane || result.ok())
    scene_pub_.publish(toBoost(result.scene));
  if (result.ok())
  {
    const boost::shared_ptr<CloudXYZ> object = toBoost(result.object);
    object_pub_.publish(object);
    publishSentAddress(object.get());
    if (objects_pub_.getNumSubscribers() > 0)
      objects_pub_.publish(toBoost(labelledObjects(*cloud, result)));
  }
  switch (result.failure)
  {
    case SegmentationFailure::None:
      status_.ok(result.reason);
      break;
    case SegmentationFailure::InvalidInput:
      NODELET_ERROR_THROTTLE(5.0, "%s", status.c_str());
      status_.error(status);
      break;
    default:  // no plane, no cluster, out of reach: the scene, not the node, is at fault
      NODELET_WARN_THROTTLE(5.0, "%s", status.c_str());
      status_.warn(status);
  }
}

void TableSegmentationNodelet::publishScene(const CloudXYZ& input, const TableSegmentationResult& result,
                                            const std::string& status)
{
  fast_grasp::SegmentedScene scene;
  scene.header = pcl_conversions::fromPCL(input.header);
  scene.ok = result.ok();
  scene.status = status;
  for (int i = 0; i < 4; ++i)
    scene.table_plane[i] = result.plane[i];
  scene.table_points = result.table ? static_cast<std::uint32_t>(result.table->size()) : 0;
  scene.object_points = result.object ? static_cast<std::uint32_t>(result.object->size()) : 0;
  scene.object_centroid.x = result.object_centroid.x();
  scene.object_centroid.y = result.object_centroid.y();
  scene.object_centroid.z = result.object_centroid.z();
  if (scene.object_points > 0)
  {
    const Eigen::Vector3f extent = result.object_max - result.object_min;
    scene.object_extent.x = extent.x();
    scene.object_extent.y = extent.y();
    scene.object_extent.z = extent.z();
  }
  scene.sensor_origin.x = input.sensor_origin_.x();
  scene.sensor_origin.y = input.sensor_origin_.y();
  scene.sensor_origin.z = input.sensor_origin_.z();
  scene.cluster_count = static_cast<std::uint32_t>(result.clusters.size());
  segmented_scene_pub_.publish(scene);
}

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::TableSegmentationNodelet, nodelet::Nodelet)
