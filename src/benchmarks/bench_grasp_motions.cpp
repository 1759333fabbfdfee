// Grasp-motion benchmark on the bundled bags: the half of the planner comparison that
// bench_planners' synthetic scenes leave out (OctoMap scenes from real frames, goal sets of IK
// solutions, straight approach and lift). Per bag, frame 0 goes through perception and the
// principal-axis grasp planner (the C-shape planner when principal-axis gives no grasp, as the
// pipeline rostests do), the arm's collision scene is built once as arm_offline builds it
// (offline_arm_scene.h), and then every planner runs the full grasp execution plan
// (planGraspMotion, config/arm.yaml + config/planners.yaml with only the planner name changed)
// --runs times; OMPL is unseeded, so runs differ. Each call is timed with a steady clock.
// Prints, asserts nothing: per bag a row per planner, a summary over all bags, and last one line
// per planner
//   <planner> bags: solved P % median X ms
//
// Usage: bench_grasp_motions [--runs 10] [--planners SBL,BiTRRT,...] [--bags mug,hammer,...]
//                            [--out FILE.csv]
#include "command_line.h"
#include "offline_arm_scene.h"

#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/core/gripper_model.h"

#include <pcl/console/print.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
namespace fs = std::filesystem;
const std::string kSource = FAST_GRASP_SOURCE_DIR;

const char* const kUsage =
    "usage: bench_grasp_motions [--runs N] [--planners A,B,...] [--bags a,b,...] [--robot NAME] [--out FILE.csv]\n"
    "  --runs N      planGraspMotion calls per bag and planner (default 10)\n"
    "  --planners    OMPL planners (default SBL,BiEST,BKPIECE,LBKPIECE,RRTConnect,BiTRRT,KPIECE,ProjEST,FMT)\n"
    "  --bags        bag names in bags/ without .bag (default: every single-object bag)\n"
    "  --robot       config/robots/NAME.yaml (default ur5)\n"
    "  --out         CSV of every call: bag,planner,run,solved,ms,trajectory_s\n";

struct Options
{
  int runs = 10;
  std::vector<std::string> planners{ "SBL", "BiEST", "BKPIECE", "LBKPIECE", "RRTConnect",
                                     "BiTRRT", "KPIECE", "ProjEST", "FMT" };
  std::vector<std::string> bags;  // empty: every bag in bags/
  std::string robot = "ur5";
  std::string out_csv;
};

/// One planGraspMotion call.
struct Call
{
  bool solved = false;
  double ms = 0.0;
  double trajectory_s = std::numeric_limits<double>::quiet_NaN();  // time_from_start of the last point
  std::string status;
};

