// Time parameterisation of a joint-space path under per-joint velocity and acceleration
// limits. ROS-free (Eigen only).
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace fast_grasp
{
struct TrajectoryPoint
{
  Eigen::VectorXd positions;      // rad
  Eigen::VectorXd velocities;     // rad/s
  Eigen::VectorXd accelerations;  // rad/s^2
  double time_from_start_s = 0.0;
};

/// Limits above these are refused: no arm's, and they make the timing's arithmetic underflow.
constexpr double kMaxJointVelocityRadS = 1000.0;
constexpr double kMaxJointAccelerationRadS2 = 100000.0;

struct TimingLimits
{
  Eigen::VectorXd velocity_rad_s;      // per joint, > 0 (UR5: pi)
  Eigen::VectorXd acceleration_rad_s2; // per joint, > 0
  /// Longest path step between output samples (joint-space Euclidean length, rad).
  double max_step_rad = 0.02;
  /// Waypoints where the path turns by more than this are corners: the arm stops there
  /// (a piecewise-linear path can only pass a corner at zero speed with finite acceleration).
  /// Smaller turns (dense Cartesian approach paths) are passed at a speed bounded by the
  /// acceleration the turn needs.
  double corner_angle_rad = 0.1;
  /// A path needing more samples at max_step_rad is refused (false with a reason): the work is
  /// linear in the samples, and 1e6 of them (the old fixed bound) took 3-6 s under the
  /// sanitizers while fuzzing. A real arm path is tens of rad long: ~1000 samples at 0.02 rad.
  std::size_t max_samples = 20000;
};

/// Time-optimal parameterisation of the piecewise-linear path through `waypoints` (positions
/// in rad) along the path: a discretised TOPP (bang-bang in path acceleration, computed by a
/// backward pass for the deceleration limit and a forward pass for the acceleration limit).
/// Every output point satisfies |velocity| <= velocity limit and |acceleration| <= acceleration
/// limit per joint, starts and ends at rest and follows the path exactly (same waypoints,
/// densified). Returns false with `why` on bad input (empty path, size mismatch, NaN,
/// non-positive limits).
bool timeParameterize(const std::vector<Eigen::VectorXd>& waypoints, const TimingLimits& limits,
                      std::vector<TrajectoryPoint>& trajectory, std::string* why = nullptr);

/// Appends `tail` to `head`, shifting its times so it starts when `head` ends (both at rest).
void appendTrajectory(std::vector<TrajectoryPoint>& head, const std::vector<TrajectoryPoint>& tail);

}  // namespace fast_grasp
