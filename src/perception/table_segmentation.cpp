#include "fast_grasp/perception/table_segmentation.h"

#include "fast_grasp/perception/grid_clusters.h"
#include "fast_grasp/perception/table_footprint.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/common/io.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <sstream>
#include <utility>

namespace fast_grasp
{
bool parseTargetCluster(const std::string& text, TargetCluster& out)
{
  if (text == "center_of_view")
    out = TargetCluster::CenterOfView;
  else if (text == "nearest")
    out = TargetCluster::Nearest;
  else if (text == "largest")
    out = TargetCluster::Largest;
  else if (text == "closest_to_point")
    out = TargetCluster::ClosestToPoint;
  else
    return false;
  return true;
}

const char* toString(TargetCluster target)
{
  switch (target)
  {
    case TargetCluster::CenterOfView:
      return "center_of_view";
    case TargetCluster::Nearest:
      return "nearest";
    case TargetCluster::Largest:
      return "largest";
    case TargetCluster::ClosestToPoint:
      return "closest_to_point";
  }
  return "unknown";
}

const char* toString(SegmentationFailure failure)
{
  switch (failure)
  {
    case SegmentationFailure::None:
      return "none";
    case SegmentationFailure::InvalidInput:
      return "invalid_input";
    case SegmentationFailure::NoPlane:
      return "no_plane";
    case SegmentationFailure::NoCluster:
      return "no_cluster";
    case SegmentationFailure::ObjectOutOfReach:
      return "object_out_of_reach";
  }
  return "unknown";
}

namespace
{
std::string validateParams(const TableSegmentationParams& params)
{
  if (!(params.plane_distance_m > 0.0))
    return "plane_distance_m must be positive";
  if (params.ransac_max_iterations < 1)
    return "ransac_max_iterations must be >= 1";
  if (!params.up_axis.allFinite() || params.up_axis.norm() < 1e-6f)
    return "up_axis must be a non-zero finite vector";
  if (!(params.max_table_tilt_rad >= 0.0 && params.max_table_tilt_rad < M_PI / 2))
    return "max_table_tilt_rad must be in [0, pi/2)";
  if (params.min_table_points < 3)
    return "min_table_points must be >= 3";
  if (!(params.cluster_tolerance_m > 0.0))
    return "cluster_tolerance_m must be positive";
  if (params.min_cluster_points < 1 || params.max_cluster_points < params.min_cluster_points)
    return "need 1 <= min_cluster_points <= max_cluster_points";
  if (params.concave_split.k_neighbours < 3 || !(params.concave_split.link_radius_m > 0.0) ||
      !(params.concave_split.concave_tolerance_rad > 0.0 && params.concave_split.concave_tolerance_rad < M_PI) ||
      params.concave_split.min_piece_points < 1 || params.concave_split.min_standing_piece_points < 0 ||
      params.concave_split.bend_samples < 0 ||
      !(params.concave_split.table_cell_m > 0.0))
    return "concave split: need k_neighbours >= 3, link_radius_m > 0, concave_tolerance_rad in (0, pi), "
           "min_piece_points >= 1, min_standing_piece_points >= 0, bend_samples >= 0, table_cell_m > 0";
  const ContainerJoinParams& container = params.container_join;
  if (!(container.min_across_overlap >= 0.0) || !(container.max_top_difference_m >= 0.0) ||
      !(container.max_depth_to_width >= 0.0 && container.max_depth_to_width <= 100.0))
    return "container join: need min_across_overlap >= 0, max_top_difference_m >= 0, max_depth_to_width in [0, 100]";
  const OcclusionJoinParams& join = params.occlusion_join;
  if (!(join.max_gap_m >= 0.0 && join.max_gap_m <= 10.0) || !(join.max_top_difference_m >= 0.0) ||
      !(join.sample_step_m >= 1e-4) || !(join.hidden_margin_m >= 0.0) || !(join.angular_cell >= 1e-4 && join.angular_cell <= 1.0))
    return "occlusion join: need max_gap_m in [0, 10], max_top_difference_m >= 0, sample_step_m >= 1e-4, "
           "hidden_margin_m >= 0, angular_cell in [1e-4, 1]";
  const NeckJoinParams& neck = params.neck_join;
  if (!(neck.min_elongation >= 0.0 && neck.min_elongation <= 100.0) || !(neck.max_gap_m >= 0.0 && neck.max_gap_m <= 1.0) ||
      !(neck.standing_height_m >= 0.0 && neck.standing_height_m <= 1.0))
    return "neck join: need min_elongation in [0, 100], max_gap_m in [0, 1], standing_height_m in [0, 1]";
  if (!(params.stacked_overlap_fraction > 0.0 && params.stacked_overlap_fraction <= 1.0))
    return "stacked_overlap_fraction must be in (0, 1]";
  if (!params.reference_point_m.allFinite() || !params.target_point_m.allFinite())
    return "reference_point_m and target_point_m must be finite";
  return {};
}

CloudXYZ::Ptr emptyLike(const CloudXYZ& cloud)
{
  auto out = std::make_shared<CloudXYZ>();
  out->header = cloud.header;
  out->sensor_origin_ = cloud.sensor_origin_;
  out->sensor_orientation_ = cloud.sensor_orientation_;
  out->is_dense = true;
  return out;
}

void finishCloud(CloudXYZ& cloud)
{
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
}

/// Fraction of `points` whose projection lies on the footprint of `base`.
double overlapFraction(const CloudXYZ& cloud, const pcl::Indices& points, const pcl::Indices& base,
                       const Eigen::Vector4f& plane, double cell_m)
{
  TableFootprint footprint(plane, cell_m);
  for (const auto i : base)
    footprint.add(cloud.points[i].getVector3fMap(), /*dilate=*/true);
  std::size_t over = 0;
  for (const auto i : points)
    over += footprint.covers(cloud.points[i].getVector3fMap()) ? 1 : 0;
  return points.empty() ? 0.0 : static_cast<double>(over) / static_cast<double>(points.size());
}

struct HeightRange
{
  double low = std::numeric_limits<double>::infinity();
  double high = -std::numeric_limits<double>::infinity();
};

HeightRange heightRange(const CloudXYZ& cloud, const pcl::Indices& points, const Eigen::Vector4f& plane)
{
  HeightRange range;
  for (const auto i : points)
  {
    const double height = plane.head<3>().dot(cloud.points[static_cast<std::size_t>(i)].getVector3fMap()) + plane[3];
    range.low = std::min(range.low, height);
    range.high = std::max(range.high, height);
  }
  return range;
}

/// Merges into clusters[target] every cluster stacked on it: one lies above the other and mostly
/// over its footprint (a cap over a bottle, a stem under a glass bowl). Repeats, since a merged part
/// extends the object. Clusters of the target's gap_group (pieces of its Euclidean cluster)
/// are never merged. Updates target and centroids; returns the number of merged clusters.
int mergeStackedClusters(const CloudXYZ& cloud, const Eigen::Vector4f& plane, const TableSegmentationParams& params,
                         const std::vector<int>& gap_group, int& target, std::vector<pcl::PointIndices>& clusters,
                         std::vector<Eigen::Vector3f>& centroids)
{
  pcl::Indices object_points = clusters[target].indices;
  std::vector<bool> merged(clusters.size(), false);
  int merged_count = 0;
  for (bool changed = true; changed;)
  {
    changed = false;
    for (std::size_t c = 0; c < clusters.size(); ++c)
    {
      if (static_cast<int>(c) == target || merged[c] || gap_group[c] == gap_group[static_cast<std::size_t>(target)])
        continue;
      const pcl::Indices& part = clusters[c].indices;
      // Stacked means one above the other: their height ranges meet at most within the
      // clustering tolerance. An object lying against another's side overlaps its footprint
      // (the footprint is dilated by a cell) but shares its heights.
      const HeightRange part_heights = heightRange(cloud, part, plane), object_heights = heightRange(cloud, object_points, plane);
      const double tolerance = params.cluster_tolerance_m;
      if (part_heights.low < object_heights.high - tolerance && object_heights.low < part_heights.high - tolerance)
        continue;
      if (overlapFraction(cloud, part, object_points, plane, params.cluster_tolerance_m) <
              params.stacked_overlap_fraction &&
          overlapFraction(cloud, object_points, part, plane, params.cluster_tolerance_m) <
              params.stacked_overlap_fraction)
        continue;
      merged[c] = true;
      changed = true;
      ++merged_count;
      object_points.insert(object_points.end(), part.begin(), part.end());
    }
  }
  if (merged_count == 0)
    return 0;
  pcl::PointIndices object = clusters[target];
  std::vector<pcl::PointIndices> kept;
  std::vector<Eigen::Vector3f> kept_centroids;
  for (std::size_t c = 0; c < clusters.size(); ++c)
  {
    if (merged[c])
      object.indices.insert(object.indices.end(), clusters[c].indices.begin(), clusters[c].indices.end());
    else if (static_cast<int>(c) != target)
    {
      kept.push_back(clusters[c]);
      kept_centroids.push_back(centroids[c]);
    }
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto i : object.indices)
    sum += cloud.points[i].getVector3fMap().cast<double>();
  // Keep the list largest first.
  const auto position = std::find_if(kept.begin(), kept.end(), [&](const pcl::PointIndices& k) {
    return k.indices.size() < object.indices.size();
  });
  target = static_cast<int>(position - kept.begin());
  kept_centroids.insert(kept_centroids.begin() + target, (sum / static_cast<double>(object.indices.size())).cast<float>());
  kept.insert(position, std::move(object));
  clusters = std::move(kept);
  centroids = std::move(kept_centroids);
  return merged_count;
}
}  // namespace

TableSegmentationResult segmentTable(const CloudXYZ::ConstPtr& cloud, const TableSegmentationParams& params)
{
  TableSegmentationResult result;
  const CloudXYZ empty_cloud;
  const CloudXYZ& like = cloud ? *cloud : empty_cloud;
  result.table = emptyLike(like);
  result.object = emptyLike(like);
  result.scene = emptyLike(like);
  auto fail = [&result](SegmentationFailure why, const std::string& reason) {
    result.failure = why;
    result.reason = reason;
    return result;
  };
  if (const std::string bad = validateParams(params); !bad.empty())
    return fail(SegmentationFailure::InvalidInput, "invalid parameters: " + bad);
  if (!cloud || cloud->empty())
    return fail(SegmentationFailure::InvalidInput, "empty cloud (0 points)");
  for (const auto& p : cloud->points)
  {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return fail(SegmentationFailure::InvalidInput, "cloud holds non-finite points (expected a preprocessed cloud)");
  }
  if (cloud->size() < static_cast<std::size_t>(params.min_table_points))
  {
    std::ostringstream why;
    why << "no plane: only " << cloud->size() << " points, fewer than min_table_points " << params.min_table_points;
    return fail(SegmentationFailure::NoPlane, why.str());
  }

  // RANSAC restricted to near-horizontal planes so a large object side never wins.
  const Stopwatch ransac_watch;
  const Eigen::Vector3f up = params.up_axis.normalized();
  pcl::SACSegmentation<PointXYZ> ransac;
  ransac.setOptimizeCoefficients(true);
  ransac.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  ransac.setMethodType(pcl::SAC_RANSAC);
  ransac.setAxis(up);
  ransac.setEpsAngle(params.max_table_tilt_rad);
  ransac.setDistanceThreshold(params.plane_distance_m);
  ransac.setMaxIterations(params.ransac_max_iterations);
  ransac.setInputCloud(cloud);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  ransac.segment(inliers, coefficients);
  if (coefficients.values.size() != 4 || inliers.indices.size() < static_cast<std::size_t>(params.min_table_points))
  {
    std::ostringstream why;
    why << "no plane: best plane within " << params.max_table_tilt_rad << " rad of the up axis has "
        << inliers.indices.size() << " inliers, fewer than min_table_points " << params.min_table_points;
    return fail(SegmentationFailure::NoPlane, why.str());
  }
  Eigen::Vector4f plane(coefficients.values[0], coefficients.values[1], coefficients.values[2],
                        coefficients.values[3]);
  const float normal_length = plane.head<3>().norm();
  if (!plane.allFinite() || normal_length < 1e-6f)
    return fail(SegmentationFailure::NoPlane, "no plane: RANSAC returned a degenerate model");
  plane /= normal_length;
  if (plane.head<3>().dot(up) < 0.0f)
    plane = -plane;
  result.plane = plane;
  result.has_plane = true;

  // Classify by signed height: the table band, under it (gone), above it (object candidates).
  const float band = static_cast<float>(params.plane_distance_m);
  const float min_height = static_cast<float>(params.min_height_above_table_m);
  auto candidates = std::make_shared<pcl::Indices>();
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    const float height = plane.head<3>().dot(cloud->points[i].getVector3fMap()) + plane[3];
    if (std::abs(height) <= band)
      result.table->push_back(cloud->points[i]);
    if (height > std::max(min_height, band))
      candidates->push_back(static_cast<pcl::index_t>(i));
  }
  finishCloud(*result.table);
  result.ransac_time_s = ransac_watch.elapsedSeconds();

