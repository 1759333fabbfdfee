#include "fast_grasp/arm/robot_collision.h"

#include "fast_grasp/arm/sphere_aabb.h"

#include <fcl/fcl.h>
#include <octomap/OcTree.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

namespace fast_grasp
{
using CollisionGeometryPtr = std::shared_ptr<fcl::CollisionGeometryd>;

namespace
{
/// A padded robot shape or a scene box as the culling tests see it. FCL's primitives are
/// centred on their frame's origin: box half extents; cylinder (radius, radius, half length
/// along z); sphere (radius, radius, radius).
struct ConvexShape
{
  RobotShape::Type type = RobotShape::Type::Box;
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
  double bounding_radius = 0.0;  // about the origin
};
}  // namespace

struct RobotCollision::Geometry
{
  std::vector<CollisionGeometryPtr> shapes;  // padded FCL shapes, one per RobotShape
  std::vector<ConvexShape> convex;           // the same padded shapes, for the culling tests
  // Each shape's pose in its body frame (ArmKinematics::bodyFrames): linkInBodyFrame * offset,
  // rotation and translation apart (contiguous 3 x 3 products, see ShapeFrames::place).
  std::vector<Eigen::Matrix3d> in_body_rotation;
  std::vector<Eigen::Vector3d> in_body_translation;
  // Broad phase against the scene's boxes: per shape, (bounding radius + kGjkToleranceM)^2,
  // -1 for shapes fixed to the base (never tested against the scene).
  std::vector<double> box_reach2;
  // Per body (ArmKinematics::bodyFrames): a sphere around all its shapes' bounding spheres,
  // centre in the body frame. Self pairs are grouped by body pair; a body pair whose spheres
  // are apart skips all its shape pairs (the UR5's hand carries 5 shapes: 35 of its 51 self
  // pairs are hand pairs).
  std::vector<Eigen::Vector3d> body_centre;
  std::vector<double> body_radius;  // 0 for a body without shapes
  // Broad phase against the scene's boxes: per body, (body_radius + kGjkToleranceM)^2, -1 for
  // body 0 (fixed to the base, never tested against the scene) and bodies without shapes.
  std::vector<double> body_box_reach2;
  struct BodyPairPairs
  {
    int body_a = 0, body_b = 0;
    std::size_t begin = 0, end = 0;  // range of RobotCollision::self_pairs_
  };
  std::vector<BodyPairPairs> self_groups;
};

/// The shapes' world poses for one check: every centre at once (the bounding-sphere tests
/// need nothing more, and most pairs end there), a shape's rotation only when a finer test
/// asks for it (pose()): placing all 13 UR5 shapes fully was a fifth of a check (callgrind).
struct RobotCollision::ShapeFrames
{
  const std::vector<RobotShape>* shapes = nullptr;
  const Geometry* geometry = nullptr;
  // ArmKinematics::bodyFrames (dof + 1): the calling thread's scratch in shapeFrames(), valid
  // until its next call on that thread (one check at a time per thread).
  const Eigen::Isometry3d* bodies = nullptr;
  std::vector<Eigen::Isometry3d> poses;       // translation set; rotation where placed
  std::vector<Eigen::Vector3d> body_centres;  // world centres of Geometry::body_centre
  // poses[i]'s rotation is set when placed_check[i] == check: no clearing per check (a
  // std::vector<char>::assign was a memset call per check).
  std::vector<std::uint64_t> placed_check;
  std::uint64_t check = 0;
  std::vector<std::uint64_t> body_box_mask;  // box broad phase scratch: per body, boxes it may reach

  void reset(const std::vector<RobotShape>& all, const Geometry& g, const Eigen::Isometry3d* body_frames);
  Eigen::Vector3d centre(std::size_t i) const { return poses[i].translation(); }
  const Eigen::Isometry3d& pose(std::size_t i)
  {
    if (placed_check[i] != check)
      place(i);
    return poses[i];
  }

private:
  void place(std::size_t i);
};

struct RobotCollision::Scene
{
  struct Box
  {
    std::string name;
    CollisionGeometryPtr geometry;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    ConvexShape convex;
    Eigen::Vector3d aabb_half_m = Eigen::Vector3d::Zero();  // world axis-aligned half extents
    Eigen::Vector3d aabb_min = Eigen::Vector3d::Zero(), aabb_max = Eigen::Vector3d::Zero();  // world
  };
  /// World axis-aligned bounds of an OctoMap's leaves (grown by one voxel).
  struct Bounds
  {
    Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  };
  double resolution_m = 0.01;
  std::shared_ptr<const octomap::OcTree> obstacles;  // null when empty
  std::shared_ptr<const fcl::OcTreed> obstacles_fcl;
  Bounds obstacles_bounds;
  std::shared_ptr<const octomap::OcTree> target;
  std::shared_ptr<const fcl::OcTreed> target_fcl;
  Bounds target_bounds;
  std::vector<Box> boxes;
  AabbLanes box_lanes;  // the boxes' aabb_min / aabb_max, four at a time (sphereAabbMask)
};

namespace
{
Eigen::Isometry3d toEigen(const urdf::Pose& p)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() << p.position.x, p.position.y, p.position.z;
  t.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).normalized().toRotationMatrix();
  return t;
}

