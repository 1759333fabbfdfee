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
/// What every planner accepts as one object view: the top-level keys of
/// config/grasp_planners.yaml (docs/parameters/grasping.md), the same for all planners.
struct PlannerInputLimits
{
  /// Finite points spanning more than this along an axis are not one object a hand grasps
  /// (grippers open < 0.3 m): a segmentation failure, the table, or a unit error. The planners'
  /// occupancy grids grow with the square of the extent and their contour candidates with the
  /// extent, each checked against every point: fuzzed views 4-6.5 m wide took 1-4 s each under
  /// the sanitizers (docs/tests.md).
  double max_object_extent_m = 1.0;

  /// "" or why these limits are unusable.
  std::string validate() const;
};

/// A number in a planner's failure or summary message: 3 significant digits.
std::string formatNumber(double value);

/// The typed failure for a view that `planner` cannot plan on, or nullopt when it can.
/// Checked in this order:
///  - `params_problem` (the planner's own Params::validate() text) non-empty: InvalidParameters;
///  - `limits` fail PlannerInputLimits::validate(): InvalidParameters;
///  - the gripper fails GripperModel::validate(): InvalidParameters;
///  - a null cloud or no finite point: EmptyInput;
///  - fewer than max(min_points, 3) finite points: DegenerateInput;
///  - no sensor origin, or a non-finite one: DegenerateInput (every planner approaches from
///    the seen side);
///  - finite points spanning more than limits.max_object_extent_m along an axis:
///    DegenerateInput (not one graspable object).
/// Messages start with "<planner>: ". compute_time_s is left to the caller.
std::optional<GraspResult> checkPlannerInput(const std::string& planner, const std::string& params_problem,
                                             const GripperModel& gripper, const ObjectView& view,
                                             std::size_t min_points, const PlannerInputLimits& limits);

}  // namespace fast_grasp
