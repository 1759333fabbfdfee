#include "fast_grasp/cshape_grasp.h"

#include "fast_grasp/grasp_geometry.h"

#include <pcl/filters/uniform_sampling.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

namespace fast_grasp
{
namespace
{
/// A neighbour in the frame of one normal: depth s along the approach (0 at the normal's
/// point), tangent coordinates (u, v); rotating (u, v) by the C-shape angle gives the
/// coordinate x across the C plane and y along the closing direction.
struct LocalPoint
{
  float s = 0.0f;
  float u = 0.0f;
  float v = 0.0f;
  int index = -1;  // into the seen cloud, or -1 for an unseen-part point
};

/// A neighbour inside the C-shape's slab |x| <= w/2 for one orientation.
struct SlabPoint
{
  float x = 0.0f;
  float y = 0.0f;
  float s = 0.0f;
  int index = -1;
};

/// Why a C-shape configuration was rejected, for the failure message.
struct RejectionCounts
{
  std::size_t blocked = 0;            // something stands in front of the normal's point
  std::size_t object_collision = 0;   // the C-shape intersects seen points
  std::size_t unseen_collision = 0;   // the C-shape intersects only the unseen part
  std::size_t too_wide = 0;           // closing region wider than the max opening
  std::size_t too_narrow = 0;         // narrower than the min opening
  std::size_t few_side_points = 0;    // cannot fit the two grasp sides
  std::size_t variance = 0;           // step 7
  std::size_t force_balance = 0;      // step 8
  std::size_t wrong_side = 0;         // approach would come from behind the sensor's view
};

/// Gripper constants of Eq. 6.1 in float, computed once per plan.
struct CShapeGeometry
{
  float r1 = 0.0f;
  float r2 = 0.0f;
  float half_w = 0.0f;
  float r1_sq = 0.0f;
  float r2_sq = 0.0f;
  float tip_reach = 0.0f;  // how far in front of the centre the fingertips reach at |y| = r1

  explicit CShapeGeometry(const GripperModel& gripper)
    : r1(static_cast<float>(gripper.cshape_r1_m))
    , r2(static_cast<float>(gripper.cshape_r2_m))
    , half_w(static_cast<float>(0.5 * gripper.cshape_w_m))
    , r1_sq(r1 * r1)
    , r2_sq(r2 * r2)
    , tip_reach(std::sqrt(std::max(0.0f, r2_sq - r1_sq)))
  {
  }

  /// Eq. 6.1 in the C plane, relative to the centre: y closing, ds depth in front of the
  /// centre. C_c = annulus r1..r2 minus the mouth C_red (|y| <= r1, in front of the centre).
  bool inside(float y, float ds) const
  {
    const float rho_sq = y * y + ds * ds;
    if (rho_sq > r2_sq || rho_sq < r1_sq)
      return false;
    return !(std::abs(y) <= r1 && ds >= 0.0f);
  }

  /// The closing region: inside the inner circle or in the mouth up to the fingertips.
  bool enveloped(float y, float ds) const
  {
    if (std::abs(y) > r1)
      return false;
    if (ds >= 0.0f)
      return ds <= tip_reach;
    return y * y + ds * ds < r1_sq;
  }
};

/// Per-call scratch and inputs of the search, so plan() stays const and thread-safe.
struct SearchContext
{
  const CShapeParams& params;
  const GripperModel& gripper;
  CShapeGeometry geometry;
  /// Full-resolution seen points and their normals (oriented toward a sensor).
  CloudXYZ::Ptr seen;
  std::vector<Eigen::Vector3f> normals;
  /// Obstacles for the coarse screen: voxel centroids of the seen points, then the unseen
  /// part from index `first_unseen` on; one k-d tree over both.
  CloudXYZ::Ptr obstacles;
  std::size_t first_unseen = 0;
  pcl::KdTreeFLANN<PointXYZ> obstacle_tree;
  std::vector<Eigen::Vector3f> sensors;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  RejectionCounts rejected;
  std::size_t configurations = 0;
  std::size_t zone_found = 0;  // configurations that fit (collision-free, within the opening)
  std::vector<Grasp> candidates;

  // Scratch buffers reused for every normal.
  std::vector<int> found;
  std::vector<float> found_sq;
  std::vector<LocalPoint> coarse_local;
  std::vector<LocalPoint> fine_local;
  std::vector<SlabPoint> slab;