/// Pads a shape: its FCL geometry and the same shape for the culling tests.
std::pair<CollisionGeometryPtr, ConvexShape> makeGeometry(const RobotShape& s, double padding_m)
{
  ConvexShape convex;
  convex.type = s.type;
  switch (s.type)
  {
    case RobotShape::Type::Box:
    {
      const Eigen::Vector3d size = s.size_m + Eigen::Vector3d::Constant(2.0 * padding_m);
      convex.half = 0.5 * size;
      convex.bounding_radius = convex.half.norm();
      return { std::make_shared<fcl::Boxd>(size.x(), size.y(), size.z()), convex };
    }
    case RobotShape::Type::Cylinder:
    {
      const double r = s.size_m.x() + padding_m, l = s.size_m.z() + 2.0 * padding_m;
      convex.half << r, r, 0.5 * l;
      convex.bounding_radius = std::hypot(r, 0.5 * l);
      return { std::make_shared<fcl::Cylinderd>(r, l), convex };
    }
    case RobotShape::Type::Sphere:
    default:
      convex.type = RobotShape::Type::Sphere;
      convex.half.setConstant(s.size_m.x() + padding_m);
      convex.bounding_radius = s.size_m.x() + padding_m;
      return { std::make_shared<fcl::Sphered>(s.size_m.x() + padding_m), convex };
  }
}

// --- Conservative culling before FCL's narrow phase ------------------------------------------
// The tests below answer "provably apart" (the pair is skipped), "touching" (two boxes, for
// which the separating axis theorem is complete) or "unknown" (FCL decides). "Apart" comes
// from the separating axis theorem: two convex shapes whose projections on some axis do not
// overlap are disjoint, whichever axis it is. The candidate axes are the ones that separate
// most pairs in practice; a pair that none of them separates goes to FCL, so the culled check
// answers like FCL alone (test_arm_collision compares both on random and near-contact states).

/// Projections must be apart by more than this before a pair that FCL would hand to GJK/MPR
/// (cylinders, spheres) counts as apart: those report contact within their own tolerance
/// (1e-6), and a sub-micron gap is not worth an argument with them. Box pairs are decided
/// exactly, like FCL's own box-box test.
constexpr double kGjkToleranceM = 1e-6;

/// Half-width of a shape's projection on the unit axis n (world frame) about its centre.
double projectedHalfWidth(const ConvexShape& s, const Eigen::Isometry3d& pose, const Eigen::Vector3d& n)
{
  const auto r = pose.linear();
  switch (s.type)
  {
    case RobotShape::Type::Box:
      return s.half.x() * std::abs(n.dot(r.col(0))) + s.half.y() * std::abs(n.dot(r.col(1))) +
             s.half.z() * std::abs(n.dot(r.col(2)));
    case RobotShape::Type::Cylinder:
    {
      // Axis part h |cos| plus the disc's radius r |sin| (the disc's extent along n).
      const double c = n.dot(r.col(2));
      return s.half.z() * std::abs(c) + s.half.x() * std::sqrt(std::max(0.0, 1.0 - c * c));
    }
    case RobotShape::Type::Sphere:
    default:
      return s.half.x();
  }
}

/// Half-extents of a shape's world axis-aligned bounding box.
Eigen::Vector3d aabbHalfExtents(const ConvexShape& s, const Eigen::Isometry3d& pose)
{
  const auto r = pose.linear();
  switch (s.type)
  {
    case RobotShape::Type::Box:
      return r.cwiseAbs() * s.half;
    case RobotShape::Type::Cylinder:
    {
      const Eigen::Vector3d axis = r.col(2);
      return (s.half.z() * axis.cwiseAbs().array() +
              s.half.x() * (1.0 - axis.array().square()).max(0.0).sqrt())
          .matrix();
    }
    case RobotShape::Type::Sphere:
    default:
      return Eigen::Vector3d::Constant(s.half.x());
  }
}

/// Number of principal directions (face normals / axis) of a shape: columns of its rotation.
int principalDirections(const ConvexShape& s, int& first)
{
  switch (s.type)
  {
    case RobotShape::Type::Box:
      first = 0;
      return 3;
    case RobotShape::Type::Cylinder:
      first = 2;  // the cylinder's axis
      return 1;
    case RobotShape::Type::Sphere:
    default:
      first = 0;
      return 0;
  }
}

/// Core segment of a shape in world coordinates: the cylinder's axis, the box's longest
/// axis, the sphere's centre (the shape is its core swept by a small ball).
void coreSegment(const ConvexShape& s, const Eigen::Isometry3d& pose, Eigen::Vector3d& a, Eigen::Vector3d& b)
{
  Eigen::Index k = 2;
  if (s.type == RobotShape::Type::Box)
    s.half.maxCoeff(&k);
  const double half_length = s.type == RobotShape::Type::Sphere ? 0.0 : s.half[k];
  const Eigen::Vector3d offset = half_length * pose.linear().col(k);
  a = pose.translation() - offset;
  b = pose.translation() + offset;
}

