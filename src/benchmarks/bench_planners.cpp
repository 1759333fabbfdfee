// OMPL planner benchmark on the scenes of config/benchmarks/*.yaml (laid out around the UR5;
// another --robot stands at its benchmark_base_m and starts at its home pose), after the thesis's
// Ch6.3 (Tables 6.3/6.4): per scene and time limit, every planner runs --runs times through
// ompl::tools::Benchmark (one OMPL log per planner: each planner runs in a child process, so an
// OMPL crash costs only its row), then a table (solved %, time mean (sd), path length mean (sd)),
// a CSV of every run, PNG bar/box plots (matplotlib) and <out>/benchmark.db, the logs converted
// for Planner Arena by scripts/ompl_benchmark_db.py, are written. The last lines, one per
// planner, read
//   <planner> <scene>: solved P % median X ms (cpu Y ms)   (narrow_passage: 3 s limit; others: the first limit)
// X is wall time as OMPL records it (solve + simplification), Y the process CPU time of the same
// runs' solve + simplification (a shared machine's load inflates X, not Y; the benchmark's own
// path checks and planner data copies are in neither, see cpu_timed_planner.h); unsolved runs
// count at the limit in both.
//
// Usage: bench_planners [--runs 30] [--planners RRTConnect,BiTRRT,...] [--scenes narrow_passage,...]
//                       [--limits 3,10] [--out DIR] [--config-dir DIR] [--robot ur5] [--urdf PATH]
//                       [--padding-m 0.005] [--cartesian-step-m 0] [--end-to-end PLANNER|none] [--check]
//                       [--seed N]
// --seed N seeds OMPL's random numbers: two builds then sample the same states, and a change
// that leaves the planners' decisions alone (a faster check, an exact nearest-neighbour
// structure) shows as the same trees in less time (run-to-run spread of RRTConnect's tree
// sizes is larger than most such gains).
#include "command_line.h"
#include "cpu_timed_planner.h"
#include "fast_grasp/arm/arm_motion_planner.h"
#include "fast_grasp/arm/grasp_execution.h"

#include <ompl/geometric/SimpleSetup.h>
#include <ompl/config.h>
#include <ompl/tools/benchmark/Benchmark.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>
#include <ompl/util/String.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#ifndef FAST_GRASP_SOURCE_DIR
#define FAST_GRASP_SOURCE_DIR "."
#endif

