#include "synthetic_views.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace fast_grasp
{
namespace synthetic
{
namespace
{
constexpr double kNoHit = std::numeric_limits<double>::infinity();
constexpr double kEpsilon = 1e-12;

// Ray-box by the slab method in the box frame; the entry face gives the normal.
bool intersectBox(const Eigen::Vector3d& half, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& t,
                  Eigen::Vector3d& normal)
{
  double t_near = -kNoHit;
  double t_far = kNoHit;
  int near_axis = -1;
  for (int a = 0; a < 3; ++a)
  {
    if (std::abs(d[a]) < kEpsilon)
    {
      if (std::abs(o[a]) > half[a])
        return false;
      continue;
    }
    double t1 = (-half[a] - o[a]) / d[a];
    double t2 = (half[a] - o[a]) / d[a];
    if (t1 > t2)
      std::swap(t1, t2);
    if (t1 > t_near)
    {
      t_near = t1;
      near_axis = a;
    }
    t_far = std::min(t_far, t2);
  }
  if (near_axis < 0 || t_near > t_far || t_near <= 0.0)
    return false;  // miss, or the ray starts inside the box
  t = t_near;
  normal = Eigen::Vector3d::Zero();
  normal[near_axis] = d[near_axis] > 0.0 ? -1.0 : 1.0;
  return true;
}

// Ray-finite-cylinder (axis Z, centred) in the cylinder frame: lateral surface and caps.
bool intersectCylinder(double radius, double half_height, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       double& t, Eigen::Vector3d& normal)
{
  double best = kNoHit;
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > kEpsilon)
  {
    const double b = 2.0 * (o.x() * d.x() + o.y() * d.y());
    const double c = o.x() * o.x() + o.y() * o.y() - radius * radius;
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0)
    {
      const double root = std::sqrt(disc);
      for (double candidate : { (-b - root) / (2.0 * a), (-b + root) / (2.0 * a) })
      {
        const double z = o.z() + candidate * d.z();
        if (candidate > 0.0 && std::abs(z) <= half_height && candidate < best)
        {
          best = candidate;
          const Eigen::Vector3d p = o + candidate * d;
          normal = Eigen::Vector3d(p.x(), p.y(), 0.0).normalized();
        }
      }
    }
  }
  if (std::abs(d.z()) > kEpsilon)
  {
    for (double cap : { -half_height, half_height })
    {
      const double candidate = (cap - o.z()) / d.z();
      const Eigen::Vector3d p = o + candidate * d;
      if (candidate > 0.0 && p.x() * p.x() + p.y() * p.y() <= radius * radius && candidate < best)
      {
        best = candidate;
        normal = Eigen::Vector3d(0.0, 0.0, cap > 0.0 ? 1.0 : -1.0);
      }
    }
  }
  if (best == kNoHit)
    return false;
  t = best;
  return true;
}

bool intersectSphere(double radius, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& t,
                     Eigen::Vector3d& normal)
{
  const double b = o.dot(d);
  const double c = o.squaredNorm() - radius * radius;
  const double disc = b * b - c;  // d is unit
  if (disc < 0.0)
    return false;
  const double root = std::sqrt(disc);
  const double candidate = -b - root;
  if (candidate <= 0.0)
    return false;  // behind the camera or the camera is inside
  t = candidate;
  normal = (o + candidate * d).normalized();
  return true;
}

double boundingRadius(const Shape& shape)
{
  switch (shape.kind)
  {
    case Shape::Kind::Box:
      return 0.5 * shape.size_m.norm();
    case Shape::Kind::Cylinder:
      return std::hypot(shape.size_m.x(), 0.5 * shape.size_m.z());
    case Shape::Kind::Sphere:
      return shape.size_m.x();
  }
  return 0.0;
}
}  // namespace

Shape makeBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& edge_lengths_m, const Eigen::Matrix3d& rotation)
{
  Shape shape;
  shape.kind = Shape::Kind::Box;
  shape.pose.linear() = rotation;
  shape.pose.translation() = centre;
  shape.size_m = edge_lengths_m;
  return shape;
}

Shape makeCylinder(const Eigen::Vector3d& centre, const Eigen::Vector3d& axis, double radius_m, double height_m)
{
  Shape shape;
  shape.kind = Shape::Kind::Cylinder;
  shape.pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis.normalized()).toRotationMatrix();
  shape.pose.translation() = centre;
  shape.size_m = Eigen::Vector3d(radius_m, radius_m, height_m);
  return shape;
}

Shape makeSphere(const Eigen::Vector3d& centre, double radius_m)
{
  Shape shape;
  shape.kind = Shape::Kind::Sphere;
  shape.pose.translation() = centre;
  shape.size_m = Eigen::Vector3d::Constant(radius_m);
  return shape;
}