double median(std::vector<double> values)
{
  if (values.empty())
    return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double mean(const std::vector<double>& values)
{
  if (values.empty())
    return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (const double v : values)
    sum += v;
  return sum / static_cast<double>(values.size());
}

double solvedPercent(const std::vector<Call>& calls)
{
  if (calls.empty())
    return 0.0;
  const auto solved = std::count_if(calls.begin(), calls.end(), [](const Call& c) { return c.solved; });
  return 100.0 * static_cast<double>(solved) / static_cast<double>(calls.size());
}

std::vector<double> callMs(const std::vector<Call>& calls, bool solved_only)
{
  std::vector<double> ms;
  for (const Call& c : calls)
    if (c.solved || !solved_only)
      ms.push_back(c.ms);
  return ms;
}

/// Bag names (file stem) in bags/, sorted. The default set leaves clutter_* out (issue 11,
/// several objects; they run when named with --bags): docs/benchmarks' summaries are over the
/// single-object bags.
std::vector<std::string> bundledBags(bool with_clutter)
{
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(kSource + "/bags"))
    if (entry.path().extension() == ".bag" &&
        (with_clutter || entry.path().stem().string().rfind("clutter_", 0) != 0))
      names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// The rostests' grasp source: principal-axis, and C-shape on the bags where principal-axis
/// gives no grasp from the bag camera. Empty list (and the reasons in `note`) when neither grasps.
std::vector<GraspCandidate> planGrasps(const PreparedView& prepared, std::string& note)
{
  const GripperModel gripper = loadGripperModel(kSource + "/config/grippers/lacquey_fetch.yaml");
  const GraspPlannerConfig config = loadGraspPlannerConfig(kSource + "/config/grasp_planners.yaml");
  note.clear();
  for (const std::string algorithm : { "principal_axis", "cshape" })
  {
    const GraspResult grasps = makeGraspPlanner(algorithm, config)->plan(prepared.view, gripper);
    if (!note.empty())
      note += "; ";
    note += algorithm + ": " + std::to_string(grasps.grasps.size()) + " grasps (" + grasps.message + ")";
    if (grasps.ok())
      return grasps.grasps;
  }
  return {};
}

Call timeGraspMotion(const OfflineArm& arm, const std::vector<GraspCandidate>& grasps,
                     const GraspExecutionParams& params)
{
  Call call;
  const auto begin = std::chrono::steady_clock::now();
  const GraspPlanResult result = planGraspMotion(arm.collision, arm.start, grasps, params);
  const auto end = std::chrono::steady_clock::now();
  call.ms = std::chrono::duration<double, std::milli>(end - begin).count();
  call.solved = result.success && !result.points.empty();
  if (call.solved)
    call.trajectory_s = result.points.back().time_from_start_s;
  call.status = result.status;
  return call;
}

int run(const Options& options)
{
  std::ofstream csv;
  if (!options.out_csv.empty())
  {
    csv.open(options.out_csv);
    if (!csv)
    {
      std::cerr << "bench_grasp_motions: cannot write " << options.out_csv << "\n";
      return 1;
    }
    csv << "bag,planner,run,solved,ms,trajectory_s\n";
  }

  OfflineArm arm = loadOfflineArm(kSource + "/config/arm.yaml", kSource + "/config/planners.yaml", "", options.robot);
  std::printf("planGraspMotion per bag (frame 0), %d runs per planner; config/arm.yaml (planner %s, "
              "total_time_budget_s %.1f, planning_time_s %.1f) + config/planners.yaml, only the planner changed\n",
              options.runs, arm.params.motion.planner.c_str(), arm.params.total_time_budget_s,
              arm.params.motion.planning_time_s);

  const std::vector<std::string> bags = options.bags.empty() ? bundledBags(false) : options.bags;
  std::map<std::string, std::vector<Call>> all_calls;               // planner -> every call, all bags
  std::map<std::string, std::vector<double>> per_bag_medians;       // planner -> median ms of each bag (all calls)
  std::map<std::string, int> bags_all_solved;                       // planner -> bags at 100 %
  std::vector<std::string> benchmarked_bags, skipped_bags;

  for (const std::string& bag : bags)
  {
    std::printf("\nbag %s\n", bag.c_str());
    std::vector<GraspCandidate> grasps;
    std::string note;
    try
    {
      const BagFramePerception perception = perceiveBagFrame(kSource + "/bags/" + bag + ".bag", 0);
      grasps = planGrasps(perception.prepared, note);
      std::printf("  %s\n", note.c_str());
      if (grasps.empty())
      {
        std::printf("  skipped: no grasp\n");
        skipped_bags.push_back(bag + " (no grasp)");
        continue;
      }
      std::printf("  scene: %s\n", buildOfflineArmScene(arm, perception).c_str());
    }
    catch (const std::exception& e)
    {
      std::printf("  skipped: %s\n", e.what());
      skipped_bags.push_back(bag + " (" + e.what() + ")");
      continue;
    }
    benchmarked_bags.push_back(bag);

    std::printf("  %-12s %8s %12s %12s %14s\n", "planner", "solved%", "median ms", "mean ms", "median traj s");
    std::vector<std::string> failure_notes;
    for (const std::string& planner : options.planners)
    {
      GraspExecutionParams params = arm.params;
      params.motion.planner = planner;
      std::vector<Call> calls;
      for (int r = 0; r < options.runs; ++r)
      {
        calls.push_back(timeGraspMotion(arm, grasps, params));
        const Call& call = calls.back();
        if (csv)
          csv << bag << "," << planner << "," << r << "," << (call.solved ? 1 : 0) << "," << call.ms << ","
              << (call.solved ? std::to_string(call.trajectory_s) : "") << "\n";
      }
      std::vector<double> trajectory_s;
      for (const Call& c : calls)
        if (c.solved)
          trajectory_s.push_back(c.trajectory_s);
      const std::vector<double> solved_ms = callMs(calls, true);
      std::printf("  %-12s %7.0f%% %12.1f %12.1f %14.2f\n", planner.c_str(), solvedPercent(calls), median(solved_ms),
                  mean(solved_ms), median(trajectory_s));
      std::fflush(stdout);
      const auto failed = std::find_if(calls.begin(), calls.end(), [](const Call& c) { return !c.solved; });
      if (failed != calls.end())
        failure_notes.push_back(planner + " failed " + std::to_string(callMs(calls, false).size() - solved_ms.size()) +
                                "/" + std::to_string(calls.size()) + ", first: " + failed->status);
      per_bag_medians[planner].push_back(median(callMs(calls, false)));
      if (solved_ms.size() == calls.size())
        ++bags_all_solved[planner];
      all_calls[planner].insert(all_calls[planner].end(), calls.begin(), calls.end());
    }
    for (const std::string& line : failure_notes)
      std::printf("  %s\n", line.c_str());
  }

  std::printf("\nSummary over %zu bags (%d runs each):", benchmarked_bags.size(), options.runs);
  for (const std::string& bag : benchmarked_bags)
    std::printf(" %s", bag.c_str());
  std::printf("\n");
  for (const std::string& bag : skipped_bags)
    std::printf("  not benchmarked: %s\n", bag.c_str());
  std::printf("  median ms: over all calls, failures at their actual time; sum of medians: per-bag medians of all calls\n");
  std::printf("  %-12s %8s %12s %20s %14s\n", "planner", "solved%", "median ms", "sum of medians ms", "bags at 100%");
  for (const std::string& planner : options.planners)
  {
    double sum = 0.0;
    for (const double m : per_bag_medians[planner])
      sum += m;
    std::printf("  %-12s %7.1f%% %12.1f %20.1f %9d / %zu\n", planner.c_str(), solvedPercent(all_calls[planner]),
                median(callMs(all_calls[planner], false)), sum, bags_all_solved[planner], benchmarked_bags.size());
  }
  if (!options.out_csv.empty())
    std::printf("every call: %s\n", options.out_csv.c_str());
  std::printf("\n");
  for (const std::string& planner : options.planners)
    std::printf("%s bags: solved %.1f %% median %.1f ms\n", planner.c_str(), solvedPercent(all_calls[planner]),
                median(callMs(all_calls[planner], false)));
  return 0;
}

[[noreturn]] void usageError(const std::string& problem)
{
  std::cerr << "bench_grasp_motions: " << problem << "\n" << kUsage;
  std::exit(2);
}

Options parseOptions(int argc, char** argv)
{
  Options options;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        usageError(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--runs")
    {
      const std::string text = value();
      std::size_t used = 0;
      try
      {
        options.runs = std::stoi(text, &used);
      }
      catch (const std::exception&)
      {
        used = 0;
      }
      if (used != text.size() || options.runs < 1)
        usageError("--runs needs a positive integer, not '" + text + "'");
    }
    else if (flag == "--planners")
      options.planners = fast_grasp::splitCommaList(value());
    else if (flag == "--bags")
      options.bags = fast_grasp::splitCommaList(value());
    else if (flag == "--robot")
      options.robot = value();
    else if (flag == "--out")
      options.out_csv = value();
    else if (flag == "--help" || flag == "-h")
    {
      std::cout << kUsage;
      std::exit(0);
    }
    else
      usageError("unknown flag " + flag);
  }
  if (options.planners.empty())
    usageError("--planners is empty");
  const std::vector<std::string>& known = ArmMotionPlanner::plannerNames();
  for (const std::string& planner : options.planners)
    if (std::find(known.begin(), known.end(), planner) == known.end())
      usageError("unknown planner " + planner);
  const std::vector<std::string> bundled = bundledBags(true);
  for (const std::string& bag : options.bags)
    if (std::find(bundled.begin(), bundled.end(), bag) == bundled.end())
      usageError("no bag bags/" + bag + ".bag");
  return options;
}

}  // namespace
}  // namespace fast_grasp

int main(int argc, char** argv)
{
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  const fast_grasp::Options options = fast_grasp::parseOptions(argc, argv);
  try
  {
    return fast_grasp::run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "bench_grasp_motions: " << e.what() << "\n";
    return 1;
  }
}
