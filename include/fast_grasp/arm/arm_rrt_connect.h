// RRT-Connect (Kuffner & LaValle, ICRA 2000) as an OMPL geometric planner, written for the arm
// planner's benchmarks (issue 13). ROS-free.
#pragma once

#include "fast_grasp/arm/arm_motion_validator.h"

#include <ompl/base/Planner.h>
#include <ompl/base/StateSampler.h>
#include <ompl/datastructures/NearestNeighbors.h>
#include <ompl/util/RandomNumbers.h>

#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace fast_grasp
{
/// Two trees, one rooted at the start states and one at the goal states (sampled from the
/// goal, a GoalSampleableRegion, as the search goes: one new goal root whenever the goal tree
/// holds more than twice as many states as goals taken). Each iteration samples a state
/// uniformly, EXTENDs one tree one step (at most `range` in the space's distance) towards it
/// and then CONNECTs the other tree to the new state (EXTEND repeatedly until it reaches the
/// state or is trapped); the trees swap roles every iteration. Every tree edge is a motion
/// validated at the space's resolution (all states at the space's validSegmentCount, the
/// states OMPL's DiscreteMotionValidator checks), and a path is returned only once the trees
/// meet exactly, so the solution is exact and every segment of it is a validated motion in
/// the direction the path runs. Random numbers come from the space's sampler (OMPL's RNG, so
/// ompl::RNG::setSeed makes runs repeatable); with the same seed it grows the same trees as
/// OMPL 1.5's RRTConnect.
///
/// What it does not do that OMPL's RRTConnect does (why: the UR5 narrow passage benchmark,
/// docs/benchmarks/arms.md, "Speed work, session 17 (2)"):
/// - re-check a goal-tree state when extending the goal tree from it (OMPL validates the new
///   state and then the motion into the tree state, which checks the tree state again);
/// - a nearest-neighbour query per CONNECT step after the first: once a step towards the
///   target has ADVANCED, the state it added is strictly nearer the target than every other
///   state of the tree (the others were at least the old nearest's distance d away, the new
///   one is d - range), so it is the next step's nearest;
/// - a nearest-neighbour query per iteration for the "distance between trees" progress
///   property;
/// - approximate solutions (a timeout returns TIMEOUT, no path).
class ArmRRTConnect : public ompl::base::Planner
{
public:
  struct Motion
  {
    ompl::base::State* state = nullptr;
    Motion* parent = nullptr;
    const ompl::base::State* root = nullptr;  // the state of this tree's root it grew from
  };
  using Tree = ompl::NearestNeighbors<Motion*>;
  /// Makes an empty tree; its distance function is set by setup(). Null: OMPL's default.
  using TreeFactory = std::function<std::shared_ptr<Tree>()>;

  explicit ArmRRTConnect(const ompl::base::SpaceInformationPtr& si, TreeFactory make_tree = nullptr);
  ~ArmRRTConnect() override;

  /// Longest EXTEND step in the space's distance (0 before setup(): OMPL's SelfConfig chooses).
  void setRange(double range) { range_ = range; }
  double getRange() const { return range_; }

  void setup() override;
  void clear() override;
  ompl::base::PlannerStatus solve(const ompl::base::PlannerTerminationCondition& ptc) override;
  void getPlannerData(ompl::base::PlannerData& data) const override;

private:
  enum class Step
  {
    Trapped,
    Advanced,
    Reached
  };
  /// One EXTEND of `tree` from `near` towards `target`; the added motion in *added.
  Step extend(Tree& tree, bool start_tree, Motion* near, const ompl::base::State* target, Motion** added);
  /// The motion a -> b, `fresh` (a or b) not yet checked, the other end known valid: `fresh`
  /// first, then the interior states in bisection order (the same states, interpolated from
  /// a towards b, as DiscreteMotionValidator::checkMotion(a, b)).
  bool checkMotion(const ompl::base::State* a, const ompl::base::State* b, const ompl::base::State* fresh);
  void freeMemory();

  // Unused: OMPL 1.5's RRTConnect constructs one, which draws a seed from OMPL's seed
  // sequence; so does this planner, so that with ompl::RNG::setSeed the samplers created
  // afterwards get the same seeds and the two grow the same trees (how the benchmarks pair
  // runs of the two).
  ompl::RNG seed_alignment_;
  TreeFactory make_tree_;
  std::shared_ptr<Tree> start_tree_;
  std::shared_ptr<Tree> goal_tree_;
  ompl::base::StateSamplerPtr sampler_;
  double range_ = 0.0;
  bool own_motion_check_ = false;  // the space information validates motions discretely
  ompl::base::State* step_state_ = nullptr;      // scratch: the EXTEND step's end
  // With a BatchValidityChecker a motion's states are checked several at a time
  // (checkMotionStates: the same states in the same order, the same verdicts).
  const BatchValidityChecker* batch_checker_ = nullptr;
  MotionCheckScratch scratch_;                            // its states: a motion's interior states
  std::vector<std::pair<unsigned, unsigned>> bisection_;  // scratch: intervals to check
  std::pair<const ompl::base::State*, const ompl::base::State*> connection_{ nullptr, nullptr };
};

}  // namespace fast_grasp