  const Stopwatch clustering_watch;
  if (candidates->size() >= static_cast<std::size_t>(params.min_cluster_points))
  {
    // The grid finds pcl::EuclideanClusterExtraction's clusters in a fraction of its time
    // (grid_clusters.h); the k-d tree serves points too far-flung for the grid.
    auto on_grid = gridEuclideanClusters(*cloud, *candidates, params.cluster_tolerance_m, params.min_cluster_points,
                                         params.max_cluster_points);
    if (on_grid)
      result.clusters = std::move(*on_grid);
    else
    {
      // Unsorted radius results: clustering only needs the neighbour set, not its order.
      auto tree = std::make_shared<pcl::search::KdTree<PointXYZ>>(/*sorted=*/false);
      tree->setInputCloud(cloud, candidates);
      pcl::EuclideanClusterExtraction<PointXYZ> clustering;
      clustering.setClusterTolerance(params.cluster_tolerance_m);
      clustering.setMinClusterSize(params.min_cluster_points);
      clustering.setMaxClusterSize(params.max_cluster_points);
      clustering.setSearchMethod(tree);
      clustering.setInputCloud(cloud);
      clustering.setIndices(candidates);
      clustering.extract(result.clusters);
    }
  }
  // gap_group[c]: the Euclidean cluster that clusters[c] is a piece of.
  std::vector<int> gap_group(result.clusters.size());
  std::iota(gap_group.begin(), gap_group.end(), 0);
  if (params.split_concave_creases && !result.clusters.empty())
  {
    std::vector<int> euclidean_of(cloud->size(), -1);
    for (std::size_t c = 0; c < result.clusters.size(); ++c)
      for (const auto i : result.clusters[c].indices)
        euclidean_of[static_cast<std::size_t>(i)] = static_cast<int>(c);
    result.clusters = splitAtConcaveCreases(*cloud, result.clusters, cloud->sensor_origin_.head<3>(), plane, *result.table,
                                            params.concave_split);
    gap_group.clear();
    for (const auto& piece : result.clusters)
      gap_group.push_back(euclidean_of[static_cast<std::size_t>(piece.indices.front())]);
  }
  // After a join, each output cluster keeps the gap group of the first input cluster it holds.
  auto followJoins = [&](const std::vector<int>& joined_into) {
    std::vector<int> joined_group(result.clusters.size(), -1);
    for (std::size_t c = 0; c < joined_into.size(); ++c)
      if (joined_group[static_cast<std::size_t>(joined_into[c])] < 0)
        joined_group[static_cast<std::size_t>(joined_into[c])] = gap_group[c];
    gap_group = joined_group;
  };
  if (params.join_container_insides && result.clusters.size() >= 2)
  {
    std::vector<int> joined_into;
    result.clusters = joinContainerInsides(*cloud, result.clusters, cloud->sensor_origin_.head<3>(), plane,
                                           params.container_join, params.concave_split, &joined_into);
    followJoins(joined_into);
  }
  if (params.join_occluded_pieces && result.clusters.size() >= 3)
  {
    std::vector<int> joined_into;
    result.clusters = joinOccludedPieces(*cloud, result.clusters, cloud->sensor_origin_.head<3>(),
                                         cloud->sensor_orientation_, plane, params.occlusion_join, &joined_into);
    followJoins(joined_into);
  }
  if (params.join_lying_necks && result.clusters.size() >= 2)
  {
    std::vector<int> joined_into;
    result.clusters = joinNecksToLyingBodies(*cloud, result.clusters, plane, params.neck_join, &joined_into);
    followJoins(joined_into);
  }
  auto fillScene = [&]() {
    std::vector<bool> in_object(cloud->size(), false);
    if (result.target_index >= 0)
      for (const auto i : result.clusters[result.target_index].indices)
        in_object[i] = true;
    result.scene->reserve(cloud->size());
    for (std::size_t i = 0; i < cloud->size(); ++i)
      if (!in_object[i])
        result.scene->push_back(cloud->points[i]);
    finishCloud(*result.scene);
  };
  if (result.clusters.empty())
  {
    fillScene();
    result.clustering_time_s = clustering_watch.elapsedSeconds();
    std::ostringstream why;
    why << "no cluster: " << candidates->size() << " points above the table, none forms a cluster of >= "
        << params.min_cluster_points << " points (tolerance " << params.cluster_tolerance_m << " m)";
    return fail(SegmentationFailure::NoCluster, why.str());
  }