/// Closest points c1 on [p1, q1] and c2 on [p2, q2] (Ericson, Real-Time Collision Detection,
/// 5.1.9).
void closestPointsOfSegments(const Eigen::Vector3d& p1, const Eigen::Vector3d& q1, const Eigen::Vector3d& p2,
                             const Eigen::Vector3d& q2, Eigen::Vector3d& c1, Eigen::Vector3d& c2)
{
  const Eigen::Vector3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  constexpr double kEps = 1e-12;
  if (a <= kEps && e > kEps)
    t = std::clamp(f / e, 0.0, 1.0);
  else if (a > kEps)
  {
    const double c = d1.dot(r);
    if (e <= kEps)
      s = std::clamp(-c / a, 0.0, 1.0);
    else
    {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > kEps ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0)
      {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      }
      else if (t > 1.0)
      {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  c1 = p1 + d1 * s;
  c2 = p2 + d2 * t;
}

/// What the separating axis tests can tell about a pair of shapes.
enum class PairVerdict
{
  Apart,     // a separating axis exists: no contact
  Touching,  // two boxes and none of their 15 axes separates: contact (SAT is complete for boxes)
  Unknown    // no candidate axis separates, and the candidates are not complete: ask FCL
};

/// Candidates, cheapest and most often separating first: the bounding spheres, the line
/// between the closest points of the core segments, the principal directions of both shapes,
/// then their cross products (edge-edge axes). For two boxes these are all 15 axes of the
/// separating axis theorem (a degenerate cross product belongs to parallel edges, whose
/// separation the face axes already cover), so "none separates" means contact.
PairVerdict classifyPair(const ConvexShape& a, const Eigen::Isometry3d& ta, const ConvexShape& b,
                         const Eigen::Isometry3d& tb)
{
  const Eigen::Vector3d d = tb.translation() - ta.translation();
  const double reach = a.bounding_radius + b.bounding_radius;
  if (d.squaredNorm() > reach * reach)
    return PairVerdict::Apart;
  const auto ra = ta.linear();
  const auto rb = tb.linear();
  const bool boxes = a.type == RobotShape::Type::Box && b.type == RobotShape::Type::Box;
  const double margin = boxes ? 0.0 : kGjkToleranceM;
  auto separates = [&](const Eigen::Vector3d& axis) {
    const double norm2 = axis.squaredNorm();
    if (norm2 < 1e-12)
      return false;  // degenerate (parallel edges, touching cores): no information
    const Eigen::Vector3d n = axis / std::sqrt(norm2);
    return std::abs(n.dot(d)) > projectedHalfWidth(a, ta, n) + projectedHalfWidth(b, tb, n) + margin;
  };
  Eigen::Vector3d a0, a1, b0, b1, ca, cb;
  coreSegment(a, ta, a0, a1);
  coreSegment(b, tb, b0, b1);
  closestPointsOfSegments(a0, a1, b0, b1, ca, cb);
  if (separates(cb - ca))
    return PairVerdict::Apart;
  int first_a = 0, first_b = 0;
  const int count_a = principalDirections(a, first_a), count_b = principalDirections(b, first_b);
  for (int i = first_a; i < first_a + count_a; ++i)
    if (separates(ra.col(i)))
      return PairVerdict::Apart;
  for (int j = first_b; j < first_b + count_b; ++j)
    if (separates(rb.col(j)))
      return PairVerdict::Apart;
  for (int i = first_a; i < first_a + count_a; ++i)
    for (int j = first_b; j < first_b + count_b; ++j)
      if (separates(ra.col(i).cross(rb.col(j))))
        return PairVerdict::Apart;
  return boxes ? PairVerdict::Touching : PairVerdict::Unknown;
}

/// Does one of a scene box's face normals separate a shape from it? The first axes to try for
/// a robot shape near a table, wall or shelf board (its closest-point axis, classifyPair's
/// first, rarely separates from a large flat box): the shoulder's cylinder beside the table
/// cost a whole classifyPair (~1000 instructions) in every UR5 check; a face test is ~40.
/// Same margin as classifyPair: exact for two boxes, FCL's tolerance otherwise.
bool boxFaceSeparates(const ConvexShape& shape, const Eigen::Isometry3d& shape_pose, const ConvexShape& box,
                      const Eigen::Isometry3d& box_pose)
{
  const Eigen::Vector3d d = shape_pose.translation() - box_pose.translation();
  const double margin = shape.type == RobotShape::Type::Box ? 0.0 : kGjkToleranceM;
  for (int k = 0; k < 3; ++k)
  {
    const Eigen::Vector3d n = box_pose.linear().col(k);
    if (std::abs(n.dot(d)) > box.half[k] + projectedHalfWidth(shape, shape_pose, n) + margin)
      return true;
  }
  return false;
}

/// Can a shape with world AABB (centre, half) reach the bounds of an OctoMap?
bool aabbMayTouchBounds(const Eigen::Vector3d& centre, const Eigen::Vector3d& half, const Eigen::Vector3d& min,
                        const Eigen::Vector3d& max)
{
  return ((centre + half).array() >= min.array()).all() && ((centre - half).array() <= max.array()).all();
}

bool insideShape(const RobotShape& s, const Eigen::Isometry3d& pose, const Eigen::Vector3d& p, double pad)
{
  const Eigen::Vector3d local = pose.inverse() * p;
  switch (s.type)
  {
    case RobotShape::Type::Box:
      return (local.cwiseAbs().array() <= (0.5 * s.size_m.array() + pad)).all();
    case RobotShape::Type::Cylinder:
      return local.head<2>().norm() <= s.size_m.x() + pad && std::abs(local.z()) <= 0.5 * s.size_m.z() + pad;
    case RobotShape::Type::Sphere:
    default:
      return local.norm() <= s.size_m.x() + pad;
  }
}

bool collide(const fcl::CollisionGeometryd* a, const Eigen::Isometry3d& ta, const fcl::CollisionGeometryd* b,
             const Eigen::Isometry3d& tb)
{
  fcl::CollisionRequestd request;  // one contact is enough: we only need a yes/no
  fcl::CollisionResultd result;
  return fcl::collide(a, ta, b, tb, request, result) > 0;
}

std::shared_ptr<const octomap::OcTree> insertPoints(const std::shared_ptr<const octomap::OcTree>& old,
                                                    double resolution_m,
                                                    const pcl::PointCloud<pcl::PointXYZ>& cloud, std::size_t& inserted)
{
  auto tree = old ? std::make_shared<octomap::OcTree>(*old) : std::make_shared<octomap::OcTree>(resolution_m);
  inserted = 0;
  for (const pcl::PointXYZ& p : cloud.points)
  {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      continue;
    // Points only mark voxels occupied; no ray casting, so unseen space stays unknown (and
    // is made an obstacle explicitly by the caller, e.g. the unseen-part cloud or boxes).
    tree->updateNode(octomap::point3d(p.x, p.y, p.z), true, true);
    ++inserted;
  }
  tree->updateInnerOccupancy();
  return tree;
}
}  // namespace

namespace
{
/// Bounds of every leaf (occupied or not: FCL applies its own occupancy threshold), grown by
/// one voxel so that rounding in FCL's octree boxes cannot fall outside them. An empty tree
/// gets inverted bounds, which no shape touches.
RobotCollision::Scene::Bounds leafBounds(const octomap::OcTree& tree)
{
  RobotCollision::Scene::Bounds bounds;
  bounds.min.setConstant(std::numeric_limits<double>::infinity());
  bounds.max.setConstant(-std::numeric_limits<double>::infinity());
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
  {
    const Eigen::Vector3d centre(it.getX(), it.getY(), it.getZ());
    const double half = 0.5 * it.getSize() + tree.getResolution();
    bounds.min = bounds.min.cwiseMin(centre - Eigen::Vector3d::Constant(half));
    bounds.max = bounds.max.cwiseMax(centre + Eigen::Vector3d::Constant(half));
  }
  return bounds;
}
}  // namespace

RobotCollision::RobotCollision(const ArmKinematics& kinematics, double link_padding_m,
                               std::vector<std::string> finger_links, double finger_padding_m)
  : kinematics_(kinematics)
  , link_padding_m_(std::max(0.0, link_padding_m))
  , finger_padding_m_(finger_padding_m < 0.0 ? link_padding_m_ : finger_padding_m)
{
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(kinematics_.urdfXml());
  if (!model)
    throw std::runtime_error("RobotCollision: the URDF does not parse");
  std::map<std::string, std::size_t> chain_index;
  for (std::size_t i = 0; i < kinematics_.linkNames().size(); ++i)
    chain_index[kinematics_.linkNames()[i]] = i;
  const std::set<std::string> fingers(finger_links.begin(), finger_links.end());

  std::vector<urdf::LinkSharedPtr> links;
  model->getLinks(links);
  for (const urdf::LinkSharedPtr& link : links)
  {
    if (link->collision_array.empty() && !link->collision)
      continue;
    // Walk up through fixed joints to the chain link that carries this link.
    Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
    urdf::LinkConstSharedPtr current = link;
    bool attached = true;
    while (chain_index.count(current->name) == 0)
    {
      const urdf::JointConstSharedPtr joint = current->parent_joint;
      if (!joint || joint->type != urdf::Joint::FIXED || !current->getParent())
      {
        attached = false;  // moves independently of the chain (or above its base): not ours
        break;
      }
      offset = toEigen(joint->parent_to_joint_origin_transform) * offset;
      current = current->getParent();
    }
    if (!attached)
      continue;
    std::vector<urdf::CollisionSharedPtr> collisions = link->collision_array;
    if (collisions.empty())
      collisions.push_back(link->collision);
    for (const urdf::CollisionSharedPtr& c : collisions)
    {
      if (!c || !c->geometry)
        continue;
      RobotShape shape;
      shape.link = link->name;
      shape.chain_link = chain_index[current->name];
      shape.body = kinematics_.movingJointsBefore(shape.chain_link);
      shape.offset = offset * toEigen(c->origin);
      shape.finger = fingers.count(link->name) > 0;
      switch (c->geometry->type)
      {
        case urdf::Geometry::BOX:
        {
          const auto* box = static_cast<const urdf::Box*>(c->geometry.get());
          shape.type = RobotShape::Type::Box;
          shape.size_m << box->dim.x, box->dim.y, box->dim.z;
          break;
        }
        case urdf::Geometry::CYLINDER:
        {
          const auto* cyl = static_cast<const urdf::Cylinder*>(c->geometry.get());
          shape.type = RobotShape::Type::Cylinder;
          shape.size_m << cyl->radius, cyl->radius, cyl->length;
          break;
        }
        case urdf::Geometry::SPHERE:
        {
          const auto* sph = static_cast<const urdf::Sphere*>(c->geometry.get());
          shape.type = RobotShape::Type::Sphere;
          shape.size_m.setConstant(sph->radius);
          break;
        }
        default:
          ++skipped_meshes_;
          continue;
      }
      shapes_.push_back(shape);
    }
  }
  auto geometry = std::make_shared<Geometry>();
  for (const RobotShape& s : shapes_)
  {
    const auto g = makeGeometry(s, s.finger ? finger_padding_m_ : link_padding_m_);
    geometry->shapes.push_back(g.first);
    geometry->convex.push_back(g.second);
    const Eigen::Isometry3d in_body = kinematics_.linkInBodyFrame(s.chain_link) * s.offset;
    geometry->in_body_rotation.push_back(in_body.linear());
    geometry->in_body_translation.push_back(in_body.translation());
    const double reach = g.second.bounding_radius + kGjkToleranceM;
    geometry->box_reach2.push_back(s.body == 0 ? -1.0 : reach * reach);
  }
  // Body spheres: centred on the box around the body's shape spheres, wide enough for all of
  // them (plus a nanometre against rounding: a body sphere must never cut off a shape sphere).
  {
    const std::size_t bodies = kinematics_.dof() + 1;
    std::vector<Eigen::Vector3d> low(bodies, Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()));
    std::vector<Eigen::Vector3d> high(bodies, Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity()));
    for (std::size_t i = 0; i < shapes_.size(); ++i)
    {
      const std::size_t b = static_cast<std::size_t>(shapes_[i].body);
      const Eigen::Vector3d r = Eigen::Vector3d::Constant(geometry->convex[i].bounding_radius);
      low[b] = low[b].cwiseMin(geometry->in_body_translation[i] - r);
      high[b] = high[b].cwiseMax(geometry->in_body_translation[i] + r);
    }
    geometry->body_centre.assign(bodies, Eigen::Vector3d::Zero());
    geometry->body_radius.assign(bodies, 0.0);
    for (std::size_t i = 0; i < shapes_.size(); ++i)
    {
      const std::size_t b = static_cast<std::size_t>(shapes_[i].body);
      geometry->body_centre[b] = 0.5 * (low[b] + high[b]);
    }
    for (std::size_t i = 0; i < shapes_.size(); ++i)
    {
      const std::size_t b = static_cast<std::size_t>(shapes_[i].body);
      geometry->body_radius[b] =
          std::max(geometry->body_radius[b], (geometry->in_body_translation[i] - geometry->body_centre[b]).norm() +
                                                 geometry->convex[i].bounding_radius + 1e-9);
    }
    geometry->body_box_reach2.assign(bodies, -1.0);
    for (std::size_t b = 1; b < bodies; ++b)  // body 0 is fixed to the base: never tested
      if (geometry->body_radius[b] > 0.0)
      {
        const double reach = geometry->body_radius[b] + kGjkToleranceM;
        geometry->body_box_reach2[b] = reach * reach;
      }
  }
  geometry_ = geometry;
  // Self-collision: bodies joined by one joint touch by design (the URDF's adjacent links);
  // every other pair of bodies is checked.
  for (std::size_t i = 0; i < shapes_.size(); ++i)
    for (std::size_t j = i + 1; j < shapes_.size(); ++j)
      if (std::abs(shapes_[i].body - shapes_[j].body) > 1)
        self_pairs_.emplace_back(i, j);
  // Like the MoveIt Setup Assistant's "default" rule, pairs already touching in the zero
  // configuration (with padding: e.g. the UR5 base and the lift motor, 1.5 cm apart) touch by
  // construction and are not checked.
  {
    std::vector<Eigen::Isometry3d> poses;
    shapePoses(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(kinematics_.dof())), poses);
    std::vector<std::pair<std::size_t, std::size_t>> checked;
    for (const auto& pair : self_pairs_)
    {
      if (collide(geometry_->shapes[pair.first].get(), poses[pair.first], geometry_->shapes[pair.second].get(),
                  poses[pair.second]))
        allowed_pairs_.push_back(shapes_[pair.first].link + " / " + shapes_[pair.second].link);
      else
        checked.push_back(pair);
    }
    self_pairs_ = checked;
  }
  // Grouped by body pair (stable: within a group the pairs keep their order), one range each.
  std::stable_sort(self_pairs_.begin(), self_pairs_.end(), [this](const auto& x, const auto& y) {
    const auto key = [this](const std::pair<std::size_t, std::size_t>& p) {
      const int a = shapes_[p.first].body, b = shapes_[p.second].body;
      return std::make_pair(std::min(a, b), std::max(a, b));
    };
    return key(x) < key(y);
  });
  for (std::size_t k = 0; k < self_pairs_.size(); ++k)
  {
    const int a = shapes_[self_pairs_[k].first].body, b = shapes_[self_pairs_[k].second].body;
    if (geometry->self_groups.empty() || geometry->self_groups.back().body_a != std::min(a, b) ||
        geometry->self_groups.back().body_b != std::max(a, b))
      geometry->self_groups.push_back({ std::min(a, b), std::max(a, b), k, k });
    geometry->self_groups.back().end = k + 1;
  }
  // Lever arms: joint origins at the zero pose (distances between consecutive joint origins
  // and from a joint to the shapes it carries directly are rigid), chained by the triangle
  // inequality.
  {
    const std::size_t dof = kinematics_.dof();
    std::vector<Eigen::Isometry3d> links;
    kinematics_.linkPoses(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dof)), links);
    // Origin of joint k = pose of the first chain link with k + 1 moving joints before it.
    std::vector<Eigen::Vector3d> origins(dof, Eigen::Vector3d::Zero());
    for (std::size_t l = links.size(); l-- > 0;)
    {
      const int moving = kinematics_.movingJointsBefore(l);
      if (moving >= 1)
        origins[static_cast<std::size_t>(moving - 1)] = links[l].translation();
    }
    std::vector<Eigen::Isometry3d> poses;
    shapePoses(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dof)), poses);
    lever_arms_m_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dof));
    for (std::size_t i = 0; i < shapes_.size(); ++i)
    {
      const int body = shapes_[i].body;
      if (body < 1)
        continue;
      double reach = (poses[i].translation() - origins[static_cast<std::size_t>(body - 1)]).norm() +
                     geometry_->convex[i].bounding_radius;
      for (int j = body - 1; j >= 0; --j)
      {
        lever_arms_m_[j] = std::max(lever_arms_m_[j], reach);
        if (j > 0)
          reach += (origins[static_cast<std::size_t>(j)] - origins[static_cast<std::size_t>(j - 1)]).norm();
      }
    }
  }
  auto scene = std::make_shared<Scene>();
  scene_ = scene;
}

