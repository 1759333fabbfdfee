#include "fast_grasp/grasping/lying_cylinder.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace fast_grasp
{
namespace
{
float median(std::vector<float>& values)
{
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}
/// The axis's direction: the horizontal direction the side's normals are square to (the least
/// spread of their horizontal parts), starting from the footprint's major axis and leaving out
/// normals along the current estimate (an end face). The footprint alone is off by ~10 deg when
/// the camera sees an end face (its points skew the seen footprint).
Eigen::Vector3f axisFromNormals(const ObjectView& view, const ObjectExtent& extent)
{
  const auto [e1, e2] = tablePlaneBasis(extent.up);
  Eigen::Vector3f axis = extent.major_axis.normalized();
  for (int iteration = 0; iteration < 2; ++iteration)
  {
    Eigen::Matrix2f scatter = Eigen::Matrix2f::Zero();
    std::size_t used = 0;
    for (const auto& p : view.cloud->points)
    {
      const Eigen::Vector3f n = p.getNormalVector3fMap();
      if (!n.allFinite() || n.norm() < 0.5f || !p.getVector3fMap().allFinite())
        continue;
      const Eigen::Vector3f unit = n.normalized();
      if (std::abs(unit.dot(axis)) > 0.7f)
        continue;
      const Eigen::Vector2f horizontal(unit.dot(e1), unit.dot(e2));
      scatter += horizontal * horizontal.transpose();
      ++used;
    }
    if (used < 10)
      break;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2f> spread(scatter);
    const Eigen::Vector2f least = spread.eigenvectors().col(0);  // eigenvalues ascending
    axis = (least.x() * e1 + least.y() * e2).normalized();
  }
  return axis;
}
}  // namespace

std::string LyingCylinderParams::validate() const
{
  std::ostringstream why;
  if (!(min_length_to_height >= 0.0 && min_length_to_height <= 100.0))
    why << "lying_cylinder min_length_to_height must be in [0, 100]; ";
  if (!(max_median_residual_frac > 0.0 && max_median_residual_frac <= 1.0))
    why << "lying_cylinder max_median_residual_frac must be in (0, 1]; ";
  if (!(max_median_normal_angle_rad > 0.0 && max_median_normal_angle_rad <= M_PI))
    why << "lying_cylinder max_median_normal_angle_rad must be in (0, pi]; ";
  if (min_points < 3)
    why << "lying_cylinder min_points must be >= 3; ";
  if (!(std::abs(min_fingertip_reach_m) <= 0.1))
    why << "lying_cylinder min_fingertip_reach_m must be in [-0.1, 0.1] m; ";
  return why.str();
}

LyingCylinder fitLyingCylinder(const ObjectView& view, const ObjectExtent& extent, const LyingCylinderParams& params)
{
  LyingCylinder out;
  const auto refuse = [&out](const std::string& why) {
    out.why = why;
    return out;
  };
  if (!params.enabled)
    return refuse("off");
  if (!view.has_table_plane || !view.cloud)
    return refuse("no table plane");
  const float radius = 0.5f * extent.height_m;
  if (extent.length_m < static_cast<float>(params.min_length_to_height) * extent.height_m)
    return refuse("footprint not long enough for its height");
  // A circle's footprint is as wide as the circle is high, and a camera above the table sees
  // at least its near half: a box on its side (a cereal box: 6 cm deep, 17 cm high) is not one,
  // however well its big faces fit a circle that large.
  if (extent.breadth_m < 0.5f * extent.height_m || extent.breadth_m > 1.25f * extent.height_m)
    return refuse("footprint not as wide as it is high");
  const Eigen::Vector3f& up = extent.up;
  const Eigen::Vector3f axis = axisFromNormals(view, extent);
  const Eigen::Vector3f across = up.cross(axis).normalized();

  // Each point's (across, height) in the cross-section.
  std::vector<Eigen::Vector2f> section;
  std::vector<Eigen::Vector3f> normals;
  section.reserve(view.cloud->size());
  normals.reserve(view.cloud->size());
  float along_lo = std::numeric_limits<float>::max(), along_hi = -along_lo;
  float across_lo = along_lo, across_hi = -along_lo;
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    section.emplace_back(across.dot(q), up.dot(q) + extent.table_offset);
    normals.push_back(p.getNormalVector3fMap());
    along_lo = std::min(along_lo, axis.dot(q));
    along_hi = std::max(along_hi, axis.dot(q));
    across_lo = std::min(across_lo, section.back().x());
    across_hi = std::max(across_hi, section.back().x());
  }
  if (section.size() < params.min_points)
    return refuse("too few points");
  // The axis's position across: the one unknown, by a coarse-to-fine scan of the points' summed
  // squared distance from the circle, each capped at a third of the radius (a bottle's neck,
  // stray points: outliers, not evidence), over the seen points' span and a radius beyond it
  // on both sides (40 steps, then 40 within the best step's neighbours, twice: ~0.05 mm).
  const auto cost = [&](float centre) {
    const float cap = radius * radius / 9.0f;
    float sum = 0.0f;
    for (const Eigen::Vector2f& s : section)
    {
      const float e = Eigen::Vector2f(s.x() - centre, s.y() - radius).norm() - radius;
      sum += std::min(e * e, cap);
    }
    return sum;
  };
  float lo = std::min(across_lo, across_hi) - radius, hi = std::max(across_lo, across_hi) + radius;
  float axis_across = 0.5f * (lo + hi);
  for (int level = 0; level < 3; ++level)
  {
    const int steps = 40;
    const float step = (hi - lo) / static_cast<float>(steps);
    float best = std::numeric_limits<float>::max();
    for (int i = 0; i <= steps; ++i)
    {
      const float centre = lo + step * static_cast<float>(i);
      const float c = cost(centre);
      if (c < best)
      {
        best = c;
        axis_across = centre;
      }
    }
    lo = axis_across - step;
    hi = axis_across + step;
  }
  // Round, not a box: the points lie on the circle and their normals point away from its axis.
  std::vector<float> residuals, angles;
  residuals.reserve(section.size());
  angles.reserve(section.size());
  for (std::size_t i = 0; i < section.size(); ++i)
  {
    const Eigen::Vector2f radial(section[i].x() - axis_across, section[i].y() - radius);
    residuals.push_back(std::abs(radial.norm() - radius));
    const Eigen::Vector3f& n = normals[i];
    if (!n.allFinite() || n.norm() < 0.5f || radial.norm() < 1e-4f)
      continue;
    const Eigen::Vector2f n2(across.dot(n), up.dot(n));
    if (n2.norm() < 0.3f * n.norm())
      continue;  // along the axis: an end face
    // normals are oriented toward the sensor, the near half's outward side: the sign is free
    const float cosine = std::abs(n2.normalized().dot(radial.normalized()));
    angles.push_back(std::acos(std::min(cosine, 1.0f)));
  }
  out.radius_m = radius;
  out.median_residual_m = median(residuals);
  out.median_normal_angle_rad = angles.empty() ? 0.0f : median(angles);
  out.axis = axis;
  out.axis_point = axis_across * across + (radius - extent.table_offset) * up + 0.5f * (along_lo + along_hi) * axis;
  if (out.median_residual_m > static_cast<float>(params.max_median_residual_frac) * radius)
    return refuse("points off the circle");
  if (angles.size() * 4 < section.size() ||
      out.median_normal_angle_rad > static_cast<float>(params.max_median_normal_angle_rad))
    return refuse("normals not radial");
  out.found = true;
  return out;
}

std::optional<float> fingertipReachPastAxis(const GraspCandidate& grasp, const GripperModel& gripper,
                                            const LyingCylinder& cylinder)
{
  if (!cylinder.found)
    return std::nullopt;
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  const Eigen::Vector3f closing = grasp.pose.linear().col(1).cast<float>().normalized();
  const Eigen::Vector3f& axis = cylinder.axis;
  if (std::abs(closing.dot(axis)) > 0.5f || std::abs(approach.dot(axis)) > std::cos(static_cast<float>(M_PI) / 4.0f))
    return std::nullopt;
  Eigen::Vector3f in_section = approach - approach.dot(axis) * axis;
  in_section.normalize();
  const Eigen::Vector3f tip =
      grasp.pose.translation().cast<float>() + 0.5f * static_cast<float>(gripper.finger_depth_m) * approach;
  Eigen::Vector3f from_axis = tip - cylinder.axis_point;
  from_axis -= from_axis.dot(axis) * axis;
  return in_section.dot(from_axis);
}

}  // namespace fast_grasp