  // Target choice.
  std::vector<Eigen::Vector3f> centroids;
  for (const auto& cluster : result.clusters)
  {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto i : cluster.indices)
      sum += cloud->points[i].getVector3fMap().cast<double>();
    centroids.push_back((sum / static_cast<double>(cluster.indices.size())).cast<float>());
  }
  int best = 0;  // clusters come largest first
  if (params.target == TargetCluster::CenterOfView)
  {
    const Eigen::Vector3f eye = cloud->sensor_origin_.head<3>();
    const Eigen::Vector3f optical_axis = cloud->sensor_orientation_ * Eigen::Vector3f::UnitZ();
    float best_cosine = -2.0f;
    for (std::size_t c = 0; c < centroids.size(); ++c)
    {
      const float cosine = (centroids[c] - eye).normalized().dot(optical_axis);
      if (cosine > best_cosine)
      {
        best_cosine = cosine;
        best = static_cast<int>(c);
      }
    }
  }
  else if (params.target != TargetCluster::Largest)
  {
    const Eigen::Vector3f goal =
        params.target == TargetCluster::ClosestToPoint ? params.target_point_m : params.reference_point_m;
    float best_distance = std::numeric_limits<float>::infinity();
    for (std::size_t c = 0; c < centroids.size(); ++c)
    {
      const float distance = (centroids[c] - goal).norm();
      if (distance < best_distance)
      {
        best_distance = distance;
        best = static_cast<int>(c);
      }
    }
  }
  if (params.merge_stacked_clusters && result.clusters.size() > 1)
  {
    result.merged_clusters = mergeStackedClusters(*cloud, plane, params, gap_group, best, result.clusters, centroids);
  }
  result.target_index = best;
  result.object_centroid = centroids[best];
  result.object_min = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  result.object_max = -result.object_min;
  result.object->reserve(result.clusters[best].indices.size());
  for (const auto i : result.clusters[best].indices)
  {
    const auto& p = cloud->points[i];
    result.object->push_back(p);
    result.object_min = result.object_min.cwiseMin(p.getVector3fMap());
    result.object_max = result.object_max.cwiseMax(p.getVector3fMap());
  }
  finishCloud(*result.object);
  fillScene();
  result.clustering_time_s = clustering_watch.elapsedSeconds();

  const float distance = (result.object_centroid - params.reference_point_m).norm();
  if (params.max_object_distance_m > 0.0 && distance > params.max_object_distance_m)
  {
    std::ostringstream why;
    why << "object out of reach: target cluster centroid is " << distance << " m from the arm base, beyond "
        << "max_object_distance_m " << params.max_object_distance_m;
    return fail(SegmentationFailure::ObjectOutOfReach, why.str());
  }
  std::ostringstream summary;
  summary << result.clusters.size() << " cluster(s), target " << toString(params.target) << " with "
          << result.object->size() << " points";
  if (result.merged_clusters > 0)
    summary << " (" << result.merged_clusters << " stacked part(s) merged)";
  summary << ", table " << result.table->size() << " points";
  result.reason = summary.str();
  return result;
}

