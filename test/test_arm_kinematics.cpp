// UR5 kinematics from the URDF: FK equals the independent DH product, IK round trips,
// bad input returns no solution.
#include "fast_grasp/arm/arm_kinematics.h"
#include "fast_grasp/arm/joint_sin_cos.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace
{
using fast_grasp::ArmKinematics;
using fast_grasp::IkParams;
constexpr double kPi = 3.14159265358979323846;

std::string urdfPath() { return std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/ur5_gripper_xtion.urdf"; }

/// Standard DH product of the UR5's published parameters: base (DH frame 0) -> flange.
Eigen::Isometry3d dhForward(const Eigen::VectorXd& q)
{
  const double d[6] = { 0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823 };
  const double a[6] = { 0.0, -0.425, -0.39225, 0.0, 0.0, 0.0 };
  const double alpha[6] = { kPi / 2, 0.0, 0.0, kPi / 2, -kPi / 2, 0.0 };
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i)
  {
    Eigen::Isometry3d link = Eigen::Isometry3d::Identity();
    link.rotate(Eigen::AngleAxisd(q[i], Eigen::Vector3d::UnitZ()));
    link.translate(Eigen::Vector3d(a[i], 0.0, d[i]));
    link.rotate(Eigen::AngleAxisd(alpha[i], Eigen::Vector3d::UnitX()));
    t = t * link;
  }
  return t;
}

void expectPoseNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tol)
{
  EXPECT_TRUE(a.matrix().isApprox(b.matrix(), tol) || (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() < tol)
      << "\n" << a.matrix() << "\nvs\n" << b.matrix();
}

TEST(ArmKinematics, LoadsUr5Chain)
{
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath());
  ASSERT_EQ(kin.dof(), 6u);
  const std::vector<std::string> expected = { "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                              "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint" };
  EXPECT_EQ(kin.jointNames(), expected);
  for (int j = 0; j < 6; ++j)
  {
    EXPECT_NEAR(kin.lowerLimits()[j], -kPi, 1e-6);
    EXPECT_NEAR(kin.upperLimits()[j], kPi, 1e-6);
    EXPECT_NEAR(kin.velocityLimits()[j], kPi, 1e-6);
  }
  EXPECT_THROW(ArmKinematics::fromUrdfFile("/nonexistent.urdf"), std::runtime_error);
  EXPECT_THROW(ArmKinematics::fromUrdfFile(urdfPath(), "base_link", "no_such_link"), std::runtime_error);
}

TEST(ArmKinematics, ForwardKinematicsMatchesDhParameters)
{
  // `base` is the DH base frame (ur_description), tool0 the DH flange frame.
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath(), "base", "tool0");
  const ArmKinematics kin_link = ArmKinematics::fromUrdfFile(urdfPath(), "base_link", "tool0");
  std::vector<Eigen::VectorXd> qs;
  Eigen::VectorXd q(6);
  q << 0, 0, 0, 0, 0, 0;
  qs.push_back(q);
  q << 0.3, -1.2, 1.1, -0.5, 1.4, 2.0;
  qs.push_back(q);
  q << -2.5, -0.4, -2.2, 3.0, -1.0, -3.0;
  qs.push_back(q);
  q << kPi / 2, -kPi / 2, kPi / 2, -kPi / 2, -kPi / 2, 0.0;
  qs.push_back(q);
  for (const Eigen::VectorXd& qi : qs)
  {
    expectPoseNear(kin.fk(qi), dhForward(qi), 1e-6);
    // base_link is the DH base turned by pi about z.
    expectPoseNear(kin_link.fk(qi), Eigen::Isometry3d(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ())) * dhForward(qi),
                   1e-6);
  }
  // Zero pose by hand: flange at (a2 + a3, -d4, d1 - d5) in the DH base frame... rotated.
  const Eigen::Vector3d p0 = kin.fk(qs[0]).translation();
  EXPECT_NEAR(p0.x(), -0.425 - 0.39225, 1e-9);
  EXPECT_NEAR(p0.y(), -0.10915 - 0.0823, 1e-9);
  EXPECT_NEAR(p0.z(), 0.089159 - 0.09465, 1e-9);
}