bool RobotCollision::resetScene(double octomap_resolution_m)
{
  if (!(octomap_resolution_m > 0.0 && octomap_resolution_m <= 1.0))
    return false;
  auto scene = std::make_shared<Scene>();
  scene->resolution_m = octomap_resolution_m;
  scene_ = scene;
  return true;
}

std::size_t RobotCollision::addObstacleCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud,
                                             const Eigen::VectorXd& robot_state, double self_filter_padding_m)
{
  const pcl::PointCloud<pcl::PointXYZ> filtered = removeRobotPoints(cloud, robot_state, self_filter_padding_m);
  auto scene = std::make_shared<Scene>(*scene_);
  std::size_t inserted = 0;
  scene->obstacles = insertPoints(scene_->obstacles, scene->resolution_m, filtered, inserted);
  scene->obstacles_fcl = std::make_shared<fcl::OcTreed>(scene->obstacles);
  scene->obstacles_bounds = leafBounds(*scene->obstacles);
  scene_ = scene;
  return inserted;
}

std::size_t RobotCollision::setTargetCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  auto scene = std::make_shared<Scene>(*scene_);
  std::size_t inserted = 0;
  scene->target = insertPoints(nullptr, scene->resolution_m, cloud, inserted);
  scene->target_fcl = inserted > 0 ? std::make_shared<fcl::OcTreed>(scene->target) : nullptr;
  scene->target_bounds = leafBounds(*scene->target);
  if (inserted == 0)
    scene->target = nullptr;
  scene_ = scene;
  return inserted;
}

