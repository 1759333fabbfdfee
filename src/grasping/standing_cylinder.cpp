#include "fast_grasp/grasping/standing_cylinder.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace fast_grasp
{
namespace
{
/// A standing round object's silhouette is as wide as it is: a circle wider than this times the
/// seen footprint's longer side is a flat face's (a standing box's two seen faces fitted a
/// 25 cm circle to a 16 cm box).
constexpr float kMaxDiameterToFootprint = 1.2f;

/// Angle the directions `angles` (rad) span: the full turn less the widest gap between them.
float angularSpan(std::vector<float> angles)
{
  if (angles.size() < 2)
    return 0.0f;
  std::sort(angles.begin(), angles.end());
  float widest_gap = angles.front() + 2.0f * static_cast<float>(M_PI) - angles.back();
  for (std::size_t i = 1; i < angles.size(); ++i)
    widest_gap = std::max(widest_gap, angles[i] - angles[i - 1]);
  return 2.0f * static_cast<float>(M_PI) - widest_gap;
}
}  // namespace

std::string StandingCylinderParams::validate() const
{
  std::ostringstream why;
  if (!(min_height_m >= 0.0))
    why << "standing_cylinder min_height_m must be >= 0; ";
  if (!(band_half_height_m > 0.0 && band_half_height_m <= 0.1))
    why << "standing_cylinder band_half_height_m must be in (0, 0.1] m; ";
  if (min_points < 5)
    why << "standing_cylinder min_points must be >= 5; ";
  if (!(max_median_residual_frac > 0.0 && max_median_residual_frac <= 1.0))
    why << "standing_cylinder max_median_residual_frac must be in (0, 1]; ";
  if (!(max_median_normal_angle_rad > 0.0 && max_median_normal_angle_rad <= M_PI))
    why << "standing_cylinder max_median_normal_angle_rad must be in (0, pi]; ";
  if (!(min_arc_rad >= 0.0 && min_arc_rad <= 2.0 * M_PI))
    why << "standing_cylinder min_arc_rad must be in [0, 2 pi]; ";
  if (!(max_shortfall_frac >= 0.0 && max_shortfall_frac <= 1.0))
    why << "standing_cylinder max_shortfall_frac must be in [0, 1]; ";
  return why.str();
}

StandingSection fitStandingSection(const ObjectView& view, const ObjectExtent& extent, float height_m,
                                   const StandingCylinderParams& params)
{
  StandingSection out;
  if (!view.has_table_plane || !view.cloud)
  {
    out.why = "no table plane";
    return out;
  }
  const auto [e1, e2] = tablePlaneBasis(extent.up);
  // The side wall in the band: points whose normals lie within 45 deg of the table plane (a
  // top face or a shoulder facing up is no part of the section).
  std::vector<Eigen::Vector2f> points, normals;
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    const Eigen::Vector3f n = p.getNormalVector3fMap();
    if (!q.allFinite() || !n.allFinite() || n.norm() < 0.5f)
      continue;
    if (std::abs(extent.up.dot(q) + extent.table_offset - height_m) > static_cast<float>(params.band_half_height_m))
      continue;
    const Eigen::Vector2f flat_normal(e1.dot(n), e2.dot(n));
    if (flat_normal.norm() < 0.7f * n.norm())
      continue;
    points.emplace_back(e1.dot(q), e2.dot(q));
    normals.push_back(flat_normal.normalized());
  }
  if (points.size() < params.min_points)
  {
    out.why = "too few side points at that height";
    return out;
  }
  // Algebraic circle (Kasa): u^2 + v^2 + D u + E v + F = 0 in least squares, about the points'
  // mean for conditioning.
  Eigen::Vector2f mean = Eigen::Vector2f::Zero();
  for (const auto& q : points)
    mean += q;
  mean /= static_cast<float>(points.size());
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const auto& q : points)
  {
    const Eigen::Vector2d d = (q - mean).cast<double>();
    const Eigen::Vector3d row(d.x(), d.y(), 1.0);
    normal_matrix += row * row.transpose();
    rhs -= row * d.squaredNorm();
  }
  const Eigen::Vector3d def = normal_matrix.ldlt().solve(rhs);
  const Eigen::Vector2d centre_local(-0.5 * def.x(), -0.5 * def.y());
  const double radius2 = centre_local.squaredNorm() - def.z();
  if (!def.allFinite() || !(radius2 > 0.0))
  {
    out.why = "no circle";
    return out;
  }
  // Then Gauss-Newton on the points' distances from the circle: on half an arc with depth noise
  // the algebraic fit comes out a few millimetres small (a 37 mm bottle at 34 mm), and the
  // shortfall is measured from its centre.
  Eigen::Vector3d circle(centre_local.x(), centre_local.y(), std::sqrt(radius2));
  for (int iteration = 0; iteration < 10; ++iteration)
  {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (const auto& q : points)
    {
      const Eigen::Vector2d d = (q - mean).cast<double>() - circle.head<2>();
      const double distance = d.norm();
      if (distance < 1e-9)
        continue;
      const Eigen::Vector3d jacobian(-d.x() / distance, -d.y() / distance, -1.0);
      jtj += jacobian * jacobian.transpose();
      jtr += jacobian * (distance - circle.z());
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite())
      break;
    circle += step;
    if (step.norm() < 1e-7)
      break;
  }
  if (!circle.allFinite() || !(circle.z() > 0.0))
  {
    out.why = "no circle";
    return out;
  }
  const Eigen::Vector2f centre = mean + circle.head<2>().cast<float>();
  out.radius_m = static_cast<float>(circle.z());
  out.centre = centre.x() * e1 + centre.y() * e2 + (height_m - extent.table_offset) * extent.up;

  std::vector<float> residuals, angles, directions;
  residuals.reserve(points.size());
  angles.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const Eigen::Vector2f radial = points[i] - centre;
    residuals.push_back(std::abs(radial.norm() - out.radius_m));
    if (radial.norm() < 1e-4f)
      continue;
    // normals are oriented toward the sensor, the seen side's outward direction: the sign is free
    angles.push_back(std::acos(std::min(std::abs(normals[i].dot(radial.normalized())), 1.0f)));
    directions.push_back(std::atan2(radial.y(), radial.x()));
  }
  out.median_residual_m = medianInPlace(residuals);
  out.median_normal_angle_rad = angles.empty() ? static_cast<float>(M_PI) : medianInPlace(angles);
  out.arc_rad = angularSpan(std::move(directions));
  if (2.0f * out.radius_m > kMaxDiameterToFootprint * extent.length_m)
    out.why = "circle wider than the object";
  else if (out.median_residual_m > static_cast<float>(params.max_median_residual_frac) * out.radius_m)
    out.why = "points off the circle";
  else if (out.median_normal_angle_rad > static_cast<float>(params.max_median_normal_angle_rad))
    out.why = "normals not radial";
  else if (out.arc_rad < static_cast<float>(params.min_arc_rad))
    out.why = "too little of the circle seen";
  else
    out.found = true;
  return out;
}