  SearchContext(const CShapeParams& p, const GripperModel& g) : params(p), gripper(g), geometry(g) {}
};

/// Outcome of one normal: its best passing orientation, if any.
struct Evaluation
{
  bool passed = false;
  Grasp grasp;
};

/// Collision of the C-shape at centre depth `centre_s` with the slab points.
/// Returns 0 = free, 1 = hits seen points, 2 = hits only unseen points.
int collide(const CShapeGeometry& c, const std::vector<SlabPoint>& slab, float centre_s)
{
  bool unseen_hit = false;
  for (const SlabPoint& q : slab)
    if (c.inside(q.y, q.s - centre_s))
    {
      if (q.index >= 0)
        return 1;
      unseen_hit = true;
    }
  return unseen_hit ? 2 : 0;
}

struct ClosingRegion
{
  float y_min_seen = std::numeric_limits<float>::max();
  float y_max_seen = -std::numeric_limits<float>::max();
  float y_min_all = std::numeric_limits<float>::max();
  float y_max_all = -std::numeric_limits<float>::max();
  std::size_t seen_count = 0;
};

ClosingRegion closingRegion(const CShapeGeometry& c, const std::vector<SlabPoint>& slab, float centre_s)
{
  ClosingRegion region;
  for (const SlabPoint& q : slab)
    if (c.enveloped(q.y, q.s - centre_s))
    {
      region.y_min_all = std::min(region.y_min_all, q.y);
      region.y_max_all = std::max(region.y_max_all, q.y);
      if (q.index >= 0)
      {
        region.y_min_seen = std::min(region.y_min_seen, q.y);
        region.y_max_seen = std::max(region.y_max_seen, q.y);
        ++region.seen_count;
      }
    }
  return region;
}

/// Mean local position (x, y, s) of the seen enveloped points within `tolerance` of the
/// extreme closing coordinates: where the fingers meet the object.
void contactPoints(const CShapeGeometry& c, const std::vector<SlabPoint>& slab, float centre_s,
                   const ClosingRegion& region, float tolerance, Eigen::Vector3f& contact_a, Eigen::Vector3f& contact_b)
{
  Eigen::Vector3f sum_a = Eigen::Vector3f::Zero();
  Eigen::Vector3f sum_b = Eigen::Vector3f::Zero();
  int count_a = 0;
  int count_b = 0;
  for (const SlabPoint& q : slab)
  {
    if (q.index < 0 || !c.enveloped(q.y, q.s - centre_s))
      continue;
    const Eigen::Vector3f local(q.x, q.y, q.s);
    if (q.y <= region.y_min_seen + tolerance)
    {
      sum_a += local;
      ++count_a;
    }
    if (q.y >= region.y_max_seen - tolerance)
    {
      sum_b += local;
      ++count_b;
    }
  }
  contact_a = sum_a / static_cast<float>(std::max(count_a, 1));
  contact_b = sum_b / static_cast<float>(std::max(count_b, 1));
}

/// Steps 7 and 8: the two grasp sides are the extreme closing coordinates of the enveloped
/// points in `bins` slices across the C width; a line y = k x + b is fitted to each.
/// Returns false when a side has too few slices to fit.
bool analyseSides(const SearchContext& ctx, const std::vector<SlabPoint>& slab, float centre_s, double& sigma,
                  double& variance)
{
  const int bins = std::max(ctx.params.side_bins, 1);
  const float half_w = ctx.geometry.half_w;
  constexpr float kNone = std::numeric_limits<float>::max();
  std::vector<Eigen::Vector2f> low(static_cast<std::size_t>(bins), Eigen::Vector2f(0.0f, kNone));
  std::vector<Eigen::Vector2f> high(static_cast<std::size_t>(bins), Eigen::Vector2f(0.0f, -kNone));
  for (const SlabPoint& q : slab)
  {
    if (q.index < 0 || !ctx.geometry.enveloped(q.y, q.s - centre_s))
      continue;
    int bin = static_cast<int>((q.x + half_w) / (2.0f * half_w) * static_cast<float>(bins));
    bin = std::clamp(bin, 0, bins - 1);
    if (q.y < low[bin].y())
      low[bin] = Eigen::Vector2f(q.x, q.y);
    if (q.y > high[bin].y())
      high[bin] = Eigen::Vector2f(q.x, q.y);
  }
  std::vector<Eigen::Vector2d> side_a;
  std::vector<Eigen::Vector2d> side_b;
  for (int b = 0; b < bins; ++b)
  {
    if (low[b].y() != kNone)
      side_a.emplace_back(low[b].x(), low[b].y());
    if (high[b].y() != -kNone)
      side_b.emplace_back(high[b].x(), high[b].y());
  }
  if (static_cast<int>(side_a.size()) < ctx.params.min_side_bins ||
      static_cast<int>(side_b.size()) < ctx.params.min_side_bins)
    return false;
  sigma = 0.0;
  variance = 0.0;
  for (const auto* side : { &side_a, &side_b })
  {
    const LineFit fit = fitLine(*side);
    // sigma of step 8: the angle of each side to the C axis (0 = perpendicular to closing).
    sigma += std::abs(fit.angleRad());
    if (fit.vertical)
    {
      variance = std::numeric_limits<double>::infinity();
      continue;
    }
    const double norm = std::sqrt(1.0 + fit.k * fit.k);
    for (const auto& p : *side)
      variance += std::abs(fit.k * p.x() - p.y() + fit.b) / norm;
  }
  return true;
}

/// The points of `local` inside the C slab |x| <= w/2 at orientation (cos_t, sin_t).
void extractSlab(const CShapeGeometry& c, const std::vector<LocalPoint>& local, float cos_t, float sin_t,
                 std::vector<SlabPoint>& slab)
{
  slab.clear();
  for (const LocalPoint& q : local)
  {
    const float x = q.u * cos_t + q.v * sin_t;
    if (std::abs(x) <= c.half_w)
      slab.push_back({ x, -q.u * sin_t + q.v * cos_t, q.s, q.index });
  }
}

/// Steps 5 and 6 for one orientation: the centre by Eq. 6.9, the grasp depth by the depth
/// rule, and the collision of the C-shape there with the seen and unseen points.
struct Placement
{
  bool blocked = false;
  int collision = 0;  // 0 free, 1 seen points, 2 unseen points only
  float grasp_s = 0.0f;
  ClosingRegion region;
  Eigen::Vector3f contact_a = Eigen::Vector3f::Zero();
  Eigen::Vector3f contact_b = Eigen::Vector3f::Zero();
};

Placement place(const SearchContext& ctx, const std::vector<SlabPoint>& slab)
{
  const CShapeGeometry& c = ctx.geometry;
  Placement placement;
  // Eq. 6.9: push the C in until the back of its inner circle touches the object (seen or
  // unseen, Eq. 6.8). The thesis maximises min(Z1, Z2) over the convex-hull vertices of the
  // projected points; in depth s = -Z that is min(s + sqrt(r1^2 - y^2)), a concave function
  // whose minimum over the hull is attained at a hull vertex, i.e. equals its minimum over
  // all points -- so no hull is built (2 ms per hull at 10k points, per configuration).
  float centre_s = std::numeric_limits<float>::max();
  for (const SlabPoint& q : slab)
    if (std::abs(q.y) < c.r1)
      centre_s = std::min(centre_s, q.s + std::sqrt(c.r1_sq - q.y * q.y));
  if (centre_s < 0.0f)
  {
    // Something lies in front of the normal's point within the mouth: the C cannot reach
    // this point along this normal (and would leave the searched neighbourhood).
    placement.blocked = true;
    return placement;
  }
  const float tolerance = static_cast<float>(ctx.params.contact_tolerance_m);
  placement.grasp_s = centre_s;
  placement.region = closingRegion(c, slab, centre_s);
  contactPoints(c, slab, centre_s, placement.region, tolerance, placement.contact_a, placement.contact_b);
  if (ctx.params.depth_rule == CShapeParams::DepthRule::ContactDepth)
  {
    const float contact_s = std::min(centre_s, 0.5f * (placement.contact_a.z() + placement.contact_b.z()));
    if (contact_s < centre_s && collide(c, slab, contact_s) == 0)
    {
      placement.grasp_s = contact_s;
      placement.region = closingRegion(c, slab, contact_s);
      contactPoints(c, slab, contact_s, placement.region, tolerance, placement.contact_a, placement.contact_b);
      return placement;  // collision-free by the check above
    }
  }
  placement.collision = collide(c, slab, centre_s);  // the Eq. 6.9 placement
  return placement;
}

void record(SearchContext& ctx, const Grasp& grasp)
{
  if (ctx.candidates.size() < ctx.params.max_recorded_candidates)
    ctx.candidates.push_back(grasp);
}

float radiusOfSearch(const CShapeGeometry& c, float& centre_depth)
{
  // The C-shape centre lies at depth [0, r1] (Eq. 6.9 with the normal's own point), and the
  // C spans [centre - r2, centre + tip_reach] in depth and r2 / w/2 across: one ball
  // around the middle of that segment covers every orientation.
  const float low = -c.r2;
  const float high = c.r1 + c.tip_reach;
  centre_depth = 0.5f * (low + high);
  const float half_length = 0.5f * (high - low);
  const float lateral = std::sqrt(c.r2_sq + c.half_w * c.half_w);
  return std::sqrt(half_length * half_length + lateral * lateral) + 1e-4f;
}

/// Steps 4-8 for one normal. Every orientation is first screened against the coarse
/// obstacles (voxel centroids + unseen part); only the survivors are re-placed and analysed
/// against the full-resolution points, so the cost per normal stays near the size of the
/// coarse neighbourhood.
Evaluation evaluateNormal(SearchContext& ctx, int point_index)
{
  Evaluation best;
  const CShapeParams& params = ctx.params;
  const CShapeGeometry& c = ctx.geometry;
  const Eigen::Vector3f p = ctx.seen->points[static_cast<std::size_t>(point_index)].getVector3fMap();
  const Eigen::Vector3f approach = -ctx.normals[static_cast<std::size_t>(point_index)];
  const Eigen::Vector3f u = approach.unitOrthogonal();
  const Eigen::Vector3f v = approach.cross(u);

  // Only the cylinder around the approach axis that some orientation can reach matters.
  const float lateral_sq = c.r2_sq + c.half_w * c.half_w;
  const float depth_low = -c.r2;
  const float depth_high = c.r1 + c.tip_reach;
  auto toLocal = [&](const Eigen::Vector3f& point, int index, std::vector<LocalPoint>& out) {
    const Eigen::Vector3f d = point - p;
    const float s = d.dot(approach);
    if (s < depth_low || s > depth_high)
      return;
    const float pu = d.dot(u);
    const float pv = d.dot(v);
    if (pu * pu + pv * pv <= lateral_sq)
      out.push_back({ s, pu, pv, index });
  };

  // Coarse neighbourhood from the one obstacle tree.
  float ball_depth = 0.0f;
  const float ball_radius = radiusOfSearch(c, ball_depth);
  PointXYZ ball_centre;
  ball_centre.getVector3fMap() = p + approach * ball_depth;
  ctx.coarse_local.clear();
  ctx.obstacle_tree.radiusSearch(ball_centre, ball_radius, ctx.found, ctx.found_sq);
  for (int index : ctx.found)
    toLocal(ctx.obstacles->points[static_cast<std::size_t>(index)].getVector3fMap(),
            static_cast<std::size_t>(index) < ctx.first_unseen ? index : -1, ctx.coarse_local);

  // Fig. 6.8: the first C axis is the principal axis of the local patch in the tangent plane.
  const float axis_radius =
      params.local_axis_radius_m > 0.0 ? static_cast<float>(params.local_axis_radius_m) : c.r1;
  double su = 0, sv = 0, suu = 0, svv = 0, suv = 0;
  int n_axis = 0;
  for (const LocalPoint& q : ctx.coarse_local)
    if (q.index >= 0 && q.s * q.s + q.u * q.u + q.v * q.v <= axis_radius * axis_radius)
    {
      su += q.u;
      sv += q.v;
      suu += q.u * q.u;
      svv += q.v * q.v;
      suv += q.u * q.v;
      ++n_axis;
    }
  double first_angle = 0.0;
  if (n_axis >= 3)
  {
    const double cuu = suu / n_axis - (su / n_axis) * (su / n_axis);
    const double cvv = svv / n_axis - (sv / n_axis) * (sv / n_axis);
    const double cuv = suv / n_axis - (su / n_axis) * (sv / n_axis);
    first_angle = 0.5 * std::atan2(2.0 * cuv, cuu - cvv);
  }

  // Coarse screen of every orientation (the C is symmetric under a half turn).
  const int orientations = std::max(1, static_cast<int>(std::ceil(M_PI / params.angle_increment_rad - 1e-9)));
  std::vector<std::pair<double, double>> survivors;  // (coarse sigma, angle)
  for (int k = 0; k < orientations; ++k)
  {
    ++ctx.configurations;
    const double theta = first_angle + k * params.angle_increment_rad;
    extractSlab(c, ctx.coarse_local, static_cast<float>(std::cos(theta)), static_cast<float>(std::sin(theta)),
                ctx.slab);
    const Placement placement = place(ctx, ctx.slab);
    if (placement.blocked)
      ++ctx.rejected.blocked;
    else if (placement.collision == 1)
      ++ctx.rejected.object_collision;
    else if (placement.collision == 2)
      ++ctx.rejected.unseen_collision;
    else if (placement.region.y_max_all - placement.region.y_min_all > ctx.gripper.max_opening_m)
      ++ctx.rejected.too_wide;
    else
    {
      // Rank survivors by their coarse force balance so the full-resolution stage can stop
      // at the first orientation that passes.
      double sigma = 0.0;
      double variance = 0.0;
      const double rank = analyseSides(ctx, ctx.slab, placement.grasp_s, sigma, variance)
                              ? sigma
                              : std::numeric_limits<double>::max();
      survivors.emplace_back(rank, theta);
    }
  }
  if (survivors.empty())
    return best;
  std::stable_sort(survivors.begin(), survivors.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  // Full-resolution neighbourhood: every seen point (a linear pass is cheaper than another
  // tree at these sizes) plus the unseen points already found.
  ctx.fine_local.clear();
  for (std::size_t i = 0; i < ctx.seen->size(); ++i)
    toLocal(ctx.seen->points[i].getVector3fMap(), static_cast<int>(i), ctx.fine_local);
  for (const LocalPoint& q : ctx.coarse_local)
    if (q.index < 0)
      ctx.fine_local.push_back(q);

  for (const auto& survivor : survivors)
  {
    const double theta = survivor.second;
    const float cos_t = static_cast<float>(std::cos(theta));
    const float sin_t = static_cast<float>(std::sin(theta));
    extractSlab(c, ctx.fine_local, cos_t, sin_t, ctx.slab);
    const Placement placement = place(ctx, ctx.slab);
    if (placement.blocked)
    {
      ++ctx.rejected.blocked;
      continue;
    }
    if (placement.collision != 0)
    {
      ++(placement.collision == 1 ? ctx.rejected.object_collision : ctx.rejected.unseen_collision);
      continue;
    }
    const ClosingRegion& region = placement.region;
    const double width_seen = region.y_max_seen - region.y_min_seen;
    const double width_all = region.y_max_all - region.y_min_all;
    if (region.seen_count == 0 || width_all > ctx.gripper.max_opening_m)
    {
      ++ctx.rejected.too_wide;
      continue;
    }
    if (width_seen < ctx.gripper.min_opening_m)
    {
      ++ctx.rejected.too_narrow;
      continue;
    }
    ++ctx.zone_found;

    double sigma = 0.0;
    double variance = 0.0;
    if (!analyseSides(ctx, ctx.slab, placement.grasp_s, sigma, variance))
    {
      ++ctx.rejected.few_side_points;
      continue;
    }

    // The grasp in the base frame: origin at the C centre on the normal's line.
    const Eigen::Vector3f axis_x = cos_t * u + sin_t * v;
    const Eigen::Vector3f closing = -sin_t * u + cos_t * v;
    auto toBase = [&](const Eigen::Vector3f& local) -> Eigen::Vector3d {
      return (p + local.x() * axis_x + local.y() * closing + local.z() * approach).cast<double>();
    };
    const Eigen::Vector3f centre = p + approach * placement.grasp_s;
    Grasp grasp;
    grasp.pose = makeGraspPose(centre.cast<double>(), approach.cast<double>(), closing.cast<double>());
    grasp.width_m = width_seen;
    grasp.force_balance_rad = sigma;
    grasp.variance_m = variance;
    grasp.contact_a = toBase(placement.contact_a);
    grasp.contact_b = toBase(placement.contact_b);
    grasp.algorithm = "cshape";
    // Lever of gravity about the closing line: distance of the centroid from that line.
    const Eigen::Vector3f to_centroid = ctx.centroid - centre;
    grasp.torque_offset_m = (to_centroid - to_centroid.dot(closing) * closing).norm();
    grasp.score = -(sigma + params.variance_weight_rad_per_m * std::min(variance, 1e3) +
                    params.torque_weight_rad_per_m * grasp.torque_offset_m +
                    params.unseen_width_weight_rad_per_m * (width_all - width_seen));

    bool from_sensor_side = false;
    for (const Eigen::Vector3f& sensor : ctx.sensors)
      from_sensor_side = from_sensor_side || approach.dot(centre - sensor) > 0.0f;
    if (!from_sensor_side)
    {
      ++ctx.rejected.wrong_side;
      continue;
    }
    record(ctx, grasp);
    if (variance > params.variance_threshold_m)
    {
      ++ctx.rejected.variance;
      continue;
    }
    if (sigma > params.force_balance_threshold_rad)
    {
      ++ctx.rejected.force_balance;
      continue;
    }
    best.passed = true;
    best.grasp = grasp;
    break;  // the best-ranked orientation that passes at full resolution
  }
  return best;
}

std::string describe(const RejectionCounts& r)
{
  std::ostringstream out;
  out << r.object_collision << " hit the object (wider than the C-shape), " << r.unseen_collision
      << " hit the unseen part, " << r.too_wide << " wider than the max opening, " << r.too_narrow
      << " narrower than the min opening, " << r.blocked << " blocked in front, " << r.few_side_points
      << " without two fittable sides, " << r.variance << " above the variance threshold, " << r.force_balance
      << " above the force-balance threshold, " << r.wrong_side << " approaching from behind the sensor";
  return out.str();
}
}  // namespace

std::string CShapeParams::validate() const
{
  std::ostringstream why;
  if (!(angle_increment_rad > 0.0 && angle_increment_rad <= M_PI))
    why << "angle_increment_rad must lie in (0, pi]; ";
  if (!(normal_downsample_radius_m > 0.0))
    why << "normal_downsample_radius_m must be positive; ";
  if (!(local_axis_radius_m >= 0.0))
    why << "local_axis_radius_m must be >= 0; ";
  if (max_grasps < 1)
    why << "max_grasps must be >= 1; ";
  if (!(time_budget_s > 0.0))
    why << "time_budget_s must be positive; ";
  if (!(variance_threshold_m >= 0.0))
    why << "variance_threshold_m must be >= 0; ";
  if (side_bins < 2 || min_side_bins < 2 || min_side_bins > side_bins)
    why << "need 2 <= min_side_bins <= side_bins; ";
  if (!(force_balance_threshold_rad >= 0.0))
    why << "force_balance_threshold_rad must be >= 0; ";
  if (!(contact_tolerance_m >= 0.0))
    why << "contact_tolerance_m must be >= 0; ";
  if (!(min_thickness_m >= 0.0))
    why << "min_thickness_m must be >= 0; ";
  if (!(unseen.extension_m >= 0.0) || unseen.step_m < 0.0 || unseen.grid_cell_m < 0.0)
    why << "unseen part lengths must be >= 0; ";
  return why.str();
}

bool insideCShape(const CShapePose& pose, const GripperModel& gripper, const Eigen::Vector3f& point)
{
  const CShapeGeometry c(gripper);
  const Eigen::Vector3f approach = pose.approach.normalized();
  const Eigen::Vector3f closing = (pose.closing - pose.closing.dot(approach) * approach).normalized();
  const Eigen::Vector3f d = point - pose.centre;
  const float x = d.dot(approach.cross(closing));
  if (std::abs(x) > c.half_w)
    return false;
  return c.inside(d.dot(closing), d.dot(approach));
}

std::size_t countInsideCShape(const CShapePose& pose, const GripperModel& gripper, const CloudXYZ& cloud)
{
  std::size_t count = 0;
  for (const auto& p : cloud.points)
    if (std::isfinite(p.x) && insideCShape(pose, gripper, p.getVector3fMap()))
      ++count;
  return count;
}

CShapeGraspPlanner::CShapeGraspPlanner(CShapeParams params) : params_(std::move(params)) {}

GraspResult CShapeGraspPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  const Stopwatch stopwatch;
  auto finish = [&](GraspResult result) {
    result.compute_time_s = stopwatch.elapsedSeconds();
    return result;
  };

