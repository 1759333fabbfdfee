#include "fast_grasp/grasping/one_seen_face.h"

#include "fast_grasp/grasping/grasp_features.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <vector>

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
  const Eigen::Vector3f closing = grasp.pose.linear().col(1).cast<float>();
  const float facing_cos = static_cast<float>(params.min_facing_cos);
  float low = std::numeric_limits<float>::infinity(), high = -low;
  std::size_t facing_plus = 0, facing_minus = 0;
  const std::vector<PointBetweenFingers> between = pointsBetweenOpenFingers(grasp, gripper, *view.cloud);
  for (const PointBetweenFingers& point : between)
  {
    low = std::min(low, point.local.y());
    high = std::max(high, point.local.y());
    const float along = point.normal.dot(closing);  // a missing normal is zero: it faces nowhere
    facing_plus += along > facing_cos ? 1u : 0u;
    facing_minus += along < -facing_cos ? 1u : 0u;
  }
  constexpr std::size_t kFewestPoints = 10;  // fewer say nothing about a face
  if (between.size() < kFewestPoints || !(high - low < static_cast<float>(params.max_width_m)))
    return false;
  return static_cast<double>(std::max(facing_plus, facing_minus)) >=
         params.min_facing_share * static_cast<double>(between.size());
}

}  // namespace fast_grasp