TEST(ArmKinematics, GraspFrameFollowsTheGraspConvention)
{
  const ArmKinematics tool = ArmKinematics::fromUrdfFile(urdfPath(), "base_link", "tool0");
  const ArmKinematics grasp = ArmKinematics::fromUrdfFile(urdfPath(), "base_link", "grasp_frame");
  Eigen::VectorXd q(6);
  q << 0.4, -1.0, 1.3, -0.2, 0.7, -1.1;
  const Eigen::Isometry3d t = tool.fk(q), g = grasp.fk(q);
  // X = approach = tool0 z, Y = closing = tool0 x, centre 0.115 m out of the flange.
  EXPECT_TRUE(g.linear().col(0).isApprox(t.linear().col(2), 1e-9));
  EXPECT_TRUE(g.linear().col(1).isApprox(t.linear().col(0), 1e-9));
  EXPECT_TRUE(g.linear().col(2).isApprox(t.linear().col(1), 1e-9));
  EXPECT_TRUE(g.translation().isApprox(t.translation() + 0.115 * t.linear().col(2), 1e-9));
}

TEST(ArmKinematics, JacobianMatchesFiniteDifferences)
{
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath());
  Eigen::VectorXd q(6);
  q << 0.1, -0.9, 1.2, 0.3, -0.6, 0.8;
  const Eigen::Matrix<double, 6, Eigen::Dynamic> jac = kin.jacobian(q);
  const double h = 1e-7;
  for (int j = 0; j < 6; ++j)
  {
    Eigen::VectorXd qh = q;
    qh[j] += h;
    const Eigen::Vector3d dp = (kin.fk(qh).translation() - kin.fk(q).translation()) / h;
    EXPECT_LT((jac.col(j).head<3>() - dp).norm(), 1e-5) << j;
  }
}

TEST(ArmKinematics, IkRoundTripOnRandomReachablePoses)
{
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath());
  std::mt19937 rng(7);
  IkParams params;
  int solved = 0;
  const int poses = 1000;
  const Eigen::VectorXd seed = Eigen::VectorXd::Zero(6);
  for (int i = 0; i < poses; ++i)
  {
    const Eigen::Isometry3d target = kin.fk(kin.randomConfiguration(rng));
    params.random_seed = static_cast<std::uint32_t>(i);
    params.timeout_s = 0.05;  // generous: the test asserts success, not speed
    const std::vector<Eigen::VectorXd> sols = kin.ik(target, seed, params);
    if (sols.empty())
      continue;
    ++solved;
    const Eigen::Isometry3d reached = kin.fk(sols.front());
    EXPECT_LT((reached.translation() - target.translation()).norm(), 1e-3);
    EXPECT_LT(Eigen::AngleAxisd(reached.linear().transpose() * target.linear()).angle(), 0.01);
    EXPECT_TRUE(kin.withinLimits(sols.front()));
  }
  EXPECT_GE(solved, 990);
}

TEST(ArmKinematics, SolutionsAreRankedByDistanceFromTheStart)
{
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath());
  Eigen::VectorXd q(6);
  q << 0.5, -1.2, 1.4, -0.8, -1.2, 0.3;
  IkParams params;
  params.max_solutions = 8;
  params.timeout_s = 0.05;
  const std::vector<Eigen::VectorXd> sols = kin.ik(kin.fk(q), q, params);
  ASSERT_GE(sols.size(), 2u);  // a UR5 pose has up to 8 solutions within +-pi
  EXPECT_LT((sols.front() - q).norm(), 1e-3);  // the start itself is the nearest solution
  for (std::size_t i = 1; i < sols.size(); ++i)
    EXPECT_LE((sols[i - 1] - q).norm(), (sols[i] - q).norm() + 1e-12);
}

TEST(ArmKinematics, BadInputGivesNoSolution)
{
  const ArmKinematics kin = ArmKinematics::fromUrdfFile(urdfPath());
  const Eigen::VectorXd seed = Eigen::VectorXd::Zero(6);
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 2.0, 0.0, 0.5;  // beyond the 0.85 m + gripper reach
  EXPECT_TRUE(kin.ik(far, seed).empty());
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan.translation().x() = std::nan("");
  EXPECT_TRUE(kin.ik(nan, seed).empty());
  EXPECT_TRUE(kin.ik(kin.fk(seed), Eigen::VectorXd::Zero(5)).empty());
  EXPECT_FALSE(kin.fk(Eigen::VectorXd::Zero(3)).matrix().allFinite());
  // Configured limits replace the URDF's and are enforced by IK.
  ArmKinematics narrow = kin;
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(6, -0.5), hi = Eigen::VectorXd::Constant(6, 0.5);
  ASSERT_TRUE(narrow.setJointLimits(lo, hi));
  EXPECT_FALSE(narrow.setJointLimits(hi, lo));
  Eigen::VectorXd outside(6);
  outside << 2.0, -1.0, 1.5, 0.0, 1.0, 0.0;
  IkParams params;
  params.timeout_s = 0.01;
  for (const Eigen::VectorXd& s : narrow.ik(kin.fk(outside), seed, params))
    EXPECT_TRUE(narrow.withinLimits(s));
}

