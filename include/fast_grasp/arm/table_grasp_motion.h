// Grasp motion to one object of a table of several (issue 11, beyond the thesis, which grasps a
// single object): the arm's scene holds every object but the one it is grasping, each with the
// space hidden behind it. ROS-free.
#pragma once

#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
/// One perception frame of a table of objects, as TableSegmentation publishes it (base_link).
struct TableSceneClouds
{
  /// Everything but the target cluster, table included (TableSegmentation ~scene). Points that
  /// are also in `objects` belong to their object.
  const pcl::PointCloud<pcl::PointXYZ>* scene = nullptr;
  /// Every cluster, each point labelled with its object (TableSegmentation ~objects; 0 = target).
  const pcl::PointCloud<pcl::PointXYZL>* objects = nullptr;
  std::optional<Eigen::Vector4f> table_plane;  // a, b, c, d; (a, b, c) from the table up
  /// Camera positions for each object's unseen part (thesis Ch6, Eq. 6.8); empty: none is built.
  std::vector<Eigen::Vector3f> sensor_origins;
  UnseenPartParams unseen;
};

/// What buildGraspScene needs to grasp the object labelled `label`: its points are the object and
/// its unseen part the `unseen` obstacle; every other object (seen points and unseen part) and
/// every scene point that is not the object's go to `scene`.
struct ObjectSceneClouds
{
  pcl::PointCloud<pcl::PointXYZ> scene;
  pcl::PointCloud<pcl::PointXYZ> object;
  pcl::PointCloud<pcl::PointXYZ> unseen;
  std::optional<Eigen::Vector4f> table_plane;
  /// Pointers into this struct: keep it alive while they are used.
  GraspSceneClouds clouds() const;
};

/// Each labelled object's finite points and the space hidden behind it, split from one frame
/// once: the scene of every object tried is assembled from them (n unseen parts per frame, not
/// n per object tried).
struct TableObjectClouds
{
  std::vector<std::uint32_t> labels;  // in the order they first appear in `objects`
  std::vector<pcl::PointCloud<pcl::PointXYZ>> points;
  std::vector<pcl::PointCloud<pcl::PointXYZ>> unseen;  // empty without sensor origins
};
TableObjectClouds splitTableObjects(const TableSceneClouds& table);

ObjectSceneClouds sceneForObject(const TableSceneClouds& table, const TableObjectClouds& objects,
                                 std::uint32_t label);
/// One object's scene straight from the frame (splits it first).
ObjectSceneClouds sceneForObject(const TableSceneClouds& table, std::uint32_t label);

struct TableGraspPlanResult
{
  GraspPlanResult plan;  // grasp_index indexes the whole grasp list
  bool ok() const { return plan.success; }
  std::int64_t object_id = -1;  // the object grasped, -1 when none
  /// Per object tried, in order: "object 2: <planGraspMotion status>".
  std::vector<std::string> objects_tried;
};

/// Plans `grasps` (best first; object_ids[i] is grasps[i]'s object) one object at a time, in the
/// order the objects first appear in the list: `collision`'s scene is rebuilt without that object
/// (sceneForObject, buildGraspScene at `start`) and planGraspMotion tries its grasps. The first
/// object with a plan is the one grasped. params.total_time_budget_s bounds all objects
/// together. Never throws on bad input: mismatched lists or no objects cloud give ok() == false
/// with a status.
TableGraspPlanResult planTableGraspMotion(RobotCollision& collision, const Eigen::VectorXd& start,
                                          const std::vector<GraspCandidate>& grasps,
                                          const std::vector<std::uint32_t>& object_ids, const TableSceneClouds& table,
                                          const GraspExecutionParams& params);

}  // namespace fast_grasp
