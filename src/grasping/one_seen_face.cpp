#include "fast_grasp/grasping/one_seen_face.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>

namespace fast_grasp
{
std::string OneSeenFaceParams::validate() const
{
  std::ostringstream why;
  if (!(max_width_m >= 0.0 && max_width_m <= 0.1))
    why << "one_seen_face max_width_m must be in [0, 0.1] m; ";
  if (!(min_facing_cos >= 0.0 && min_facing_cos <= 1.0))
    why << "one_seen_face min_facing_cos must be in [0, 1]; ";
  if (!(min_facing_share > 0.0 && min_facing_share <= 1.0))
    why << "one_seen_face min_facing_share must be in (0, 1]; ";
  return why.str();
}

bool closesAcrossOneSeenFace(const GraspCandidate& grasp, const GripperModel& gripper, const ObjectView& view,
                             const OneSeenFaceParams& params)
{
  if (!params.enabled || !view.cloud || !(grasp.width_m < params.max_width_m))
    return false;
  const Eigen::Matrix3f rotation = grasp.pose.linear().cast<float>();
  const Eigen::Vector3f origin = grasp.pose.translation().cast<float>();
  const Eigen::Vector3f closing = rotation.col(1);
  // The closing region at full opening, finger-wide (graspFeatures' "points between").
  const float half_depth = 0.5f * static_cast<float>(gripper.finger_depth_m);
  const float half_opening = 0.5f * static_cast<float>(gripper.max_opening_m);
  const float half_width = 0.5f * static_cast<float>(gripper.finger_width_m);
  const float facing_cos = static_cast<float>(params.min_facing_cos);
  float low = std::numeric_limits<float>::infinity(), high = -low;
  std::size_t between = 0, facing_plus = 0, facing_minus = 0;
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    const Eigen::Vector3f local = rotation.transpose() * (q - origin);
    if (std::abs(local.x()) > half_depth || std::abs(local.y()) > half_opening || std::abs(local.z()) > half_width)
      continue;
    ++between;
    low = std::min(low, local.y());
    high = std::max(high, local.y());
    const float along = p.getNormalVector3fMap().dot(closing);  // NaN normals count nowhere
    facing_plus += along > facing_cos ? 1u : 0u;
    facing_minus += along < -facing_cos ? 1u : 0u;
  }
  constexpr std::size_t kFewestPoints = 10;  // fewer say nothing about a face
  if (between < kFewestPoints || !(high - low < static_cast<float>(params.max_width_m)))
    return false;
  return static_cast<double>(std::max(facing_plus, facing_minus)) >=
         params.min_facing_share * static_cast<double>(between);
}

}  // namespace fast_grasp
