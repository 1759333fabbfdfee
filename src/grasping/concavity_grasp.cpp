#include "fast_grasp/grasping/concavity_grasp.h"
#include "fast_grasp/grasping/planner_input.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <pcl/filters/voxel_grid.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/surface/convex_hull.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>

namespace fast_grasp
{
namespace
{
// Below this PCA spread (sqrt of the smallest eigenvalue) the points span no volume and
// qhull would fail on a flat initial simplex: the cloud is treated as flat (concavity 0).
constexpr double kFlatSpreadM = 1e-4;
// The projection grid is capped per side so a huge or mis-scaled cloud cannot allocate
// without bound; beyond it the cell grows. 500, not 2000: closing 2000 x 2000 cells per region
// took seconds per plan on a metres-wide cloud (5 s under ASan while fuzzing, 0.5 s natively);
// objects up to 1 m keep the 2 mm cell.
constexpr int kMaxGridCellsPerSide = 500;
// A boundary chain breaks where the nearest remaining boundary cell is farther than this many
// cells (another part of the contour, not the next cell of this one).
constexpr double kChainLinkCells = 2.5;
// Boundaries longer than this (cells) are not chained (O(m^2) nearest-neighbour ordering).
constexpr std::size_t kMaxBoundaryCells = 4000;

/// Eq. 5.2 and 5.3 from chain point `first` on: the first segment (n, n + 1) whose ends lie on
/// either side of the circle of radius r about p0, and the crossing point on it.
bool firstCircleCrossing(const std::vector<Eigen::Vector2f>& chain, std::size_t first, const Eigen::Vector2f& p0,
                         float r, Eigen::Vector2f& crossing, std::size_t& segment)
{
  for (std::size_t n = first; n + 1 < chain.size(); ++n)
  {
    const Eigen::Vector2f& a = chain[n];
    const Eigen::Vector2f& b = chain[n + 1];
    const float da = (a - p0).norm(), db = (b - p0).norm();
    if (!((da < r && r <= db) || (db < r && r <= da)))  // Eq. 5.2
      continue;
    // Eq. 5.3 in parametric form: |a + t (b - a) - p0|^2 = r^2, t in [0, 1] (the thesis's
    // slope form divides by p_n.y - p_n+1.y, zero on a horizontal segment).
    const Eigen::Vector2f e = b - a, f = a - p0;
    const float qa = e.squaredNorm(), qb = 2.0f * f.dot(e), qc = f.squaredNorm() - r * r;
    const float discriminant = qb * qb - 4.0f * qa * qc;
    if (!(qa > 0.0f) || discriminant < 0.0f)
      continue;
    const float root = std::sqrt(discriminant);
    // Leaving the circle (a inside): the larger root; entering it again: the smaller.
    const float t = std::clamp(qc < 0.0f ? (-qb + root) / (2.0f * qa) : (-qb - root) / (2.0f * qa), 0.0f, 1.0f);
    crossing = a + t * e;
    segment = n;
    return true;
  }
  return false;
}

/// Boundary cells (centres) of the closed occupancy grid of `xy`.
std::vector<Eigen::Vector2f> projectedBoundary(const std::vector<Eigen::Vector2f>& xy, double cell_m)
{
  std::vector<Eigen::Vector2f> boundary;
  if (xy.empty())
    return boundary;
  Eigen::Vector2f low = xy.front(), high = xy.front();
  for (const auto& q : xy)
  {
    low = low.cwiseMin(q);
    high = high.cwiseMax(q);
  }
  double cell = cell_m;
  const double extent = (high - low).maxCoeff();
  if (extent / cell > kMaxGridCellsPerSide - 5)
    cell = extent / (kMaxGridCellsPerSide - 5);
  // Two empty cells of padding: the dilation never reaches the array's edge.
  const int cols = static_cast<int>(std::floor((high.x() - low.x()) / cell)) + 5;
  const int rows = static_cast<int>(std::floor((high.y() - low.y()) / cell)) + 5;
  auto at = [cols](int c, int r) { return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + c; };
  std::vector<std::uint8_t> occupied(static_cast<std::size_t>(cols) * rows, 0);
  for (const auto& q : xy)
  {
    const int c = static_cast<int>(std::floor((q.x() - low.x()) / cell)) + 2;
    const int r = static_cast<int>(std::floor((q.y() - low.y()) / cell)) + 2;
    occupied[at(std::clamp(c, 2, cols - 3), std::clamp(r, 2, rows - 3))] = 1;
  }
  // Closing: holes between down-sampled points are not contour.
  std::vector<std::uint8_t> closed = occupied;
  closeBinaryGrid(closed, cols, rows, 1);
  for (std::size_t i = 0; i < closed.size(); ++i)
    closed[i] = static_cast<std::uint8_t>(closed[i] || occupied[i]);
  for (int r = 1; r < rows - 1; ++r)
    for (int c = 1; c < cols - 1; ++c)
      if (closed[at(c, r)] &&
          !(closed[at(c - 1, r)] && closed[at(c + 1, r)] && closed[at(c, r - 1)] && closed[at(c, r + 1)]))
        boundary.emplace_back(static_cast<float>(low.x() + (c - 2 + 0.5) * cell),
                              static_cast<float>(low.y() + (r - 2 + 0.5) * cell));
  return boundary;
}

/// Fig. 5.12: boundary points in order, by nearest neighbour from an extreme point (the one
/// farthest from the boundary's centroid: an end of an open strip, any point of a closed
/// contour); a new chain starts where the next point is farther than `link_m`.
std::vector<std::vector<Eigen::Vector2f>> orderBoundary(const std::vector<Eigen::Vector2f>& points, double link_m)
{
  std::vector<std::vector<Eigen::Vector2f>> chains;
  if (points.empty() || points.size() > kMaxBoundaryCells)
    return chains;
  Eigen::Vector2f centroid = Eigen::Vector2f::Zero();
  for (const auto& q : points)
    centroid += q;
  centroid /= static_cast<float>(points.size());
  std::vector<bool> used(points.size(), false);
  std::size_t left = points.size();
  const float link_squared = static_cast<float>(link_m * link_m);
  while (left > 0)
  {
    std::size_t start = 0;
    float farthest = -1.0f;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (!used[i] && (points[i] - centroid).squaredNorm() > farthest)
      {
        farthest = (points[i] - centroid).squaredNorm();
        start = i;
      }
    std::vector<Eigen::Vector2f> chain{ points[start] };
    used[start] = true;
    --left;
    while (left > 0)
    {
      std::size_t nearest = 0;
      float best = std::numeric_limits<float>::infinity();
      for (std::size_t i = 0; i < points.size(); ++i)
        if (!used[i] && (points[i] - chain.back()).squaredNorm() < best)
        {
          best = (points[i] - chain.back()).squaredNorm();
          nearest = i;
        }
      if (best > link_squared)
        break;
      chain.push_back(points[nearest]);
      used[nearest] = true;
      --left;
    }
    if (chain.size() >= 2)
      chains.push_back(std::move(chain));
  }
  return chains;
}

/// Counts of why candidates were not kept, for the failure message.
struct Rejections
{
  std::size_t not_outer = 0;     // the step point is inside the object along its closing line (Eq. 5.1)
  std::size_t too_wide = 0;
  std::size_t too_narrow = 0;
  std::size_t few_sides = 0;     // too few side slices to fit Eq. 5.4
  std::size_t unbalanced = 0;    // force balance above the threshold
  std::size_t duplicates = 0;
  double narrowest_m = std::numeric_limits<double>::infinity();
  double best_balance_rad = std::numeric_limits<double>::infinity();
};

/// Everything shared by the candidates of one plan.
struct PlanContext
{
  const ConcavityParams* params = nullptr;
  const GripperModel* gripper = nullptr;
  const CloudXYZ* object = nullptr;     // down-sampled object points (the candidates' bands)
  Eigen::Vector3f sensor = Eigen::Vector3f::Zero();
  double hand_width_m = 0.0;
  std::vector<GraspCandidate> evaluated;  // every candidate with a width (markers)
  std::vector<GraspCandidate> stable;     // within the opening and the force-balance threshold
  std::size_t evaluated_count = 0;
  std::size_t within_opening = 0;
  Rejections rejected;
  CloudXYZ hull;  // the regions' boundaries, base frame
};

/// Steps 4-6 on one region (indices into ctx.object) projected along one of its OBB axes
/// (`view`, pointing toward the sensor; the hand approaches along -view).
void analyseProjection(const std::vector<int>& region, const PrincipalFrame& frame, const Eigen::Vector3f& view,
                       const Eigen::Vector3f& u1, const Eigen::Vector3f& u2, PlanContext& ctx)
{
  const ConcavityParams& p = *ctx.params;
  const GripperModel& gripper = *ctx.gripper;
  const CloudXYZ& object = *ctx.object;

  // Step 4: projection onto the OBB plane across the approach and its boundary.
  std::vector<Eigen::Vector2f> xy;
  xy.reserve(region.size());
  for (const int i : region)
  {
    const Eigen::Vector3f d = object[static_cast<std::size_t>(i)].getVector3fMap() - frame.centroid;
    xy.emplace_back(d.dot(u1), d.dot(u2));
  }
  const std::vector<Eigen::Vector2f> boundary = projectedBoundary(xy, p.grid_cell_m);
  // Every object point in the same plane coordinates and its depth along `view`, once: each
  // candidate's band is then two 2-D dot products per point.
  std::vector<Eigen::Vector2f> object_xy;
  std::vector<float> object_depth;
  object_xy.reserve(object.size());
  object_depth.reserve(object.size());
  for (const PointXYZ& point : object.points)
  {
    const Eigen::Vector3f d = point.getVector3fMap() - frame.centroid;
    object_xy.emplace_back(d.dot(u1), d.dot(u2));
    object_depth.push_back(d.dot(view));
  }
  for (const auto& b : boundary)
  {
    const Eigen::Vector3f q = frame.centroid + b.x() * u1 + b.y() * u2;
    ctx.hull.push_back(PointXYZ(q.x(), q.y(), q.z()));
  }
  const double hand_width = ctx.hand_width_m;
  const std::vector<std::vector<Eigen::Vector2f>> chains = orderBoundary(boundary, kChainLinkCells * p.grid_cell_m);

  // Band points of one candidate: (along, across, depth) about its centre line.
  struct BandPoint
  {
    float along, across, depth;
  };
  std::vector<BandPoint> band;
  const float half_hand = static_cast<float>(0.5 * hand_width);
  const Eigen::Vector3f approach = -view;
  for (const auto& chain : chains)
  {
    std::vector<std::size_t> segments;
    // Step 5: step points (Eqs. 5.2-5.3) until the rest of the chain is within a hand width.
    const std::vector<Eigen::Vector2f> steps = boundaryStepPoints(chain, p.step_m, hand_width, &segments);
    for (std::size_t s = 0; s < steps.size(); ++s)
    {
      Eigen::Vector2f q_point;
      std::size_t unused = 0;
      if (!firstCircleCrossing(chain, segments[s], steps[s], static_cast<float>(hand_width), q_point, unused))
        continue;  // the chain ends within a hand width of this step point
      const Eigen::Vector2f along_2d = (q_point - steps[s]).normalized();
      const Eigen::Vector2f mid_2d = 0.5f * (q_point + steps[s]);
      const Eigen::Vector3f along = (along_2d.x() * u1 + along_2d.y() * u2).normalized();
      const Eigen::Vector3f closing = (-along_2d.y() * u1 + along_2d.x() * u2).normalized();
      const Eigen::Vector3f mid = frame.centroid + mid_2d.x() * u1 + mid_2d.y() * u2;
      ++ctx.evaluated_count;

      // The candidate's cloud (Fig. 5.17): the object's points within half a hand width of the
      // perpendicular bisector of P0Q.
      band.clear();
      const float mid_depth = (mid - frame.centroid).dot(view);
      for (std::size_t i = 0; i < object_xy.size(); ++i)
      {
        const Eigen::Vector2f d = object_xy[i] - mid_2d;
        const float a = d.dot(along_2d);
        if (std::abs(a) <= half_hand)
          band.push_back({ a, along_2d.x() * d.y() - along_2d.y() * d.x(), object_depth[i] - mid_depth });
      }
      if (band.empty())
        continue;
      std::sort(band.begin(), band.end(), [](const BandPoint& x, const BandPoint& y) { return x.across < y.across; });
      // The part of the object at the step point: split the closing line at gaps.
      const float gap = static_cast<float>(p.gap_m), tolerance = static_cast<float>(p.boundary_tolerance_m);
      std::size_t part_begin = 0, part_end = 0;
      bool found = false;
      for (std::size_t begin = 0; begin < band.size() && !found;)
      {
        std::size_t end = begin + 1;
        while (end < band.size() && band[end].across - band[end - 1].across <= gap)
          ++end;
        if (band[begin].across - tolerance <= 0.0f && band[end - 1].across + tolerance >= 0.0f)
        {
          part_begin = begin;
          part_end = end;
          found = true;
        }
        begin = end;
      }
      if (!found)
        continue;
      const float lo = band[part_begin].across, hi = band[part_end - 1].across;
      // Eq. 5.1's outer-layer test: a finger must find free space beside the step point.
      if (std::min(std::abs(lo), std::abs(hi)) > tolerance)
      {
        ++ctx.rejected.not_outer;
        continue;
      }
      const double width = hi - lo;
      ctx.rejected.narrowest_m = std::min(ctx.rejected.narrowest_m, width);
      if (width > gripper.max_opening_m)
      {
        ++ctx.rejected.too_wide;
        continue;
      }
      if (width < gripper.min_opening_m)
      {
        ++ctx.rejected.too_narrow;
        continue;
      }
      ++ctx.within_opening;

      // Step 6: the two grasp sides (extremes of each slice of the band) and Eq. 5.4.
      const int bins = p.side_bins;
      std::vector<float> low_side(bins, std::numeric_limits<float>::infinity());
      std::vector<float> high_side(bins, -std::numeric_limits<float>::infinity());
      std::vector<float> low_along(bins, 0.0f), high_along(bins, 0.0f);
      double depth_a = 0.0, depth_b = 0.0;
      int count_a = 0, count_b = 0;
      for (std::size_t i = part_begin; i < part_end; ++i)
      {
        const BandPoint& b = band[i];
        const int bin = std::clamp(static_cast<int>((b.along + half_hand) / (2.0f * half_hand) * bins), 0, bins - 1);
        if (b.across < low_side[bin])
        {
          low_side[bin] = b.across;
          low_along[bin] = b.along;
        }
        if (b.across > high_side[bin])
        {
          high_side[bin] = b.across;
          high_along[bin] = b.along;
        }
        if (b.across <= lo + p.side_depth_m)
        {
          depth_a += b.depth;
          ++count_a;
        }
        if (b.across >= hi - p.side_depth_m)
        {
          depth_b += b.depth;
          ++count_b;
        }
      }
      std::vector<Eigen::Vector2d> side_a, side_b;
      for (int bin = 0; bin < bins; ++bin)
        if (std::isfinite(low_side[bin]))
        {
          side_a.emplace_back(low_along[bin], low_side[bin]);
          side_b.emplace_back(high_along[bin], high_side[bin]);
        }
      if (static_cast<int>(side_a.size()) < p.min_side_bins)
      {
        ++ctx.rejected.few_sides;
        continue;
      }
      // Eq. 5.4 (closing = k * along + b): sides normal to the closing direction give k = 0.
      const double balance = std::abs(fitLine(side_a).angleRad()) + std::abs(fitLine(side_b).angleRad());
      const Eigen::Vector3d contact_a =
          (mid + lo * closing + static_cast<float>(depth_a / std::max(count_a, 1)) * view).cast<double>();
      const Eigen::Vector3d contact_b =
          (mid + hi * closing + static_cast<float>(depth_b / std::max(count_b, 1)) * view).cast<double>();
      GraspCandidate grasp;
      grasp.algorithm = "concavity";
      grasp.width_m = width;
      grasp.force_balance_rad = balance;
      grasp.contact_a = contact_a;
      grasp.contact_b = contact_b;
      const Eigen::Vector3d centre = 0.5 * (contact_a + contact_b);
      grasp.pose = makeGraspPose(centre, approach.cast<double>(), closing.cast<double>());
      // Manipulability stand-in: the approach's angle to the line of sight.
      const Eigen::Vector3d line_of_sight = (centre - ctx.sensor.cast<double>()).normalized();
      const double misalignment = 1.0 - std::clamp(grasp.approach().dot(line_of_sight), -1.0, 1.0);
      const double penalty =
          balance / std::max(p.force_balance_max_rad, 1e-6) + p.view_alignment_weight * misalignment;
      grasp.score = 1.0 / (1.0 + penalty);
      if (ctx.evaluated.size() < p.max_recorded_candidates)
        ctx.evaluated.push_back(grasp);
      ctx.rejected.best_balance_rad = std::min(ctx.rejected.best_balance_rad, balance);
      if (balance > p.force_balance_max_rad)
      {
        ++ctx.rejected.unbalanced;
        continue;
      }
      const bool duplicate = std::any_of(ctx.stable.begin(), ctx.stable.end(), [&](const GraspCandidate& other) {
        return (other.position() - grasp.position()).norm() < p.duplicate_distance_m &&
               std::abs(other.binormal().dot(grasp.binormal())) > 0.98;
      });
      if (duplicate)
      {
        ++ctx.rejected.duplicates;
        continue;
      }
      ctx.stable.push_back(grasp);
    }
  }
}

/// Step 3 on one region: its OBB frame (PCA); every OBB axis within
/// max_approach_view_angle_rad of the line of sight (at least the nearest) is an approach axis,
/// nearest first, and the region is projected onto the other two.
void analyseRegion(const std::vector<int>& region, PlanContext& ctx)
{
  if (region.size() < 3)
    return;
  const PrincipalFrame frame = computePrincipalFrame(*ctx.object, region);
  if (frame.point_count < 3)
    return;
  const Eigen::Vector3f sight = (ctx.sensor - frame.centroid).normalized();
  const Eigen::Vector3f alignment = (frame.axes.transpose() * sight).cwiseAbs();
  std::array<int, 3> order{ 0, 1, 2 };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return alignment(a) > alignment(b); });
  const float min_cos = static_cast<float>(std::cos(ctx.params->max_approach_view_angle_rad));
  for (std::size_t k = 0; k < order.size(); ++k)
  {
    const int axis = order[k];
    if (k > 0 && alignment(axis) < min_cos)
      break;
    Eigen::Vector3f view = frame.axes.col(axis);
    if (view.dot(sight) < 0.0f)
      view = -view;
    analyseProjection(region, frame, view, frame.axes.col((axis + 1) % 3), frame.axes.col((axis + 2) % 3), ctx);
  }
}

