#include "fast_grasp/grasping/near_range.h"

#include "fast_grasp/grasping/grasp_features.h"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <sstream>
#include <unordered_set>
#include <vector>

namespace fast_grasp
{
std::string NearRangeParams::validate() const
{
  std::ostringstream why;
  if (!(sensor_min_range_m >= 0.0 && sensor_min_range_m <= 10.0))
    why << "sensor_min_range_m must be in [0, 10] m; ";
  if (!(margin_m > 0.0 && margin_m <= 0.5))
    why << "margin_m must be in (0, 0.5] m; ";
  if (min_points < 1)
    why << "min_points must be >= 1; ";
  if (!(extension_m > 0.0 && extension_m <= 2.0))
    why << "extension_m must be in (0, 2] m; ";
  // Finer than 1 mm would make millions of points for an extension of decimetres.
  if (!(step_m >= 0.001 && step_m <= extension_m))
    why << "step_m must be in [0.001, extension_m] m; ";
  if (!(next_view_step_back_m >= 0.0 && next_view_step_back_m <= 2.0))
    why << "next_view_step_back_m must be in [0, 2] m; ";
  std::string s = why.str();
  if (!s.empty())
    s.resize(s.size() - 2);
  return s;
}

NearRangeBlindSpace nearRangeBlindSpace(const CloudNormal& cloud, const Eigen::Vector3f& sensor_origin,
                                        const Eigen::Vector3f& optical_axis, const Eigen::Vector3f& up,
                                        const NearRangeParams& params)
{
  NearRangeBlindSpace blind;
  if (!(params.sensor_min_range_m > 0.0) || !sensor_origin.allFinite() || !optical_axis.allFinite() ||
      !up.allFinite() || !(optical_axis.norm() > 0.5f) || !(up.norm() > 0.5f))
    return blind;
  const Eigen::Vector3f axis = optical_axis.normalized();
  const Eigen::Vector3f upward = up.normalized();
  const auto limit = static_cast<float>(params.sensor_min_range_m);
  const float deepest = limit + static_cast<float>(params.margin_m);

  const auto step = static_cast<float>(params.step_m);
  // One point per step_m cube: the 21-bit signed cell indices of x, y, z packed into 63 bits
  // (±1048576 cells of >= 1 mm: ±1 km).
  const auto cellKey = [step](const Eigen::Vector3f& q) {
    const auto cell = [step](float v) { return (static_cast<std::int64_t>(std::floor(v / step)) + (1 << 20)) & 0x1FFFFF; };
    return (cell(q.x()) << 42) | (cell(q.y()) << 21) | cell(q.z());
  };

  // The points at the limit, one per cube: a dense cloud (max_input_points) must not multiply
  // into millions of copies below.
  std::vector<Eigen::Vector3f> at_limit;
  std::unordered_set<std::int64_t> seeds;
  for (const auto& p : cloud.points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    const float depth = (q - sensor_origin).dot(axis);
    if (depth > deepest)  // nearer than the limit cannot be seen, but a noisy point may read so
      continue;
    ++blind.at_limit;
    if (seeds.insert(cellKey(q)).second)
      at_limit.push_back(q);
  }
  if (blind.at_limit < params.min_points)
    return blind;

  const int steps = static_cast<int>(std::floor(params.extension_m / params.step_m + 1e-6));
  std::unordered_set<std::int64_t> occupied;
  const auto add = [&](const Eigen::Vector3f& q) {
    // Only space nearer than the limit is blind: farther, the camera would have seen the object.
    if ((q - sensor_origin).dot(axis) >= limit)
      return;
    if (occupied.insert(cellKey(q)).second)
      blind.points.push_back(PointXYZ(q.x(), q.y(), q.z()));
  };
  for (const Eigen::Vector3f& q : at_limit)
  {
    const Eigen::Vector3f to_camera = sensor_origin - q;
    const float camera_distance = to_camera.norm();
    const Eigen::Vector3f toward_camera = camera_distance > 0.0f ? Eigen::Vector3f(to_camera / camera_distance)
                                                                 : Eigen::Vector3f::Zero();
    for (int k = 1; k <= steps; ++k)
    {
      const float s = static_cast<float>(k) * step;
      add(q + s * upward);
      if (params.toward_camera && s < camera_distance)
        add(q + s * toward_camera);
    }
  }
  blind.points.width = static_cast<std::uint32_t>(blind.points.size());
  blind.points.height = 1;
  return blind;
}

std::optional<CloudCamera> cloudCamera(const CloudNormal& cloud)
{
  const Eigen::Vector3f origin = cloud.sensor_origin_.head<3>();
  const Eigen::Quaternionf& orientation = cloud.sensor_orientation_;
  if (!origin.allFinite() || origin.isZero() || !orientation.coeffs().allFinite() ||
      !(orientation.norm() > 0.5f) || orientation.coeffs().isApprox(Eigen::Quaternionf::Identity().coeffs()))
    return std::nullopt;
  return CloudCamera{ origin, orientation.normalized() * Eigen::Vector3f::UnitZ() };
}

CloudNormal nearLimitCut(const CloudNormal& cloud, const NearRangeParams& params)
{
  CloudNormal cut;
  if (!params.flag_grasps_on_cut || !(params.sensor_min_range_m > 0.0))
    return cut;
  const std::optional<CloudCamera> camera = cloudCamera(cloud);
  if (!camera)
    return cut;
  const auto deepest = static_cast<float>(params.sensor_min_range_m + params.margin_m);
  for (const auto& p : cloud.points)
    if (p.getVector3fMap().allFinite() && (p.getVector3fMap() - camera->origin).dot(camera->optical_axis) <= deepest)
      cut.push_back(p);
  if (cut.size() < params.min_points)
    cut.clear();
  return cut;
}

bool closesOnNearLimitCut(const GraspCandidate& grasp, const GripperModel& gripper, const CloudNormal& cut,
                          const NearRangeParams& params)
{
  return !cut.empty() && pointsBetweenOpenFingers(grasp, gripper, cut).size() >= params.min_points;
}

std::optional<Eigen::Isometry3d> nextViewBackFromNearLimit(const CloudNormal& cloud, const NearRangeParams& params)
{
  if (!(params.next_view_step_back_m > 0.0))
    return std::nullopt;
  const std::optional<CloudCamera> camera = cloudCamera(cloud);
  if (!camera)
    return std::nullopt;
  Eigen::Isometry3d view = Eigen::Isometry3d::Identity();
  view.linear() = cloud.sensor_orientation_.normalized().toRotationMatrix().cast<double>();
  view.translation() = (camera->origin - static_cast<float>(params.next_view_step_back_m) * camera->optical_axis).cast<double>();
  return view;
}

std::string nextViewBackFromNearLimitNote(const NearRangeParams& params)
{
  return "next view: the camera " + std::to_string(std::lround(100.0 * params.next_view_step_back_m)) +
         " cm farther back, beyond the near limit";
}

std::size_t addNearRangeBlindSpace(ObjectView& view, const NearRangeParams& params)
{
  if (!params.add_blind_space || !(params.sensor_min_range_m > 0.0) || !view.cloud)
    return 0;
  // Nobody set the camera pose: its blind zone is unknown.
  const std::optional<CloudCamera> camera = cloudCamera(*view.cloud);
  if (!camera)
    return 0;
  const Eigen::Vector3f up = view.has_table_plane ? Eigen::Vector3f(view.table_plane.head<3>()) : Eigen::Vector3f(-view.gravity);
  const NearRangeBlindSpace blind = nearRangeBlindSpace(*view.cloud, camera->origin, camera->optical_axis, up, params);
  if (blind.points.empty())
    return 0;
  auto obstacles = std::make_shared<CloudXYZ>();
  if (view.obstacles)
    *obstacles = *view.obstacles;
  *obstacles += blind.points;
  view.obstacles = obstacles;
  return blind.at_limit;
}

}  // namespace fast_grasp
