// libFuzzer target: the planners' YAML parameter loader (loadGraspPlannerConfig) on arbitrary
// bytes, then every planner built from what it accepted. Seeds: config/grasp_planners.yaml.
#include "fuzz_input.h"

#include "fast_grasp/grasping/grasp_planner_params.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  using namespace fast_grasp;
  const std::string path = fuzz::writeTempFile(std::string(reinterpret_cast<const char*>(data), size), ".yaml");
  GraspPlannerConfig config;
  try
  {
    config = loadGraspPlannerConfig(path);
  }
  catch (const std::runtime_error&)
  {
    return 0;  // a readable rejection (yaml-cpp's exceptions are runtime_errors too)
  }
  // Accepted parameters must build every planner or be rejected by it with an exception the
  // nodelets catch (std::invalid_argument / runtime_error), never crash.
  for (const std::string& algorithm : graspAlgorithmNames())
  {
    try
    {
      makeGraspPlanner(algorithm, config);
    }
    catch (const std::exception&)
    {
    }
  }
  return 0;
}
