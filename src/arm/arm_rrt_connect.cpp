#include "fast_grasp/arm/arm_rrt_connect.h"

#include <ompl/base/DiscreteMotionValidator.h>
#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/tools/config/SelfConfig.h>

#include <algorithm>

namespace fast_grasp
{
namespace ob = ompl::base;

ArmRRTConnect::ArmRRTConnect(const ob::SpaceInformationPtr& si, TreeFactory make_tree)
  : ob::Planner(si, "RRTConnect"), make_tree_(std::move(make_tree))
{
  specs_.recognizedGoal = ob::GOAL_SAMPLEABLE_REGION;
  specs_.directed = true;
  declareParam<double>("range", this, &ArmRRTConnect::setRange, &ArmRRTConnect::getRange, "0.:1.:10000.");
}

ArmRRTConnect::~ArmRRTConnect()
{
  freeMemory();
}

void ArmRRTConnect::setup()
{
  ob::Planner::setup();
  ompl::tools::SelfConfig config(si_, getName());
  config.configurePlannerRange(range_);
  auto make = [this]() -> std::shared_ptr<Tree> {
    if (make_tree_)
      return make_tree_();
    return std::shared_ptr<Tree>(ompl::tools::SelfConfig::getDefaultNearestNeighbors<Motion*>(this));
  };
  if (!start_tree_)
    start_tree_ = make();
  if (!goal_tree_)
    goal_tree_ = make();
  auto distance = [this](const Motion* a, const Motion* b) { return si_->distance(a->state, b->state); };
  start_tree_->setDistanceFunction(distance);
  goal_tree_->setDistanceFunction(distance);
  own_motion_check_ = dynamic_cast<const ob::DiscreteMotionValidator*>(si_->getMotionValidator().get()) != nullptr;
  batch_checker_ = dynamic_cast<const BatchValidityChecker*>(si_->getStateValidityChecker().get());
}

void ArmRRTConnect::freeMemory()
{
  std::vector<Motion*> motions;
  for (const std::shared_ptr<Tree>& tree : { start_tree_, goal_tree_ })
  {
    if (!tree)
      continue;
    motions.clear();
    tree->list(motions);
    for (Motion* m : motions)
    {
      si_->freeState(m->state);
      delete m;
    }
  }
}

void ArmRRTConnect::clear()
{
  ob::Planner::clear();
  sampler_.reset();
  freeMemory();
  if (start_tree_)
    start_tree_->clear();
  if (goal_tree_)
    goal_tree_->clear();
  connection_ = { nullptr, nullptr };
}

bool ArmRRTConnect::checkMotion(const ob::State* a, const ob::State* b, const ob::State* fresh)
{
  if (!own_motion_check_)
  {
    // Another motion validator: its own checkMotion, which takes the first state as valid.
    if (fresh == b)
      return si_->checkMotion(a, b);
    return si_->isValid(a) && si_->checkMotion(a, b);
  }
  const unsigned segments = si_->getStateSpace()->validSegmentCount(a, b);
  if (batch_checker_)
    return checkMotionStates(*si_, *batch_checker_, a, b, fresh, segments, scratch_);
  // `fresh` first, then the interior states 1 .. segments-1 in breadth-first bisection order:
  // a collision somewhere along the motion is found after a few checks, not after walking up
  // to it.
  if (!si_->isValid(fresh))
    return false;
  if (segments < 2)
    return true;
  bisection_.clear();
  bisection_.emplace_back(1u, segments - 1);
  for (std::size_t next = 0; next < bisection_.size(); ++next)
  {
    const unsigned low = bisection_[next].first;
    const unsigned high = bisection_[next].second;
    const unsigned mid = (low + high) / 2;
    si_->getStateSpace()->interpolate(a, b, static_cast<double>(mid) / static_cast<double>(segments),
                                      scratch_.states[0]);
    if (!si_->isValid(scratch_.states[0]))
      return false;
    if (low < mid)
      bisection_.emplace_back(low, mid - 1);
    if (high > mid)
      bisection_.emplace_back(mid + 1, high);
  }
  return true;
}

ArmRRTConnect::Step ArmRRTConnect::extend(Tree& tree, bool start_tree, Motion* near, const ob::State* target,
                                          Motion** added)
{
  const ob::State* end = target;
  bool reaches = true;
  const double d = si_->distance(near->state, target);
  if (d > range_)
  {
    si_->getStateSpace()->interpolate(near->state, target, range_ / d, step_state_);
    // A space whose interpolation cannot move (constrained spaces) would otherwise "advance"
    // forever without progress.
    if (si_->equalStates(near->state, step_state_))
      return Step::Trapped;
    end = step_state_;
    reaches = false;
  }
  // Tree edges run in the direction a path will use them: start tree root -> leaf, goal tree
  // leaf -> root. The tree state `near` is valid already.
  const bool valid = start_tree ? checkMotion(near->state, end, end) : checkMotion(end, near->state, end);
  if (!valid)
    return Step::Trapped;
  auto* motion = new Motion;
  motion->state = si_->cloneState(end);
  motion->parent = near;
  motion->root = near->root;
  tree.add(motion);
  *added = motion;
  return reaches ? Step::Reached : Step::Advanced;
}

ob::PlannerStatus ArmRRTConnect::solve(const ob::PlannerTerminationCondition& ptc)
{
  checkValidity();
  auto* goal = dynamic_cast<ob::GoalSampleableRegion*>(pdef_->getGoal().get());
  if (!goal)
  {
    OMPL_ERROR("%s: the goal is not a GoalSampleableRegion", getName().c_str());
    return ob::PlannerStatus::UNRECOGNIZED_GOAL_TYPE;
  }
  auto addRoot = [this](Tree& tree, const ob::State* state) {
    auto* motion = new Motion;
    motion->state = si_->cloneState(state);
    motion->root = motion->state;
    tree.add(motion);
  };
  while (const ob::State* start = pis_.nextStart())
    addRoot(*start_tree_, start);
  if (start_tree_->size() == 0)
  {
    OMPL_ERROR("%s: no valid start state", getName().c_str());
    return ob::PlannerStatus::INVALID_START;
  }
  if (!goal->couldSample())
  {
    OMPL_ERROR("%s: the goal region has no states to sample", getName().c_str());
    return ob::PlannerStatus::INVALID_GOAL;
  }
  if (!sampler_)
    sampler_ = si_->allocStateSampler();

  ob::State* target = si_->allocState();
  step_state_ = si_->allocState();
  for (ob::State*& state : scratch_.states)
    state = si_->allocState();
  Motion target_motion;
  target_motion.state = target;
  bool solved = false;
  bool grow_start = true;
  while (!ptc)
  {
    Tree& grown = grow_start ? *start_tree_ : *goal_tree_;
    Tree& other = grow_start ? *goal_tree_ : *start_tree_;
    const bool grown_is_start = grow_start;
    grow_start = !grow_start;

    // A new goal root while the goal tree is empty or has grown past twice the goals taken.
    if (goal_tree_->size() == 0 || pis_.getSampledGoalsCount() < goal_tree_->size() / 2)
    {
      const ob::State* g = goal_tree_->size() == 0 ? pis_.nextGoal(ptc) : pis_.nextGoal();
      if (g)
        addRoot(*goal_tree_, g);
      if (goal_tree_->size() == 0)
      {
        OMPL_ERROR("%s: no valid goal state could be sampled", getName().c_str());
        break;
      }
    }

    sampler_->sampleUniform(target);
    Motion* added = nullptr;
    if (extend(grown, grown_is_start, grown.nearest(&target_motion), target, &added) == Step::Trapped)
      continue;

    // CONNECT the other tree to the state just added. After an ADVANCED step the state it
    // added is the other tree's nearest to that state (see the class comment).
    const ob::State* aim = added->state;
    Motion aim_motion;
    aim_motion.state = added->state;
    Motion* from = other.nearest(&aim_motion);
    Motion* reached = nullptr;
    Step step = Step::Advanced;
    while (step == Step::Advanced)
    {
      Motion* next = nullptr;
      step = extend(other, !grown_is_start, from, aim, &next);
      if (step != Step::Trapped)
        from = reached = next;
    }
    if (step != Step::Reached)
      continue;
    Motion* start_side = grown_is_start ? added : reached;
    Motion* goal_side = grown_is_start ? reached : added;
    if (!goal->isStartGoalPairValid(start_side->root, goal_side->root))
      continue;
    // Both sides end in the same state: keep it once.
    if (start_side->parent)
      start_side = start_side->parent;
    else
      goal_side = goal_side->parent;
    connection_ = { start_side->state, goal_side->state };
    std::vector<const ob::State*> from_start;
    for (const Motion* m = start_side; m; m = m->parent)
      from_start.push_back(m->state);
    auto path = std::make_shared<ompl::geometric::PathGeometric>(si_);
    path->getStates().reserve(from_start.size() + 16);
    for (auto it = from_start.rbegin(); it != from_start.rend(); ++it)
      path->append(*it);
    for (const Motion* m = goal_side; m; m = m->parent)
      path->append(m->state);
    pdef_->addSolutionPath(path, false, 0.0, getName());
    solved = true;
    break;
  }
  si_->freeState(target);
  si_->freeState(step_state_);
  step_state_ = nullptr;
  for (ob::State*& state : scratch_.states)
  {
    si_->freeState(state);
    state = nullptr;
  }
  OMPL_INFORM("%s: %u states (%u start + %u goal)", getName().c_str(),
              static_cast<unsigned>(start_tree_->size() + goal_tree_->size()),
              static_cast<unsigned>(start_tree_->size()), static_cast<unsigned>(goal_tree_->size()));
  return solved ? ob::PlannerStatus::EXACT_SOLUTION : ob::PlannerStatus::TIMEOUT;
}

void ArmRRTConnect::getPlannerData(ob::PlannerData& data) const
{
  ob::Planner::getPlannerData(data);
  std::vector<Motion*> motions;
  if (start_tree_)
    start_tree_->list(motions);
  for (const Motion* m : motions)
  {
    if (m->parent)
      data.addEdge(ob::PlannerDataVertex(m->parent->state, 1), ob::PlannerDataVertex(m->state, 1));
    else
      data.addStartVertex(ob::PlannerDataVertex(m->state, 1));
  }
  motions.clear();
  if (goal_tree_)
    goal_tree_->list(motions);
  for (const Motion* m : motions)
  {
    if (m->parent)  // towards the root, the direction a path takes it
      data.addEdge(ob::PlannerDataVertex(m->state, 2), ob::PlannerDataVertex(m->parent->state, 2));
    else
      data.addGoalVertex(ob::PlannerDataVertex(m->state, 2));
  }
  if (connection_.first)
    data.addEdge(data.vertexIndex(connection_.first), data.vertexIndex(connection_.second));
}

}  // namespace fast_grasp
