// Forward and inverse kinematics of a serial chain read from a URDF (UR5 by default). ROS-free:
// urdfdom parses the file, kdl_parser builds the KDL chain; KDL stays out of this header.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Knobs of the numerical IK. Defaults match TRAC-IK's published UR5 benchmark setting
/// (5 ms budget, 1e-5 tolerance).
struct IkParams
{
  double timeout_s = 0.005;                 // budget for all restarts together (thread CPU time)
  double position_tolerance_m = 1e-5;
  double orientation_tolerance_rad = 1e-5;
  int max_solutions = 1;                    // stop once this many distinct solutions are found
  double distinct_solution_rad = 1e-3;      // two solutions closer than this (max-norm) are one
  int max_iterations_per_attempt = 60;      // Levenberg-Marquardt steps before a random restart
  std::uint32_t random_seed = 42;           // restarts are deterministic for a given seed
};

/// Chain kinematics. Copies are cheap (the parsed model is shared and immutable) and every
/// const member is thread-safe: no solver scratch is shared between calls.
class ArmKinematics
{
public:
  /// Parses a URDF file / string and extracts the chain base_link -> tip_link.
  /// Throws std::runtime_error naming the file or link when that is impossible (misuse).
  static ArmKinematics fromUrdfFile(const std::string& urdf_path, const std::string& base_link = "base_link",
                                    const std::string& tip_link = "grasp_frame");
  static ArmKinematics fromUrdfString(const std::string& urdf_xml, const std::string& base_link = "base_link",
                                      const std::string& tip_link = "grasp_frame");

  std::size_t dof() const;
  const std::vector<std::string>& jointNames() const;
  const std::string& baseLink() const;
  const std::string& tipLink() const;
  const std::string& urdfXml() const;

  /// Position limits (rad); continuous joints get +-pi. Defaults come from the URDF.
  const Eigen::VectorXd& lowerLimits() const { return lower_rad_; }
  const Eigen::VectorXd& upperLimits() const { return upper_rad_; }
  const Eigen::VectorXd& velocityLimits() const { return velocity_rad_s_; }
  /// Overrides the URDF position limits (config/arm.yaml joint_limits_rad). Returns false and
  /// keeps the old limits when the sizes are wrong or lower > upper.
  bool setJointLimits(const Eigen::VectorXd& lower_rad, const Eigen::VectorXd& upper_rad);
  bool setVelocityLimits(const Eigen::VectorXd& velocity_rad_s);

  /// Continuous joints (isContinuous) are within their limits at any finite angle.
  bool withinLimits(const Eigen::VectorXd& q, double tolerance_rad = 1e-9) const;
  /// True for a joint the URDF declares continuous whose position limits span a full turn
  /// (2 pi; the limits are then only where sampling and IK restarts draw from): it turns
  /// without end, and q and q + 2 pi k are the same pose. A robot config that narrows such a
  /// joint below a full turn makes it a bounded joint.
  bool isContinuous(std::size_t joint) const;
  /// q with every continuous joint shifted by a multiple of 2 pi to within pi of `reference`
  /// (the same pose, the short way round from the reference); other joints unchanged.
  Eigen::VectorXd nearestEquivalent(const Eigen::VectorXd& q, const Eigen::VectorXd& reference) const;
  /// Uniform random joint vector within the position limits.
  Eigen::VectorXd randomConfiguration(std::mt19937& rng) const;

  /// Pose of tip_link in base_link. q must have dof() entries (else returns NaN pose).
  Eigen::Isometry3d fk(const Eigen::VectorXd& q) const;
  /// Pose in base_link of every chain link, in the order of linkNames(). Links fixed to a
  /// chain link but off the chain (fingers, camera) are placed by RobotCollision.
  void linkPoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& poses) const;
  /// Chain links: base_link first, then the child link of each KDL segment up to tip_link.
  const std::vector<std::string>& linkNames() const;
  /// Number of moving joints between base_link and link i of linkNames() (0 = fixed to base).
  int movingJointsBefore(std::size_t link_index) const;
  /// dof() + 1 body frames at q: frame 0 is base_link, frame k the origin frame of the k-th
  /// moving joint turned by its q. Link i of linkNames() is rigid in frame
  /// movingJointsBefore(i), at linkInBodyFrame(i): linkPoses = bodyFrames * linkInBodyFrame,
  /// for one product per moving joint (collision checking places its shapes this way).
  /// q of the wrong size gives NaN frames.
  void bodyFrames(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& frames) const;
  /// bodyFrames of `count` (<= kBodyFrameBatch) joint vectors (dof() values each) at once:
  /// frames[k * (dof() + 1) + b] is body b of qs[k], bit for bit what bodyFrames gives (the
  /// same products in the same order, four states per SIMD instruction). Why: a validity
  /// check's forward kinematics was a fifth of it, and the states of a motion are checked
  /// together (RobotCollision::firstInCollision). Chains with a prismatic joint or a joint
  /// axis off the frame axes, or more than kMaxBatchJoints joints, go state by state.
  static constexpr std::size_t kBodyFrameBatch = 4;
  static constexpr std::size_t kMaxBatchJoints = 16;
  void bodyFramesBatch(const double* const* qs, std::size_t count, Eigen::Isometry3d* frames) const;
  Eigen::Isometry3d linkInBodyFrame(std::size_t link_index) const;
  /// 6 x dof geometric Jacobian at the tip, expressed in base_link (rows: linear, angular).
  Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian(const Eigen::VectorXd& q) const;

  /// Every distinct solution found within params.timeout_s (up to params.max_solutions),
  /// within the joint limits, ranked by distance from `seed` (nearest first); continuous
  /// joints are returned within pi of the seed's angle (nearestEquivalent). The first
  /// attempt starts at `seed`, the rest at random joint vectors. Empty when none was found
  /// (unreachable pose, NaN pose, wrong seed size).
  std::vector<Eigen::VectorXd> ik(const Eigen::Isometry3d& target, const Eigen::VectorXd& seed,
                                  const IkParams& params = IkParams()) const;

  /// Maps every revolute joint into its limits by +-2*pi where possible (q unchanged else).
  void wrapIntoLimits(Eigen::VectorXd& q) const;

  struct Model;  // parsed chain (KDL-free view); defined in the source

private:
  /// Recomputes wraps_ and the limits withinLimits() compares against (every validity check
  /// of a planner runs it) from the model and the current limits.
  void updateContinuousJoints();

  std::shared_ptr<const Model> model_;
  Eigen::VectorXd lower_rad_;
  Eigen::VectorXd upper_rad_;
  std::vector<bool> wraps_;             // isContinuous per joint
  Eigen::ArrayXd check_lower_rad_;      // lower_rad_, -inf on continuous joints
  Eigen::ArrayXd check_upper_rad_;      // upper_rad_, +inf on continuous joints
  Eigen::VectorXd velocity_rad_s_;
};

}  // namespace fast_grasp
