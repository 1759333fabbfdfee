// An OMPL planner that runs another one and notes the process CPU clock when the other's
// solve() returns. bench_planners gives it to ompl::tools::Benchmark instead of the planner
// itself: OMPL's Benchmark runs solve(), then, before the post-run event (the first hook after
// solve() it offers), checks the raw path twice (PathGeometric::check at 1x and 4x resolution),
// simplifies it, checks the simplified path twice and copies the planner data. Those checks and
// copies are the benchmark's bookkeeping, not planning (the UR5 narrow passage: 13 % of the
// instructions between the pre- and post-run events, callgrind), so the CPU time of a run is
// taken from the pre-run event to the end of solve() (this class), plus the simplification
// timed on its own (bench_planners).
#pragma once

#include <ompl/base/Planner.h>

#include <ctime>
#include <string>
#include <utility>

namespace fast_grasp
{
/// This process's CPU time (s): every thread of it, e.g. the termination condition's thread
/// that ompl::base::Planner::solve(fn, interval) starts next to the planner.
inline double processCpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Forwards every planner call OMPL's Benchmark makes (problem, setup, solve, clear, planner
/// data) to `planner` and shows its name, parameters, specs and progress properties as its own,
/// so the benchmark's logs read as if `planner` ran alone.
class CpuTimedPlanner : public ompl::base::Planner
{
public:
  explicit CpuTimedPlanner(ompl::base::PlannerPtr planner)
    : ompl::base::Planner(planner->getSpaceInformation(), planner->getName()), planner_(std::move(planner))
  {
    specs_ = planner_->getSpecs();
    params_.include(planner_->params());
    plannerProgressProperties_ = planner_->getPlannerProgressProperties();
  }

  const ompl::base::PlannerPtr& planner() const { return planner_; }
  /// processCpuSeconds() when the last solve() returned (0 before the first).
  double cpuSecondsAtSolveEnd() const { return cpu_s_at_solve_end_; }

  void setProblemDefinition(const ompl::base::ProblemDefinitionPtr& pdef) override
  {
    ompl::base::Planner::setProblemDefinition(pdef);
    planner_->setProblemDefinition(pdef);
  }
  void setup() override
  {
    ompl::base::Planner::setup();
    if (!planner_->isSetup())
      planner_->setup();
  }
  void checkValidity() override { planner_->checkValidity(); }
  ompl::base::PlannerStatus solve(const ompl::base::PlannerTerminationCondition& ptc) override
  {
    const ompl::base::PlannerStatus status = planner_->solve(ptc);
    cpu_s_at_solve_end_ = processCpuSeconds();
    return status;
  }
  void clear() override
  {
    ompl::base::Planner::clear();
    planner_->clear();
  }
  void clearQuery() override
  {
    ompl::base::Planner::clearQuery();
    planner_->clearQuery();
  }
  void getPlannerData(ompl::base::PlannerData& data) const override { planner_->getPlannerData(data); }

private:
  ompl::base::PlannerPtr planner_;
  double cpu_s_at_solve_end_ = 0.0;
};

}  // namespace fast_grasp
