// libFuzzer target: grasp_offline's --pcd input (readPcdCloud: PCL's header parser and the
// ascii, binary and binary_compressed readers) on arbitrary files, then the perception that
// grasp_offline runs on what it read (prepareView, with or without the table fit). Seeds: small
// PCDs cut from the bundled bags in all three encodings (make_seed_corpus.py).
#include "fuzz_input.h"

#include "offline_pipeline.h"

#include <random>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  using namespace fast_grasp;
  const std::string path = fuzz::writeTempFile(std::string(reinterpret_cast<const char*>(data), size), ".pcd");
  std::string problem;
  const CloudXYZ::Ptr cloud = readPcdCloud(path, problem);
  if (!cloud)
  {
    if (problem.empty())
      __builtin_trap();  // rejected without a reason
    return 0;
  }
  // Perception on a large cloud is correct but slow; the fuzzer's point is the reader.
  if (cloud->size() > 5000)
    return 0;
  SensorCloud sensor;
  sensor.xyz_cloud = cloud;
  sensor.sensor_origin = Eigen::Vector3f(0.0f, 0.0f, 1.0f);  // --viewpoint 0,0,1
  ViewPreparationParams params = deployedViewPreparationParams();
  params.segment_table = size % 2 == 0;  // --already-segmented for odd sizes
  std::mt19937 rng(0);
  const PreparedView prepared = prepareView({ sensor }, params, rng);
  if (prepared.ok() != prepared.problem.empty())
    __builtin_trap();
  return 0;
}
