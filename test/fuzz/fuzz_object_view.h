// An arbitrary object view and gripper decoded from fuzz bytes, for the planners' plan().
//
// Layout (little-endian; test/fuzz/make_seed_corpus.py writes it):
//   u8 flags: bit 0 table plane, bit 1 raw float32 points (else int16 0.1 mm + int8 normals),
//             bit 2 own gripper, bit 3 own gravity, bits 4-5 number of sensor origins (0-3)
//   origins     3 x f32 each
//   table plane 4 x f32 (bit 0)
//   gravity     3 x f32 (bit 3)
//   gripper     12 x f32 + u8 underactuated (bit 2): max/min opening, finger width/thickness/depth,
//               hand depth, palm thickness/width, cshape r1/r2/w, (unused)
//   points      the rest: x y z nx ny nz (6 x f32 raw, or 3 x i16 + 3 x i8)
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"

#include <cstddef>
#include <cstdint>

namespace fast_grasp
{
namespace fuzz
{
constexpr std::size_t kMaxViewPoints = 4000;  // natively < 0.2 s a plan(); 1-7 s under the sanitizers (docs/tests.md)

struct FuzzedView
{
  ObjectView view;
  GripperModel gripper;
};

FuzzedView decodeObjectView(const std::uint8_t* data, std::size_t size);

/// The planners' parameters as deployed (config/grasp_planners.yaml), loaded once.
int runPlanner(const char* algorithm, const std::uint8_t* data, std::size_t size);

}  // namespace fuzz
}  // namespace fast_grasp
