#include "fast_grasp/grasping/planner_input.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <sstream>

namespace fast_grasp
{
std::string formatNumber(double value)
{
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

std::string PlannerInputLimits::validate() const
{
  if (!(max_object_extent_m > 0.0) || !std::isfinite(max_object_extent_m))
    return "max_object_extent_m must be positive and finite (is " + formatNumber(max_object_extent_m) + ")";
  return "";
}

std::optional<GraspResult> checkPlannerInput(const std::string& planner, const std::string& params_problem,
                                             const GripperModel& gripper, const ObjectView& view,
                                             std::size_t min_points, const PlannerInputLimits& limits)
{
  const std::string prefix = planner + ": ";
  if (!params_problem.empty())
    return GraspResult::fail(GraspFailure::InvalidParameters, prefix + params_problem);
  const std::string limits_problem = limits.validate();
  if (!limits_problem.empty())
    return GraspResult::fail(GraspFailure::InvalidParameters, prefix + limits_problem);
  const std::string gripper_problem = gripper.validate();
  if (!gripper_problem.empty())
    return GraspResult::fail(GraspFailure::InvalidParameters, prefix + "gripper: " + gripper_problem);
  if (!view.cloud)
    return GraspResult::fail(GraspFailure::EmptyInput, prefix + "null cloud");
  std::size_t finite = 0;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  for (const auto& point : view.cloud->points)
    if (std::isfinite(point.x) && std::isfinite(point.y) && std::isfinite(point.z))
    {
      ++finite;
      lo = lo.cwiseMin(point.getVector3fMap());
      hi = hi.cwiseMax(point.getVector3fMap());
    }
  if (finite == 0)
    return GraspResult::fail(GraspFailure::EmptyInput, prefix + "no finite point in the cloud");
  const std::size_t needed = std::max<std::size_t>(min_points, 3);
  if (finite < needed)
    return GraspResult::fail(GraspFailure::DegenerateInput, prefix + "only " + std::to_string(finite) +
                                                                " finite points (min_points " +
                                                                std::to_string(needed) + ")");
  const bool origins_finite = std::all_of(view.sensor_origins.begin(), view.sensor_origins.end(),
                                          [](const Eigen::Vector3f& origin) { return origin.allFinite(); });
  if (view.sensor_origins.empty() || !origins_finite)
    return GraspResult::fail(GraspFailure::DegenerateInput,
                             prefix + "no sensor origin, or one is not finite: the approach must come from the seen side");
  const double extent = static_cast<double>((hi - lo).maxCoeff());
  if (extent > limits.max_object_extent_m)
    return GraspResult::fail(GraspFailure::DegenerateInput,
                             prefix + "the points span " + formatNumber(extent) + " m (more than max_object_extent_m " +
                                 formatNumber(limits.max_object_extent_m) +
                                 " m): not one graspable object, or not in metres");
  return std::nullopt;
}

}  // namespace fast_grasp