bool isSideGrasp(const GraspCandidate& grasp, const ObjectExtent& extent)
{
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  const Eigen::Vector3f closing = grasp.pose.linear().col(1).cast<float>().normalized();
  return std::abs(approach.dot(extent.up)) <= std::sin(static_cast<float>(M_PI) / 4.0f) &&
         std::abs(closing.dot(extent.up)) <= std::sin(static_cast<float>(M_PI) / 6.0f);
}

float fingertipReachPastStandingAxis(const GraspCandidate& grasp, const GripperModel& gripper,
                                     const StandingSection& section, const Eigen::Vector3f& up)
{
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  Eigen::Vector3f flat = approach - approach.dot(up) * up;
  if (flat.norm() < 1e-6f)
    return 0.0f;
  flat.normalize();
  const Eigen::Vector3f tip =
      grasp.pose.translation().cast<float>() + 0.5f * static_cast<float>(gripper.finger_depth_m) * approach;
  return flat.dot(tip - section.centre);
}

std::optional<StandingSection> standingSectionMissed(const GraspCandidate& grasp, const GripperModel& gripper,
                                                     const ObjectView& view, const ObjectExtent& extent,
                                                     const StandingCylinderParams& params)
{
  if (!params.enabled || extent.height_m < static_cast<float>(params.min_height_m) || !isSideGrasp(grasp, extent))
    return std::nullopt;
  const float height = extent.up.dot(grasp.pose.translation().cast<float>()) + extent.table_offset;
  StandingSection section = fitStandingSection(view, extent, height, params);
  if (!section.found)
    return std::nullopt;
  const float reach = fingertipReachPastStandingAxis(grasp, gripper, section, extent.up);
  if (reach >= -static_cast<float>(params.max_shortfall_frac) * section.radius_m)
    return std::nullopt;
  return section;
}

}  // namespace fast_grasp