bool intersectRay(const Shape& shape, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& t,
                  Eigen::Vector3d& normal)
{
  const Eigen::Isometry3d to_local = shape.pose.inverse();
  const Eigen::Vector3d o = to_local * origin;
  const Eigen::Vector3d d = (to_local.linear() * direction).normalized();
  Eigen::Vector3d local_normal;
  bool hit = false;
  switch (shape.kind)
  {
    case Shape::Kind::Box:
      hit = intersectBox(0.5 * shape.size_m, o, d, t, local_normal);
      break;
    case Shape::Kind::Cylinder:
      hit = intersectCylinder(shape.size_m.x(), 0.5 * shape.size_m.z(), o, d, t, local_normal);
      break;
    case Shape::Kind::Sphere:
      hit = intersectSphere(shape.size_m.x(), o, d, t, local_normal);
      break;
  }
  if (hit)
    normal = shape.pose.linear() * local_normal;
  return hit;
}

CloudNormal::Ptr renderView(const std::vector<Shape>& shapes, const ViewParams& view)
{
  CloudNormal::Ptr cloud(new CloudNormal);
  if (shapes.empty() || !(view.spacing_m > 0.0))
    return cloud;

  // Look at the centre of the shapes' bounding spheres; cover their union.
  Eigen::Vector3d low = Eigen::Vector3d::Constant(kNoHit);
  Eigen::Vector3d high = Eigen::Vector3d::Constant(-kNoHit);
  for (const Shape& shape : shapes)
  {
    const double r = boundingRadius(shape);
    low = low.cwiseMin(shape.pose.translation() - Eigen::Vector3d::Constant(r));
    high = high.cwiseMax(shape.pose.translation() + Eigen::Vector3d::Constant(r));
  }
  const Eigen::Vector3d look_at = 0.5 * (low + high);
  double extent = 0.0;
  for (const Shape& shape : shapes)
    extent = std::max(extent, (shape.pose.translation() - look_at).norm() + boundingRadius(shape));

  const Eigen::Vector3d forward = (look_at - view.viewpoint).normalized();
  const Eigen::Vector3d u = forward.unitOrthogonal();
  const Eigen::Vector3d v = forward.cross(u);
  const int half_cells = static_cast<int>(std::ceil(extent / view.spacing_m));

  std::mt19937 rng(view.noise_seed);
  std::normal_distribution<double> noise(0.0, view.noise_stddev_m > 0.0 ? view.noise_stddev_m : 1.0);

  for (int i = -half_cells; i <= half_cells; ++i)
    for (int j = -half_cells; j <= half_cells; ++j)
    {
      const Eigen::Vector3d target = look_at + view.spacing_m * (i * u + j * v);
      const Eigen::Vector3d direction = (target - view.viewpoint).normalized();
      double best_t = kNoHit;
      Eigen::Vector3d best_normal = Eigen::Vector3d::Zero();
      for (const Shape& shape : shapes)
      {
        double t = 0.0;
        Eigen::Vector3d normal;
        if (intersectRay(shape, view.viewpoint, direction, t, normal) && t < best_t)
        {
          best_t = t;
          best_normal = normal;
        }
      }
      if (best_t == kNoHit)
        continue;
      if (view.max_incidence_rad > 0.0 && std::abs(best_normal.dot(direction)) < std::cos(view.max_incidence_rad))
        continue;  // a surface this oblique to the ray returns nothing
      if (view.noise_stddev_m > 0.0)
        best_t += noise(rng);
      const Eigen::Vector3d p = view.viewpoint + best_t * direction;
      // The nearest hit always faces the camera for closed solids; flip only as a guard.
      if (best_normal.dot(view.viewpoint - p) < 0.0)
        best_normal = -best_normal;
      PointNormal point;
      point.x = static_cast<float>(p.x());
      point.y = static_cast<float>(p.y());
      point.z = static_cast<float>(p.z());
      point.normal_x = static_cast<float>(best_normal.x());
      point.normal_y = static_cast<float>(best_normal.y());
      point.normal_z = static_cast<float>(best_normal.z());
      point.curvature = 0.0f;
      cloud->push_back(point);
    }
  cloud->is_dense = true;
  return cloud;
}

CloudNormal::Ptr renderView(const Shape& shape, const ViewParams& view)
{
  return renderView(std::vector<Shape>{ shape }, view);
}

ObjectView makeObjectView(const CloudNormal::ConstPtr& cloud, const Eigen::Vector3d& viewpoint)
{
  ObjectView object_view;
  object_view.cloud = cloud;
  object_view.sensor_origins = { viewpoint.cast<float>() };
  return object_view;
}

GripperModel robotiqLikeGripper()
{
  GripperModel gripper;
  gripper.name = "robotiq_2f85";
  gripper.max_opening_m = 0.085;
  gripper.min_opening_m = 0.002;
  gripper.finger_width_m = 0.022;
  return gripper;
}

CloudXYZ toXyz(const CloudNormal& cloud)
{
  CloudXYZ xyz;
  for (const auto& p : cloud.points)
    xyz.push_back(PointXYZ(p.x, p.y, p.z));
  return xyz;
}

}  // namespace synthetic
}  // namespace fast_grasp
