// An OMPL state validity checker that also checks a run of states together. ROS-free.
#pragma once

#include <ompl/base/StateValidityChecker.h>

#include <cstddef>

namespace fast_grasp
{
/// isValid, plus the same verdicts for a run of states at once: the arm planner's checker
/// shares the forward kinematics of several states (RobotCollision::firstInCollision), and a
/// motion's states are checked in a fixed order that stops at the first invalid one, so the
/// caller hands over the next few states of that order (ArmRRTConnect, ArmMotionValidator).
class BatchValidityChecker : public ompl::base::StateValidityChecker
{
public:
  using ompl::base::StateValidityChecker::StateValidityChecker;

  /// The index of the first state of states[0 .. count) that isValid rejects, or count when
  /// it accepts them all. States after the first invalid one may be left unchecked.
  virtual std::size_t firstInvalid(const ompl::base::State* const* states, std::size_t count) const = 0;
};

}  // namespace fast_grasp
