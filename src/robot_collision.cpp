#include "fast_grasp/robot_collision.h"

#include <fcl/fcl.h>
#include <octomap/OcTree.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

namespace fast_grasp
{
using CollisionGeometryPtr = std::shared_ptr<fcl::CollisionGeometryd>;

struct RobotCollision::Geometry
{
  std::vector<CollisionGeometryPtr> shapes;  // padded FCL shapes, one per RobotShape
  std::vector<double> bounding_radius;       // of each padded shape about its origin
  // Capsule enclosing each padded shape (segment in the shape frame + radius): a cheap,
  // conservative pre-test that spares most of FCL's GJK calls.
  std::vector<Eigen::Vector3d> capsule_a, capsule_b;
  std::vector<double> capsule_radius;
};

struct RobotCollision::Scene
{
  struct Box
  {
    std::string name;
    CollisionGeometryPtr geometry;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    double bounding_radius = 0.0;
    Eigen::Vector3d half_size = Eigen::Vector3d::Zero();
  };
  double resolution_m = 0.01;
  std::shared_ptr<const octomap::OcTree> obstacles;  // null when empty
  std::shared_ptr<const fcl::OcTreed> obstacles_fcl;
  std::shared_ptr<const octomap::OcTree> target;
  std::shared_ptr<const fcl::OcTreed> target_fcl;
  std::vector<Box> boxes;
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

/// Pads a shape and returns the FCL geometry plus its bounding radius about its origin.
std::pair<CollisionGeometryPtr, double> makeGeometry(const RobotShape& s, double padding_m)
{
  switch (s.type)
  {
    case RobotShape::Type::Box:
    {
      const Eigen::Vector3d size = s.size_m + Eigen::Vector3d::Constant(2.0 * padding_m);
      return { std::make_shared<fcl::Boxd>(size.x(), size.y(), size.z()), 0.5 * size.norm() };
    }
    case RobotShape::Type::Cylinder:
    {
      const double r = s.size_m.x() + padding_m, l = s.size_m.z() + 2.0 * padding_m;
      return { std::make_shared<fcl::Cylinderd>(r, l), std::hypot(r, 0.5 * l) };
    }
    case RobotShape::Type::Sphere:
    default:
      return { std::make_shared<fcl::Sphered>(s.size_m.x() + padding_m), s.size_m.x() + padding_m };
  }
}

/// Enclosing capsule of a padded shape, in the shape frame.
void enclosingCapsule(const RobotShape& s, double padding_m, Eigen::Vector3d& a, Eigen::Vector3d& b, double& radius)
{
  a.setZero();
  b.setZero();
  switch (s.type)
  {
    case RobotShape::Type::Box:
    {
      const Eigen::Vector3d half = 0.5 * s.size_m + Eigen::Vector3d::Constant(padding_m);
      Eigen::Index k = 0;
      half.maxCoeff(&k);
      a[k] = -half[k];
      b[k] = half[k];
      radius = std::hypot(half[(k + 1) % 3], half[(k + 2) % 3]);
      break;
    }
    case RobotShape::Type::Cylinder:
      a.z() = -(0.5 * s.size_m.z() + padding_m);
      b.z() = -a.z();
      radius = s.size_m.x() + padding_m;
      break;
    case RobotShape::Type::Sphere:
    default:
      radius = s.size_m.x() + padding_m;
  }
}

/// Squared distance between segments [p1, q1] and [p2, q2] (Ericson, Real-Time Collision
/// Detection, 5.1.9).
double segmentDistanceSquared(const Eigen::Vector3d& p1, const Eigen::Vector3d& q1, const Eigen::Vector3d& p2,
                              const Eigen::Vector3d& q2)
{
  const Eigen::Vector3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  constexpr double kEps = 1e-12;
  if (a <= kEps && e <= kEps)
    return r.squaredNorm();
  if (a <= kEps)
    t = std::clamp(f / e, 0.0, 1.0);
  else
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
  return ((p1 + d1 * s) - (p2 + d2 * t)).squaredNorm();
}

/// Does segment [a, b] meet the axis-aligned box |x| <= half (slab test)?
bool segmentHitsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& half)
{
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector3d d = b - a;
  for (int k = 0; k < 3; ++k)
  {
    if (std::abs(d[k]) < 1e-12)
    {
      if (std::abs(a[k]) > half[k])
        return false;
      continue;
    }
    double ta = (-half[k] - a[k]) / d[k], tb = (half[k] - a[k]) / d[k];
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1)
      return false;
  }
  return true;
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

RobotCollision::RobotCollision(const ArmKinematics& kinematics, double link_padding_m,
                               std::vector<std::string> finger_links)
  : kinematics_(kinematics), link_padding_m_(std::max(0.0, link_padding_m))
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
    const auto g = makeGeometry(s, link_padding_m_);
    geometry->shapes.push_back(g.first);
    geometry->bounding_radius.push_back(g.second);
    Eigen::Vector3d a, b;
    double radius = 0.0;
    enclosingCapsule(s, link_padding_m_, a, b, radius);
    geometry->capsule_a.push_back(a);
    geometry->capsule_b.push_back(b);
    geometry->capsule_radius.push_back(radius);
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
                     geometry_->bounding_radius[i];
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
  scene_ = scene;
  return inserted;
}

