#include "fast_grasp/grasping/lying_cylinder.h"

#include "fast_grasp/grasping/grasp_geometry.h"
#include "fast_grasp/grasping/gripper_volume.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace fast_grasp
{
namespace
{
/// The horizontal direction the most normals are square to: a scan over half a turn (2 deg,
/// then 0.1 deg steps) of the summed squared normal components along it, each capped at 0.25
/// (a normal within 60 deg of the direction is an end face, not evidence against it). The seen
/// footprint's major axis is no guide: an end face skews it by ~10 deg, and it runs across a
/// can half hidden in a pile, seen shorter than it is wide.
Eigen::Vector3f squareToMostNormals(const std::vector<Eigen::Vector3f>& normals, const Eigen::Vector3f& e1,
                                    const Eigen::Vector3f& e2)
{
  const auto cost = [&](float angle) {
    const Eigen::Vector3f d = std::cos(angle) * e1 + std::sin(angle) * e2;
    float sum = 0.0f;
    for (const Eigen::Vector3f& n : normals)
      sum += std::min(n.dot(d) * n.dot(d), 0.25f);
    return sum;
  };
  const float degree = static_cast<float>(M_PI) / 180.0f;
  float best_angle = 0.0f, best = std::numeric_limits<float>::max();
  for (int i = 0; i < 90; ++i)
    if (const float c = cost(2.0f * degree * static_cast<float>(i)); c < best)
    {
      best = c;
      best_angle = 2.0f * degree * static_cast<float>(i);
    }
  const float coarse = best_angle;
  for (int i = -20; i <= 20; ++i)
    if (const float c = cost(coarse + 0.1f * degree * static_cast<float>(i)); c < best)
    {
      best = c;
      best_angle = coarse + 0.1f * degree * static_cast<float>(i);
    }
  return std::cos(best_angle) * e1 + std::sin(best_angle) * e2;
}

/// Seen points within this fraction of the radius of the fitted circle are the body.
constexpr float kBodyResidualFrac = 0.15f;
/// The body's normals judge the spread once the body is this many times as long as high.
constexpr float kBodyMinLengthToHeight = 1.0f;

/// The view seen along one horizontal axis: the circle of `radius` tangent to the table fitted
/// to the points' cross-section, and how round they are about it.
struct SectionFit
{
  Eigen::Vector3f axis = Eigen::Vector3f::UnitX();
  Eigen::Vector3f axis_point = Eigen::Vector3f::Zero();
  float median_residual_m = std::numeric_limits<float>::max();
  float median_normal_angle_rad = static_cast<float>(M_PI);
  float normal_spread_ratio = 1.0f;
  /// The same over the body's points only (within kBodyResidualFrac of the circle: not a
  /// bottle's shoulder and neck), and those points' span along the axis.
  float body_normal_spread_ratio = 1.0f;
  float body_length_m = 0.0f;
  float body_breadth_m = 0.0f;  // the body's points' span across the axis
  float length_m = 0.0f;   // the points' span along the axis
  float breadth_m = 0.0f;  // ... and across it
  std::size_t normals_used = 0;
};

SectionFit fitSection(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& normals,
                      const ObjectExtent& extent, const Eigen::Vector3f& axis, float radius)
{
  SectionFit fit;
  fit.axis = axis;
  const Eigen::Vector3f& up = extent.up;
  const Eigen::Vector3f across = up.cross(axis).normalized();
  std::vector<Eigen::Vector2f> section;  // (across, height above the table)
  section.reserve(points.size());
  float along_lo = std::numeric_limits<float>::max(), along_hi = -along_lo;
  float across_lo = along_lo, across_hi = -along_lo;
  for (const Eigen::Vector3f& q : points)
  {
    section.emplace_back(across.dot(q), up.dot(q) + extent.table_offset);
    along_lo = std::min(along_lo, axis.dot(q));
    along_hi = std::max(along_hi, axis.dot(q));
    across_lo = std::min(across_lo, section.back().x());
    across_hi = std::max(across_hi, section.back().x());
  }
  fit.length_m = along_hi - along_lo;
  fit.breadth_m = across_hi - across_lo;
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
  float lo = across_lo - radius, hi = across_hi + radius;
  float axis_across = 0.5f * (lo + hi);
  for (int level = 0; level < 3; ++level)
  {
    const int steps = 40;
    const float step = (hi - lo) / static_cast<float>(steps);
    float best = std::numeric_limits<float>::max();
    for (int i = 0; i <= steps; ++i)
    {
      const float centre = lo + step * static_cast<float>(i);
      if (const float c = cost(centre); c < best)
      {
        best = c;
        axis_across = centre;
      }
    }
    lo = axis_across - step;
    hi = axis_across + step;
  }
  fit.axis_point = axis_across * across + (radius - extent.table_offset) * up + 0.5f * (along_lo + along_hi) * axis;

  // Round: the points lie on the circle, their normals point away from its axis, and the side's
  // normals (not an end face's) all lie in the cross-section, spread within it.
  std::vector<float> residuals, angles;
  residuals.reserve(section.size());
  angles.reserve(section.size());
  Eigen::Matrix2f scatter = Eigen::Matrix2f::Zero(), body_scatter = Eigen::Matrix2f::Zero();
  float body_lo = std::numeric_limits<float>::max(), body_hi = -body_lo;
  float body_across_lo = body_lo, body_across_hi = -body_lo;
  const auto [e1, e2] = tablePlaneBasis(up);
  for (std::size_t i = 0; i < section.size(); ++i)
  {
    const Eigen::Vector2f radial(section[i].x() - axis_across, section[i].y() - radius);
    residuals.push_back(std::abs(radial.norm() - radius));
    if (residuals.back() <= kBodyResidualFrac * radius)
    {
      body_across_lo = std::min(body_across_lo, section[i].x());
      body_across_hi = std::max(body_across_hi, section[i].x());
    }
    const Eigen::Vector3f& n = normals[i];
    if (!n.allFinite() || n.norm() < 0.5f || radial.norm() < 1e-4f || std::abs(n.normalized().dot(axis)) > 0.5f)
      continue;  // no normal, or an end face's
    const Eigen::Vector3f unit = n.normalized();
    const Eigen::Vector2f horizontal(unit.dot(e1), unit.dot(e2));
    scatter += horizontal * horizontal.transpose();
    if (residuals.back() <= kBodyResidualFrac * radius)
    {
      body_scatter += horizontal * horizontal.transpose();
      body_lo = std::min(body_lo, axis.dot(points[i]));
      body_hi = std::max(body_hi, axis.dot(points[i]));
    }
    // normals are oriented toward the sensor, the near half's outward side: the sign is free
    const Eigen::Vector2f in_section(across.dot(unit), up.dot(unit));
    const float cosine = std::abs(in_section.normalized().dot(radial.normalized()));
    angles.push_back(std::acos(std::min(cosine, 1.0f)));
  }
  fit.median_residual_m = medianInPlace(residuals);
  fit.normals_used = angles.size();
  if (!angles.empty())
    fit.median_normal_angle_rad = medianInPlace(angles);
  const auto spreadRatio = [](const Eigen::Matrix2f& normal_scatter) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2f> spread(normal_scatter);
    return spread.eigenvalues()(1) > 1e-9f ? spread.eigenvalues()(0) / spread.eigenvalues()(1) : 1.0f;
  };
  fit.normal_spread_ratio = spreadRatio(scatter);
  fit.body_normal_spread_ratio = spreadRatio(body_scatter);
  fit.body_length_m = body_hi > body_lo ? body_hi - body_lo : 0.0f;
  fit.body_breadth_m = body_across_hi > body_across_lo ? body_across_hi - body_across_lo : 0.0f;
  return fit;
}
}  // namespace

