#include "fast_grasp/grasping/grasp_features.h"

#include "fast_grasp/grasping/gripper_volume.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace fast_grasp
{
namespace
{
float clampf(float v, float lo, float hi)
{
  return std::min(std::max(v, lo), hi);
}
}  // namespace

ObjectExtent objectExtent(const ObjectView& view)
{
  ObjectExtent e;
  e.up = -view.gravity.normalized();
  if (view.has_table_plane && view.table_plane.head<3>().norm() > 1e-6f)
  {
    const float n = view.table_plane.head<3>().norm();
    e.up = view.table_plane.head<3>() / n;
    e.table_offset = view.table_plane(3) / n;
  }
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  float top = -std::numeric_limits<float>::max(), bottom = std::numeric_limits<float>::max();
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
    sum += q.cast<double>();
    ++count;
    const float h = e.up.dot(q) + e.table_offset;
    top = std::max(top, h);
    bottom = std::min(bottom, h);
  }
  if (count == 0)
    return e;
  e.centroid = (sum / static_cast<double>(count)).cast<float>();
  // Without a table the lowest seen point stands in for it.
  if (!view.has_table_plane)
  {
    e.table_offset -= bottom;
    top -= bottom;
  }
  e.height_m = std::max(top, 1e-3f);
  e.max_extent_m = std::max((hi - lo).maxCoeff(), 1e-3f);
  e.box_min = lo;
  e.box_max = hi;

  // Footprint: 2-D PCA of the points in the table plane.
  const auto [e1, e2] = tablePlaneBasis(e.up);
  Eigen::Matrix2f cov = Eigen::Matrix2f::Zero();
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f d = p.getVector3fMap() - e.centroid;
    if (!d.allFinite())
      continue;
    const Eigen::Vector2f in_plane(d.dot(e1), d.dot(e2));
    cov += in_plane * in_plane.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2f> pca(cov);
  const Eigen::Vector2f major2 = pca.eigenvectors().col(1);
  e.major_axis = major2.x() * e1 + major2.y() * e2;
  const Eigen::Vector3f minor_axis = e.up.cross(e.major_axis);
  float major_lo = std::numeric_limits<float>::max(), major_hi = -major_lo;
  float minor_lo = major_lo, minor_hi = major_hi;
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    major_lo = std::min(major_lo, e.major_axis.dot(q));
    major_hi = std::max(major_hi, e.major_axis.dot(q));
    minor_lo = std::min(minor_lo, minor_axis.dot(q));
    minor_hi = std::max(minor_hi, minor_axis.dot(q));
  }
  e.length_m = major_hi - major_lo;
  e.breadth_m = minor_hi - minor_lo;
  return e;
}

std::pair<Eigen::Vector3f, Eigen::Vector3f> tablePlaneBasis(const Eigen::Vector3f& up)
{
  const Eigen::Vector3f seed = std::abs(up.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
  const Eigen::Vector3f e1 = (seed - seed.dot(up) * up).normalized();
  return { e1, up.cross(e1) };
}

const std::vector<std::string>& graspFeatureSources()
{
  static const std::vector<std::string> sources{ "principal_axis", "cshape", "boundary", "concavity", "top_down",
                                                 "side", "end" };
  return sources;
}

const std::vector<std::string>& graspFeatureNames()
{
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& s : graspFeatureSources())
      n.push_back("from_" + s);
    for (const char* f : { "contact_height_frac", "contact_height_frac_sq", "centroid_arm_frac", "approach_down",
                           "width_frac", "grip_depth_frac", "points_between_log", "table_clearance_frac",
                           "object_height_frac", "contact_facing", "contact_facing_up", "cone_margin_rad",
                           "centroid_arm_m", "weight_torque", "neighbour_support" })
      n.emplace_back(f);
    return n;
  }();
  return names;
}

std::vector<PointBetweenFingers> pointsBetweenOpenFingers(const GraspCandidate& grasp, const GripperModel& gripper,
                                                          const CloudNormal& cloud)
{
  const Eigen::Matrix3f rotation = grasp.pose.linear().cast<float>();
  const Eigen::Vector3f origin = grasp.pose.translation().cast<float>();
  const float half_depth = 0.5f * static_cast<float>(gripper.finger_depth_m);
  const float half_opening = 0.5f * static_cast<float>(gripper.max_opening_m);
  const float half_width = 0.5f * static_cast<float>(gripper.finger_width_m);
  std::vector<PointBetweenFingers> between;
  for (const auto& p : cloud.points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    const Eigen::Vector3f local = rotation.transpose() * (q - origin);
    if (std::abs(local.x()) > half_depth || std::abs(local.y()) > half_opening || std::abs(local.z()) > half_width)
      continue;
    Eigen::Vector3f normal = p.getNormalVector3fMap();
    if (!normal.allFinite() || normal.norm() < 0.5f)
      normal.setZero();
    between.push_back({ local, normal });
  }
  return between;
}

