#include "fast_grasp/core/grasp_types.h"

#include <algorithm>

namespace fast_grasp
{
Eigen::Isometry3d makeGraspPose(const Eigen::Vector3d& centre, const Eigen::Vector3d& approach,
                                const Eigen::Vector3d& closing)
{
  const Eigen::Vector3d x = approach.normalized();
  Eigen::Vector3d y = closing - closing.dot(x) * x;
  if (y.squaredNorm() < 1e-12)
  {
    // Closing parallel to approach: pick any perpendicular so the pose stays a rotation.
    y = x.unitOrthogonal();
  }
  y.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = y;
  pose.linear().col(2) = x.cross(y);
  pose.translation() = centre;
  return pose;
}

const char* toString(GraspFailure failure)
{
  switch (failure)
  {
    case GraspFailure::None:
      return "ok";
    case GraspFailure::EmptyInput:
      return "EmptyInput";
    case GraspFailure::DegenerateInput:
      return "DegenerateInput";
    case GraspFailure::NoGraspableZone:
      return "NoGraspableZone";
    case GraspFailure::NoStableGrasp:
      return "NoStableGrasp";
    case GraspFailure::Timeout:
      return "Timeout";
    case GraspFailure::InvalidParameters:
      return "InvalidParameters";
  }
  return "Unknown";
}

void sortGraspsBestFirst(std::vector<GraspCandidate>& grasps)
{
  auto balance = [](const GraspCandidate& g) { return std::isnan(g.force_balance_rad) ? 1e9 : g.force_balance_rad; };
  std::stable_sort(grasps.begin(), grasps.end(), [&](const GraspCandidate& a, const GraspCandidate& b) {
    if (a.score != b.score)
      return a.score > b.score;
    return balance(a) < balance(b);
  });
}

}  // namespace fast_grasp