void RobotCollision::addBox(const std::string& name, const Eigen::Vector3d& size_m, const Eigen::Isometry3d& pose)
{
  auto scene = std::make_shared<Scene>(*scene_);
  Scene::Box box;
  box.name = name;
  box.geometry = std::make_shared<fcl::Boxd>(size_m.x(), size_m.y(), size_m.z());
  box.pose = pose;
  box.convex.type = RobotShape::Type::Box;
  box.convex.half = 0.5 * size_m.cwiseAbs();
  box.convex.bounding_radius = box.convex.half.norm();
  box.aabb_half_m = aabbHalfExtents(box.convex, pose);
  box.aabb_min = pose.translation() - box.aabb_half_m;
  box.aabb_max = pose.translation() + box.aabb_half_m;
  scene->boxes.push_back(box);
  std::vector<Eigen::Vector3d> lo, hi;
  for (const Scene::Box& b : scene->boxes)
  {
    lo.push_back(b.aabb_min);
    hi.push_back(b.aabb_max);
  }
  scene->box_lanes.assign(lo, hi);
  scene_ = scene;
}

std::size_t RobotCollision::obstacleVoxelCount() const
{
  return scene_->obstacles ? scene_->obstacles->getNumLeafNodes() : 0;
}
std::size_t RobotCollision::targetVoxelCount() const { return scene_->target ? scene_->target->getNumLeafNodes() : 0; }
double RobotCollision::octomapResolution() const { return scene_->resolution_m; }

