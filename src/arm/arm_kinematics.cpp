#include "fast_grasp/arm/arm_kinematics.h"

#include "fast_grasp/arm/joint_sin_cos.h"

#include <kdl/chain.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Cholesky>

#if defined(__x86_64__) || defined(__i386__)
#define FAST_GRASP_X86_CLONES 1
#endif

#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace fast_grasp
{
namespace
{
constexpr double kPi = 3.14159265358979323846;

Eigen::Isometry3d toEigen(const KDL::Frame& f)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 3; ++c)
      t.linear()(r, c) = f.M(r, c);
    t.translation()(r) = f.p(r);
  }
  return t;
}

double threadCpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Orientation error as a rotation vector (axis * angle) taking `current` to `target`.
Eigen::Vector3d rotationError(const Eigen::Matrix3d& target, const Eigen::Matrix3d& current)
{
  const Eigen::AngleAxisd aa(target * current.transpose());
  return aa.axis() * aa.angle();
}
}  // namespace

/// Rigid transform stored as a contiguous 3 x 3 rotation and a translation. Collision
/// checking runs the chain walk for every state a planner checks; Eigen unrolls and inlines
/// products of these, not those of an Isometry3d's 3 x 3 blocks of a 4 x 4 matrix.
struct Rigid
{
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Rigid() = default;
  explicit Rigid(const Eigen::Isometry3d& t) : r(t.linear()), p(t.translation()) {}
  Eigen::Isometry3d isometry() const
  {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = r;
    t.translation() = p;
    return t;
  }
  Rigid operator*(const Rigid& b) const
  {
    Rigid out;
    out.r.noalias() = r * b.r;
    out.p.noalias() = r * b.p;
    out.p += p;
    return out;
  }
};

/// A revolute joint about a frame axis as the batched body frames see it: its pre frame in
/// the previous body frame (rotation row by row, translation), the columns u and v its
/// rotation turns, and the axis sign.
struct BatchJoint
{
  double r[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  double p[3] = { 0, 0, 0 };
  int u = 0, v = 1;
  int joint_index = 0;
  double axis_sign = 1.0;
};

/// One chain segment, KDL-free: pose(q) = pre * joint(q) * post, the joint being a rotation
/// about (or translation along) `axis` through the origin of the `pre` frame.
struct ArmKinematics::Model
{
  enum class JointType
  {
    Fixed,
    Revolute,
    Prismatic
  };
  struct Segment
  {
    std::string link;
    JointType type = JointType::Fixed;
    int joint_index = -1;  // index into q for moving joints
    Rigid pre;
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit, in the pre frame
    /// 0 / 1 / 2 when axis is +-x / +-y / +-z (the UR5's, and most URDFs'), else -1: a
    /// rotation about a frame axis mixes two columns instead of building a matrix.
    int principal_axis = -1;
    double axis_sign = 1.0;
    Rigid post;
    Rigid pre_post;  // pre * post: the whole segment when the joint is fixed
  };
  std::string urdf_xml;
  std::string base_link;
  std::string tip_link;
  std::vector<Segment> segments;
  std::vector<std::string> joint_names;
  std::vector<std::string> link_names;  // base_link + one per segment
  std::vector<int> moving_before;        // per link_names entry
  std::vector<bool> continuous;          // per joint
  // Body frames (bodyFrames): body 0 is base_link, body k + 1 the pre frame of moving joint k
  // turned by q_k; every link with k + 1 moving joints before it is rigid in it.
  std::vector<std::size_t> moving_segments;  // per joint: index into segments
  std::vector<Rigid> joint_in_body;          // per joint: its pre frame in the previous body frame
  std::vector<Rigid> link_in_body;           // per link_names entry: pose in body moving_before[link]
  // bodyFramesBatch: per joint, joint_in_body row by row and the two columns its rotation
  // turns; empty when a joint is prismatic or turns about an axis that is not a frame axis
  // (those chains take bodyFrames state by state).
  std::vector<BatchJoint> batch_joints;

  /// Calls visit(body, frame) for body 0 (the identity) and each moving joint's body frame:
  /// one product and one axis rotation per moving joint (walk() spends two products per
  /// moving segment and one per fixed one).
  template <typename Joints, typename Visit>
  void walkBodies(const Joints& q, Visit&& visit) const
  {
    Rigid t;
    visit(std::size_t(0), t);
    for (std::size_t k = 0; k < moving_segments.size(); ++k)
    {
      const Segment& s = segments[moving_segments[k]];
      Rigid frame = t * joint_in_body[k];
      if (s.type == JointType::Revolute)
        rotate(frame.r, s, q[s.joint_index]);
      else
        frame.p.noalias() += frame.r * (s.axis * q[s.joint_index]);
      t = frame;
      visit(k + 1, t);
    }
  }

