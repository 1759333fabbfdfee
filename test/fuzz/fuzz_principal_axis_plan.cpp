// libFuzzer target: the principal_axis planner's plan() on an arbitrary object view and gripper
// (layout: fuzz_object_view.h). Seeds: test/fuzz/corpus/object_view/.
#include "fuzz_object_view.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  return fast_grasp::fuzz::runPlanner("principal_axis", data, size);
}