std::vector<double> graspFeatures(const GraspCandidate& grasp, const std::string& source, const ObjectView& view,
                                  const ObjectExtent& extent, const GripperModel& gripper)
{
  const auto& sources = graspFeatureSources();
  std::vector<double> f(graspFeatureNames().size(), 0.0);
  for (std::size_t i = 0; i < sources.size(); ++i)
    f[i] = source == sources[i] ? 1.0 : 0.0;
  std::size_t k = sources.size();

  const Eigen::Matrix3f rotation = grasp.pose.linear().cast<float>();
  const Eigen::Vector3f origin = grasp.pose.translation().cast<float>();
  const Eigen::Vector3f approach = rotation.col(0), closing = rotation.col(1);
  const float opening = static_cast<float>(gripper.max_opening_m);
  const float finger_depth = static_cast<float>(gripper.finger_depth_m);

  float y_min = std::numeric_limits<float>::max(), y_max = -y_min;
  float x_min = std::numeric_limits<float>::max(), x_max = -x_min;
  const std::vector<PointBetweenFingers> region = pointsBetweenOpenFingers(grasp, gripper, *view.cloud);
  for (const PointBetweenFingers& point : region)
  {
    y_min = std::min(y_min, point.local.y());
    y_max = std::max(y_max, point.local.y());
    x_min = std::min(x_min, point.local.x());
    x_max = std::max(x_max, point.local.x());
  }
  const std::size_t between = region.size();
  const float height = extent.up.dot(origin) + extent.table_offset;
  const float height_frac = clampf(height / extent.height_m, -0.5f, 1.5f);
  f[k++] = height_frac;
  f[k++] = height_frac * height_frac;
  // The lever the object's weight has about the closing line (it pivots out about it).
  const Eigen::Vector3f to_centroid = extent.centroid - origin;
  const float arm = (to_centroid - to_centroid.dot(closing) * closing).norm();
  f[k++] = clampf(arm / extent.max_extent_m, 0.0f, 2.0f);
  f[k++] = -approach.dot(extent.up);  // 1: from above, 0: from the side
  f[k++] = between > 0 ? clampf((y_max - y_min) / opening, 0.0f, 1.0f) : 0.0;
  f[k++] = between > 0 ? clampf((x_max - x_min) / finger_depth, 0.0f, 1.0f) : 0.0;
  f[k++] = std::log1p(static_cast<double>(between)) / std::log(1000.0);
  // Lowest corner of the open hand (the boxes the gripper-volume check fits) above the table,
  // over the finger depth.
  float lowest = std::numeric_limits<float>::max();
  for (const GripperBox& box : openGripperBoxes(gripper, gripper.max_opening_m))
    for (int corner = 0; corner < 8; ++corner)
      lowest = std::min(lowest, extent.up.dot(origin + rotation * box.corner(corner)) + extent.table_offset);
  f[k++] = clampf(lowest / finger_depth, -1.0f, 2.0f);
  f[k++] = clampf(extent.height_m / opening, 0.0f, 4.0f);
  // Contacts: points within 1 cm of each side's outermost point. facing = mean |n . closing|
  // (1: flat faces square to the fingers), facing_up = mean n . up (> 0: the fingers press on
  // surfaces that face up, above a round object's equator, and it slips out when lifted).
  double facing = 0.0, facing_up = 0.0;
  std::size_t contacts = 0;
  for (const auto& [local, normal] : region)
  {
    const float y = local.y();
    if (y > y_max - 0.01f || y < y_min + 0.01f)
    {
      facing += std::abs(normal.dot(closing));
      facing_up += normal.dot(extent.up);
      ++contacts;
    }
  }
  f[k++] = contacts ? facing / static_cast<double>(contacts) : 0.0;
  f[k++] = contacts ? facing_up / static_cast<double>(contacts) : 0.0;
  // Friction cone: the mean normal of the first 5 mm of each seen side against the closing
  // line, as the margin to atan(0.8) (the evaluator's friction); the worse side counts. Only
  // points whose normal faces that finger count (a top face's rim is no contact), and a side
  // with none is unseen and does not count.
  double margin = std::atan(0.8);
  for (const float side : { -1.0f, 1.0f })
  {
    Eigen::Vector3f mean = Eigen::Vector3f::Zero();
    for (const auto& [local, normal] : region)
      if ((side > 0.0f ? local.y() > y_max - 0.005f : local.y() < y_min + 0.005f) && side * normal.dot(closing) > 0.2f)
        mean += normal;
    if (mean.norm() < 1e-3f)
      continue;
    // the outward normal at the +Y side points along +Y, toward that finger: normals are
    // oriented toward the sensor, so flip them to the finger's side
    const float cosine = clampf(std::abs(mean.normalized().dot(closing)), 0.0f, 1.0f);
    margin = std::min(margin, std::atan(0.8) - std::acos(static_cast<double>(cosine)));
  }
  f[k++] = between > 0 ? margin : -1.0;
  // The object's weight turning it about the closing line: the lever in units of 5 cm, and
  // lever x the footprint box's volume in litres (~kg at water's density), what the fingers'
  // friction must resist when the object is lifted and shaken.
  const double arm_m = static_cast<double>(arm);
  const double volume_l = 1000.0 * static_cast<double>(extent.length_m) * extent.breadth_m * extent.height_m;
  f[k++] = std::min(arm_m / 0.05, 4.0);
  f[k++] = std::min(arm_m / 0.05 * volume_l, 8.0);
  f[k++] = 0.0;  // neighbour_support: filled in by the fused planner, which sees the whole pool
  return f;
}

double GraspSuccessModel::probability(const std::vector<double>& features) const
{
  double z = bias;
  for (std::size_t i = 0; i < weights.size() && i < features.size(); ++i)
    z += weights[i] * features[i];
  return 1.0 / (1.0 + std::exp(-z));
}

std::string GraspSuccessModel::validate() const
{
  std::ostringstream why;
  if (!weights.empty() && weights.size() != graspFeatureNames().size())
    why << "model has " << weights.size() << " weights for " << graspFeatureNames().size() << " features; ";
  if (!std::isfinite(bias))
    why << "model bias is not finite; ";
  for (const double w : weights)
    if (!std::isfinite(w))
    {
      why << "a model weight is not finite; ";
      break;
    }
  return why.str();
}

}  // namespace fast_grasp
