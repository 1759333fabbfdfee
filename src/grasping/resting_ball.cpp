#include "fast_grasp/grasping/resting_ball.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

namespace fast_grasp
{
namespace
{
/// At most this many points enter the scan (every k-th): a ball's cap is smooth, and the scan
/// costs grid cells x points (~0.3 ms at 400).
constexpr std::size_t kMaxFitPoints = 400;
}  // namespace

std::string RestingBallParams::validate() const
{
  std::ostringstream why;
  if (!(max_median_residual_frac > 0.0 && max_median_residual_frac <= 1.0))
    why << "resting_ball max_median_residual_frac must be in (0, 1]; ";
  if (!(max_median_normal_angle_rad > 0.0 && max_median_normal_angle_rad <= M_PI))
    why << "resting_ball max_median_normal_angle_rad must be in (0, pi]; ";
  if (min_points < 3)
    why << "resting_ball min_points must be >= 3; ";
  if (!(min_fingertip_depth_m >= 0.0 && min_fingertip_depth_m <= 0.2))
    why << "resting_ball min_fingertip_depth_m must be in [0, 0.2] m; ";
  if (!(max_length_to_height >= 1.25 && max_length_to_height <= 10.0))
    why << "resting_ball max_length_to_height must be in [1.25, 10]; ";
  if (!(flat_max_height_to_breadth >= 0.0 && flat_max_height_to_breadth < 1.0))
    why << "resting_ball flat_max_height_to_breadth must be in [0, 1) (a ball is as high as it is broad); ";
  if (!(flat_min_fingertip_past_centre_frac >= 0.0 && flat_min_fingertip_past_centre_frac <= 1.0))
    why << "resting_ball flat_min_fingertip_past_centre_frac must be in [0, 1]; ";
  return why.str();
}

RestingBall fitRestingBall(const ObjectView& view, const ObjectExtent& extent, const RestingBallParams& params)
{
  RestingBall out;
  const auto refuse = [&out](const std::string& why) {
    out.why = why;
    return out;
  };
  if (!params.enabled)
    return refuse("off");
  if (!view.has_table_plane || !view.cloud)
    return refuse("no table plane");
  std::vector<Eigen::Vector3f> points, normals;
  for (const auto& p : view.cloud->points)
  {
    const Eigen::Vector3f n = p.getNormalVector3fMap();
    if (p.getVector3fMap().allFinite() && n.allFinite() && n.norm() > 0.5f)
    {
      points.push_back(p.getVector3fMap());
      normals.push_back(n.normalized());
    }
  }
  if (points.size() < params.min_points)
    return refuse("too few points");
  const float radius = 0.5f * extent.height_m;
  // A ball's footprint is as wide as it is high both ways (a camera above sees at least its near
  // half): a bar, a lying bottle or a flat box is not one. Up to max_length_to_height a longer
  // footprint is an ellipsoid's, fitted as a ball after scaling the footprint's axes to the height.
  if (extent.length_m > static_cast<float>(params.max_length_to_height) * extent.height_m ||
      extent.breadth_m < 0.5f * extent.height_m)
    return refuse("footprint not as wide as it is high");
  const bool ellipsoid = extent.length_m > 1.25f * extent.height_m;
  const Eigen::Vector3f& e1 = extent.major_axis;  // (named, not structured bindings: the lambdas below use them)
  const Eigen::Vector3f e2 = extent.up.cross(e1).normalized();
  const float half_length = ellipsoid ? std::max(radius, 0.5f * extent.length_m) : radius;
  const float half_breadth = ellipsoid ? std::max(0.5f * radius, 0.5f * extent.breadth_m) : radius;
  const float scale1 = radius / half_length, scale2 = radius / half_breadth;
  // Into the space where the body is a ball of `radius` (points) and back (normals: inverse transpose).
  const auto toBall = [&](const Eigen::Vector3f& p) -> Eigen::Vector3f {
    return scale1 * e1.dot(p) * e1 + scale2 * e2.dot(p) * e2 + extent.up.dot(p) * extent.up;
  };
  const auto normalToBall = [&](const Eigen::Vector3f& n) -> Eigen::Vector3f {
    return (e1.dot(n) / scale1 * e1 + e2.dot(n) / scale2 * e2 + extent.up.dot(n) * extent.up).normalized();
  };
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    points[i] = toBall(points[i]);
    normals[i] = normalToBall(normals[i]);
  }

