// OMPL planner benchmark on the UR5 scenes of config/benchmarks/*.yaml, after the thesis's
// Ch6.3 (Tables 6.3/6.4): per scene and time limit, every planner runs --runs times through
// ompl::tools::Benchmark (its .log opens in Planner Arena after ompl_benchmark_statistics.py),
// then a table (solved %, time mean (sd), path length mean (sd)), a CSV of every run and PNG
// bar/box plots (matplotlib) are written. The last lines, one per planner, read
//   <planner> narrow_passage: solved P % median X ms      (3 s limit)
//
// Usage: bench_planners [--runs 30] [--planners RRTConnect,BiTRRT,...] [--scenes narrow_passage,...]
//                       [--limits 3,10] [--out DIR] [--config-dir DIR] [--urdf PATH]
//                       [--padding-m 0.01] [--check]
#include "fast_grasp/arm_motion_planner.h"
#include "fast_grasp/grasp_execution.h"

#include <ompl/geometric/SimpleSetup.h>
#include <ompl/tools/benchmark/Benchmark.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#ifndef FAST_GRASP_SOURCE_DIR
#define FAST_GRASP_SOURCE_DIR "."
#endif

namespace
{
namespace fs = std::filesystem;
using fast_grasp::ArmMotionPlanner;

std::vector<std::string> splitList(const std::string& s)
{
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty())
      out.push_back(item);
  return out;
}

struct Stats
{
  double mean = 0.0, sd = 0.0, median = 0.0;
};

Stats stats(std::vector<double> v)
{
  Stats s;
  if (v.empty())
    return s;
  for (double x : v)
    s.mean += x;
  s.mean /= v.size();
  for (double x : v)
    s.sd += (x - s.mean) * (x - s.mean);
  s.sd = v.size() > 1 ? std::sqrt(s.sd / (v.size() - 1)) : 0.0;
  std::sort(v.begin(), v.end());
  s.median = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  return s;
}

double property(const std::map<std::string, std::string>& run, const std::string& key, double fallback)
{
  const auto it = run.find(key);
  if (it == run.end() || it->second.empty())
    return fallback;
  try
  {
    return std::stod(it->second);
  }
  catch (const std::exception&)
  {
    return fallback;
  }
}

struct PlannerSummary
{
  std::string planner;
  double solved_percent = 0.0;
  Stats time_s;       // solve + simplification, solved runs
  Stats length_rad;   // simplified path length, solved runs
  double median_all_ms = 0.0;  // over all runs, unsolved counted at the time limit
};

const char* kPlotScript = R"PY(
import csv, sys, collections
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
path, out = sys.argv[1], sys.argv[2]
runs = collections.defaultdict(lambda: collections.defaultdict(list))
for r in csv.DictReader(open(path)):
    key = (r["scene"], r["limit_s"])
    runs[key][r["planner"]].append(r)
for (scene, limit), planners in runs.items():
    names = list(planners.keys())
    solved = [100.0 * sum(int(x["solved"]) for x in planners[n]) / len(planners[n]) for n in names]
    times = [[float(x["time_s"]) for x in planners[n] if x["solved"] == "1"] or [float("nan")] for n in names]
    lengths = [[float(x["length_rad"]) for x in planners[n] if x["solved"] == "1"] or [float("nan")] for n in names]
    fig, ax = plt.subplots(3, 1, figsize=(max(8, 0.6 * len(names)), 12))
    ax[0].bar(names, solved); ax[0].set_ylabel("solved %"); ax[0].set_ylim(0, 105)
    ax[1].boxplot(times, labels=names); ax[1].set_ylabel("time (s)"); ax[1].set_yscale("log")
    ax[2].boxplot(lengths, labels=names); ax[2].set_ylabel("path length (rad)")
    for a in ax: a.tick_params(axis="x", rotation=60)
    fig.suptitle("%s, %s s limit" % (scene, limit)); fig.tight_layout()
    fig.savefig("%s/%s_%ss.png" % (out, scene, limit)); plt.close(fig)
)PY";
}  // namespace