std::vector<Eigen::Vector3d> RobotCollision::occupiedVoxelCentres(bool target) const
{
  std::vector<Eigen::Vector3d> centres;
  const std::shared_ptr<const octomap::OcTree>& tree = target ? scene_->target : scene_->obstacles;
  if (!tree)
    return centres;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it)
    if (tree->isNodeOccupied(*it))
      centres.emplace_back(it.getX(), it.getY(), it.getZ());
  return centres;
}

void RobotCollision::ShapeFrames::reset(const std::vector<RobotShape>& all, const Geometry& g,
                                        const Eigen::Isometry3d* body_frames)
{
  shapes = &all;
  geometry = &g;
  bodies = body_frames;
  const std::size_t n = all.size();
  if (poses.size() != n)
  {
    poses.resize(n);
    placed_check.assign(n, 0);
  }
  ++check;
  for (std::size_t i = 0; i < n; ++i)
  {
    const Eigen::Isometry3d& body = bodies[static_cast<std::size_t>(all[i].body)];
    Eigen::Vector3d translation = body.translation();
    translation.noalias() += body.linear() * g.in_body_translation[i];
    poses[i].translation() = translation;
  }
  body_centres.resize(g.body_centre.size());
  for (std::size_t b = 0; b < g.body_centre.size(); ++b)
  {
    Eigen::Vector3d centre = bodies[b].translation();
    centre.noalias() += bodies[b].linear() * g.body_centre[b];
    body_centres[b] = centre;
  }
}

void RobotCollision::ShapeFrames::place(std::size_t i)
{
  // body * in_body on contiguous 3 x 3 copies: Eigen inlines that product, not the one of an
  // Isometry3d's blocks.
  const Eigen::Isometry3d& body = bodies[static_cast<std::size_t>((*shapes)[i].body)];
  const Eigen::Matrix3d body_rotation = body.linear();
  Eigen::Matrix3d rotation;
  rotation.noalias() = body_rotation * geometry->in_body_rotation[i];
  poses[i].linear() = rotation;
  poses[i].makeAffine();
  placed_check[i] = check;
}