namespace
{
namespace fs = std::filesystem;
using fast_grasp::ArmMotionPlanner;

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
  double median_solve_ms = 0.0;  // solve() alone (no simplification), same convention
  double median_cpu_ms = 0.0;    // CPU time of solve + simplification, unsolved runs at the limit
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
  std::string robot = "ur5";  // config/robots/<robot>.yaml: URDF, limits, padding, contact links
  std::string urdf;           // empty: the robot's
  double padding_m = -1.0;    // < 0: the robot's link_padding_m
  // The OMPL runs validate motions like the thesis (longest_valid_segment_fraction alone);
  // --cartesian-step-m 0.01 benchmarks the planners with the sound validator inside instead.
  double cartesian_step_m = 0.0;
  std::string end_to_end_planner = fast_grasp::MotionPlanningParams().planner;  // ArmMotionPlanner::plan() runs
  bool check_only = false;
  static const char* const kUsage =
      "usage: bench_planners [--runs N] [--planners A,B,...] [--scenes S,...] [--limits SECONDS,...] [--out DIR]\n"
      "                      [--config-dir DIR] [--robot ur5|lwr4|jaco] [--urdf FILE] [--padding-m M]\n"
      "                      [--cartesian-step-m M]\n"
      "                      [--end-to-end PLANNER] [--check] [--seed N]\n"
      "  every OMPL planner on the thesis appendix scenes through ompl::tools::Benchmark (docs/benchmarks/)\n";
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    if (flag == "--check")
    {
      check_only = true;
      continue;
    }
    if (i + 1 >= argc)
      fast_grasp::exitWithUsage("flag " + flag + " needs a value", kUsage);
    const std::string value = argv[++i];
    if (flag == "--runs") runs = std::max(1, std::atoi(value.c_str()));
    else if (flag == "--planners") planners = fast_grasp::splitCommaList(value);
    else if (flag == "--scenes") scenes = fast_grasp::splitCommaList(value);
    else if (flag == "--limits")
    {
      limits.clear();
      for (const std::string& l : fast_grasp::splitCommaList(value))
        limits.push_back(std::atof(l.c_str()));
    }
    else if (flag == "--out") out_dir = value;
    else if (flag == "--config-dir") config_dir = value;
    else if (flag == "--urdf") urdf = value;
    else if (flag == "--robot") robot = value;
    else if (flag == "--padding-m") padding_m = std::atof(value.c_str());
    else if (flag == "--cartesian-step-m") cartesian_step_m = std::atof(value.c_str());
    else if (flag == "--end-to-end") end_to_end_planner = value;
    else if (flag == "--seed") ompl::RNG::setSeed(static_cast<std::uint_fast32_t>(std::strtoul(value.c_str(), nullptr, 10)));
    else
      fast_grasp::exitWithUsage("unknown flag " + flag, kUsage);
  }
  if (scenes.empty())
  {
    for (const auto& entry : fs::directory_iterator(config_dir + "/benchmarks"))
      if (entry.path().extension() == ".yaml")
        scenes.push_back(entry.path().stem().string());
    std::sort(scenes.begin(), scenes.end());
  }
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress visible when redirected
  fs::create_directories(out_dir);

  fast_grasp::ArmKinematics kin;
  fast_grasp::GraspExecutionParams robot_params;
  fast_grasp::MotionPlanningParams base_params;
  try
  {
    robot_params = fast_grasp::loadGraspExecutionParams(config_dir + "/arm.yaml", config_dir + "/planners.yaml", robot);
    if (!urdf.empty())
      robot_params.urdf_path = urdf;
    if (padding_m >= 0.0)
      robot_params.link_padding_m = padding_m;
    kin = fast_grasp::makeRobotCollision(robot_params).kinematics();
    base_params.planner_params = robot_params.motion.planner_params;  // planners.yaml + the robot's own
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }

  std::ofstream csv(out_dir + "/runs.csv");
  csv << "scene,limit_s,planner,run,solved,time_s,length_rad,cpu_s\n";
  std::map<std::string, std::vector<PlannerSummary>> summary_lines;
  std::vector<std::string> ompl_logs;  // written by this run (the out dir may hold older ones)
  std::vector<std::string> end_to_end_lines;
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
    // The scenes are laid out around the UR5: another arm stands at its benchmark_base_m,
    // starts at its home pose and seeds its IK there (the same Cartesian poses for every arm).
    const bool other_robot = scene.joints_robot != robot_params.robot.name;
    scene = fast_grasp::sceneForRobot(scene, robot_params.robot, kin.jointNames());
    if (other_robot && !scene.has_goal_pose)
    {
      std::printf("scene %s: skipped: its goal is a joint vector of another robot\n", scene_name.c_str());
      continue;
    }
    fast_grasp::RobotCollision collision = fast_grasp::makeRobotCollision(robot_params);
    fast_grasp::addSceneBoxes(scene, collision);
    const ArmMotionPlanner planner(collision);
    fast_grasp::MotionPlanningParams params = base_params;
    params.max_cartesian_step_m = cartesian_step_m;
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
    {
      // Cost of one validity check (the planners' inner loop), on random joint vectors.
      std::mt19937 rng(3);
      const int checks = 20000;
      int valid = 0;
      const auto t0 = std::chrono::steady_clock::now();
      for (int c = 0; c < checks; ++c)
        valid += planner.isValid(kin.randomConfiguration(rng), params) ? 1 : 0;
      const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / checks;
      std::printf("  validity check: %.1f us mean, %.1f %% of random states valid\n", us, 100.0 * valid / checks);
      for (const std::string& pair : collision.defaultAllowedPairs())
        std::printf("  unchecked pair (touching at zero pose): %s\n", pair.c_str());
      for (std::size_t g = 0; g < goals.size(); ++g)
      {
        std::printf("  goal %zu:", g);
        for (Eigen::Index j = 0; j < goals[g].size(); ++j)
          std::printf(" %.3f", goals[g][j]);
        std::printf("\n");
      }
      continue;
    }
    for (double limit : limits)
    {
      std::printf("\n%s, max. %.0f s computing time, %d runs (Time: solve + simplify of solved runs; "
                  "path length in rad)\n",
                  scene_name.c_str(), limit, runs);
      std::printf("  %-12s %8s %18s %18s %10s %10s %10s\n", "Planner", "solved%", "Time (s)", "Path length", "median ms",
                  "solve ms", "cpu ms");
      std::vector<PlannerSummary> summaries;
      for (const std::string& name : planners)
      {
        // Each planner runs in its own child process: some OMPL 1.5 planners crash in some
        // scenes (here BFMT; the thesis lost LBTRRT that way), and a crash must cost that
        // planner's row only. The child writes its OMPL log and a CSV of its runs.
        std::ostringstream stem;
        stem << out_dir << "/" << scene_name << "_" << limit << "s_" << name;
        const std::string runs_file = stem.str() + ".csv";
        std::fflush(stdout);
        const pid_t child = fork();
        if (child == 0)
        {
          const std::shared_ptr<ompl::geometric::SimpleSetup> setup = planner.makeSetup(start, goals, params);
          ompl::tools::Benchmark benchmark(*setup, scene_name);
          std::vector<std::string> unknown;
          ompl::base::PlannerPtr p =
              ArmMotionPlanner::allocatePlanner(name, setup->getSpaceInformation(), params.planner_params, &unknown);
          if (!p)
            _exit(3);
          for (const std::string& u : unknown)
          {
            std::vector<std::string> known;
            ArmMotionPlanner::allocatePlanner(name, setup->getSpaceInformation(), {})->params().getParamNames(known);
            std::string list;
            for (const std::string& k : known)
              list += " " + k;
            std::printf("  warning: OMPL has no parameter %s (it has:%s)\n", u.c_str(), list.c_str());
          }
          p->setName(name);
          const auto timed = std::make_shared<fast_grasp::CpuTimedPlanner>(p);
          benchmark.addPlanner(timed);
          // Wall time is what OMPL records; on a shared machine it includes waiting for a core.
          // CPU time of a run: the process's (each planner runs in its own child process, so
          // the planner's work on however many cores, independent of the load beside it) from
          // the pre-run event to the end of solve() (CpuTimedPlanner), plus the simplification.
          // Not the benchmark's path checks and planner data copy between them (see
          // cpu_timed_planner.h): a caller of the planner does not pay them. The simplification
          // runs here, not in OMPL's Benchmark (request.simplify off), to time it on its own;
          // the same properties are recorded as OMPL 1.5's Benchmark would.
          double cpu_at_start = 0.0;
          benchmark.setPreRunEvent([&cpu_at_start](const ompl::base::PlannerPtr&) {
            cpu_at_start = fast_grasp::processCpuSeconds();
          });
          benchmark.setPostRunEvent([&cpu_at_start, &timed, &setup](const ompl::base::PlannerPtr&,
                                                                   ompl::tools::Benchmark::RunProperties& run) {
            double cpu_s = timed->cpuSecondsAtSolveEnd() - cpu_at_start;
            if (setup->haveSolutionPath())
            {
              const double cpu_before = fast_grasp::processCpuSeconds();
              const auto wall_before = std::chrono::steady_clock::now();
              setup->simplifySolution();
              cpu_s += fast_grasp::processCpuSeconds() - cpu_before;
              run["simplification time REAL"] = ompl::toString(
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count());
              const ompl::geometric::PathGeometric& path = setup->getSolutionPath();
              run["simplified solution length REAL"] = ompl::toString(path.length());
              run["simplified solution smoothness REAL"] = ompl::toString(path.smoothness());
              run["simplified solution clearance REAL"] = ompl::toString(path.clearance());
              run["simplified solution segments INTEGER"] = std::to_string(path.getStateCount() - 1);
              run["simplified correct solution BOOLEAN"] = std::to_string(path.check());
              const unsigned factor = setup->getStateSpace()->getValidSegmentCountFactor();
              setup->getStateSpace()->setValidSegmentCountFactor(factor * 4);
              run["simplified correct solution strict BOOLEAN"] = std::to_string(path.check());
              setup->getStateSpace()->setValidSegmentCountFactor(factor);
            }
            run["cpu time REAL"] = std::to_string(cpu_s);
          });
          ompl::tools::Benchmark::Request request(limit, 4096.0, static_cast<unsigned>(runs), 0.5, false, false,
                                                  /*simplify=*/false);
          benchmark.benchmark(request);
          benchmark.saveResultsToFile((stem.str() + ".log").c_str());
          std::ofstream out(runs_file);
          for (const auto& experiment : benchmark.getRecordedExperimentData().planners)
            for (const auto& run : experiment.runs)
            {
              const bool exact =
                  property(run, "solved BOOLEAN", 0) > 0.5 && property(run, "approximate solution BOOLEAN", 0) < 0.5;
              out << (exact ? 1 : 0) << " " << property(run, "time REAL", limit) << " "
                  << property(run, "simplification time REAL", 0.0) << " "
                  << property(run, "simplified solution length REAL", property(run, "solution length REAL", 0.0))
                  << " " << property(run, "cpu time REAL", limit) << "\n";
            }
          out.close();
          std::fflush(stdout);
          _exit(0);
        }
        int child_status = 0;
        waitpid(child, &child_status, 0);
        const bool crashed = !WIFEXITED(child_status) || WEXITSTATUS(child_status) != 0;
        if (!crashed && fs::exists(stem.str() + ".log"))
          ompl_logs.push_back(stem.str() + ".log");
        PlannerSummary summary;
        summary.planner = name;
        std::vector<double> times, lengths, all_ms, solve_ms, cpu_ms;
        int solved = 0, index = 0, total = 0;
        std::ifstream in(runs_file);
        int exact = 0;
        double solve_s = 0.0, simplify_s = 0.0, length = 0.0, cpu_s = 0.0;
        while (!crashed && in >> exact >> solve_s >> simplify_s >> length >> cpu_s)
        {
          ++total;
          const double t = solve_s + simplify_s;
          if (exact)
          {
            ++solved;
            times.push_back(t);
            lengths.push_back(length);
          }
          all_ms.push_back(1e3 * (exact ? t : limit));
          solve_ms.push_back(1e3 * (exact ? solve_s : limit));
          cpu_ms.push_back(1e3 * (exact ? cpu_s : limit));
          csv << scene_name << "," << limit << "," << name << "," << index++ << "," << exact << "," << t << ","
              << length << "," << cpu_s << "\n";
        }
        std::remove(runs_file.c_str());
        if (crashed || total == 0)
        {
          for (int r = 0; r < runs; ++r)
            csv << scene_name << "," << limit << "," << name << "," << r << ",0," << limit << ",0," << limit << "\n";
          all_ms.assign(static_cast<std::size_t>(runs), 1e3 * limit);
          solve_ms = all_ms;
          cpu_ms = all_ms;
          total = runs;
        }
        summary.solved_percent = 100.0 * solved / std::max(1, total);
        summary.time_s = stats(times);
        summary.length_rad = stats(lengths);
        summary.median_all_ms = stats(all_ms).median;
        summary.median_solve_ms = stats(solve_ms).median;
        summary.median_cpu_ms = stats(cpu_ms).median;
        std::printf("  %-12s %7.1f%% %9.3f (%6.3f) %9.2f (%6.2f) %10.1f %10.1f %10.1f%s\n", summary.planner.c_str(),
                    summary.solved_percent, summary.time_s.mean, summary.time_s.sd, summary.length_rad.mean,
                    summary.length_rad.sd, summary.median_all_ms, summary.median_solve_ms, summary.median_cpu_ms,
                    crashed ? "  (crashed in OMPL)" : "");
        std::fflush(stdout);
        summaries.push_back(summary);
      }
      // Summary lines: narrow_passage at 3 s (the UR5 target), every other scene at the
      // first limit asked for.
      if (scene_name == "narrow_passage" ? std::abs(limit - 3.0) < 1e-9 : limit == limits.front())
        summary_lines[scene_name] = summaries;
      // End to end, as the grasp pipeline runs it: ArmMotionPlanner::plan() with the lazy sound
      // validation and local repair (MotionPlanningParams defaults), same scene and limit.
      if (end_to_end_planner != "none")
      {
        fast_grasp::MotionPlanningParams e2e = params;
        e2e.planner = end_to_end_planner;
        e2e.planning_time_s = limit;
        e2e.max_cartesian_step_m = fast_grasp::MotionPlanningParams().max_cartesian_step_m;
        e2e.lazy_validation = true;
        std::vector<double> ms;
        int ok = 0, repaired = 0;
        for (int r = 0; r < runs; ++r)
        {
          const fast_grasp::MotionPlanResult res = planner.plan(start, goals, e2e);
          ok += res.ok() ? 1 : 0;
          repaired += res.repaired_segments;
          ms.push_back(1e3 * (res.ok() ? res.planning_time_s : limit));
        }
        const std::string line = "end-to-end plan() " + end_to_end_planner + " " + scene_name + ": solved " +
                                 std::to_string(100.0 * ok / runs).substr(0, 5) + " % median " +
                                 std::to_string(stats(ms).median).substr(0, 7) + " ms (" + std::to_string(repaired) +
                                 " segments repaired)";
        std::printf("  %s\n", line.c_str());
        if (scene_name == "narrow_passage" && std::abs(limit - 3.0) < 1e-9)
          end_to_end_lines.push_back(line);
      }
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
      std::printf("plots: %s/<scene>_<limit>s.png; OMPL logs: %s/*.log\n", out_dir.c_str(), out_dir.c_str());
    // Planner Arena database. Debian's OMPL records an empty version string in its logs.
    if (!ompl_logs.empty())
    {
      const std::string db = fs::absolute(out_dir + "/benchmark.db").string();
      std::string convert = "/usr/bin/python3 " + std::string(FAST_GRASP_SOURCE_DIR) +
                            "/scripts/ompl_benchmark_db.py --library-version " +
                            std::to_string(OMPL_MAJOR_VERSION) + "." + std::to_string(OMPL_MINOR_VERSION) + "." +
                            std::to_string(OMPL_PATCH_VERSION) + " -o '" + db + "'";
      for (const std::string& log : ompl_logs)
        convert += " '" + log + "'";
      convert += " > /dev/null";
      if (std::system(convert.c_str()) == 0)
        std::printf("Planner Arena database: %s\n", db.c_str());
      else
        std::printf("Planner Arena database not written: scripts/ompl_benchmark_db.py failed\n");
    }
  }
  for (const std::string& line : end_to_end_lines)
    std::printf("%s\n", line.c_str());
  for (const auto& entry : summary_lines)
    for (const PlannerSummary& s : entry.second)
      std::printf("%s %s: solved %.1f %% median %.1f ms (cpu %.1f ms)\n", s.planner.c_str(), entry.first.c_str(),
                  s.solved_percent, s.median_all_ms, s.median_cpu_ms);
  return 0;
}
