// libFuzzer target: ArmKinematics::ik (and fk, the Jacobian, the limit wrap it uses) on arbitrary
// target poses, seeds, joint limits and solver parameters, on the bundled UR5 and LWR4 chains.
//
// Layout: u8 robot (bit 0: LWR4) and flags (bit 1: raw 4x4 target matrix, else translation +
//         quaternion; bit 2: own joint limits), target (16 or 7 x f64), seed (dof x f64),
//         [lower, upper (dof x f64 each)], f64 position / orientation tolerance, u8 max_solutions,
//         u8 iterations per attempt, u32 random seed, u8 timeout in 0.1 ms (0-25.5 ms; a longer
//         budget only repeats restarts).
#include "fuzz_input.h"

#include "fast_grasp/arm/arm_kinematics.h"

#include <cmath>

using namespace fast_grasp;

namespace
{
const ArmKinematics& robot(bool lwr4)
{
  static const ArmKinematics ur5 =
      ArmKinematics::fromUrdfFile(std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/ur5_gripper_xtion.urdf");
  static const ArmKinematics lwr =
      ArmKinematics::fromUrdfFile(std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/lwr4_gripper_xtion.urdf");
  return lwr4 ? lwr : ur5;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fuzz::FuzzInput in(data, size);
  const auto flags = in.read<std::uint8_t>();
  ArmKinematics kinematics = robot(flags & 1);
  const Eigen::Index n = static_cast<Eigen::Index>(kinematics.dof());
  Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
  if (flags & 2)
  {
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        target.matrix()(r, c) = in.read<double>();
  }
  else
  {
    Eigen::Vector3d t;
    for (int k = 0; k < 3; ++k)
      t[k] = in.read<double>();
    Eigen::Quaterniond q;
    q.w() = in.read<double>();
    q.x() = in.read<double>();
    q.y() = in.read<double>();
    q.z() = in.read<double>();
    if (std::isfinite(q.norm()) && q.norm() > 1e-12)
      q.normalize();
    target.linear() = q.toRotationMatrix();
    target.translation() = t;
  }
  Eigen::VectorXd seed(n);
  for (Eigen::Index j = 0; j < n; ++j)
    seed[j] = in.read<double>();
  if (flags & 4)
  {
    Eigen::VectorXd lower(n), upper(n);
    for (Eigen::Index j = 0; j < n; ++j)
      lower[j] = in.read<double>();
    for (Eigen::Index j = 0; j < n; ++j)
      upper[j] = in.read<double>();
    kinematics.setJointLimits(lower, upper);
  }
  IkParams params;
  params.position_tolerance_m = in.read<double>();
  params.orientation_tolerance_rad = in.read<double>();
  params.max_solutions = in.read<std::uint8_t>() % 9;
  params.max_iterations_per_attempt = in.read<std::uint8_t>();
  params.random_seed = in.read<std::uint32_t>();
  params.timeout_s = in.read<std::uint8_t>() * 1e-4;

  const std::vector<Eigen::VectorXd> solutions = kinematics.ik(target, seed, params);
  if (static_cast<int>(solutions.size()) > std::max(params.max_solutions, 0))
    __builtin_trap();
  for (const Eigen::VectorXd& q : solutions)
  {
    // A solution is a finite joint vector within the limits.
    if (q.size() != n || !q.allFinite() || !kinematics.withinLimits(q, 1e-6))
      __builtin_trap();
  }
  Eigen::VectorXd wrapped = seed;
  kinematics.wrapIntoLimits(wrapped);
  if (seed.allFinite())
  {
    kinematics.fk(seed);
    kinematics.jacobian(seed);
  }
  return 0;
}
