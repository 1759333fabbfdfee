#include "fast_grasp/grasping/table_grasps.h"

#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/principal_axis_next_view.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

namespace fast_grasp
{
const char* toString(ObjectChoice choice)
{
  switch (choice)
  {
    case ObjectChoice::BestGrasp:
      return "best_grasp";
    case ObjectChoice::Topmost:
      return "topmost";
    case ObjectChoice::NearestToBase:
      return "nearest_to_base";
  }
  return "?";
}

bool parseObjectChoice(const std::string& text, ObjectChoice& choice)
{
  for (const ObjectChoice c : { ObjectChoice::BestGrasp, ObjectChoice::Topmost, ObjectChoice::NearestToBase })
    if (text == toString(c))
    {
      choice = c;
      return true;
    }
  return false;
}

std::string TableGraspParams::validate() const
{
  std::ostringstream why;
  if (!(neighbour_clearance_m >= 0.0 && neighbour_clearance_m <= 0.1))
    why << "neighbour_clearance_m must be in [0, 0.1]; ";
  if (!(approach_distance_m >= 0.0 && approach_distance_m <= 0.5))
    why << "approach_distance_m must be in [0, 0.5]; ";
  if (!(unseen.extension_m > 0.0 && unseen.extension_m <= 1.0))
    why << "unseen extension must be in (0, 1] m; ";
  if (!(next_view_turn_rad >= 0.0 && next_view_turn_rad <= M_PI))
    why << "next_view_turn_rad must be in [0, pi]; ";
  return why.str();
}

bool handSweepHits(const Eigen::Isometry3d& pose, const GripperModel& gripper, const Eigen::Matrix3Xf& obstacles,
                   double approach_distance_m, double clearance_m)
{
  if (obstacles.cols() == 0)
    return false;
  std::array<GripperBox, 3> boxes = openGripperBoxes(gripper, gripper.max_opening_m);
  const Eigen::Vector3f grow = Eigen::Vector3f::Constant(static_cast<float>(clearance_m));
  for (GripperBox& box : boxes)
  {
    box.min -= grow;
    box.max += grow;
    box.min.x() -= static_cast<float>(approach_distance_m);  // where the hand was on its way in
  }
  const Eigen::Matrix3f to_local = pose.linear().cast<float>().transpose();
  const Eigen::Vector3f origin = pose.translation().cast<float>();
  const Eigen::Matrix3Xf local = to_local * (obstacles.colwise() - origin);
  for (Eigen::Index i = 0; i < local.cols(); ++i)
    for (const GripperBox& box : boxes)
      if (box.contains(local.col(i)))
        return true;
  return false;
}

namespace
{
/// Appends the finite points of `cloud` to `out`.
template <typename PointT>
void appendPoints(const pcl::PointCloud<PointT>& cloud, std::vector<Eigen::Vector3f>& out)
{
  for (const auto& p : cloud.points)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      out.push_back(p.getVector3fMap());
}
}  // namespace

TableGraspResult planTableGrasps(const std::vector<ObjectView>& views, const GraspPlanner& planner,
                                 const GripperModel& gripper, const TableGraspParams& params)
{
  const Stopwatch watch;
  TableGraspResult table;
  // What each object puts in the other objects' way: its seen points and, optionally, the
  // space behind them (a neighbour's hidden back is as solid as its front).
  std::vector<std::vector<Eigen::Vector3f>> obstacles(views.size());
  for (std::size_t i = 0; i < views.size(); ++i)
  {
    if (!views[i].cloud)
      continue;
    appendPoints(*views[i].cloud, obstacles[i]);
    if (views[i].obstacles)  // what its view already keeps hands out of: its blind space (near_range.h)
      appendPoints(*views[i].obstacles, obstacles[i]);
    if (params.neighbour_unseen_parts && !views[i].sensor_origins.empty())
    {
      std::optional<Eigen::Vector4f> plane;
      if (views[i].has_table_plane)
        plane = views[i].table_plane;
      const UnseenPart unseen = buildUnseenPart(*views[i].cloud, views[i].sensor_origins, params.unseen, plane);
      if (unseen.ok())
        appendPoints(unseen.points, obstacles[i]);
    }
  }

  // How far from an object's points any part of a hand grasping it can be: the fingers' depth
  // and the palm behind them, half the opening and a finger to the side.
  const float reach = static_cast<float>(gripper.finger_depth_m + gripper.palm_thickness_m +
                                         0.5 * gripper.max_opening_m + gripper.finger_thickness_m +
                                         params.neighbour_clearance_m);
  for (std::size_t i = 0; i < views.size(); ++i)
  {
    ObjectGrasps object;
    object.object = i;
    // The planner's own hand check keeps out of the neighbours (those within reach): its best
    // grasps are then ones that fit among them, not ones the sweep below would all drop.
    ObjectView view = views[i];
    const ObjectExtent extent = view.cloud ? objectExtent(view) : ObjectExtent{};
    if (extent.max_extent_m > 0.0f)
    {
      const Eigen::Vector3f lo = extent.box_min.array() - reach;
      const Eigen::Vector3f hi = extent.box_max.array() + reach;
      auto near = std::make_shared<CloudXYZ>();
      if (views[i].obstacles)
        *near = *views[i].obstacles;
      for (std::size_t j = 0; j < views.size(); ++j)
        if (j != i)
          for (const Eigen::Vector3f& q : obstacles[j])
            if ((q.array() >= lo.array()).all() && (q.array() <= hi.array()).all())
              near->push_back(PointXYZ(q.x(), q.y(), q.z()));
      if (!near->empty())
        view.obstacles = near;
    }
    object.result = planner.plan(view, gripper);
    if (views[i].cloud)
    {
      object.top_height_m = extent.height_m;
      object.centroid = extent.centroid;
      object.base_distance_m = extent.centroid.norm();
    }
    // The others' obstacles and the view's own (its blind space), in one matrix: the hand
    // comes in through them from the pre-grasp, which the planner's check at the grasp misses.
    std::vector<Eigen::Vector3f> own;  // finite points only, as obstacles[j]
    if (views[i].obstacles)
      appendPoints(*views[i].obstacles, own);
    std::size_t others = own.size();
    for (std::size_t j = 0; j < views.size(); ++j)
      if (j != i)
        others += obstacles[j].size();
    Eigen::Matrix3Xf in_the_way(3, static_cast<Eigen::Index>(others));
    Eigen::Index column = 0;
    for (const Eigen::Vector3f& p : own)
      in_the_way.col(column++) = p;
    for (std::size_t j = 0; j < views.size(); ++j)
      if (j != i)
        for (const Eigen::Vector3f& p : obstacles[j])
          in_the_way.col(column++) = p;
    auto& grasps = object.result.grasps;
    const auto blocked = std::remove_if(grasps.begin(), grasps.end(), [&](const GraspCandidate& g) {
      return handSweepHits(g.pose, gripper, in_the_way, params.approach_distance_m, params.neighbour_clearance_m);
    });
    object.blocked_by_neighbours = static_cast<std::size_t>(grasps.end() - blocked);
    grasps.erase(blocked, grasps.end());
    if (grasps.empty() && object.blocked_by_neighbours > 0)
    {
      object.result.failure = GraspFailure::NoStableGrasp;
      object.result.message += (object.result.message.empty() ? "" : "; ") +
                               std::to_string(object.blocked_by_neighbours) +
                               " grasp(s) blocked by neighbouring objects" +
                               (views[i].obstacles ? " or the object's blind space" : "");
    }
    table.objects.push_back(std::move(object));
  }

  for (std::size_t i = 0; i < table.objects.size(); ++i)
    if (table.objects[i].ok())
      table.order.push_back(i);
  const auto& objects = table.objects;
  std::stable_sort(table.order.begin(), table.order.end(), [&](std::size_t a, std::size_t b) {
    switch (params.object_choice)
    {
      case ObjectChoice::Topmost:
        return objects[a].top_height_m > objects[b].top_height_m;
      case ObjectChoice::NearestToBase:
        return objects[a].base_distance_m < objects[b].base_distance_m;
      case ObjectChoice::BestGrasp:
        break;
    }
    // A grasp the hold check expects to drop comes after every grasp it trusts, whatever the
    // model's score: on a pile a failed attempt disturbs the rest and two in a row end the table.
    const GraspCandidate& best_a = objects[a].result.grasps.front();
    const GraspCandidate& best_b = objects[b].result.grasps.front();
    if (best_a.drop_risk != best_b.drop_risk)
      return best_b.drop_risk;
    return best_a.score > best_b.score;
  });
  if (!table.ok())
    table.next_view = tableNextView(views, params.next_view_turn_rad);
  table.compute_time_s = watch.elapsedSeconds();
  return table;
}

std::optional<Eigen::Isometry3d> tableNextView(const std::vector<ObjectView>& views, double turn_rad)
{
  if (!(turn_rad > 0.0) || views.empty() || views.front().sensor_origins.empty())
    return std::nullopt;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  for (const ObjectView& view : views)
    if (view.cloud)
      for (const auto& p : view.cloud->points)
        if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
        {
          sum += p.getVector3fMap().cast<double>();
          ++count;
        }
  if (count == 0)
    return std::nullopt;
  const ObjectView& first = views.front();
  CameraAboutAxis camera;
  camera.sensor = first.sensor_origins.front();
  camera.centroid = (sum / static_cast<double>(count)).cast<float>();
  camera.gravity = first.gravity;
  camera.axis = first.has_table_plane ? Eigen::Vector3f(first.table_plane.head<3>()) : Eigen::Vector3f(-first.gravity);
  if (!camera.sensor.allFinite() || !camera.axis.allFinite() || camera.axis.norm() < 1e-6f)
    return std::nullopt;
  const Eigen::Isometry3d one_way = viewTurnedAboutAxis(camera, turn_rad);
  const Eigen::Isometry3d other_way = viewTurnedAboutAxis(camera, -turn_rad);
  return one_way.translation().norm() <= other_way.translation().norm() ? one_way : other_way;
}

}  // namespace fast_grasp
