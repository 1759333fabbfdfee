// libFuzzer target: timeParameterize (and appendTrajectory) on arbitrary joint paths and limits.
//
// Layout: u8 joints (1-8), u8 limit joints (the limits may disagree with the path: 0-8),
//         velocity and acceleration limits (limit joints x f64 each), f64 max_step_rad,
//         f64 corner_angle_rad, then waypoints: joints x (raw f64 if flag bit, else i16 * 1e-3 rad)
//         until the input ends (at most 256); u8 flags first: bit 0 raw waypoints.
#include "fuzz_input.h"

#include "fast_grasp/arm/trajectory_timing.h"

#include <cmath>

using namespace fast_grasp;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fuzz::FuzzInput in(data, size);
  const auto flags = in.read<std::uint8_t>();
  const Eigen::Index joints = 1 + in.read<std::uint8_t>() % 8;
  const Eigen::Index limit_joints = in.read<std::uint8_t>() % 9;
  TimingLimits limits;
  limits.velocity_rad_s.resize(limit_joints);
  limits.acceleration_rad_s2.resize(limit_joints);
  for (Eigen::Index j = 0; j < limit_joints; ++j)
    limits.velocity_rad_s[j] = in.read<double>();
  for (Eigen::Index j = 0; j < limit_joints; ++j)
    limits.acceleration_rad_s2[j] = in.read<double>();
  limits.max_step_rad = in.read<double>();
  limits.corner_angle_rad = in.read<double>();
  std::vector<Eigen::VectorXd> path;
  const std::size_t bytes_per_point = joints * ((flags & 1) ? sizeof(double) : sizeof(std::int16_t));
  while (in.remaining() >= bytes_per_point && path.size() < 256)
  {
    Eigen::VectorXd q(joints);
    for (Eigen::Index j = 0; j < joints; ++j)
      q[j] = (flags & 1) ? in.read<double>() : in.read<std::int16_t>() * 1e-3;
    path.push_back(q);
  }
  std::vector<TrajectoryPoint> trajectory;
  std::string why;
  const bool ok = timeParameterize(path, limits, trajectory, &why);
  if (ok == trajectory.empty() || (!ok && why.empty()))
    __builtin_trap();  // true with no points, or false without a reason
  double last_time = 0.0;
  for (const TrajectoryPoint& p : trajectory)
  {
    // Times start at 0 and never decrease; every sample is finite.
    if (!std::isfinite(p.time_from_start_s) || p.time_from_start_s < last_time || !p.positions.allFinite() ||
        !p.velocities.allFinite() || !p.accelerations.allFinite())
      __builtin_trap();
    last_time = p.time_from_start_s;
  }
  if (ok)
  {
    std::vector<TrajectoryPoint> twice = trajectory;
    appendTrajectory(twice, trajectory);
  }
  return 0;
}