// Forward kinematics takes its sines and cosines from jointSinCos: within 1e-16 of libm's
// (absolute: a rounding step of values near 1) on a dense sweep of joint angles, at and next to
// the multiples of pi/4 where its quadrants and polynomials meet, and on large angles; libm's
// answer beyond its range and for NaN.
TEST(ArmKinematics, BodyFramesBatchIsBodyFramesToTheBit)
{
  // The batched kinematics must give every frame bodyFrames gives, bit for bit (the planner's
  // validity verdicts, and with them its seeded trees, depend on it): all three robots, groups
  // of 1 to 4 states, random states, large angles (also past 1e6 rad, where jointSinCos hands
  // over to libm) and the multiples of pi / 4 where the sine's quadrant changes.
  for (const char* name : { "ur5", "lwr4", "jaco" })
  {
    const ArmKinematics kin =
        ArmKinematics::fromUrdfFile(std::string(FAST_GRASP_SOURCE_DIR) + "/urdf/" + name + "_gripper_xtion.urdf");
    const std::size_t n = kin.dof();
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> wide(-50.0, 50.0);
    std::vector<Eigen::Isometry3d> reference, batch(ArmKinematics::kBodyFrameBatch * (n + 1));
    int mismatches = 0, compared = 0;
    for (int trial = 0; trial < 3000; ++trial)
    {
      const std::size_t count = 1 + static_cast<std::size_t>(trial) % ArmKinematics::kBodyFrameBatch;
      std::vector<Eigen::VectorXd> qs(count);
      const double* pointers[ArmKinematics::kBodyFrameBatch];
      for (std::size_t k = 0; k < count; ++k)
      {
        qs[k] = kin.randomConfiguration(rng);
        if (trial % 3 == 1)
          for (std::size_t j = 0; j < n; ++j)
            qs[k][static_cast<Eigen::Index>(j)] = wide(rng);
        if (trial % 3 == 2)
          for (std::size_t j = 0; j < n; ++j)
            qs[k][static_cast<Eigen::Index>(j)] = kPi / 4 * static_cast<double>(static_cast<int>(rng() % 17) - 8);
        if (trial % 7 == 6)  // beyond jointSinCos's reduction (libm's sine and cosine)
          qs[k][static_cast<Eigen::Index>(rng() % n)] = (rng() % 2 ? 1.0 : -1.0) * 3.7e7;
        pointers[k] = qs[k].data();
      }
      kin.bodyFramesBatch(pointers, count, batch.data());
      for (std::size_t k = 0; k < count; ++k)
      {
        kin.bodyFrames(qs[k], reference);
        ASSERT_EQ(reference.size(), n + 1);
        for (std::size_t b = 0; b <= n; ++b, ++compared)
          if (std::memcmp(reference[b].data(), batch[k * (n + 1) + b].data(), 16 * sizeof(double)) != 0 &&
              mismatches++ == 0)
            ADD_FAILURE() << name << ": state " << qs[k].transpose() << " body " << b << "\n"
                          << reference[b].matrix() << "\nvs\n" << batch[k * (n + 1) + b].matrix();
      }
    }
    EXPECT_EQ(mismatches, 0) << name;
    EXPECT_GT(compared, 3000) << name;
  }
}

TEST(JointSinCos, AgreesWithLibm)
{
  double worst = 0.0, worst_at = 0.0;
  auto compare = [&](double x) {
    double s = 0.0, c = 0.0;
    fast_grasp::jointSinCos(x, s, c);
    const double error = std::max(std::abs(s - std::sin(x)), std::abs(c - std::cos(x)));
    if (error > worst)
    {
      worst = error;
      worst_at = x;
    }
  };
  for (double x = -7.0; x <= 7.0; x += 1e-5)
    compare(x);
  for (int k = -40; k <= 40; ++k)
    for (double x = std::nextafter(k * kPi / 4, -100.0), n = 0; n < 20; ++n, x = std::nextafter(x, 100.0))
      compare(x);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> large(-1e6, 1e6);
  for (int i = 0; i < 200000; ++i)
    compare(large(rng));
  EXPECT_LE(worst, 2.3e-16) << "at " << worst_at;
  double s = 0.0, c = 0.0;
  fast_grasp::jointSinCos(3e7, s, c);
  EXPECT_EQ(s, std::sin(3e7));
  EXPECT_EQ(c, std::cos(3e7));
  fast_grasp::jointSinCos(std::numeric_limits<double>::quiet_NaN(), s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

}  // namespace
