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

TableObjectClouds splitTableObjects(const TableSceneClouds& table)
{
  TableObjectClouds out;
  if (!table.objects)
    return out;
  for (const auto& p : table.objects->points)
  {
    if (!finite(p))
      continue;
    auto it = std::find(out.labels.begin(), out.labels.end(), p.label);
    if (it == out.labels.end())
    {
      out.labels.push_back(p.label);
      out.points.emplace_back();
      it = out.labels.end() - 1;
    }
    out.points[static_cast<std::size_t>(it - out.labels.begin())].push_back(pcl::PointXYZ(p.x, p.y, p.z));
  }
  out.unseen.resize(out.points.size());
  if (!table.sensor_origins.empty())
    for (std::size_t i = 0; i < out.points.size(); ++i)
    {
      const UnseenPart hidden = buildUnseenPart(out.points[i], table.sensor_origins, table.unseen, table.table_plane);
      if (hidden.ok())
        out.unseen[i] = hidden.points;
    }
  return out;
}

ObjectSceneClouds sceneForObject(const TableSceneClouds& table, const TableObjectClouds& objects,
                                 std::uint32_t label)
{
  ObjectSceneClouds out;
  out.table_plane = table.table_plane;
  const auto it = std::find(objects.labels.begin(), objects.labels.end(), label);
  const std::size_t chosen = static_cast<std::size_t>(it - objects.labels.begin());  // == size: none
  std::unordered_set<PointBits, PointBitsHash> chosen_bits;
  if (chosen < objects.labels.size())
  {
    out.object = objects.points[chosen];
    out.unseen = objects.unseen[chosen];
    for (const auto& p : out.object.points)
      chosen_bits.insert(bitsOf(p));
  }
  if (table.scene)
    for (const auto& p : table.scene->points)
      if (finite(p) && chosen_bits.count(bitsOf(p)) == 0)
        out.scene.push_back(p);
  // The other objects: their seen points (the target's are not in ~scene; the rest are twice,
  // which only sets the same voxels again) and the space hidden behind them.
  for (std::size_t i = 0; i < objects.labels.size(); ++i)
    if (i != chosen)
    {
      out.scene += objects.points[i];
      out.scene += objects.unseen[i];
    }
  return out;
}

ObjectSceneClouds sceneForObject(const TableSceneClouds& table, std::uint32_t label)
{
  return sceneForObject(table, splitTableObjects(table), label);
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

  const TableObjectClouds objects = splitTableObjects(table);
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
    const ObjectSceneClouds scene = sceneForObject(table, objects, id);
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
