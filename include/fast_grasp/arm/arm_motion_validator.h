// Discrete motion checks whose states are handed to the validity checker several at a time.
// ROS-free.
#pragma once

#include "fast_grasp/arm/batch_validity_checker.h"

#include <ompl/base/DiscreteMotionValidator.h>
#include <ompl/base/SpaceInformation.h>

#include <array>
#include <cstddef>
#include <utility>
#include <vector>

namespace fast_grasp
{
/// Scratch of checkMotionStates: one per caller and thread.
struct MotionCheckScratch
{
  static constexpr std::size_t kBatch = 4;  // states per BatchValidityChecker::firstInvalid call
  std::vector<std::pair<unsigned, unsigned>> bisection;
  std::vector<unsigned> order;
  std::array<ompl::base::State*, kBatch> states{};  // allocated by the caller
};

/// Checks `first` (a or b), then the interior states i / segments of the motion a -> b,
/// i = 1 .. segments - 1, in breadth-first bisection order (a collision somewhere along the
/// motion is found after a few checks, not after walking up to it) - the states and the order
/// of OMPL's DiscreteMotionValidator::checkMotion(a, b) - and stops at the first invalid one.
/// The states go to checker.firstInvalid kBatch at a time (one alone to isValid), so the
/// verdict is the one-by-one verdict. scratch.states must be allocated states of si.
bool checkMotionStates(const ompl::base::SpaceInformation& si, const BatchValidityChecker& checker,
                       const ompl::base::State* a, const ompl::base::State* b, const ompl::base::State* first,
                       unsigned segments, MotionCheckScratch& scratch);

/// OMPL's DiscreteMotionValidator, whose checkMotion(s1, s2) checks the same states in the same
/// order (s2, then the interior in bisection order) with checkMotionStates when the space's
/// validity checker is a BatchValidityChecker. Why: OMPL's path simplification and path
/// checks validate long motions (~8 states each in the UR5 narrow passage) through it. The
/// valid / invalid motion counters count as OMPL's do.
class ArmMotionValidator : public ompl::base::DiscreteMotionValidator
{
public:
  explicit ArmMotionValidator(const ompl::base::SpaceInformationPtr& si) : DiscreteMotionValidator(si) {}

  using DiscreteMotionValidator::checkMotion;  // the last-valid-state variant: OMPL's walk
  bool checkMotion(const ompl::base::State* s1, const ompl::base::State* s2) const override;
};

}  // namespace fast_grasp
