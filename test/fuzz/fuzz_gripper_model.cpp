// libFuzzer target: the gripper YAML loader (loadGripperModel) and GripperModel::validate on
// arbitrary bytes. Seeds: config/grippers/*.yaml.
#include "fuzz_input.h"

#include "fast_grasp/core/gripper_model.h"

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  using namespace fast_grasp;
  const std::string path = fuzz::writeTempFile(std::string(reinterpret_cast<const char*>(data), size), ".yaml");
  try
  {
    const GripperModel gripper = loadGripperModel(path);
    gripper.validate();
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