std::size_t RobotCollision::setTargetCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  auto scene = std::make_shared<Scene>(*scene_);
  std::size_t inserted = 0;
  scene->target = insertPoints(nullptr, scene->resolution_m, cloud, inserted);
  scene->target_fcl = inserted > 0 ? std::make_shared<fcl::OcTreed>(scene->target) : nullptr;
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
  box.bounding_radius = 0.5 * size_m.norm();
  box.half_size = 0.5 * size_m;
  scene->boxes.push_back(box);
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

void RobotCollision::shapePoses(const Eigen::VectorXd& q, std::vector<Eigen::Isometry3d>& poses) const
{
  std::vector<Eigen::Isometry3d> links;
  kinematics_.linkPoses(q, links);
  poses.resize(shapes_.size());
  for (std::size_t i = 0; i < shapes_.size(); ++i)
    poses[i] = links[shapes_[i].chain_link] * shapes_[i].offset;
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

namespace
{
/// Cheap reject before FCL: can a sphere (centre, radius) reach an oriented box?
bool sphereMayTouchBox(const Eigen::Vector3d& centre, double radius, const Eigen::Isometry3d& box_pose,
                       const Eigen::Vector3d& half_size)
{
  const Eigen::Vector3d local = box_pose.linear().transpose() * (centre - box_pose.translation());
  const Eigen::Vector3d outside = (local.cwiseAbs() - half_size).cwiseMax(0.0);
  return outside.squaredNorm() <= radius * radius;
}
}  // namespace

bool RobotCollision::selfCollision(const std::vector<Eigen::Isometry3d>& poses, std::string* why) const
{
  for (const auto& pair : self_pairs_)
  {
    const std::size_t i = pair.first, j = pair.second;
    // Bounding-sphere reject first: most pairs are far apart.
    const double reach = geometry_->bounding_radius[i] + geometry_->bounding_radius[j];
    if ((poses[i].translation() - poses[j].translation()).squaredNorm() > reach * reach)
      continue;
    const double capsules = geometry_->capsule_radius[i] + geometry_->capsule_radius[j];
    if (segmentDistanceSquared(poses[i] * geometry_->capsule_a[i], poses[i] * geometry_->capsule_b[i],
                               poses[j] * geometry_->capsule_a[j], poses[j] * geometry_->capsule_b[j]) >
        capsules * capsules)
      continue;
    if (collide(geometry_->shapes[i].get(), poses[i], geometry_->shapes[j].get(), poses[j]))
    {
      if (why)
        *why = "self: " + shapes_[i].link + " / " + shapes_[j].link;
      return true;
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
  std::vector<Eigen::Isometry3d> poses;
  shapePoses(q, poses);
  return selfCollision(poses, why);
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
  std::vector<Eigen::Isometry3d> poses;
  shapePoses(q, poses);
  const Scene& scene = *scene_;
  // Environment first: with a table most invalid states are caught by one cheap box test.
  for (std::size_t i = 0; i < shapes_.size(); ++i)
  {
    if (shapes_[i].body == 0)
      continue;  // fixed to the base: the mount may touch the table, and it never moves
    const fcl::CollisionGeometryd* shape = geometry_->shapes[i].get();
    const double radius = geometry_->bounding_radius[i];
    for (const Scene::Box& box : scene.boxes)
    {
      if (!sphereMayTouchBox(poses[i].translation(), radius, box.pose, box.half_size))
        continue;
      // The capsule meets the box only if its segment meets the box grown by its radius.
      const Eigen::Isometry3d to_box = box.pose.inverse() * poses[i];
      if (!segmentHitsBox(to_box * geometry_->capsule_a[i], to_box * geometry_->capsule_b[i],
                          box.half_size + Eigen::Vector3d::Constant(geometry_->capsule_radius[i])))
        continue;
      if (collide(shape, poses[i], box.geometry.get(), box.pose))
      {
        if (why)
          *why = "box " + box.name + " / " + shapes_[i].link;
        return true;
      }
    }
  }
  if (selfCollision(poses, why))
    return true;
  for (std::size_t i = 0; i < shapes_.size(); ++i)
  {
    if (shapes_[i].body == 0)
      continue;
    const fcl::CollisionGeometryd* shape = geometry_->shapes[i].get();
    if (scene.obstacles_fcl && collide(shape, poses[i], scene.obstacles_fcl.get(), Eigen::Isometry3d::Identity()))
    {
      if (why)
        *why = "octomap / " + shapes_[i].link;
      return true;
    }
    if (scene.target_fcl && !options.ignore_target && !(options.allow_finger_target_contact && shapes_[i].finger) &&
        collide(shape, poses[i], scene.target_fcl.get(), Eigen::Isometry3d::Identity()))
    {
      if (why)
        *why = "target / " + shapes_[i].link;
      return true;
    }
  }
  return false;
}

}  // namespace fast_grasp