int main(int argc, char** argv)
{
  int runs = 30;
  std::vector<std::string> planners = ArmMotionPlanner::plannerNames();
  std::vector<std::string> scenes;
  std::vector<double> limits = { 3.0, 10.0 };
  std::string out_dir = "bench_planners_out";
  std::string config_dir = std::string(FAST_GRASP_SOURCE_DIR) + "/config";
  std::string urdf = std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/ur5_gripper_xtion.urdf";
  double padding_m = 0.01;
  bool check_only = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    if (flag == "--check")
    {
      check_only = true;
      continue;
    }
    if (i + 1 >= argc)
    {
      std::fprintf(stderr, "flag %s needs a value\n", flag.c_str());
      return 2;
    }
    const std::string value = argv[++i];
    if (flag == "--runs") runs = std::max(1, std::atoi(value.c_str()));
    else if (flag == "--planners") planners = splitList(value);
    else if (flag == "--scenes") scenes = splitList(value);
    else if (flag == "--limits")
    {
      limits.clear();
      for (const std::string& l : splitList(value))
        limits.push_back(std::atof(l.c_str()));
    }
    else if (flag == "--out") out_dir = value;
    else if (flag == "--config-dir") config_dir = value;
    else if (flag == "--urdf") urdf = value;
    else if (flag == "--padding-m") padding_m = std::atof(value.c_str());
    else
    {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  if (scenes.empty())
  {
    for (const auto& entry : fs::directory_iterator(config_dir + "/benchmarks"))
      if (entry.path().extension() == ".yaml")
        scenes.push_back(entry.path().stem().string());
    std::sort(scenes.begin(), scenes.end());
  }
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);
  fs::create_directories(out_dir);

  fast_grasp::ArmKinematics kin;
  fast_grasp::MotionPlanningParams base_params;
  try
  {
    kin = fast_grasp::ArmKinematics::fromUrdfFile(urdf);
    base_params.planner_params = fast_grasp::loadPlannerParameters(config_dir + "/planners.yaml");
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }

  std::ofstream csv(out_dir + "/runs.csv");
  csv << "scene,limit_s,planner,run,solved,time_s,length_rad\n";
  std::map<std::string, std::vector<PlannerSummary>> narrow_3s;
  for (const std::string& scene_name : scenes)
  {
    fast_grasp::ArmScene scene;
    try
    {
      scene = fast_grasp::loadArmScene(config_dir + "/benchmarks/" + scene_name + ".yaml");
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
    fast_grasp::RobotCollision collision(kin, padding_m);
    fast_grasp::addSceneBoxes(scene, collision);
    const ArmMotionPlanner planner(collision);
    fast_grasp::MotionPlanningParams params = base_params;
    params.keep_gripper_horizontal = scene.keep_gripper_horizontal;
    params.horizontal_tolerance_rad = scene.horizontal_tolerance_rad;
    Eigen::VectorXd start;
    std::vector<Eigen::VectorXd> goals;
    std::string why;
    if (!fast_grasp::resolveScene(scene, planner, params, start, goals, &why))
    {
      std::printf("scene %s: unusable: %s\n", scene_name.c_str(), why.c_str());
      continue;
    }
    const double hand_travel = (kin.fk(start).translation() - kin.fk(goals.front()).translation()).norm();
    std::printf("scene %s: %s\n  %zu goal configurations, hand travel %.2f m, start tilt %.3f rad\n",
                scene_name.c_str(), scene.description.c_str(), goals.size(), hand_travel, planner.gripperTiltRad(start));
    if (check_only)
      continue;
    for (double limit : limits)
    {
      const std::shared_ptr<ompl::geometric::SimpleSetup> setup = planner.makeSetup(start, goals, params);
      ompl::tools::Benchmark benchmark(*setup, scene_name);
      std::vector<std::string> unknown;
      for (const std::string& name : planners)
      {
        ompl::base::PlannerPtr p =
            ArmMotionPlanner::allocatePlanner(name, setup->getSpaceInformation(), params.planner_params, &unknown);
        if (!p)
        {
          std::fprintf(stderr, "unknown planner %s\n", name.c_str());
          return 2;
        }
        p->setName(name);
        benchmark.addPlanner(p);
      }
      for (const std::string& u : unknown)
        std::printf("  warning: OMPL has no parameter %s\n", u.c_str());
      ompl::tools::Benchmark::Request request(limit, 4096.0, static_cast<unsigned>(runs), 0.5, false, false, true);
      benchmark.benchmark(request);
      std::ostringstream log_name;
      log_name << out_dir << "/" << scene_name << "_" << limit << "s.log";
      benchmark.saveResultsToFile(log_name.str().c_str());

      std::printf("\n%s, max. %.0f s computing time, %d runs (Time: solve + simplify of solved runs; "
                  "path length in rad)\n",
                  scene_name.c_str(), limit, runs);
      std::printf("  %-12s %8s %18s %18s %12s\n", "Planner", "solved%", "Time (s)", "Path length", "median ms");
      std::vector<PlannerSummary> summaries;
      for (const auto& experiment : benchmark.getRecordedExperimentData().planners)
      {
        PlannerSummary summary;
        summary.planner = experiment.name;
        std::vector<double> times, lengths, all_ms;
        int solved = 0, index = 0;
        for (const auto& run : experiment.runs)
        {
          const bool exact = property(run, "solved BOOLEAN", 0) > 0.5 && property(run, "approximate solution BOOLEAN", 0) < 0.5;
          const double t = property(run, "time REAL", limit) + property(run, "simplification time REAL", 0.0);
          const double len = property(run, "simplified solution length REAL", property(run, "solution length REAL", 0.0));
          if (exact)
          {
            ++solved;
            times.push_back(t);
            lengths.push_back(len);
          }
          all_ms.push_back(1e3 * (exact ? t : limit));
          csv << scene_name << "," << limit << "," << experiment.name << "," << index++ << "," << (exact ? 1 : 0) << ","
              << t << "," << len << "\n";
        }
        summary.solved_percent = experiment.runs.empty() ? 0.0 : 100.0 * solved / experiment.runs.size();
        summary.time_s = stats(times);
        summary.length_rad = stats(lengths);
        summary.median_all_ms = stats(all_ms).median;
        std::printf("  %-12s %7.1f%% %9.3f (%6.3f) %9.2f (%6.2f) %12.1f\n", summary.planner.c_str(),
                    summary.solved_percent, summary.time_s.mean, summary.time_s.sd, summary.length_rad.mean,
                    summary.length_rad.sd, summary.median_all_ms);
        summaries.push_back(summary);
      }
      if (scene_name == "narrow_passage" && std::abs(limit - 3.0) < 1e-9)
        narrow_3s[scene_name] = summaries;
    }
  }
  csv.close();
  if (!check_only)
  {
    const std::string script = out_dir + "/plot_benchmark.py";
    std::ofstream(script) << kPlotScript;
    const std::string command = "/usr/bin/python3 " + script + " " + out_dir + "/runs.csv " + out_dir + " 2>&1";
    if (std::system(command.c_str()) != 0)
      std::printf("plots skipped: /usr/bin/python3 with matplotlib is needed (apt-get install python3-matplotlib)\n");
    else
      std::printf("plots: %s/<scene>_<limit>s.png; OMPL logs: %s/*.log (ompl_benchmark_statistics.py -> Planner Arena)\n",
                  out_dir.c_str(), out_dir.c_str());
  }
  for (const auto& entry : narrow_3s)
    for (const PlannerSummary& s : entry.second)
      std::printf("%s narrow_passage: solved %.1f %% median %.1f ms\n", s.planner.c_str(), s.solved_percent,
                  s.median_all_ms);
  return 0;
}