std::string describeRejections(const Rejections& r)
{
  std::ostringstream out;
  out << r.not_outer << " step points inside the object along their closing line, " << r.too_wide
      << " wider than the opening, " << r.too_narrow << " narrower than the minimum opening, " << r.few_sides
      << " with too few side points, " << r.unbalanced << " above the force-balance threshold";
  return out.str();
}
}  // namespace

std::string ConcavityParams::validate() const
{
  if (!(voxel_leaf_m >= 0.0) || !(min_concavity_m > 0.0) || !(cluster_tolerance_m > 0.0) || !(grid_cell_m > 0.0) ||
      !(step_m > 0.0) || !(hand_width_m >= 0.0) || !(boundary_tolerance_m >= 0.0) || !(gap_m > 0.0) ||
      !(side_depth_m >= 0.0) || !(force_balance_max_rad > 0.0) || !(view_alignment_weight >= 0.0) ||
      !(max_approach_view_angle_rad >= 0.0) ||
      !(duplicate_distance_m >= 0.0) || !(min_thickness_m >= 0.0))
    return "a length, step or threshold is negative, zero or not a number";
  if (side_bins < 2 || min_side_bins < 2 || min_side_bins > side_bins)
    return "side_bins and min_side_bins must satisfy 2 <= min_side_bins <= side_bins";
  if (max_regions < 1 || max_grasps < 1 || min_points < 1 || min_region_points < 1 || max_analysis_points < 100)
    return "max_regions, max_grasps, min_points and min_region_points must be >= 1, max_analysis_points >= 100";
  if (!(unseen.extension_m >= 0.0) || unseen.step_m < 0.0 || unseen.grid_cell_m < 0.0 || unseen.min_grid_cell_m < 0.0 ||
      unseen.max_grid_cells_per_side < 2)
    return "unseen part: negative length or fewer than 2 grid cells per side";
  return gripper_fit.validate();
}

