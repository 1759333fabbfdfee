#include "fast_grasp/arm/table_grasp_motion.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_set>

namespace fast_grasp
{
namespace
{
/// A point's exact bits: the scene and the objects are copies of the same input points, so a
/// point of the object is found in the scene by equality, not by a distance that would also
/// take a touching neighbour's points.
struct PointBits
{
  std::uint32_t x, y, z;
  bool operator==(const PointBits& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PointBitsHash
{
  std::size_t operator()(const PointBits& b) const
  {
    return (static_cast<std::size_t>(b.x) * 73856093u) ^ (static_cast<std::size_t>(b.y) * 19349663u) ^
           (static_cast<std::size_t>(b.z) * 83492791u);
  }
};
template <typename PointT>
PointBits bitsOf(const PointT& p)
{
  PointBits b{};
  std::memcpy(&b.x, &p.x, sizeof(float));
  std::memcpy(&b.y, &p.y, sizeof(float));
  std::memcpy(&b.z, &p.z, sizeof(float));
  return b;
}
template <typename PointT>
bool finite(const PointT& p)
{
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}
}  // namespace

GraspSceneClouds ObjectSceneClouds::clouds() const
{
  GraspSceneClouds c;
  c.scene = &scene;
  c.object = object.empty() ? nullptr : &object;
  c.unseen = unseen.empty() ? nullptr : &unseen;
  c.table_plane = table_plane;
  return c;
}

ObjectSceneClouds sceneForObject(const TableSceneClouds& table, std::uint32_t label)
{
  ObjectSceneClouds out;
  out.table_plane = table.table_plane;
  // Every object's points, by label (finite only).
  std::vector<std::uint32_t> labels;
  std::unordered_set<PointBits, PointBitsHash> chosen;
  std::vector<pcl::PointCloud<pcl::PointXYZ>> others;
  if (table.objects)
  {
    for (const auto& p : table.objects->points)
    {
      if (!finite(p))
        continue;
      if (p.label == label)
      {
        out.object.push_back(pcl::PointXYZ(p.x, p.y, p.z));
        chosen.insert(bitsOf(p));
        continue;
      }
      auto it = std::find(labels.begin(), labels.end(), p.label);
      if (it == labels.end())
      {
        labels.push_back(p.label);
        others.emplace_back();
        it = labels.end() - 1;
      }
      others[static_cast<std::size_t>(it - labels.begin())].push_back(pcl::PointXYZ(p.x, p.y, p.z));
    }
  }
  if (table.scene)
    for (const auto& p : table.scene->points)
      if (finite(p) && chosen.count(bitsOf(p)) == 0)
        out.scene.push_back(p);
  // The other objects: their seen points (the target's are not in ~scene; the rest are twice,
  // which only sets the same voxels again) and the space hidden behind them.
  for (const auto& cloud : others)
  {
    out.scene += cloud;
    if (!table.sensor_origins.empty())
    {
      const UnseenPart hidden = buildUnseenPart(cloud, table.sensor_origins, table.unseen, table.table_plane);
      if (hidden.ok())
        out.scene += hidden.points;
    }
  }
  if (!out.object.empty() && !table.sensor_origins.empty())
  {
    const UnseenPart hidden = buildUnseenPart(out.object, table.sensor_origins, table.unseen, table.table_plane);
    if (hidden.ok())
      out.unseen = hidden.points;
  }
  return out;
}

TableGraspPlanResult planTableGraspMotion(RobotCollision& collision, const Eigen::VectorXd& start,
                                          const std::vector<GraspCandidate>& grasps,
                                          const std::vector<std::uint32_t>& object_ids, const TableSceneClouds& table,
                                          const GraspExecutionParams& params)
{
  const Stopwatch clock;
  TableGraspPlanResult result;
  if (grasps.size() != object_ids.size())
  {
    result.plan.status = "grasps and object ids differ in number (" + std::to_string(grasps.size()) + " vs " +
                         std::to_string(object_ids.size()) + ")";
    return result;
  }
  if (!table.objects || table.objects->empty())
  {
    result.plan.status = "no labelled objects for the table's scene";
    return result;
  }
  if (grasps.empty())
  {
    result.plan.status = "no grasps given";
    return result;
  }
  std::vector<std::uint32_t> order;  // objects as they first appear (the grasp planner's pick order)
  for (const std::uint32_t id : object_ids)
    if (std::find(order.begin(), order.end(), id) == order.end())
      order.push_back(id);

  for (const std::uint32_t id : order)
  {
    const double left_s = params.total_time_budget_s - clock.elapsedSeconds();
    if (left_s <= 0.0)
    {
      result.objects_tried.push_back("object " + std::to_string(id) + ": not tried (time budget spent)");
      continue;
    }
    std::vector<GraspCandidate> own;
    std::vector<int> index;  // into grasps
    for (std::size_t i = 0; i < grasps.size(); ++i)
      if (object_ids[i] == id)
      {
        own.push_back(grasps[i]);
        index.push_back(static_cast<int>(i));
      }
    const ObjectSceneClouds scene = sceneForObject(table, id);
    const std::string note = buildGraspScene(collision, start, scene.clouds(), params);
    GraspExecutionParams within = params;
    within.total_time_budget_s = left_s;
    GraspPlanResult plan = planGraspMotion(collision, start, own, within);
    result.objects_tried.push_back("object " + std::to_string(id) + ": " + plan.status + " (" + note + ")");
    // The grasp index in the whole list's numbering; skip reasons keep the object's own
    // numbering ("grasp 0" = its best grasp), prefixed with the object.
    for (std::string& reason : plan.skipped_reasons)
      reason = "object " + std::to_string(id) + ", " + reason;
    if (plan.grasp_index >= 0)
      plan.grasp_index = index[static_cast<std::size_t>(plan.grasp_index)];
    std::vector<std::string> skipped = std::move(result.plan.skipped_reasons);
    skipped.insert(skipped.end(), plan.skipped_reasons.begin(), plan.skipped_reasons.end());
    result.plan = std::move(plan);
    result.plan.skipped_reasons = std::move(skipped);
    if (result.plan.success)
    {
      result.object_id = id;
      result.plan.status = "object " + std::to_string(id) + ": " + result.plan.status;
      break;
    }
  }
  if (!result.plan.success)
  {
    std::string status = "no object's grasp plannable";
    for (const std::string& tried : result.objects_tried)
      status += "; " + tried;
    result.plan.status = status;
  }
  result.plan.planning_time_s = clock.elapsedSeconds();
  return result;
}

}  // namespace fast_grasp