  /// Walks the chain; calls visit(segment_index, pose_after_segment, pose_before_joint)
  /// (for a fixed segment both are the pose after it).
  template <typename Visit>
  Rigid walk(const Eigen::VectorXd& q, Visit&& visit) const
  {
    Rigid t, before;
    for (std::size_t i = 0; i < segments.size(); ++i)
    {
      const Segment& s = segments[i];
      if (s.type == JointType::Fixed)
      {
        t = t * s.pre_post;
        visit(i, t, t);
        continue;
      }
      before = t * s.pre;
      Rigid after = before;
      if (s.type == JointType::Revolute)
        rotate(after.r, s, q[s.joint_index]);
      else
        after.p.noalias() += before.r * (s.axis * q[s.joint_index]);
      t = after * s.post;
      visit(i, t, before);
    }
    return t;
  }

  /// r *= rotation of `angle` about the segment's axis.
  static void rotate(Eigen::Matrix3d& r, const Segment& s, double angle)
  {
    if (s.principal_axis < 0)
    {
      r = r * Eigen::AngleAxisd(angle, s.axis).toRotationMatrix();
      return;
    }
    // Rotation about frame axis k: columns k+1 and k+2 turn in their plane.
    double sn = 0.0, c = 1.0;
    jointSinCos(angle, sn, c);  // libm's sin and cos were 13 % of a validity check
    sn *= s.axis_sign;
    const int u = (s.principal_axis + 1) % 3, v = (s.principal_axis + 2) % 3;
    const Eigen::Vector3d cu = r.col(u), cv = r.col(v);
    r.col(u) = c * cu + sn * cv;
    r.col(v) = c * cv - sn * cu;
  }
};

ArmKinematics ArmKinematics::fromUrdfFile(const std::string& urdf_path, const std::string& base_link,
                                          const std::string& tip_link)
{
  std::ifstream in(urdf_path);
  if (!in)
    throw std::runtime_error("ArmKinematics: cannot open URDF file '" + urdf_path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return fromUrdfString(buffer.str(), base_link, tip_link);
}

ArmKinematics ArmKinematics::fromUrdfString(const std::string& urdf_xml, const std::string& base_link,
                                            const std::string& tip_link)
{
  const urdf::ModelInterfaceSharedPtr urdf_model = urdf::parseURDF(urdf_xml);
  if (!urdf_model)
    throw std::runtime_error("ArmKinematics: the URDF does not parse");
  KDL::Tree tree;
  if (!kdl_parser::treeFromUrdfModel(*urdf_model, tree))
    throw std::runtime_error("ArmKinematics: kdl_parser could not build a tree from the URDF");
  KDL::Chain chain;
  if (!tree.getChain(base_link, tip_link, chain))
    throw std::runtime_error("ArmKinematics: no chain from '" + base_link + "' to '" + tip_link + "'");

  auto model = std::make_shared<Model>();
  model->urdf_xml = urdf_xml;
  model->base_link = base_link;
  model->tip_link = tip_link;
  model->link_names.push_back(base_link);
  model->moving_before.push_back(0);
  ArmKinematics kin;
  std::vector<double> lower, upper, velocity;
  for (unsigned i = 0; i < chain.getNrOfSegments(); ++i)
  {
    const KDL::Segment& seg = chain.getSegment(i);
    const KDL::Joint& joint = seg.getJoint();
    Model::Segment s;
    s.link = seg.getName();
    // KDL: Segment::pose(q) = joint.pose(q) * f_tip, and the joint frame at q = 0 is a pure
    // offset to the joint origin; recover f_tip so the walk needs no KDL at run time.
    const KDL::Frame joint_zero = joint.pose(0.0);
    const KDL::Frame f_tip = joint_zero.Inverse() * seg.getFrameToTip();
    s.pre = Rigid(toEigen(joint_zero));
    s.post = Rigid(toEigen(f_tip));
    s.pre_post = s.pre * s.post;
    if (joint.getType() != KDL::Joint::None)
    {
      // KDL's axis is in the segment root frame; express it in the joint's (pre) frame.
      const KDL::Vector axis_root = joint.JointAxis();
      const Eigen::Vector3d axis(axis_root.x(), axis_root.y(), axis_root.z());
      s.axis = (s.pre.r.transpose() * axis).normalized();
      for (int k = 0; k < 3; ++k)
        if (std::abs(std::abs(s.axis[k]) - 1.0) < 1e-12)
        {
          s.principal_axis = k;
          s.axis_sign = s.axis[k] > 0.0 ? 1.0 : -1.0;
        }
      const bool prismatic = joint.getType() == KDL::Joint::TransAxis || joint.getType() == KDL::Joint::TransX ||
                             joint.getType() == KDL::Joint::TransY || joint.getType() == KDL::Joint::TransZ;
      s.type = prismatic ? Model::JointType::Prismatic : Model::JointType::Revolute;
      s.joint_index = static_cast<int>(model->joint_names.size());
      model->joint_names.push_back(joint.getName());
      const urdf::JointConstSharedPtr uj = urdf_model->getJoint(joint.getName());
      const bool continuous = uj && uj->type == urdf::Joint::CONTINUOUS;
      model->continuous.push_back(continuous);
      double lo = -kPi, hi = kPi, vel = kPi;
      if (uj && uj->limits)
      {
        if (!continuous)
        {
          lo = uj->limits->lower;
          hi = uj->limits->upper;
        }
        if (uj->limits->velocity > 0.0)
          vel = uj->limits->velocity;
      }
      lower.push_back(lo);
      upper.push_back(hi);
      velocity.push_back(vel);
    }
    model->segments.push_back(s);
    model->link_names.push_back(s.link);
    model->moving_before.push_back(static_cast<int>(model->joint_names.size()));
  }
  if (model->joint_names.empty())
    throw std::runtime_error("ArmKinematics: the chain '" + base_link + "' -> '" + tip_link + "' has no moving joint");
  {
    // Fold the fixed segments and each moving segment's post into the next joint's pre frame.
    Rigid in_body;  // the current chain point in the current body frame
    model->link_in_body.push_back(in_body);  // base_link
    for (std::size_t i = 0; i < model->segments.size(); ++i)
    {
      const Model::Segment& s = model->segments[i];
      if (s.type == Model::JointType::Fixed)
        in_body = in_body * s.pre_post;
      else
      {
        model->moving_segments.push_back(i);
        model->joint_in_body.push_back(in_body * s.pre);
        in_body = s.post;
      }
      model->link_in_body.push_back(in_body);
    }
    bool batchable = true;
    for (std::size_t k = 0; k < model->moving_segments.size(); ++k)
    {
      const Model::Segment& s = model->segments[model->moving_segments[k]];
      batchable = batchable && s.type == Model::JointType::Revolute && s.principal_axis >= 0;
      BatchJoint j;
      const Rigid& pre = model->joint_in_body[k];
      for (int row = 0; row < 3; ++row)
      {
        for (int col = 0; col < 3; ++col)
          j.r[row * 3 + col] = pre.r(row, col);
        j.p[row] = pre.p[row];
      }
      j.u = (s.principal_axis + 1) % 3;
      j.v = (s.principal_axis + 2) % 3;
      j.joint_index = s.joint_index;
      j.axis_sign = s.axis_sign;
      model->batch_joints.push_back(j);
    }
    if (!batchable)
      model->batch_joints.clear();
  }
  kin.model_ = model;
  kin.lower_rad_ = Eigen::Map<Eigen::VectorXd>(lower.data(), static_cast<Eigen::Index>(lower.size()));
  kin.upper_rad_ = Eigen::Map<Eigen::VectorXd>(upper.data(), static_cast<Eigen::Index>(upper.size()));
  kin.velocity_rad_s_ = Eigen::Map<Eigen::VectorXd>(velocity.data(), static_cast<Eigen::Index>(velocity.size()));
  kin.updateContinuousJoints();
  return kin;
}

std::size_t ArmKinematics::dof() const { return model_->joint_names.size(); }
const std::vector<std::string>& ArmKinematics::jointNames() const { return model_->joint_names; }
const std::string& ArmKinematics::baseLink() const { return model_->base_link; }
const std::string& ArmKinematics::tipLink() const { return model_->tip_link; }
const std::string& ArmKinematics::urdfXml() const { return model_->urdf_xml; }
const std::vector<std::string>& ArmKinematics::linkNames() const { return model_->link_names; }
int ArmKinematics::movingJointsBefore(std::size_t link_index) const { return model_->moving_before.at(link_index); }

bool ArmKinematics::setJointLimits(const Eigen::VectorXd& lower_rad, const Eigen::VectorXd& upper_rad)
{
  if (lower_rad.size() != static_cast<Eigen::Index>(dof()) || upper_rad.size() != lower_rad.size() ||
      !lower_rad.allFinite() || !upper_rad.allFinite() || (lower_rad.array() > upper_rad.array()).any())
    return false;
  lower_rad_ = lower_rad;
  upper_rad_ = upper_rad;
  updateContinuousJoints();
  return true;
}

bool ArmKinematics::setVelocityLimits(const Eigen::VectorXd& velocity_rad_s)
{
  if (velocity_rad_s.size() != static_cast<Eigen::Index>(dof()) || !velocity_rad_s.allFinite() ||
      (velocity_rad_s.array() <= 0.0).any())
    return false;
  velocity_rad_s_ = velocity_rad_s;
  return true;
}

bool ArmKinematics::withinLimits(const Eigen::VectorXd& q, double tolerance_rad) const
{
  if (q.size() != static_cast<Eigen::Index>(dof()) || !q.allFinite())
    return false;
  return ((q.array() >= check_lower_rad_ - tolerance_rad) && (q.array() <= check_upper_rad_ + tolerance_rad)).all();
}

bool ArmKinematics::isContinuous(std::size_t joint) const { return joint < wraps_.size() && wraps_[joint]; }

void ArmKinematics::updateContinuousJoints()
{
  wraps_.assign(dof(), false);
  check_lower_rad_ = lower_rad_.array();
  check_upper_rad_ = upper_rad_.array();
  for (std::size_t j = 0; j < dof(); ++j)
  {
    const Eigen::Index i = static_cast<Eigen::Index>(j);
    wraps_[j] = model_->continuous[j] && upper_rad_[i] - lower_rad_[i] >= 2.0 * kPi - 1e-9;
    if (wraps_[j])
    {
      check_lower_rad_[i] = -std::numeric_limits<double>::infinity();
      check_upper_rad_[i] = std::numeric_limits<double>::infinity();
    }
  }
}

Eigen::VectorXd ArmKinematics::nearestEquivalent(const Eigen::VectorXd& q, const Eigen::VectorXd& reference) const
{
  Eigen::VectorXd out = q;
  if (q.size() != reference.size())
    return out;
  for (Eigen::Index j = 0; j < q.size(); ++j)
    if (isContinuous(static_cast<std::size_t>(j)) && std::isfinite(q[j]) && std::isfinite(reference[j]))
      out[j] = q[j] - 2.0 * kPi * std::round((q[j] - reference[j]) / (2.0 * kPi));
  return out;
}

Eigen::VectorXd ArmKinematics::randomConfiguration(std::mt19937& rng) const
{
  Eigen::VectorXd q(dof());
  for (Eigen::Index j = 0; j < q.size(); ++j)
    q[j] = std::uniform_real_distribution<double>(lower_rad_[j], upper_rad_[j])(rng);
  return q;
}

Eigen::Isometry3d ArmKinematics::fk(const Eigen::VectorXd& q) const
{
  if (q.size() != static_cast<Eigen::Index>(dof()))
  {
    Eigen::Isometry3d nan;
    nan.matrix().setConstant(std::numeric_limits<double>::quiet_NaN());
    return nan;
  }
  return model_->walk(q, [](std::size_t, const Rigid&, const Rigid&) {}).isometry();
}

void ArmKinematics::linkPoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& poses) const
{
  poses.resize(model_->link_names.size());
  poses[0] = Eigen::Isometry3d::Identity();
  if (q.size() != static_cast<Eigen::Index>(dof()))
    return;
  model_->walk(q, [&poses](std::size_t i, const Rigid& t, const Rigid&) {
    poses[i + 1].linear() = t.r;
    poses[i + 1].translation() = t.p;
    poses[i + 1].makeAffine();
  });
}

void ArmKinematics::bodyFrames(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& frames) const
{
  frames.resize(dof() + 1);
  if (q.size() != static_cast<Eigen::Index>(dof()))
  {
    for (Eigen::Isometry3d& f : frames)
      f.matrix().setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  model_->walkBodies(q, [&frames](std::size_t body, const Rigid& t) {
    frames[body].linear() = t.r;
    frames[body].translation() = t.p;
    frames[body].makeAffine();
  });
}

namespace
{
#ifdef FAST_GRASP_X86_CLONES
__attribute__((target_clones("avx2", "default")))
#endif
/// The body frames of four states (lanes), walkBodies' products and rotations on four lanes
/// at once: GCC vector types, one AVX2 instruction per four (SSE2: two) scalar operations of
/// the same kind. Each element is the sum walkBodies' Eigen products form, in the same order
/// (joint_in_body's rows times the frame's columns left to right, then the translation), and
/// "avx2" does not enable FMA, so every frame is walkBodies' to the bit. angle4: per joint,
/// four lanes. frames: per lane (the first `lanes` are stored), joints + 1 column-major
/// 4 x 4 matrices (Eigen::Isometry3d's storage), body 0 the identity.
void bodyFramesOfFour(const BatchJoint* joints, std::size_t n, const double* angle4, std::size_t lanes, double* frames)
{
  typedef double Lanes __attribute__((vector_size(32)));
  typedef long long Integers __attribute__((vector_size(32)));
  Lanes tr[9], tp[3];
  for (int e = 0; e < 9; ++e)
    tr[e] = Lanes{ 0.0, 0.0, 0.0, 0.0 };
  tr[0] = tr[4] = tr[8] = Lanes{ 1.0, 1.0, 1.0, 1.0 };
  tp[0] = tp[1] = tp[2] = Lanes{ 0.0, 0.0, 0.0, 0.0 };
  const std::size_t stride = 16 * (n + 1);  // doubles per lane
  for (std::size_t lane = 0; lane < lanes; ++lane)
  {
    double* m = frames + lane * stride;
    for (int e = 0; e < 16; ++e)
      m[e] = (e % 5 == 0) ? 1.0 : 0.0;
  }
  for (std::size_t k = 0; k < n; ++k)
  {
    const BatchJoint& j = joints[k];
    Lanes fr[9], fp[3];
    for (int row = 0; row < 3; ++row)
    {
      for (int col = 0; col < 3; ++col)
        fr[row * 3 + col] = tr[row * 3 + 0] * j.r[0 * 3 + col] + tr[row * 3 + 1] * j.r[1 * 3 + col] +
                            tr[row * 3 + 2] * j.r[2 * 3 + col];
      fp[row] = (tr[row * 3 + 0] * j.p[0] + tr[row * 3 + 1] * j.p[1] + tr[row * 3 + 2] * j.p[2]) + tp[row];
    }
    // jointSinCos on four lanes: the same reduction and polynomials, operation by operation;
    // the quadrant's conversion and the final choice lane by lane, and lanes outside
    // |angle| < 1e6 (and NaN) from jointSinCos itself (libm).
    Lanes angle;
    std::memcpy(&angle, angle4 + 4 * k, sizeof angle);
    const Lanes scaled = angle * 0.63661977236758134308;  // 2 / pi
    const Lanes half = scaled >= 0.0 ? Lanes{ 0.5, 0.5, 0.5, 0.5 } : Lanes{ -0.5, -0.5, -0.5, -0.5 };
    const Lanes rounded = scaled + half;
    Integers quadrant;
    Lanes q;
    for (int lane = 0; lane < 4; ++lane)
    {
      // Lanes jointSinCos hands to libm convert nothing (their result is replaced below).
      quadrant[lane] = std::abs(angle[lane]) < 1e6 ? static_cast<long long>(rounded[lane]) : 0;
      q[lane] = static_cast<double>(quadrant[lane]);
    }
    Lanes r, sin_r, cos_r;
    sin_cos_detail::reduceAngle(angle, q, r);
    const Lanes z = r * r;
    sin_cos_detail::sinOfReduced(r, z, sin_r);
    sin_cos_detail::cosOfReduced(z, cos_r);
    Lanes c, sn;
    for (int lane = 0; lane < 4; ++lane)
    {
      double sl = 0.0, cl = 1.0;
      if (!(std::abs(angle[lane]) < 1e6))
        jointSinCos(angle[lane], sl, cl);
      else
        sin_cos_detail::rotateByQuadrant(quadrant[lane], sin_r[lane], cos_r[lane], sl, cl);
      sn[lane] = sl * j.axis_sign;
      c[lane] = cl;
    }
    for (int row = 0; row < 3; ++row)
    {
      const Lanes cu = fr[row * 3 + j.u], cv = fr[row * 3 + j.v];
      fr[row * 3 + j.u] = c * cu + sn * cv;
      fr[row * 3 + j.v] = c * cv - sn * cu;
    }
    for (int e = 0; e < 9; ++e)
      tr[e] = fr[e];
    for (int e = 0; e < 3; ++e)
      tp[e] = fp[e];
    for (std::size_t lane = 0; lane < lanes; ++lane)
    {
      double* m = frames + lane * stride + 16 * (k + 1);
      for (int col = 0; col < 3; ++col)
      {
        for (int row = 0; row < 3; ++row)
          m[col * 4 + row] = fr[row * 3 + col][lane];
        m[col * 4 + 3] = 0.0;
      }
      for (int row = 0; row < 3; ++row)
        m[12 + row] = fp[row][lane];
      m[15] = 1.0;
    }
  }
}
}  // namespace

void ArmKinematics::bodyFramesBatch(const double* const* qs, std::size_t count, Eigen::Isometry3d* frames) const
{
  const std::size_t n = dof();
  if (count < 2 || model_->batch_joints.empty() || count > kBodyFrameBatch || n > kMaxBatchJoints)
  {
    // One state, or not a chain of frame-axis revolute joints: state by state.
    for (std::size_t k = 0; k < count; ++k)
      model_->walkBodies(qs[k], [&](std::size_t b, const Rigid& t) {
        Eigen::Isometry3d& f = frames[k * (n + 1) + b];
        f.linear() = t.r;
        f.translation() = t.p;
        f.makeAffine();
      });
    return;
  }
  double angle4[4 * kMaxBatchJoints];
  for (std::size_t k = 0; k < n; ++k)
  {
    const BatchJoint& j = model_->batch_joints[k];
    for (std::size_t lane = 0; lane < 4; ++lane)
      angle4[4 * k + lane] = lane < count ? qs[lane][j.joint_index] : 0.0;  // lanes past count: not stored
  }
  static_assert(sizeof(Eigen::Isometry3d) == 16 * sizeof(double), "Isometry3d is a plain 4 x 4 matrix");
  bodyFramesOfFour(model_->batch_joints.data(), n, angle4, count, frames[0].data());
}

Eigen::Isometry3d ArmKinematics::linkInBodyFrame(std::size_t link_index) const
{
  return model_->link_in_body.at(link_index).isometry();
}

Eigen::Matrix<double, 6, Eigen::Dynamic> ArmKinematics::jacobian(const Eigen::VectorXd& q) const
{
  Eigen::Matrix<double, 6, Eigen::Dynamic> jac(6, static_cast<Eigen::Index>(dof()));
  jac.setZero();
  if (q.size() != static_cast<Eigen::Index>(dof()))
    return jac;
  // Joint axes and origins in the base frame, then columns relative to the tip position.
  std::vector<Eigen::Vector3d> axes(dof()), origins(dof());
  std::vector<bool> prismatic(dof(), false);
  const Rigid tip =
      model_->walk(q, [&](std::size_t i, const Rigid&, const Rigid& before) {
        const Model::Segment& s = model_->segments[i];
        if (s.type == Model::JointType::Fixed)
          return;
        axes[s.joint_index] = before.r * s.axis;
        origins[s.joint_index] = before.p;
        prismatic[s.joint_index] = s.type == Model::JointType::Prismatic;
      });
  for (std::size_t j = 0; j < dof(); ++j)
  {
    if (prismatic[j])
      jac.col(j).head<3>() = axes[j];
    else
    {
      jac.col(j).head<3>() = axes[j].cross(tip.p - origins[j]);
      jac.col(j).tail<3>() = axes[j];
    }
  }
  return jac;
}

void ArmKinematics::wrapIntoLimits(Eigen::VectorXd& q) const
{
  for (Eigen::Index j = 0; j < q.size() && j < lower_rad_.size(); ++j)
  {
    if (!std::isfinite(q[j]))
      continue;
    if (q[j] >= lower_rad_[j] && q[j] <= upper_rad_[j])
      continue;
    // Smallest shift by a multiple of 2*pi that lands inside [lower, upper], if any.
    const double shifted = lower_rad_[j] + std::fmod(std::fmod(q[j] - lower_rad_[j], 2.0 * kPi) + 2.0 * kPi, 2.0 * kPi);
    if (shifted <= upper_rad_[j])
      q[j] = shifted;
  }
}

std::vector<Eigen::VectorXd> ArmKinematics::ik(const Eigen::Isometry3d& target, const Eigen::VectorXd& seed,
                                               const IkParams& params) const
{
  std::vector<Eigen::VectorXd> solutions;
  const Eigen::Index n = static_cast<Eigen::Index>(dof());
  if (!target.matrix().allFinite() || seed.size() != n || params.max_solutions < 1)
    return solutions;
  // The budget is this thread's CPU time, not wall time: on a loaded machine (2 cores shared
  // by several builds here) preemption would otherwise turn into IK failures.
  const double deadline = threadCpuSeconds() + params.timeout_s;
  auto timeLeft = [deadline]() { return threadCpuSeconds() < deadline; };
  std::mt19937 rng(params.random_seed);

  const Eigen::Matrix3d target_rot = target.linear();
  const Eigen::Vector3d target_pos = target.translation();
  auto error = [&](const Eigen::VectorXd& q, Eigen::Matrix<double, 6, 1>& e) {
    const Eigen::Isometry3d t = fk(q);
    e.head<3>() = target_pos - t.translation();
    e.tail<3>() = rotationError(target_rot, t.linear());
  };
  auto converged = [&](const Eigen::Matrix<double, 6, 1>& e) {
    return e.head<3>().norm() < params.position_tolerance_m && e.tail<3>().norm() < params.orientation_tolerance_rad;
  };
  // Clamp into limits; revolute joints first try a +-2*pi wrap (keeps the step's direction).
  auto project = [&](Eigen::VectorXd& q) {
    wrapIntoLimits(q);
    q = q.cwiseMax(lower_rad_).cwiseMin(upper_rad_);
  };

  Eigen::VectorXd seed_in_limits = seed;
  if (!seed_in_limits.allFinite())
    seed_in_limits = 0.5 * (lower_rad_ + upper_rad_);
  project(seed_in_limits);

  // Levenberg-Marquardt on the geometric Jacobian, with TRAC-IK's trick of restarting from
  // a random joint vector as soon as progress stalls instead of iterating in a local minimum.
  Eigen::Matrix<double, 6, 1> e, e_new;
  Eigen::VectorXd q(n), q_new(n), dq(n);
  bool first_attempt = true;
  while (timeLeft() && static_cast<int>(solutions.size()) < params.max_solutions)
  {
    q = first_attempt ? seed_in_limits : randomConfiguration(rng);
    first_attempt = false;
    error(q, e);
    double err2 = e.squaredNorm();
    double lambda = 1e-4;
    bool found = converged(e);
    for (int it = 0; it < params.max_iterations_per_attempt && !found; ++it)
    {
      const Eigen::Matrix<double, 6, Eigen::Dynamic> jac = jacobian(q);
      Eigen::MatrixXd jtj = jac.transpose() * jac;
      const Eigen::VectorXd jte = jac.transpose() * e;
      bool improved = false;
      for (int tries = 0; tries < 6 && !improved; ++tries)
      {
        Eigen::MatrixXd damped = jtj;
        damped.diagonal().array() += lambda;
        dq = damped.ldlt().solve(jte);
        q_new = q + dq;
        project(q_new);
        error(q_new, e_new);
        const double err2_new = e_new.squaredNorm();
        if (err2_new < err2)
        {
          q = q_new;
          e = e_new;
          err2 = err2_new;
          lambda = std::max(lambda * 0.1, 1e-9);
          improved = true;
        }
        else
          lambda *= 10.0;
      }
      found = converged(e);
      if (!improved || (it % 8 == 7 && !timeLeft()))
        break;  // stalled (joint limit or local minimum): restart elsewhere
    }
    if (!found || !withinLimits(q))
      continue;
    q = nearestEquivalent(q, seed);  // a continuous joint turns the short way from the seed
    const bool duplicate = std::any_of(solutions.begin(), solutions.end(), [&](const Eigen::VectorXd& s) {
      return (s - q).cwiseAbs().maxCoeff() < params.distinct_solution_rad;
    });
    if (!duplicate)
      solutions.push_back(q);
  }
  const Eigen::VectorXd& rank_from = seed.allFinite() ? seed : seed_in_limits;
  std::sort(solutions.begin(), solutions.end(), [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return (a - rank_from).squaredNorm() < (b - rank_from).squaredNorm();
  });
  return solutions;
}

}  // namespace fast_grasp