std::vector<float> concavityBelowConvexHull(const CloudXYZ& points, const std::vector<Eigen::Vector3f>& sensor_origins,
                                            std::string* why)
{
  std::vector<float> depth(points.size(), 0.0f);
  auto none = [&](const std::string& reason) {
    if (why)
      *why = reason;
    return depth;
  };
  CloudXYZ::Ptr finite(new CloudXYZ);
  finite->reserve(points.size());
  for (const PointXYZ& q : points.points)
    if (std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z))
      finite->push_back(q);
  if (finite->size() < 4)
    return none("fewer than 4 finite points: no convex hull");
  const PrincipalFrame spread = computePrincipalFrame(*finite);
  if (std::sqrt(spread.eigenvalues(2)) < kFlatSpreadM)
    return none("the points are coplanar: no 3-D convex hull, no depth below it");

  pcl::ConvexHull<PointXYZ> hull;
  hull.setInputCloud(finite);
  hull.setDimension(3);
  CloudXYZ vertices;
  std::vector<pcl::Vertices> polygons;
  hull.reconstruct(vertices, polygons);
  if (polygons.empty() || vertices.empty())
    return none("qhull built no convex hull");
  Eigen::Vector3f inside = Eigen::Vector3f::Zero();
  for (const PointXYZ& v : vertices.points)
    inside += v.getVector3fMap();
  inside /= static_cast<float>(vertices.size());

  // Facet planes n . x = offset with n pointing out of the hull.
  struct Facet
  {
    Eigen::Vector3f normal;
    float offset;
  };
  std::vector<Facet> facets;
  facets.reserve(polygons.size());
  for (const pcl::Vertices& polygon : polygons)
  {
    if (polygon.vertices.size() < 3)
      continue;
    const Eigen::Vector3f a = vertices[polygon.vertices[0]].getVector3fMap();
    const Eigen::Vector3f b = vertices[polygon.vertices[1]].getVector3fMap();
    const Eigen::Vector3f c = vertices[polygon.vertices[2]].getVector3fMap();
    Eigen::Vector3f normal = (b - a).cross(c - a);
    if (!(normal.norm() > 1e-12f))
      continue;
    normal.normalize();
    float offset = normal.dot(a);
    if (normal.dot(inside) > offset)
    {
      normal = -normal;
      offset = -offset;
    }
    facets.push_back({ normal, offset });
  }

  std::vector<float> best(points.size(), std::numeric_limits<float>::infinity());
  bool any_outside = false;
  std::vector<const Facet*> front;
  for (const Eigen::Vector3f& sensor : sensor_origins)
  {
    if (!sensor.allFinite())
      continue;
    // The facets facing the sensor: every ray from it enters the hull through one of them.
    front.clear();
    for (const Facet& facet : facets)
      if (facet.normal.dot(sensor) > facet.offset + 1e-6f)
        front.push_back(&facet);
    if (front.empty())
      continue;  // the sensor is inside the hull
    any_outside = true;
    for (std::size_t i = 0; i < points.size(); ++i)
    {
      const Eigen::Vector3f p = points[i].getVector3fMap();
      if (!p.allFinite())
        continue;
      const Eigen::Vector3f ray = p - sensor;
      const float length = ray.norm();
      if (!(length > 0.0f))
        continue;
      const Eigen::Vector3f direction = ray / length;
      float entry = -std::numeric_limits<float>::infinity();
      for (const Facet* facet : front)
      {
        const float towards = facet->normal.dot(direction);
        if (towards < -1e-9f)
          entry = std::max(entry, (facet->offset - facet->normal.dot(sensor)) / towards);
      }
      if (std::isfinite(entry))
        best[i] = std::min(best[i], std::max(0.0f, length - entry));
    }
  }
  if (!any_outside)
    return none("no finite sensor origin outside the convex hull: no line of sight to measure along");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (std::isfinite(best[i]))
      depth[i] = best[i];
  if (why)
    why->clear();
  return depth;
}