std::string LyingCylinderParams::validate() const
{
  std::ostringstream why;
  if (!(min_length_to_height >= 0.0 && min_length_to_height <= 100.0))
    why << "lying_cylinder min_length_to_height must be in [0, 100]; ";
  if (!(max_normal_spread_ratio > 0.0 && max_normal_spread_ratio <= 1.0))
    why << "lying_cylinder max_normal_spread_ratio must be in (0, 1]; ";
  if (!(max_median_residual_frac > 0.0 && max_median_residual_frac <= 1.0))
    why << "lying_cylinder max_median_residual_frac must be in (0, 1]; ";
  if (!(max_median_normal_angle_rad > 0.0 && max_median_normal_angle_rad <= M_PI))
    why << "lying_cylinder max_median_normal_angle_rad must be in (0, pi]; ";
  if (min_points < 3)
    why << "lying_cylinder min_points must be >= 3; ";
  if (!(std::abs(min_fingertip_reach_m) <= 0.1))
    why << "lying_cylinder min_fingertip_reach_m must be in [-0.1, 0.1] m; ";
  if (!(max_open_hand_depth_m >= 0.0))
    why << "lying_cylinder max_open_hand_depth_m must be >= 0 (.inf: no check); ";
  if (!(open_hand_approach_m >= 0.0 && open_hand_approach_m <= 1.0))
    why << "lying_cylinder open_hand_approach_m must be in [0, 1] m; ";
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
  std::vector<Eigen::Vector3f> points, normals, unit_normals;
  points.reserve(view.cloud->size());
  normals.reserve(view.cloud->size());
  for (const auto& p : view.cloud->points)
  {
    if (!p.getVector3fMap().allFinite())
      continue;
    points.push_back(p.getVector3fMap());
    normals.push_back(p.getNormalVector3fMap());
    if (normals.back().allFinite() && normals.back().norm() > 0.5f)
      unit_normals.push_back(normals.back().normalized());
  }
  if (points.size() < params.min_points || unit_normals.size() < params.min_points)
    return refuse("too few points");
  const float radius = 0.5f * extent.height_m;
  // The direction most normals are square to is the axis, or, when an end face fills the view
  // (a short can seen along its axis), the end face's normal is what most are square to and the
  // axis lies across it: both are fitted, the rounder section wins.
  const auto [e1, e2] = tablePlaneBasis(extent.up);
  const Eigen::Vector3f first = squareToMostNormals(unit_normals, e1, e2);
  const std::array<Eigen::Vector3f, 2> axes{ first, extent.up.cross(first).normalized() };
  SectionFit best;
  for (const Eigen::Vector3f& axis : axes)
  {
    SectionFit fit = fitSection(points, normals, extent, axis, radius);
    if (fit.median_residual_m < best.median_residual_m)
      best = fit;
  }
  out.axis = best.axis;
  out.axis_point = best.axis_point;
  out.radius_m = radius;
  out.half_length_m = 0.5f * best.length_m;
  out.median_residual_m = best.median_residual_m;
  out.median_normal_angle_rad = best.median_normal_angle_rad;
  out.normal_spread_ratio = best.normal_spread_ratio;
  if (best.length_m < static_cast<float>(params.min_length_to_height) * extent.height_m)
    return refuse("not long enough for its height");
  // A circle's footprint is as wide as the circle is high, and a camera above the table sees
  // at least its near half: a box on its side (a cereal box: 6 cm deep, 17 cm high) is not one,
  // however well its big faces fit a circle that large. Where the body alone is as long as the
  // object is high, its points' breadth judges: a small object touching a lying bottle (a cap,
  // a sugar cube beside it in a pile: one cluster) widens the footprint, not the body.
  const bool body_judges = best.body_length_m >= kBodyMinLengthToHeight * extent.height_m;
  const float breadth = body_judges ? best.body_breadth_m : best.breadth_m;
  if (breadth < 0.5f * extent.height_m || breadth > 1.25f * extent.height_m)
    return refuse("footprint not as wide as it is high");
  if (best.median_residual_m > static_cast<float>(params.max_median_residual_frac) * radius)
    return refuse("points off the circle");
  if (best.normals_used * 4 < points.size() ||
      best.median_normal_angle_rad > static_cast<float>(params.max_median_normal_angle_rad))
    return refuse("normals not radial");
  // A bottle's shoulder and neck turn its normals along the axis and spread them (lying water
  // bottle, fresh training draw: 0.106 against cans' 0.02-0.06); where the body alone is at
  // least as long as the object is high, its normals judge. A ball's body (the band round it
  // square to the axis) is half as long as it is high, so a ball is still judged by all of
  // its normals (0.13-0.19).
  const float spread = body_judges ? best.body_normal_spread_ratio : best.normal_spread_ratio;
  out.normal_spread_ratio = spread;
  if (spread > static_cast<float>(params.max_normal_spread_ratio))
    return refuse("normals not square to one horizontal axis");
  out.found = true;
  return out;
}