void RobotCollision::shapeFrames(const Eigen::VectorXd& q, ShapeFrames& frames) const
{
  // Per-thread scratch: the planners call this for every checked state, and a heap
  // allocation per call showed up in the profile. Still thread-safe (one buffer per thread).
  // Body frames, not link poses: one product per moving joint instead of two per segment
  // (FK and shape placement were half of a validity check on the LWR). Its data pointer goes
  // on, not the vector: GCC repeats a thread-local's lookup (__tls_get_addr) at every use in
  // a loop (15 calls per UR5 check, callgrind).
  thread_local std::vector<Eigen::Isometry3d> bodies;
  kinematics_.bodyFrames(q, bodies);
  frames.reset(shapes_, *geometry_, bodies.data());
}

void RobotCollision::shapePoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& poses) const
{
  ShapeFrames frames;
  shapeFrames(q, frames);
  for (std::size_t i = 0; i < shapes_.size(); ++i)
    frames.pose(i);
  poses.swap(frames.poses);
}

pcl::PointCloud<pcl::PointXYZ> RobotCollision::removeRobotPoints(const pcl::PointCloud<pcl::PointXYZ>& cloud,
                                                                 const Eigen::VectorXd& q, double padding_m) const
{
  pcl::PointCloud<pcl::PointXYZ> out;
  out.header = cloud.header;
  out.reserve(cloud.size());
  const bool have_state = q.size() == static_cast<Eigen::Index>(kinematics_.dof()) && q.allFinite();
  std::vector<Eigen::Isometry3d> poses;
  if (have_state)
    shapePoses(q, poses);
  for (const pcl::PointXYZ& p : cloud.points)
  {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      continue;
    const Eigen::Vector3d v(p.x, p.y, p.z);
    bool on_robot = false;
    for (std::size_t i = 0; have_state && i < shapes_.size() && !on_robot; ++i)
      on_robot = insideShape(shapes_[i], poses[i], v, padding_m + link_padding_m_);
    if (!on_robot)
      out.push_back(p);
  }
  out.width = static_cast<std::uint32_t>(out.size());
  out.height = 1;
  out.is_dense = true;
  return out;
}

bool RobotCollision::selfCollision(ShapeFrames& frames, bool cull, std::string* why) const
{
  for (const Geometry::BodyPairPairs& group : geometry_->self_groups)
  {
    if (cull)
    {
      // Both bodies' spheres first: most body pairs are far apart, and with them all their
      // shape pairs.
      const double reach = geometry_->body_radius[static_cast<std::size_t>(group.body_a)] +
                           geometry_->body_radius[static_cast<std::size_t>(group.body_b)];
      if ((frames.body_centres[static_cast<std::size_t>(group.body_b)] -
           frames.body_centres[static_cast<std::size_t>(group.body_a)])
              .squaredNorm() > reach * reach)
        continue;
    }
    for (std::size_t k = group.begin; k < group.end; ++k)
    {
      const std::size_t i = self_pairs_[k].first, j = self_pairs_[k].second;
      if (cull)
      {
        // classifyPair's first test, here: most pairs end at it, and the call costs as much.
        const double reach = geometry_->convex[i].bounding_radius + geometry_->convex[j].bounding_radius;
        if ((frames.centre(j) - frames.centre(i)).squaredNorm() > reach * reach)
          continue;
      }
      const Eigen::Isometry3d& pose_i = frames.pose(i);
      const Eigen::Isometry3d& pose_j = frames.pose(j);
      const PairVerdict verdict =
          cull ? classifyPair(geometry_->convex[i], pose_i, geometry_->convex[j], pose_j) : PairVerdict::Unknown;
      if (verdict == PairVerdict::Apart)
        continue;
      if (verdict == PairVerdict::Touching ||
          collide(geometry_->shapes[i].get(), pose_i, geometry_->shapes[j].get(), pose_j))
      {
        if (why)
          *why = "self: " + shapes_[i].link + " / " + shapes_[j].link;
        return true;
      }
    }
  }
  return false;
}

bool RobotCollision::inSelfCollision(const Eigen::VectorXd& q, std::string* why) const
{
  if (q.size() != static_cast<Eigen::Index>(kinematics_.dof()) || !q.allFinite())
  {
    if (why)
      *why = "invalid joint vector";
    return true;
  }
  thread_local ShapeFrames frames;
  shapeFrames(q, frames);
  return selfCollision(frames, true, why);
}

bool RobotCollision::inCollision(const Eigen::VectorXd& q, const CollisionCheckOptions& options,
                                 std::string* why) const
{
  if (q.size() != static_cast<Eigen::Index>(kinematics_.dof()) || !q.allFinite())
  {
    if (why)
      *why = "invalid joint vector";
    return true;
  }
  thread_local ShapeFrames frames;  // per-thread scratch, see shapeFrames()
  shapeFrames(q, frames);
  return inCollisionAt(frames, options, why);
}