std::vector<Eigen::Vector2f> boundaryStepPoints(const std::vector<Eigen::Vector2f>& chain, double step_m,
                                                double stop_within_m, std::vector<std::size_t>* segment_of)
{
  std::vector<Eigen::Vector2f> steps;
  if (segment_of)
    segment_of->clear();
  if (chain.empty() || !(step_m > 0.0))
    return steps;
  Eigen::Vector2f p0 = chain.front();
  std::size_t first = 0;  // chain points before `first` are behind the last step point
  steps.push_back(p0);
  if (segment_of)
    segment_of->push_back(0);
  const float r = static_cast<float>(step_m);
  while (true)
  {
    // Fig. 5.13: stop when what is left of the chain lies within stop_within_m (the hand width).
    float farthest = 0.0f;
    for (std::size_t i = first; i < chain.size(); ++i)
      farthest = std::max(farthest, (chain[i] - p0).norm());
    if (farthest < stop_within_m)
      break;
    Eigen::Vector2f crossing;
    std::size_t segment = 0;
    if (!firstCircleCrossing(chain, first, p0, r, crossing, segment))
      break;
    steps.push_back(crossing);
    if (segment_of)
      segment_of->push_back(segment);
    p0 = crossing;
    first = segment + 1;  // Fig. 5.13 (b): the points up to n are removed
  }
  return steps;
}

