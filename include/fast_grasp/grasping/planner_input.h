// The input checks every grasp planner's plan() starts with: one place, one set of failure
// types, so the four (and later more) planners answer the same bad view the same way.
// ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <cstddef>
#include <optional>
#include <string>

namespace fast_grasp
{
/// The typed failure for a view that `planner` cannot plan on, or nullopt when it can.
/// Checked in this order:
///  - `params_problem` (the planner's own Params::validate() text) non-empty: InvalidParameters;
///  - the gripper fails GripperModel::validate(): InvalidParameters;
///  - a null cloud or no finite point: EmptyInput;
///  - fewer than max(min_points, 3) finite points: DegenerateInput;
///  - no sensor origin, or a non-finite one: DegenerateInput (every planner approaches from
///    the seen side);
///  - finite points spanning more than kMaxObjectExtentM along an axis: DegenerateInput (no
///    hand grasps that: it is a segmentation failure or a unit error, and the planners' grids
///    and sweeps, sized by the extent, would try to allocate for it).
/// Messages start with "<planner>: ". compute_time_s is left to the caller.
/// Larger than any graspable object by two orders of magnitude (grippers open < 0.3 m).
constexpr double kMaxObjectExtentM = 10.0;

/// A number in a planner's failure or summary message: 3 significant digits.
std::string formatNumber(double value);

std::optional<GraspResult> checkPlannerInput(const std::string& planner, const std::string& params_problem,
                                             const GripperModel& gripper, const ObjectView& view,
                                             std::size_t min_points);

}  // namespace fast_grasp