  // Validate before touching anything.
  const std::string gripper_problem = gripper.validate();
  if (!gripper_problem.empty())
    return finish(GraspResult::fail(GraspFailure::InvalidParameters, "invalid gripper: " + gripper_problem));
  const std::string params_problem = params_.validate();
  if (!params_problem.empty())
    return finish(GraspResult::fail(GraspFailure::InvalidParameters, "invalid CShapeParams: " + params_problem));
  if (!view.cloud)
    return finish(GraspResult::fail(GraspFailure::EmptyInput, "object cloud pointer is null"));
  if (view.sensor_origins.empty())
    return finish(GraspResult::fail(GraspFailure::InvalidParameters,
                                    "the view has no sensor origin (needed for normals' side and the unseen part)"));
  for (const Eigen::Vector3f& origin : view.sensor_origins)
    if (!origin.allFinite())
      return finish(GraspResult::fail(GraspFailure::InvalidParameters, "a sensor origin is not finite"));

  SearchContext ctx(params_, gripper);
  ctx.sensors = view.sensor_origins;

  // Step 2: finite points; normals (given upstream) oriented toward a viewpoint.
  ctx.seen.reset(new CloudXYZ);
  ctx.seen->reserve(view.cloud->size());
  ctx.normals.reserve(view.cloud->size());
  for (const PointNormal& q : view.cloud->points)
  {
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      continue;
    const Eigen::Vector3f position(q.x, q.y, q.z);
    Eigen::Vector3f normal(q.normal_x, q.normal_y, q.normal_z);
    const float length = normal.norm();
    if (!std::isfinite(length) || length < 1e-6f)
      normal = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
    else
    {
      normal /= length;
      bool faces_a_sensor = false;
      for (const Eigen::Vector3f& origin : view.sensor_origins)
        faces_a_sensor = faces_a_sensor || normal.dot(origin - position) > 0.0f;
      if (!faces_a_sensor)
        normal = -normal;
    }
    ctx.seen->push_back(PointXYZ(q.x, q.y, q.z));
    ctx.normals.push_back(normal);
  }
  if (ctx.seen->empty())
    return finish(GraspResult::fail(GraspFailure::EmptyInput, "object cloud has no finite point"));
  if (ctx.seen->size() < params_.min_points)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "object cloud has only " + std::to_string(ctx.seen->size()) +
                                        " finite points (need " + std::to_string(params_.min_points) + ")"));
  const PrincipalFrame frame = computePrincipalFrame(*ctx.seen);
  ctx.centroid = frame.centroid;
  if (std::sqrt(frame.eigenvalues(1)) < params_.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "object cloud is collinear: no surface to place a C-shape on"));
  if (std::sqrt(frame.eigenvalues(2)) < params_.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "object cloud is a flat sheet (thickness " +
                                        std::to_string(std::sqrt(frame.eigenvalues(2))) +
                                        " m): zero-thickness objects cannot be grasped by a C-shape"));

  // Step 4 (Fig. 6.9, Eq. 6.8): the unseen part, built once.
  GraspResult result;
  CloudXYZ unseen_points;
  if (params_.use_unseen_part)
  {
    std::optional<Eigen::Vector4f> table;
    if (view.has_table_plane)
      table = view.table_plane;
    UnseenPart unseen = buildUnseenPart(*ctx.seen, view.sensor_origins, params_.unseen, table);
    if (!unseen.ok())
      return finish(GraspResult::fail(GraspFailure::DegenerateInput, "cannot build the unseen part: " + unseen.failure));
    unseen_points = std::move(unseen.points);
  }

  // Coarse obstacles for the per-orientation screen: voxel centroids, dense enough that no
  // C-shape part (thickness r2 - r1, width w) fits between them, plus the unseen part; one
  // k-d tree per plan over both.
  const double obstacle_leaf_m =
      params_.obstacle_leaf_m > 0.0
          ? params_.obstacle_leaf_m
          : std::clamp(std::min(gripper.cshape_r2_m - gripper.cshape_r1_m, gripper.cshape_w_m) / 3.0, 1e-3, 5e-3);
  ctx.obstacles.reset(new CloudXYZ);
  {
    pcl::VoxelGrid<PointXYZ> voxel_grid;
    voxel_grid.setInputCloud(ctx.seen);
    const float leaf = static_cast<float>(obstacle_leaf_m);
    voxel_grid.setLeafSize(leaf, leaf, leaf);
    voxel_grid.filter(*ctx.obstacles);
  }
  ctx.first_unseen = ctx.obstacles->size();
  *ctx.obstacles += unseen_points;
  ctx.obstacle_tree.setSortedResults(false);
  ctx.obstacle_tree.setInputCloud(ctx.obstacles);

  // Step 3: down-sampled normals, one per voxel, each the normal of a real input point (the
  // thesis takes the point nearest to the voxel centroid through a k-d tree; PCL's
  // UniformSampling takes the point nearest to the voxel centre in one pass, no tree).
  std::vector<int> normal_indices;
  {
    pcl::UniformSampling<PointXYZ> sampler(true);
    sampler.setInputCloud(ctx.seen);
    sampler.setRadiusSearch(params_.normal_downsample_radius_m);
    CloudXYZ sampled;
    sampler.filter(sampled);
    std::vector<bool> removed(ctx.seen->size(), false);
    for (int index : *sampler.getRemovedIndices())
      removed[static_cast<std::size_t>(index)] = true;
    for (std::size_t i = 0; i < ctx.seen->size(); ++i)
      if (!removed[i] && ctx.normals[i].allFinite())
        normal_indices.push_back(static_cast<int>(i));
  }
  if (normal_indices.empty())
    return finish(GraspResult::fail(GraspFailure::DegenerateInput, "object cloud has no valid normal"));

  // Random normal order (seeded), stop at max_grasps or the time budget.
  std::mt19937 rng(params_.seed);
  std::shuffle(normal_indices.begin(), normal_indices.end(), rng);
  std::vector<Grasp> grasps;
  std::size_t normals_tried = 0;
  bool out_of_time = false;
  for (int index : normal_indices)
  {
    if (stopwatch.elapsedSeconds() > params_.time_budget_s)
    {
      out_of_time = true;
      break;
    }
    ++normals_tried;
    Evaluation evaluation = evaluateNormal(ctx, index);
    if (evaluation.passed)
    {
      grasps.push_back(std::move(evaluation.grasp));
      if (static_cast<int>(grasps.size()) >= params_.max_grasps)
        break;
    }
  }

  result.unseen = std::move(unseen_points);
  result.candidates = std::move(ctx.candidates);
  result.candidates_evaluated = ctx.configurations;
  std::ostringstream summary;
  summary << normals_tried << " of " << normal_indices.size() << " normals, " << ctx.configurations
          << " C-shape configurations: ";
  if (grasps.empty())
  {
    if (out_of_time)
    {
      result.failure = GraspFailure::Timeout;
      summary << "time budget of " << params_.time_budget_s << " s ran out before any grasp passed; ";
    }
    else if (ctx.zone_found == 0)
    {
      result.failure = GraspFailure::NoGraspableZone;
      summary << "no C-shape fits around the object with max opening " << gripper.max_opening_m << " m; ";
    }
    else
    {
      result.failure = GraspFailure::NoStableGrasp;
      summary << ctx.zone_found << " fit but none is stable; ";
    }
    summary << describe(ctx.rejected);
    result.message = summary.str();
    return finish(std::move(result));
  }
  sortGraspsBestFirst(grasps);
  result.grasps = std::move(grasps);
  summary << result.grasps.size() << " grasps, best force balance " << result.grasps.front().force_balance_rad
          << " rad" << (out_of_time ? " (time budget reached)" : "");
  result.message = summary.str();

  // The points enveloped by the best C-shape, for drawing.
  const Grasp& best = result.grasps.front();
  const Eigen::Isometry3d to_grasp = best.pose.inverse();
  const CShapeGeometry c(gripper);
  for (const PointXYZ& q : ctx.seen->points)
  {
    const Eigen::Vector3d local = to_grasp * q.getVector3fMap().cast<double>();
    // Grasp frame: x approach (depth), y closing, z across the C plane.
    if (std::abs(local.z()) <= c.half_w && c.enveloped(static_cast<float>(local.y()), static_cast<float>(local.x())))
      result.graspable_zone.push_back(q);
  }
  return finish(std::move(result));
}

}  // namespace fast_grasp
