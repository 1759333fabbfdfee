#include "fast_grasp/arm/arm_motion_validator.h"

namespace fast_grasp
{
namespace ob = ompl::base;

bool checkMotionStates(const ob::SpaceInformation& si, const BatchValidityChecker& checker, const ob::State* a,
                       const ob::State* b, const ob::State* first, unsigned segments, MotionCheckScratch& scratch)
{
  constexpr std::size_t kBatch = MotionCheckScratch::kBatch;
  // `first` alone: it is the state most often invalid (the new end of an RRT step, the end of
  // a shortcut), and a group would compute the states after it for nothing.
  if (!checker.isValid(first))
    return false;
  scratch.order.clear();
  if (segments >= 2)
  {
    scratch.bisection.clear();
    scratch.bisection.emplace_back(1u, segments - 1);
    for (std::size_t next = 0; next < scratch.bisection.size(); ++next)
    {
      const unsigned low = scratch.bisection[next].first;
      const unsigned high = scratch.bisection[next].second;
      const unsigned mid = (low + high) / 2;
      scratch.order.push_back(mid);
      if (low < mid)
        scratch.bisection.emplace_back(low, mid - 1);
      if (high > mid)
        scratch.bisection.emplace_back(mid + 1, high);
    }
  }
  const ob::StateSpace& space = *si.getStateSpace();
  const double steps = static_cast<double>(segments);
  const ob::State* group[kBatch];
  for (std::size_t next = 0; next < scratch.order.size();)
  {
    std::size_t count = 0;
    for (; count < kBatch && next < scratch.order.size(); ++count, ++next)
    {
      space.interpolate(a, b, static_cast<double>(scratch.order[next]) / steps, scratch.states[count]);
      group[count] = scratch.states[count];
    }
    if (count == 1 ? !checker.isValid(group[0]) : checker.firstInvalid(group, count) < count)
      return false;
  }
  return true;
}

bool ArmMotionValidator::checkMotion(const ob::State* s1, const ob::State* s2) const
{
  const auto* checker = dynamic_cast<const BatchValidityChecker*>(si_->getStateValidityChecker().get());
  if (!checker)
    return DiscreteMotionValidator::checkMotion(s1, s2);
  // The order vectors per thread; the interior states per call, as OMPL's validator
  // allocates its one (thread-safe, and no state outlives the space information).
  thread_local MotionCheckScratch scratch;
  MotionCheckScratch& s = scratch;
  const unsigned segments = si_->getStateSpace()->validSegmentCount(s1, s2);
  if (segments >= 2)
    for (ob::State*& state : s.states)
      state = si_->allocState();
  const bool valid = checkMotionStates(*si_, *checker, s1, s2, s2, segments, s);
  if (segments >= 2)
    for (ob::State*& state : s.states)
    {
      si_->freeState(state);
      state = nullptr;
    }
  if (valid)
    valid_++;
  else
    invalid_++;
  return valid;
}

}  // namespace fast_grasp
