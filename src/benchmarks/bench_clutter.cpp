// bench_clutter: perception plus planning over a whole cluttered table, per frame, one core
// (issue 11's budget: a 640x480 frame of ~5 objects in <= 50 ms median).
//
// Per bundled clutter bag (bags/clutter_*.bag, 4-6 objects each) the first frame goes through
// what the pipeline does with `split_touching_objects:=true all_objects:=true`: prepareView
// (preprocess, table segmentation with the concave-crease split, normals of every cluster) and
// planTableGrasps (every object planned with the neighbours as obstacles, ordered by
// object_choice), repeated --repeats times. Prints per bag the objects its truth file places
// (bags/<bag>.truth.yaml), the clusters perception found, the clusters with a grasp and the
// median ms (thread CPU time) of each half; prints, never asserts.
//
//   rosrun fast_grasp bench_clutter [--bags DIR] [--repeats N] [--gripper FILE] [--params FILE]
//                                   [--planner NAME] [--no-split]
// Last line: `clutter median: X ms per frame` (median over every bag's repeats).
#include "bag_frames.h"
#include "bench_stats.h"
#include "command_line.h"
#include "offline_pipeline.h"

#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/core/yaml_file.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/table_grasps.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace fast_grasp;

namespace
{
const char* const kUsage =
    "usage: bench_clutter [--bags DIR] [--repeats N] [--gripper FILE] [--params FILE] [--planner NAME] [--no-split]\n"
    "  every bundled clutter bag's first frame through perception (all objects, touching objects split)\n"
    "  and planning for every object: median ms per frame (prints, does not assert)\n"
    "  --bags DIR      folder of clutter_*.bag (default the package's bags/)\n"
    "  --repeats N     runs per bag (default 11)\n"
    "  --gripper FILE  default config/grippers/robotiq_2f85.yaml (the clutter targets' hand)\n"
    "  --params FILE   planner parameters (default config/grasp_planners.yaml)\n"
    "  --planner NAME  default fused\n"
    "  --no-split      Euclidean clusters only (split_concave_creases off)\n";

/// Thread CPU time since `since_ms` (threadCpuMs): one core's work, not what other processes
/// on a shared machine add to the wall time.
/// How many objects the bag's truth file (render_bag's `objects:` list) places; -1 without one.
int truthObjects(const fs::path& bag)
{
  fs::path truth = bag;
  truth.replace_extension(".truth.yaml");
  try
  {
    const YAML::Node objects = loadYamlFile(truth.string())["objects"];
    return objects && objects.IsSequence() ? static_cast<int>(objects.size()) : -1;
  }
  catch (const std::exception&)
  {
    return -1;
  }
}

double milliseconds(double since_ms)
{
  return threadCpuMs() - since_ms;
}
}  // namespace

int main(int argc, char** argv)
{
  exitOnHelpFlag(argc, argv, kUsage);
  std::string bags_dir = std::string(FAST_GRASP_SOURCE_DIR) + "/bags";
  std::string gripper_file = std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/robotiq_2f85.yaml";
  std::string params_file = std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml";
  std::string planner_name = "fused";
  int repeats = 11;
  bool split = true;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    if (flag == "--no-split")
    {
      split = false;
      continue;
    }
    if (flag != "--bags" && flag != "--repeats" && flag != "--gripper" && flag != "--params" && flag != "--planner")
      exitWithUsage("unknown flag " + flag, kUsage);
    if (i + 1 >= argc)
      exitWithUsage(flag + " needs a value", kUsage);
    const std::string value = argv[++i];
    if (flag == "--bags")
      bags_dir = value;
    else if (flag == "--repeats")
      repeats = std::max(1, std::atoi(value.c_str()));
    else if (flag == "--gripper")
      gripper_file = value;
    else if (flag == "--params")
      params_file = value;
    else
      planner_name = value;
  }
  GripperModel gripper;
  GraspPlannerConfig config;
  try
  {
    gripper = loadGripperModel(gripper_file);
    config = tablePlannerConfig(loadGraspPlannerConfig(params_file));
  }
  catch (const std::exception& e)
  {
    std::cerr << "bench_clutter: " << e.what() << "\n";
    return 1;
  }
  const std::unique_ptr<GraspPlanner> planner = makeGraspPlanner(planner_name, config);
  if (!planner)
  {
    std::cerr << "bench_clutter: --planner: no algorithm '" << planner_name << "'\n";
    return 1;
  }

  std::vector<fs::path> bags;
  std::error_code error;
  for (fs::directory_iterator entry(bags_dir, error), end; !error && entry != end; entry.increment(error))
    if (entry->path().extension() == ".bag" && entry->path().stem().string().rfind("clutter_", 0) == 0)
      bags.push_back(entry->path());
  std::sort(bags.begin(), bags.end());
  if (error || bags.empty())
  {
    std::cerr << "bench_clutter: no clutter_*.bag in " << bags_dir << (error ? ": " + error.message() : "") << "\n";
    return 1;
  }

  ViewPreparationParams perception = deployedViewPreparationParams();  // config/perception.yaml
  perception.all_objects = true;
  perception.segmentation.split_concave_creases = split;
  std::printf("planner %s, gripper %s, %s, %d repeats, one thread\n\n", planner_name.c_str(), gripper.name.c_str(),
              split ? "touching objects split" : "Euclidean clusters", repeats);
  std::printf("%-22s %8s %8s %8s %8s %14s %12s %10s\n", "bag", "points", "objects", "clusters", "grasped",
              "perception ms", "planning ms", "total ms");
  std::vector<double> all_ms;
  for (const fs::path& bag : bags)
  {
    std::vector<SensorCloud> frame;
    try
    {
      frame = { sensorCloudFromBagFrame(readBagFrames(bag.string(), "/camera/depth_registered/points").front()) };
    }
    catch (const std::exception& e)
    {
      std::printf("%-22s skipped: %s\n", bag.stem().c_str(), e.what());
      continue;
    }
    std::vector<double> perception_ms, planning_ms, total_ms;
    std::size_t points = 0, objects = 0, grasped = 0;
    std::string problem;
    for (int r = 0; r < repeats; ++r)
    {
      std::mt19937 rng(0);
      const double start = threadCpuMs();
      const PreparedView prepared = prepareView(frame, perception, rng);
      perception_ms.push_back(milliseconds(start));
      if (!prepared.ok())
      {
        problem = prepared.problem;
        break;
      }
      const double planning_start = threadCpuMs();
      const TableGraspResult table = planTableGrasps(prepared.objects, *planner, gripper, config.table_grasps);
      planning_ms.push_back(milliseconds(planning_start));
      total_ms.push_back(milliseconds(start));
      points = 0;
      for (const ObjectView& view : prepared.objects)
        points += view.cloud->size();
      objects = prepared.objects.size();
      grasped = table.order.size();
    }
    if (!problem.empty())
    {
      std::printf("%-22s failed: %s\n", bag.stem().c_str(), problem.c_str());
      continue;
    }
    all_ms.insert(all_ms.end(), total_ms.begin(), total_ms.end());
    std::printf("%-22s %8zu %8d %8zu %8zu %14.1f %12.1f %10.1f\n", bag.stem().c_str(), points, truthObjects(bag),
                objects, grasped, median(perception_ms), median(planning_ms), median(total_ms));
  }
  if (all_ms.empty())
  {
    std::cerr << "bench_clutter: no bag gave a frame\n";
    return 1;
  }
  std::printf("\nclutter median: %.1f ms per frame\n", median(all_ms));
  return 0;
}
