// IK benchmark in the style of TRAC-IK's: FK of random joint vectors within the limits gives
// reachable poses; each is solved from a fixed seed (the zero vector), 5 ms budget, 1e-5 tolerance.
// Usage: bench_ik [--robot ur5] [--poses N] [--urdf PATH] [--base LINK] [--tip LINK] [--timeout-ms T] [--seed S]
// The chain and limits come from config/robots/<robot>.yaml (--urdf/--base/--tip override them).
// Last line: "ik solved: P % median: X ms".
#include "command_line.h"
#include "fast_grasp/arm/arm_kinematics.h"
#include "fast_grasp/arm/grasp_execution.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#ifndef FAST_GRASP_SOURCE_DIR
#define FAST_GRASP_SOURCE_DIR "."
#endif

namespace
{
const char* const kUsage =
    "usage: bench_ik [--robot ur5|lwr4|jaco] [--poses N] [--urdf PATH] [--base LINK] [--tip LINK]\n"
    "                [--timeout-ms T] [--seed S]\n"
    "  IK on N random reachable poses (FK of random joint vectors); last line 'ik solved: P % median: X ms'\n";
}  // namespace

int main(int argc, char** argv)
{
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  int poses = 1000;
  std::string robot = "ur5", urdf, base, tip;
  double timeout_ms = 5.0;
  unsigned seed = 1;
  for (int i = 1; i < argc; i += 2)
  {
    const std::string flag = argv[i];
    if (i + 1 >= argc)
      fast_grasp::exitWithUsage(flag + " needs a value", kUsage);
    const std::string value = argv[i + 1];
    if (flag == "--poses") poses = std::atoi(value.c_str());
    else if (flag == "--robot") robot = value;
    else if (flag == "--urdf") urdf = value;
    else if (flag == "--base") base = value;
    else if (flag == "--tip") tip = value;
    else if (flag == "--timeout-ms") timeout_ms = std::atof(value.c_str());
    else if (flag == "--seed") seed = static_cast<unsigned>(std::atoi(value.c_str()));
    else
      fast_grasp::exitWithUsage("unknown flag " + flag, kUsage);
  }
  fast_grasp::ArmKinematics kin;
  try
  {
    const fast_grasp::GraspExecutionParams config =
        fast_grasp::loadGraspExecutionParams(std::string(FAST_GRASP_SOURCE_DIR) + "/config/arm.yaml", "", robot);
    if (urdf.empty()) urdf = config.urdf_path;
    if (base.empty()) base = config.base_link;
    if (tip.empty()) tip = config.tip_link;
    kin = fast_grasp::ArmKinematics::fromUrdfFile(urdf, base, tip);
    const std::string limits_problem = fast_grasp::applyLimits(config, kin);
    if (!limits_problem.empty())
      throw std::runtime_error(limits_problem);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  fast_grasp::IkParams params;
  params.timeout_s = timeout_ms * 1e-3;
  std::mt19937 rng(seed);
  std::vector<double> times_ms;
  int solved = 0;
  double worst_pos = 0.0, worst_rot = 0.0;
  const Eigen::VectorXd start = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(kin.dof()));
  for (int i = 0; i < poses; ++i)
  {
    const Eigen::Isometry3d target = kin.fk(kin.randomConfiguration(rng));
    params.random_seed = static_cast<std::uint32_t>(i + 1);
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<Eigen::VectorXd> sols = kin.ik(target, start, params);
    times_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (sols.empty())
      continue;
    ++solved;
    const Eigen::Isometry3d reached = kin.fk(sols.front());
    worst_pos = std::max(worst_pos, (reached.translation() - target.translation()).norm());
    worst_rot = std::max(worst_rot, Eigen::AngleAxisd(reached.linear().transpose() * target.linear()).angle());
  }
  std::vector<double> sorted = times_ms;
  std::sort(sorted.begin(), sorted.end());
  double mean = 0.0;
  for (double t : times_ms) mean += t;
  mean /= std::max<std::size_t>(1, times_ms.size());
  const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  std::printf("robot %s, chain %s -> %s, %zu joints, %d poses, timeout %.1f ms\n", robot.c_str(), base.c_str(), tip.c_str(), kin.dof(), poses,
              timeout_ms);
  std::printf("mean %.3f ms, p90 %.3f ms, max %.3f ms, worst error %.2e m / %.2e rad\n", mean,
              sorted.empty() ? 0.0 : sorted[sorted.size() * 9 / 10], sorted.empty() ? 0.0 : sorted.back(), worst_pos,
              worst_rot);
  std::printf("ik solved: %.2f %% median: %.3f ms\n", 100.0 * solved / std::max(1, poses), median);
  return 0;
}
