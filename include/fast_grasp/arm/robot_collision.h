// Collision checking of a URDF chain against itself and a scene (OctoMap of points, boxes,
// target object) with FCL. ROS-free; FCL and OctoMap stay out of this header.
#pragma once

#include "fast_grasp/arm/arm_kinematics.h"

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Which contacts a query tolerates.
struct CollisionCheckOptions
{
  /// Final approach only: the finger links may touch the target object (never anything else).
  bool allow_finger_target_contact = false;
  /// Lift after closing: the target moves with the hand, so it is no obstacle at all.
  bool ignore_target = false;
  /// Skip FCL's narrow phase for pairs that cheap conservative tests (bounding spheres,
  /// bounding boxes, separating axes) prove apart. Same answers as FCL alone, several times
  /// faster; false sends every pair to FCL (the reference the tests compare against).
  bool conservative_culling = true;
};

/// One robot collision shape, placed on a chain link (for markers and the self filter).
struct RobotShape
{
  enum class Type
  {
    Box,
    Cylinder,
    Sphere
  };
  std::string link;          // URDF link that declares the shape
  std::size_t chain_link = 0;  // index into ArmKinematics::linkNames() carrying it
  int body = 0;              // moving joints between base and the shape (0 = fixed to base)
  Type type = Type::Box;
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();  // box: x y z; cylinder: radius radius length; sphere: r r r
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();  // shape pose in the chain link's frame
  bool finger = false;
};

/// Robot model + scene. Scene edits (add/clear) are not thread-safe; every const query is
/// (scratch buffers are per thread; FCL queries run on call-local objects). Copies are cheap snapshots:
/// the scene is shared immutably and replaced on edit.
class RobotCollision
{
public:
  /// Reads the collision shapes (box, cylinder, sphere; meshes are skipped and counted) of
  /// every link rigidly attached to the chain of `kinematics`. `link_padding_m` inflates them.
  /// finger_links name the links allowed to touch the target during the final approach; they
  /// are inflated by `finger_padding_m` instead (< 0: link_padding_m too).
  explicit RobotCollision(const ArmKinematics& kinematics, double link_padding_m = 0.0,
                          std::vector<std::string> finger_links = { "left_finger_link", "right_finger_link" },
                          double finger_padding_m = -1.0);

  const ArmKinematics& kinematics() const { return kinematics_; }
  const std::vector<RobotShape>& shapes() const { return shapes_; }
  std::size_t skippedMeshes() const { return skipped_meshes_; }
  /// Per joint, an upper bound (m) on the distance from the joint's axis origin to any robot
  /// surface it moves (padded shapes). A joint-space step dq moves no robot point by more than
  /// sum_j |dq_j| * jointLeverArms()[j]: the motion validator uses it to bound the Cartesian
  /// gap between checked states.
  const Eigen::VectorXd& jointLeverArms() const { return lever_arms_m_; }
  /// Non-adjacent link pairs left unchecked because they touch in the zero configuration.
  const std::vector<std::string>& defaultAllowedPairs() const { return allowed_pairs_; }

  // --- scene -----------------------------------------------------------------------------
  /// Drops the whole scene and sets the OctoMap resolution for the clouds added next.
  /// Returns false (resolution unchanged) unless 0 < resolution_m <= 1.
  bool resetScene(double octomap_resolution_m);
  /// Adds obstacle points (scene, unseen space behind the object) to the obstacle OctoMap.
  /// Points inside the robot's own shapes at `robot_state` (inflated by self_filter_padding_m)
  /// and non-finite points are dropped first, so the arm never becomes its own obstacle (a
  /// robot_state of the wrong size or with NaNs skips that filter). Returns the number of
  /// points inserted.
  std::size_t addObstacleCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud, const Eigen::VectorXd& robot_state,
                               double self_filter_padding_m = 0.02);
  /// Replaces the target object's points (its own OctoMap, the only obstacle the fingers may
  /// touch, and only with CollisionCheckOptions::allow_finger_target_contact).
  std::size_t setTargetCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud);
  /// Adds a box obstacle (table, shelf board, unseen-space box); pose of its centre in base_link.
  void addBox(const std::string& name, const Eigen::Vector3d& size_m, const Eigen::Isometry3d& pose);
  std::size_t obstacleVoxelCount() const;
  std::size_t targetVoxelCount() const;
  double octomapResolution() const;
  /// Centres of the occupied obstacle / target voxels (markers, debugging).
  std::vector<Eigen::Vector3d> occupiedVoxelCentres(bool target = false) const;

  // --- queries ---------------------------------------------------------------------------
  /// True when q is in collision (self, boxes, obstacle OctoMap, target). `why` names the
  /// first contact found ("self: upper_arm_link / wrist_2_link", "box table / forearm_link").
  /// A q of the wrong size or with NaNs counts as a collision.
  bool inCollision(const Eigen::VectorXd& q, const CollisionCheckOptions& options = CollisionCheckOptions(),
                   std::string* why = nullptr) const;
  /// inCollision of `count` joint vectors in order, up to the first in collision: its index,
  /// or count when all are clear (the states after it are not checked). Each verdict is
  /// inCollision's: the forward kinematics of four states run together
  /// (ArmKinematics::bodyFramesBatch, the same frames to the bit), the tests state by state.
  /// Why: a motion's states are checked together (ArmRRTConnect, ArmMotionValidator), and
  /// forward kinematics was a fifth of a check.
  std::size_t firstInCollision(const Eigen::VectorXd* const* qs, std::size_t count,
                               const CollisionCheckOptions& options = CollisionCheckOptions()) const;
  bool inSelfCollision(const Eigen::VectorXd& q, std::string* why = nullptr) const;
  /// Points of `cloud` outside the robot at q (shapes inflated by padding_m).
  pcl::PointCloud<pcl::PointXYZ> removeRobotPoints(const pcl::PointCloud<pcl::PointXYZ>& cloud,
                                                   const Eigen::VectorXd& q, double padding_m) const;
  /// World poses of all shapes at q, in the order of shapes().
  void shapePoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& poses) const;

  struct Scene;  // OctoMaps and FCL geometry; defined in the source
  struct Geometry;

  struct ShapeFrames;  // one check's shape poses, rotations placed on demand; in the source

private:
  void shapeFrames(const Eigen::VectorXd& q, ShapeFrames& frames) const;
  bool inCollisionAt(ShapeFrames& frames, const CollisionCheckOptions& options, std::string* why) const;
  bool selfCollision(ShapeFrames& frames, bool cull, std::string* why) const;

  ArmKinematics kinematics_;
  std::vector<RobotShape> shapes_;
  std::shared_ptr<const Geometry> geometry_;  // FCL shapes (padded) of shapes_
  std::vector<std::pair<std::size_t, std::size_t>> self_pairs_;  // shape pairs to check
  std::vector<std::string> allowed_pairs_;
  Eigen::VectorXd lever_arms_m_;
  double link_padding_m_ = 0.0;
  double finger_padding_m_ = 0.0;
  std::size_t skipped_meshes_ = 0;
  std::shared_ptr<const Scene> scene_;
};

}  // namespace fast_grasp
