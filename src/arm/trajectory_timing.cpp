#include "fast_grasp/arm/trajectory_timing.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fast_grasp
{
namespace
{
bool fail(std::string* why, const std::string& message)
{
  if (why)
    *why = message;
  return false;
}
}  // namespace

bool timeParameterize(const std::vector<Eigen::VectorXd>& waypoints, const TimingLimits& limits,
                      std::vector<TrajectoryPoint>& trajectory, std::string* why)
{
  trajectory.clear();
  if (waypoints.empty())
    return fail(why, "empty path");
  const Eigen::Index n = waypoints.front().size();
  if (n == 0 || limits.velocity_rad_s.size() != n || limits.acceleration_rad_s2.size() != n)
    return fail(why, "joint count mismatch between path and limits");
  if (!(limits.velocity_rad_s.array() > 0.0).all() || !(limits.acceleration_rad_s2.array() > 0.0).all() ||
      !limits.velocity_rad_s.allFinite() || !limits.acceleration_rad_s2.allFinite() || !(limits.max_step_rad > 0.0))
    return fail(why, "velocity and acceleration limits must be positive and finite");
  // No arm moves a joint at 1000 rad/s or accelerates it at 1e5 rad/s^2 (a UR5: pi and 15); at
  // 1e306 the segment times underflow toward 1e-152 s and the accelerations become 0/0 (NaN)
  // (fuzzing: test/fuzz/corpus/trajectory_timing/crash_limits_1e306).
  if ((limits.velocity_rad_s.array() > kMaxJointVelocityRadS).any() ||
      (limits.acceleration_rad_s2.array() > kMaxJointAccelerationRadS2).any())
    return fail(why, "velocity limits above " + std::to_string(static_cast<int>(kMaxJointVelocityRadS)) +
                         " rad/s or acceleration limits above " +
                         std::to_string(static_cast<int>(kMaxJointAccelerationRadS2)) + " rad/s^2 are no arm's");
  // Drop repeated waypoints: a zero-length segment has no direction.
  std::vector<Eigen::VectorXd> path;
  for (const Eigen::VectorXd& q : waypoints)
  {
    if (q.size() != n || !q.allFinite())
      return fail(why, "waypoint with the wrong size or NaN");
    if (path.empty() || (q - path.back()).norm() > 1e-9)
      path.push_back(q);
  }
  if (path.size() == 1)
  {
    trajectory.push_back({ path[0], Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), 0.0 });
    return true;
  }

  // Grid along the path. Each grid point i carries its position, its tangent q' (unit in
  // joint space), a curvature q'' (non-zero only at gentle turns), and x_max = max s_dot^2.
  struct GridPoint
  {
    Eigen::VectorXd q, dq, ddq;
    double ds_next = 0.0;  // path length to the next grid point
    double x_max = std::numeric_limits<double>::infinity();
    double u_max = 0.0;  // max |s_ddot| on the interval to the next point
  };
  std::vector<GridPoint> grid;
  const std::size_t segments = path.size() - 1;
  std::vector<Eigen::VectorXd> dirs(segments);
  std::vector<double> lengths(segments);
  double grid_points = 1.0;
  for (std::size_t k = 0; k < segments; ++k)
  {
    lengths[k] = (path[k + 1] - path[k]).norm();
    dirs[k] = (path[k + 1] - path[k]) / lengths[k];
    grid_points += std::max(2.0, std::ceil(lengths[k] / limits.max_step_rad));
  }
  // The step count below is an int and the grid is allocated: a segment whose length overflows
  // (waypoints near 1e308) or a max_step_rad tiny against the path made that cast undefined
  // behaviour (UBSan, fuzzing) or an unbounded allocation.
  if (!std::isfinite(grid_points) || grid_points > static_cast<double>(limits.max_samples))
    return fail(why, "path too long for max_step_rad: more than max_samples " + std::to_string(limits.max_samples) +
                         " samples (or a non-finite segment length)");
  for (std::size_t k = 0; k < segments; ++k)
  {
    // At least two intervals per segment, so that a segment between two corners has an
    // interior point with non-zero speed.
    const int steps = std::max(2, static_cast<int>(std::ceil(lengths[k] / limits.max_step_rad)));
    const double ds = lengths[k] / steps;
    for (int s = 0; s < steps; ++s)
    {
      GridPoint g;
      g.q = path[k] + dirs[k] * (ds * s);
      g.dq = dirs[k];
      g.ddq = Eigen::VectorXd::Zero(n);
      g.ds_next = ds;
      if (s == 0 && k > 0)
      {
        const double cos_turn = std::clamp(dirs[k - 1].dot(dirs[k]), -1.0, 1.0);
        if (std::acos(cos_turn) > limits.corner_angle_rad)
          g.x_max = 0.0;  // corner: stop
        else
        {
          const double ds_prev = grid.back().ds_next;
          g.ddq = (dirs[k] - dirs[k - 1]) / (0.5 * (ds_prev + ds));
          g.dq = (dirs[k] + dirs[k - 1]).normalized();
        }
      }
      grid.push_back(g);
    }
  }
  {
    GridPoint last;
    last.q = path.back();
    last.dq = dirs.back();
    last.ddq = Eigen::VectorXd::Zero(n);
    last.x_max = 0.0;
    grid.push_back(last);
  }
  grid.front().x_max = 0.0;

  // Bounds per point. Velocity: |q'_j| s_dot <= v_j. Acceleration: |q'_j s_ddot + q''_j s_dot^2|
  // <= a_j; at curved points half of a_j is reserved for each term (conservative but simple),
  // elsewhere q'' = 0 and all of a_j goes to s_ddot.
  for (GridPoint& g : grid)
  {
    const bool curved = g.ddq.cwiseAbs().maxCoeff() > 1e-12;
    double u_max = std::numeric_limits<double>::infinity();
    for (Eigen::Index j = 0; j < n; ++j)
    {
      const double a = limits.acceleration_rad_s2[j];
      if (std::abs(g.dq[j]) > 1e-12)
      {
        g.x_max = std::min(g.x_max, std::pow(limits.velocity_rad_s[j] / std::abs(g.dq[j]), 2));
        u_max = std::min(u_max, (curved ? 0.5 * a : a) / std::abs(g.dq[j]));
      }
      if (curved && std::abs(g.ddq[j]) > 1e-12)
        g.x_max = std::min(g.x_max, 0.5 * a / std::abs(g.ddq[j]));
    }
    g.u_max = u_max;
  }
  // The interval leading into a gentle turn also shares its acceleration with the turn.
  for (std::size_t i = 1; i < grid.size(); ++i)
    if (grid[i].ddq.cwiseAbs().maxCoeff() > 1e-12)
      grid[i - 1].u_max = std::min(grid[i - 1].u_max, grid[i].u_max);

  // Backward pass (how fast each point may be passed and still stop in time), then forward
  // pass (how fast it can be reached): the bang-bang profile of the discretised problem.
  const std::size_t m = grid.size();
  std::vector<double> x(m);
  x[m - 1] = 0.0;
  for (std::size_t i = m - 1; i-- > 0;)
    x[i] = std::min(grid[i].x_max, x[i + 1] + 2.0 * grid[i].ds_next * grid[i].u_max);
  x[0] = 0.0;
  for (std::size_t i = 0; i + 1 < m; ++i)
    x[i + 1] = std::min(x[i + 1], x[i] + 2.0 * grid[i].ds_next * grid[i].u_max);

  trajectory.resize(m);
  double t = 0.0;
  for (std::size_t i = 0; i < m; ++i)
  {
    const GridPoint& g = grid[i];
    const double s_dot = std::sqrt(std::max(0.0, x[i]));
    // Path acceleration of the interval after i (the last point uses the interval before it).
    const std::size_t k = i + 1 < m ? i : i - 1;
    const double u = (x[k + 1] - x[k]) / (2.0 * grid[k].ds_next);
    trajectory[i].positions = g.q;
    trajectory[i].velocities = g.dq * s_dot;
    trajectory[i].accelerations = g.dq * u + g.ddq * x[i];
    trajectory[i].time_from_start_s = t;
    if (i + 1 < m)
    {
      const double denominator = s_dot + std::sqrt(std::max(0.0, x[i + 1]));
      t += denominator > 0.0 ? 2.0 * g.ds_next / denominator : 0.0;
    }
  }
  trajectory.back().velocities.setZero();
  return true;
}

void appendTrajectory(std::vector<TrajectoryPoint>& head, const std::vector<TrajectoryPoint>& tail)
{
  if (tail.empty())
    return;
  const double offset = head.empty() ? 0.0 : head.back().time_from_start_s;
  const bool skip_first = !head.empty() && (head.back().positions - tail.front().positions).norm() < 1e-9;
  for (std::size_t i = skip_first ? 1 : 0; i < tail.size(); ++i)
  {
    TrajectoryPoint p = tail[i];
    p.time_from_start_s += offset;
    head.push_back(p);
  }
}

}  // namespace fast_grasp