namespace
{
/// fingertipReachPastAxis's condition: the grasp closes across the axis, not end-on. Across
/// means at least 30 deg off the axis: a diagonal closing spans the chord 2r / sin(angle), at
/// 45 deg 1.4 diameters, and its fingers land on the body as surely as a square one's (a 60 deg
/// bound let the diagonal top-down grasps of lying bottles through while their square ones were
/// ranked last: clutter training piles, session 24, table 45).
bool closesAcrossAxis(const GraspCandidate& grasp, const LyingCylinder& cylinder)
{
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  const Eigen::Vector3f closing = grasp.pose.linear().col(1).cast<float>().normalized();
  return cylinder.found && std::abs(closing.dot(cylinder.axis)) <= std::cos(static_cast<float>(M_PI) / 6.0f) &&
         std::abs(approach.dot(cylinder.axis)) <= std::cos(static_cast<float>(M_PI) / 4.0f);
}

/// Distance from the origin to the convex hull of `points` (0 when inside).
float distanceToHull(std::vector<Eigen::Vector2f> points)
{
  // Andrew's monotone chain, then the origin against each edge. Hand-written for 8 points a
  // box: PCL's ConvexHull goes through qhull and a point cloud per call, for three boxes per
  // candidate and a hundred candidates per plan.
  std::sort(points.begin(), points.end(),
            [](const Eigen::Vector2f& a, const Eigen::Vector2f& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  const auto cross = [](const Eigen::Vector2f& o, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2f> hull(2 * points.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0f)
      --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;)
  {
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0f)
      --k;
    hull[k++] = points[i];
  }
  hull.resize(k > 1 ? k - 1 : k);  // counter-clockwise, the first point not repeated
  bool inside = hull.size() >= 3;
  float least = std::numeric_limits<float>::infinity();
  const Eigen::Vector2f origin = Eigen::Vector2f::Zero();
  for (std::size_t i = 0; i < hull.size(); ++i)
  {
    const Eigen::Vector2f& a = hull[i];
    const Eigen::Vector2f& b = hull[(i + 1) % hull.size()];
    if (cross(a, b, origin) < 0.0f)
      inside = false;
    const Eigen::Vector2f ab = b - a;
    const float t = ab.squaredNorm() > 0.0f ? std::clamp(-a.dot(ab) / ab.squaredNorm(), 0.0f, 1.0f) : 0.0f;
    least = std::min(least, (a + t * ab).norm());
  }
  return inside ? 0.0f : least;
}
}  // namespace

std::optional<float> openHandDepthInCylinder(const GraspCandidate& grasp, const GripperModel& gripper,
                                             const LyingCylinder& cylinder, double opening_m, double approach_m)
{
  if (!closesAcrossAxis(grasp, cylinder))
    return std::nullopt;
  // Each box swept back along the approach is still a box; seen along the axis it is the
  // convex hull of its 8 corners, and the cylinder's cross-section is a disc about the axis.
  const Eigen::Matrix3f rotation = grasp.pose.linear().cast<float>();
  const Eigen::Vector3f origin = grasp.pose.translation().cast<float>();
  const Eigen::Vector3f u = cylinder.axis.unitOrthogonal(), v = cylinder.axis.cross(u);
  float least = std::numeric_limits<float>::infinity();
  for (GripperBox box : openGripperBoxes(gripper, opening_m))
  {
    box.min.x() -= static_cast<float>(approach_m);
    std::vector<Eigen::Vector2f> section;
    float along_lo = std::numeric_limits<float>::infinity(), along_hi = -along_lo;
    for (int corner = 0; corner < 8; ++corner)
    {
      const Eigen::Vector3f q = origin + rotation * box.corner(corner) - cylinder.axis_point;
      along_lo = std::min(along_lo, q.dot(cylinder.axis));
      along_hi = std::max(along_hi, q.dot(cylinder.axis));
      section.emplace_back(q.dot(u), q.dot(v));
    }
    if (along_hi < -cylinder.half_length_m || along_lo > cylinder.half_length_m)
      continue;  // beside an end of the object, not over it
    least = std::min(least, distanceToHull(std::move(section)));
  }
  return cylinder.radius_m - least;
}

std::optional<float> fingertipReachPastAxis(const GraspCandidate& grasp, const GripperModel& gripper,
                                            const LyingCylinder& cylinder)
{
  if (!closesAcrossAxis(grasp, cylinder))
    return std::nullopt;
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  const Eigen::Vector3f& axis = cylinder.axis;
  Eigen::Vector3f in_section = approach - approach.dot(axis) * axis;
  in_section.normalize();
  const Eigen::Vector3f tip =
      grasp.pose.translation().cast<float>() + 0.5f * static_cast<float>(gripper.finger_depth_m) * approach;
  Eigen::Vector3f from_axis = tip - cylinder.axis_point;
  from_axis -= from_axis.dot(axis) * axis;
  return in_section.dot(from_axis);
}

GraspAcrossCylinder judgeGraspAcrossCylinder(const GraspCandidate& grasp, const GripperModel& gripper,
                                             const LyingCylinder& cylinder, const LyingCylinderParams& params,
                                             double opening_m)
{
  const auto reach = fingertipReachPastAxis(grasp, gripper, cylinder);
  if (!reach)
    return GraspAcrossCylinder::NotAcross;
  if (*reach < static_cast<float>(params.min_fingertip_reach_m))
    return GraspAcrossCylinder::ShortOfAxis;
  const auto depth = openHandDepthInCylinder(grasp, gripper, cylinder, opening_m, params.open_hand_approach_m);
  if (depth && *depth > static_cast<float>(params.max_open_hand_depth_m))  // .inf: never
    return GraspAcrossCylinder::OntoHiddenSide;
  return GraspAcrossCylinder::Holds;
}

}  // namespace fast_grasp