pcl::PointCloud<pcl::PointXYZL>::Ptr labelledObjects(const CloudXYZ& cloud, const TableSegmentationResult& result)
{
  auto objects = std::make_shared<pcl::PointCloud<pcl::PointXYZL>>();
  objects->header = cloud.header;
  objects->sensor_origin_ = cloud.sensor_origin_;
  objects->sensor_orientation_ = cloud.sensor_orientation_;
  if (!result.ok() || result.target_index < 0 || static_cast<std::size_t>(result.target_index) >= result.clusters.size())
    return objects;
  std::vector<std::size_t> order{ static_cast<std::size_t>(result.target_index) };
  for (std::size_t c = 0; c < result.clusters.size(); ++c)
    if (c != order.front())
      order.push_back(c);
  for (std::size_t label = 0; label < order.size(); ++label)
    for (const int i : result.clusters[order[label]].indices)
    {
      if (i < 0 || static_cast<std::size_t>(i) >= cloud.size())
        continue;
      pcl::PointXYZL p;
      p.getVector3fMap() = cloud.points[static_cast<std::size_t>(i)].getVector3fMap();
      p.label = static_cast<std::uint32_t>(label);
      objects->push_back(p);
    }
  objects->width = static_cast<std::uint32_t>(objects->size());
  objects->height = 1;
  objects->is_dense = true;
  return objects;
}

}  // namespace fast_grasp
