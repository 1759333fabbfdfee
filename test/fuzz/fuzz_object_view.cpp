#include "fuzz_object_view.h"

#include "fuzz_input.h"

#include "fast_grasp/grasping/grasp_planner_params.h"

#include <cmath>
#include <memory>
#include <string>

namespace fast_grasp
{
namespace fuzz
{
FuzzedView decodeObjectView(const std::uint8_t* data, std::size_t size)
{
  FuzzInput in(data, size);
  FuzzedView out;
  const auto flags = in.read<std::uint8_t>();
  const bool raw = flags & 0x02;
  const int origins = (flags >> 4) & 0x03;
  for (int i = 0; i < origins; ++i)
  {
    Eigen::Vector3f o;
    for (int k = 0; k < 3; ++k)
      o[k] = in.read<float>();
    out.view.sensor_origins.push_back(o);
  }
  if (flags & 0x01)
  {
    out.view.has_table_plane = true;
    for (int k = 0; k < 4; ++k)
      out.view.table_plane[k] = in.read<float>();
  }
  if (flags & 0x08)
    for (int k = 0; k < 3; ++k)
      out.view.gravity[k] = in.read<float>();
  if (flags & 0x04)
  {
    GripperModel& g = out.gripper;
    for (double* field : { &g.max_opening_m, &g.min_opening_m, &g.finger_width_m, &g.finger_thickness_m,
                           &g.finger_depth_m, &g.hand_depth_m, &g.palm_thickness_m, &g.palm_width_m, &g.cshape_r1_m,
                           &g.cshape_r2_m, &g.cshape_w_m })
      *field = in.read<float>();
    in.read<float>();
    g.underactuated = in.read<std::uint8_t>() & 1;
  }
  auto cloud = std::make_shared<CloudNormal>();
  const std::size_t point_bytes = raw ? 6 * sizeof(float) : 3 * sizeof(std::int16_t) + 3;
  const std::size_t n = std::min(in.remaining() / point_bytes, kMaxViewPoints);
  cloud->reserve(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    pcl::PointNormal p;
    p.x = in.coordinate(raw);
    p.y = in.coordinate(raw);
    p.z = in.coordinate(raw);
    if (raw)
    {
      p.normal_x = in.read<float>();
      p.normal_y = in.read<float>();
      p.normal_z = in.read<float>();
    }
    else
    {
      Eigen::Vector3f normal(in.read<std::int8_t>(), in.read<std::int8_t>(), in.read<std::int8_t>());
      if (normal.norm() > 0.0f)
        normal.normalize();
      p.normal_x = normal.x();
      p.normal_y = normal.y();
      p.normal_z = normal.z();
    }
    cloud->push_back(p);
  }
  out.view.cloud = cloud;
  return out;
}

int runPlanner(const char* algorithm, const std::uint8_t* data, std::size_t size)
{
  static const GraspPlannerConfig config =
      loadGraspPlannerConfig(std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml");
  static const std::unique_ptr<GraspPlanner> planner = makeGraspPlanner(algorithm, config);
  const FuzzedView input = decodeObjectView(data, size);
  // Bad input must come back as a status, never as an exception or a crash.
  const GraspResult result = planner->plan(input.view, input.gripper);
  // GraspResult's contract: grasps empty iff failure != None; every grasp a finite pose.
  if (result.grasps.empty() != (result.failure != GraspFailure::None))
    __builtin_trap();
  for (const GraspCandidate& grasp : result.grasps)
    if (!grasp.pose.matrix().allFinite() || !std::isfinite(grasp.width_m))
      __builtin_trap();
  return 0;
}

}  // namespace fuzz
}  // namespace fast_grasp