GraspResult ConcavityGraspPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  const Stopwatch stopwatch;
  auto finish = [&stopwatch](GraspResult result) {
    result.compute_time_s = stopwatch.elapsedSeconds();
    return result;
  };
  const ConcavityParams& p = params_;
  if (std::optional<GraspResult> bad_input =
          checkPlannerInput("concavity", p.validate(), gripper, view, std::max<std::size_t>(p.min_points, 4), p.input_limits))
    return finish(*bad_input);

  CloudXYZ::Ptr finite(new CloudXYZ);
  finite->reserve(view.cloud->size());
  for (const PointNormal& q : view.cloud->points)
    if (std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z))
      finite->push_back(PointXYZ(q.x, q.y, q.z));
  const std::vector<Eigen::Vector3f>& sensors = view.sensor_origins;  // concavity is measured along their rays
  const PrincipalFrame spread = computePrincipalFrame(*finite);
  if (std::sqrt(spread.eigenvalues(1)) < p.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "concavity: collinear points, no plane to project onto and no closing direction"));

  // Down-sampling (see voxel_leaf_m): concavity, regions and bands on the voxel centroids. A
  // large object (a racket, a pan) keeps more than max_analysis_points at that leaf: the leaf
  // grows with the square root of the excess (a surface's points go with 1 / leaf^2), and the
  // lengths tied to the point spacing grow with it.
  CloudXYZ::Ptr object(new CloudXYZ);
  double leaf_m = p.voxel_leaf_m;
  for (int pass = 0; pass < 3 && leaf_m > 0.0; ++pass)
  {
    pcl::VoxelGrid<PointXYZ> voxels;
    voxels.setInputCloud(finite);
    const float leaf = static_cast<float>(leaf_m);
    voxels.setLeafSize(leaf, leaf, leaf);
    voxels.filter(*object);
    if (object->size() <= p.max_analysis_points)
      break;
    leaf_m *= std::sqrt(static_cast<double>(object->size()) / static_cast<double>(p.max_analysis_points));
  }
  if (object->size() < 4)
    *object = *finite;
  ConcavityParams scaled = p;
  scaled.grid_cell_m = std::max(p.grid_cell_m, 1.25 * leaf_m);
  scaled.cluster_tolerance_m = std::max(p.cluster_tolerance_m, 2.5 * leaf_m);
  scaled.gap_m = std::max(p.gap_m, 2.0 * leaf_m);
  scaled.boundary_tolerance_m = std::max(p.boundary_tolerance_m, 2.0 * leaf_m);

  // Step 1: concavity of every (down-sampled) point.
  std::string no_hull;
  const std::vector<float> concavity = concavityBelowConvexHull(*object, sensors, &no_hull);
  const float deepest = concavity.empty() ? 0.0f : *std::max_element(concavity.begin(), concavity.end());

  // Step 2: salient concave points, clustered into regions, largest and deepest first.
  GraspResult result;
  std::vector<int> concave;
  for (std::size_t i = 0; i < concavity.size(); ++i)
    if (concavity[i] >= p.min_concavity_m)
    {
      concave.push_back(static_cast<int>(i));
      const PointXYZ& q = (*object)[i];
      result.graspable_zone.push_back(q);
    }
  std::vector<std::vector<int>> regions;
  if (concave.size() >= p.min_region_points)
  {
    pcl::search::KdTree<PointXYZ>::Ptr tree(new pcl::search::KdTree<PointXYZ>);
    tree->setInputCloud(object, pcl::IndicesConstPtr(new std::vector<int>(concave)));
    pcl::EuclideanClusterExtraction<PointXYZ> clustering;
    clustering.setInputCloud(object);
    clustering.setIndices(pcl::IndicesPtr(new std::vector<int>(concave)));
    clustering.setSearchMethod(tree);
    clustering.setClusterTolerance(scaled.cluster_tolerance_m);
    clustering.setMinClusterSize(static_cast<int>(p.min_region_points));
    std::vector<pcl::PointIndices> clusters;
    clustering.extract(clusters);
    std::vector<std::pair<double, std::vector<int>>> ranked;
    for (pcl::PointIndices& cluster : clusters)
    {
      double sum = 0.0;
      for (const int i : cluster.indices)
        sum += concavity[static_cast<std::size_t>(i)];
      ranked.emplace_back(sum, std::move(cluster.indices));  // points x mean concavity
    }
    std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    for (std::size_t k = 0; k < ranked.size() && k < p.max_regions; ++k)
      regions.push_back(std::move(ranked[k].second));
  }

  PlanContext ctx;
  ctx.params = &scaled;
  ctx.gripper = &gripper;
  ctx.object = object.get();
  ctx.sensor = sensors.front();
  ctx.hand_width_m = p.hand_width_m > 0.0 ? p.hand_width_m : gripper.finger_width_m;

  // Step 7 and the hand: the one hand volume against the seen points, the unseen part and the
  // table, backing out along -approach (gripper_volume.h).
  std::optional<GripperVolumeCheck> hand;
  if (p.gripper_fit.enabled)
  {
    hand.emplace(gripper, p.gripper_fit);
    hand->addSeen(*finite);
    hand->addObstacles(view);
    if (p.use_unseen_part)
    {
      UnseenPartParams unseen_params = p.unseen;
      unseen_params.min_grid_cell_m = std::max(unseen_params.min_grid_cell_m, leaf_m);
      std::optional<Eigen::Vector4f> table;
      if (view.has_table_plane)
        table = view.table_plane;
      UnseenPart unseen = buildUnseenPart(*object, sensors, unseen_params, table);
      if (unseen.ok())
      {
        hand->addUnseen(unseen.points);
        result.unseen = std::move(unseen.points);
      }
    }
    if (view.has_table_plane)
      hand->setTable(view.table_plane);
  }
  std::string first_misfit;
  std::size_t stable_total = 0;
  auto fitHand = [&](std::vector<GraspCandidate> stable) {
    sortGraspsBestFirst(stable);
    stable_total += stable.size();
    if (!hand)
    {
      if (stable.size() > p.max_grasps)
        stable.resize(p.max_grasps);
      return stable;
    }
    std::string why;
    hand->filter(stable, &why, p.max_grasps);
    if (first_misfit.empty())
      first_misfit = why;
    return stable;
  };

  std::ostringstream summary;
  summary << "concavity: ";
  if (leaf_m > p.voxel_leaf_m)
    summary << "voxel leaf grown to " << formatNumber(leaf_m) << " m (" << object->size() << " points); ";
  for (const std::vector<int>& region : regions)
    analyseRegion(region, ctx);
  std::vector<GraspCandidate> grasps = fitHand(ctx.stable);
  if (!regions.empty())
  {
    summary << regions.size() << " salient concave region(s) (largest " << regions.front().size()
            << " points, deepest " << formatNumber(deepest) << " m)";
  }
  else
  {
    summary << "no salient concavity (";
    if (concave.empty())
      summary << "deepest " << formatNumber(deepest) << " m < " << formatNumber(p.min_concavity_m) << " m";
    else
      summary << concave.size() << " points " << formatNumber(p.min_concavity_m) << "-" << formatNumber(deepest)
              << " m deep, in no cluster of " << p.min_region_points << " points";
    summary << (no_hull.empty() ? "" : "; " + no_hull) << ")";
  }
  if (grasps.empty())
  {
    // The whole object as one region: convex objects, and concavities with no grasp.
    if (!regions.empty())
      summary << " gave no grasp";
    summary << ": the whole object as one region";
    std::vector<int> all(object->size());
    std::iota(all.begin(), all.end(), 0);
    ctx.stable.clear();
    analyseRegion(all, ctx);
    grasps = fitHand(ctx.stable);
  }

  sortGraspsBestFirst(ctx.evaluated);
  result.candidates = std::move(ctx.evaluated);
  result.candidates_evaluated = ctx.evaluated_count;
  result.hull = std::move(ctx.hull);
  if (!grasps.empty())
  {
    result.grasps = std::move(grasps);
    summary << "; " << result.grasps.size() << " grasps, best force balance "
            << formatNumber(result.grasps.front().force_balance_rad) << " rad, width "
            << formatNumber(result.grasps.front().width_m) << " m";
    result.message = summary.str();
    return finish(std::move(result));
  }
  if (stable_total > 0)
  {
    result.failure = GraspFailure::NoStableGrasp;
    summary << "; " << stable_total << " stable grasps but the hand fits at none (first: " << first_misfit << ")";
  }
  else if (ctx.within_opening == 0)
  {
    result.failure = GraspFailure::NoGraspableZone;
    summary << "; no graspable zone: no boundary step point has an object extent within the "
            << formatNumber(gripper.max_opening_m) << " m opening along its closing line";
    if (std::isfinite(ctx.rejected.narrowest_m))
      summary << " (narrowest " << formatNumber(ctx.rejected.narrowest_m) << " m)";
    summary << "; " << ctx.evaluated_count << " candidates: " << describeRejections(ctx.rejected);
  }
  else
  {
    result.failure = GraspFailure::NoStableGrasp;
    summary << "; " << ctx.within_opening << " candidates fit the opening but none is stable (best force balance "
            << formatNumber(ctx.rejected.best_balance_rad) << " rad > " << formatNumber(p.force_balance_max_rad)
            << " rad); " << describeRejections(ctx.rejected);
  }
  result.message = summary.str();
  return finish(std::move(result));
}

}  // namespace fast_grasp