std::size_t RobotCollision::firstInCollision(const Eigen::VectorXd* const* qs, std::size_t count,
                                             const CollisionCheckOptions& options) const
{
  constexpr std::size_t kBatch = ArmKinematics::kBodyFrameBatch;
  const std::size_t n = kinematics_.dof();
  thread_local std::vector<Eigen::Isometry3d> bodies;  // per-thread scratch, see shapeFrames()
  thread_local ShapeFrames frames;
  bodies.resize(kBatch * (n + 1));
  Eigen::Isometry3d* body_data = bodies.data();
  ShapeFrames& scratch = frames;
  const double* joints[kBatch];
  for (std::size_t first = 0; first < count; first += kBatch)
  {
    const std::size_t group = std::min(kBatch, count - first);
    // A vector of the wrong size or with NaNs is a collision (inCollision): the group's
    // kinematics stop before it.
    std::size_t usable = 0;
    while (usable < group && qs[first + usable]->size() == static_cast<Eigen::Index>(n) &&
           qs[first + usable]->allFinite())
    {
      joints[usable] = qs[first + usable]->data();
      ++usable;
    }
    kinematics_.bodyFramesBatch(joints, usable, body_data);
    for (std::size_t k = 0; k < usable; ++k)
    {
      scratch.reset(shapes_, *geometry_, body_data + k * (n + 1));
      if (inCollisionAt(scratch, options, nullptr))
        return first + k;
    }
    if (usable < group)
      return first + usable;
  }
  return count;
}

bool RobotCollision::inCollisionAt(ShapeFrames& frames, const CollisionCheckOptions& options, std::string* why) const
{
  // The shape frames arrive as a parameter, see shapeFrames().
  const Scene& scene = *scene_;
  const bool cull = options.conservative_culling;
  // Environment first: with a table most invalid states are caught by one cheap box test.
  const std::size_t n = shapes_.size();
  auto boxContact = [&](std::size_t i, const Scene::Box& box, PairVerdict verdict) {
    if (verdict == PairVerdict::Touching ||
        collide(geometry_->shapes[i].get(), frames.pose(i), box.geometry.get(), box.pose))
    {
      if (why)
        *why = "box " + box.name + " / " + shapes_[i].link;
      return true;
    }
    return false;
  };
  if (!cull)
  {
    for (std::size_t i = 0; i < n; ++i)
      for (const Scene::Box& box : scene.boxes)
        if (shapes_[i].body != 0 && boxContact(i, box, PairVerdict::Unknown))
          return true;  // shapes fixed to the base skipped: the mount may touch the table, and it never moves
  }
  else
  {
    // Broad phase, two levels: each moving body's sphere against each box's world AABB, then
    // the shape spheres of the bodies that reach a box (exact sphere-box distances, padded by
    // FCL's tolerance). Every shape against every box was a third of a UR5 check in the narrow
    // passage (13 shapes x 5 boxes); 6 bodies x 5 boxes, then a few shapes, is a fraction.
    // Then, shape by shape as before, the separating axes and FCL for the boxes a shape's
    // sphere reaches.
    const std::size_t boxes = scene.boxes.size();
    const std::size_t bodies = frames.body_centres.size();
    frames.body_box_mask.resize(bodies);
    for (std::size_t first = 0; first < boxes; first += 64)
    {
      const std::size_t last = std::min(boxes, first + 64);
      // Every body against up to 64 boxes in one call (body 0, fixed to the base, and bodies
      // without shapes have no sphere: mask 0).
      sphereAabbMasks(scene.box_lanes, first, last - first, frames.body_centres.data(),
                      geometry_->body_box_reach2.data(), bodies, frames.body_box_mask.data());
      for (std::size_t i = 0; i < n; ++i)
      {
        if (shapes_[i].body == 0)
          continue;
        for (std::uint64_t m = frames.body_box_mask[static_cast<std::size_t>(shapes_[i].body)]; m != 0; m &= m - 1)
        {
          const Scene::Box& box = scene.boxes[first + static_cast<std::size_t>(__builtin_ctzll(m))];
          if (!sphereMayTouchAabb(frames.centre(i), geometry_->box_reach2[i], box.aabb_min, box.aabb_max))
            continue;
          if (boxFaceSeparates(geometry_->convex[i], frames.pose(i), box.convex, box.pose))
            continue;
          const PairVerdict verdict = classifyPair(geometry_->convex[i], frames.pose(i), box.convex, box.pose);
          if (verdict != PairVerdict::Apart && boxContact(i, box, verdict))
            return true;
        }
      }
    }
  }
  if (selfCollision(frames, cull, why))
    return true;
  const bool check_target = scene.target_fcl && !options.ignore_target;
  if (!scene.obstacles_fcl && !check_target)
    return false;
  for (std::size_t i = 0; i < shapes_.size(); ++i)
  {
    if (shapes_[i].body == 0)
      continue;
    const fcl::CollisionGeometryd* shape = geometry_->shapes[i].get();
    // The shape's world AABB against the bounds of the OctoMap's leaves.
    const Eigen::Isometry3d& pose = frames.pose(i);
    const Eigen::Vector3d half = aabbHalfExtents(geometry_->convex[i], pose);
    const Eigen::Vector3d centre = pose.translation();
    if (scene.obstacles_fcl &&
        (!cull || aabbMayTouchBounds(centre, half, scene.obstacles_bounds.min, scene.obstacles_bounds.max)) &&
        collide(shape, pose, scene.obstacles_fcl.get(), Eigen::Isometry3d::Identity()))
    {
      if (why)
        *why = "octomap / " + shapes_[i].link;
      return true;
    }
    if (check_target && !(options.allow_finger_target_contact && shapes_[i].finger) &&
        (!cull || aabbMayTouchBounds(centre, half, scene.target_bounds.min, scene.target_bounds.max)) &&
        collide(shape, pose, scene.target_fcl.get(), Eigen::Isometry3d::Identity()))
    {
      if (why)
        *why = "target / " + shapes_[i].link;
      return true;
    }
  }
  return false;
}

}  // namespace fast_grasp