  const std::size_t stride = (points.size() + kMaxFitPoints - 1) / kMaxFitPoints;
  const float lift = radius - extent.table_offset;  // centre = u e1 + v e2 + lift up
  std::vector<Eigen::Vector3f> fit_points;
  float u_lo = std::numeric_limits<float>::max(), u_hi = -u_lo, v_lo = u_lo, v_hi = -u_lo;
  for (std::size_t i = 0; i < points.size(); i += stride)
  {
    fit_points.push_back(points[i]);
    u_lo = std::min(u_lo, e1.dot(points[i]));
    u_hi = std::max(u_hi, e1.dot(points[i]));
    v_lo = std::min(v_lo, e2.dot(points[i]));
    v_hi = std::max(v_hi, e2.dot(points[i]));
  }
  const auto centreAt = [&](float u, float v) -> Eigen::Vector3f { return u * e1 + v * e2 + lift * extent.up; };
  // Summed squared distance from the sphere, each capped at a third of the radius (stray points
  // and a stalk are outliers, not evidence); coarse-to-fine over the footprint and a radius
  // beyond it on every side (24 x 24 cells, then 11 x 11 within the best cell's neighbours, twice).
  const auto cost = [&](float u, float v) {
    const Eigen::Vector3f c = centreAt(u, v);
    const float cap = radius * radius / 9.0f;
    float sum = 0.0f;
    for (const Eigen::Vector3f& q : fit_points)
    {
      const float e = (q - c).norm() - radius;
      sum += std::min(e * e, cap);
    }
    return sum;
  };
  float lo_u = u_lo - radius, hi_u = u_hi + radius, lo_v = v_lo - radius, hi_v = v_hi + radius;
  float best_u = 0.5f * (lo_u + hi_u), best_v = 0.5f * (lo_v + hi_v);
  for (int level = 0, steps = 24; level < 3; ++level, steps = 10)
  {
    const float step_u = (hi_u - lo_u) / static_cast<float>(steps), step_v = (hi_v - lo_v) / static_cast<float>(steps);
    float best = std::numeric_limits<float>::max();
    for (int i = 0; i <= steps; ++i)
      for (int j = 0; j <= steps; ++j)
      {
        const float u = lo_u + step_u * static_cast<float>(i), v = lo_v + step_v * static_cast<float>(j);
        if (const float c = cost(u, v); c < best)
        {
          best = c;
          best_u = u;
          best_v = v;
        }
      }
    lo_u = best_u - step_u;
    hi_u = best_u + step_u;
    lo_v = best_v - step_v;
    hi_v = best_v + step_v;
  }
  const Eigen::Vector3f ball_centre = centreAt(best_u, best_v);
  out.centre = best_u / scale1 * e1 + best_v / scale2 * e2 + lift * extent.up;
  out.horizontal_half_axes_m = Eigen::Vector2f(half_length, half_breadth);
  out.major_axis = e1;
  out.up = extent.up;
  out.radius_m = radius;

  std::vector<float> residuals, angles;
  residuals.reserve(points.size());
  angles.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const Eigen::Vector3f radial = points[i] - ball_centre;
    residuals.push_back(std::abs(radial.norm() - radius));
    if (radial.norm() < 1e-4f)
      continue;
    // normals are oriented toward the sensor, the seen side's outward direction: the sign is free
    const float cosine = std::abs(normals[i].dot(radial.normalized()));
    angles.push_back(std::acos(std::min(cosine, 1.0f)));
  }
  out.median_residual_m = medianInPlace(residuals);
  out.median_normal_angle_rad = angles.empty() ? static_cast<float>(M_PI) : medianInPlace(angles);
  if (out.median_residual_m > static_cast<float>(params.max_median_residual_frac) * radius)
    return refuse("points off the sphere");
  if (out.median_normal_angle_rad > static_cast<float>(params.max_median_normal_angle_rad))
    return refuse("normals not radial");
  out.found = true;
  return out;
}

float radiusAlong(const RestingBall& ball, const Eigen::Vector3f& direction)
{
  if (!(ball.horizontal_half_axes_m.minCoeff() > 0.0f && ball.radius_m > 0.0f))
    return ball.radius_m;
  const Eigen::Vector3f d = direction.normalized();
  const Eigen::Vector3f minor_axis = ball.up.cross(ball.major_axis);
  const Eigen::Vector3f scaled(d.dot(ball.major_axis) / ball.horizontal_half_axes_m.x(),
                               d.dot(minor_axis) / ball.horizontal_half_axes_m.y(), d.dot(ball.up) / ball.radius_m);
  return 1.0f / scaled.norm();
}

float fingertipReachPastCentre(const GraspCandidate& grasp, const GripperModel& gripper, const RestingBall& ball)
{
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>().normalized();
  const Eigen::Vector3f tip =
      grasp.pose.translation().cast<float>() + 0.5f * static_cast<float>(gripper.finger_depth_m) * approach;
  return approach.dot(tip - ball.centre);
}

bool isFlatRoundBody(const RestingBall& ball, const RestingBallParams& params)
{
  const float breadth = ball.horizontal_half_axes_m.minCoeff();
  return ball.found && breadth > 0.0f &&
         ball.radius_m <= static_cast<float>(params.flat_max_height_to_breadth) * breadth;
}

bool fingertipsStopHighOnBall(const GraspCandidate& grasp, const GripperModel& gripper, const RestingBall& ball,
                              const RestingBallParams& params)
{
  if (!ball.found)
    return false;
  const float reach = fingertipReachPastCentre(grasp, gripper, ball);
  // A ball held by the tips' edges above its equator turns about the contact line and stays a
  // ball in the pads; a flat body turned so swings its rim out of them (session 28, a flat
  // pebble lying flat: tips 0-4 mm past its centre held 17 of 29 pooled grasps, 4-8 mm 36 of 37).
  if (isFlatRoundBody(ball, params) &&
      reach < static_cast<float>(params.flat_min_fingertip_past_centre_frac) * ball.radius_m)
    return true;
  // depth into the body from its near side = its radius along the approach + reach past the centre
  const float radius = radiusAlong(ball, grasp.pose.linear().col(0).cast<float>());
  const float needed = std::min(static_cast<float>(params.min_fingertip_depth_m), radius);
  return radius + reach < needed;
}

}  // namespace fast_grasp
