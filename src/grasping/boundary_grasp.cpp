#include "fast_grasp/grasping/boundary_grasp.h"
#include "fast_grasp/grasping/planner_input.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

namespace fast_grasp
{
namespace
{
// The grid grows its cell rather than exceed this many cells per side (a mis-scaled cloud must
// not allocate without bound).
constexpr int kMaxGridCells1d = 1000;  // <= 1M cells, ~9 MB of scratch

/// Mean point spacing on the plane: the points of a 1 cm grid's well-filled cells (75th
/// percentile of the occupied cells' counts, so the part-filled rim cells do not count) are
/// spread over 1 cm^2 each.
double estimateSpacing(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi)
{
  const double coarse = std::max(0.01, std::max(hi.x() - lo.x(), hi.y() - lo.y()) / 200.0);
  const int cols = static_cast<int>((hi.x() - lo.x()) / coarse) + 1;
  const int rows = static_cast<int>((hi.y() - lo.y()) / coarse) + 1;
  std::vector<int> counts(static_cast<std::size_t>(cols * rows), 0);
  for (const auto& p : points)
  {
    const int c = std::min(cols - 1, static_cast<int>((p.x() - lo.x()) / coarse));
    const int r = std::min(rows - 1, static_cast<int>((p.y() - lo.y()) / coarse));
    ++counts[static_cast<std::size_t>(r * cols + c)];
  }
  std::vector<int> occupied;
  for (int n : counts)
    if (n > 0)
      occupied.push_back(n);
  if (occupied.empty())
    return 0.0;
  const std::size_t q = occupied.size() * 3 / 4;
  std::nth_element(occupied.begin(), occupied.begin() + static_cast<std::ptrdiff_t>(q), occupied.end());
  return coarse / std::sqrt(static_cast<double>(std::max(1, occupied[q])));
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

/// Area centroid of a simple polygon (the centre of gravity of a uniform flat object).
Eigen::Vector2d polygonCentroid(const std::vector<Eigen::Vector2d>& polygon)
{
  double area2 = 0.0;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < polygon.size(); ++i)
  {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
    const double c = cross2(a, b);
    area2 += c;
    sum += c * (a + b);
  }
  if (std::abs(area2) < 1e-12)
  {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : polygon)
      mean += p;
    return polygon.empty() ? mean : Eigen::Vector2d(mean / static_cast<double>(polygon.size()));
  }
  return sum / (3.0 * area2);
}

double signedArea(const std::vector<Eigen::Vector2d>& polygon)
{
  double area2 = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i)
    area2 += cross2(polygon[i], polygon[(i + 1) % polygon.size()]);
  return 0.5 * area2;
}

/// One pair of finger candidates in the plane.
struct PairEvaluation
{
  std::size_t i = 0, j = 0;
  Eigen::Vector2d closing = Eigen::Vector2d::Zero();  // unit, from finger i toward finger j
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double width_m = 0.0;
  double force_balance_rad = 0.0;
  double torque_offset_m = 0.0;
  double variance_m = 0.0;
  double gravity_offset_m = 0.0;
  double penalty_m = 0.0;
};

/// Eq. 4.2: a contour point inside the region the closing fingers sweep (|x| <= w_h / 2 across
/// the closing direction, between the contact and the open finger's outer face along it).
bool operable(const std::vector<Eigen::Vector2d>& contour, const PairEvaluation& pair, double hand_width_m,
              double open_half_extent_m, double tolerance_m)
{
  const Eigen::Vector2d across(-pair.closing.y(), pair.closing.x());
  const double half_width = 0.5 * hand_width_m;
  const double inner = 0.5 * pair.width_m + tolerance_m;
  for (const auto& p : contour)
  {
    const Eigen::Vector2d d = p - pair.centre;
    const double x = d.dot(across);
    if (std::abs(x) > half_width)
      continue;
    const double y = std::abs(d.dot(pair.closing));
    if (y > inner && y <= open_half_extent_m)
      return false;
  }
  return true;
}
}  // namespace

std::string BoundaryParams::validate() const
{
  std::ostringstream why;
  if (!(grid_cell_m > 0.0) || !std::isfinite(grid_cell_m))
    why << "grid_cell_m must be > 0; ";
  if (!(spacing_cell_factor >= 0.0))
    why << "spacing_cell_factor must be >= 0; ";
  if (close_cells < 0)
    why << "close_cells must be >= 0; ";
  if (!(step_m > 0.0) || !std::isfinite(step_m))
    why << "step_m must be > 0; ";
  if (!(finger_width_m >= 0.0))
    why << "finger_width_m must be >= 0 (0 = the gripper's); ";
  if (!(inside_probe_step_m > 0.0) || inside_probe_max_steps < 1)
    why << "inside_probe_step_m must be > 0 and inside_probe_max_steps >= 1; ";
  if (!(force_balance_max_rad >= 0.0) || !(torque_offset_max_m >= 0.0) || !(opening_margin_m >= 0.0) ||
      !(variance_max_m >= 0.0) || !(operability_tolerance_m >= 0.0))
    why << "thresholds must be >= 0; ";
  if (!(force_balance_weight_m_per_rad >= 0.0) || !(torque_weight >= 0.0) || !(variance_weight >= 0.0) ||
      !(width_weight >= 0.0))
    why << "score weights must be >= 0; ";
  if (max_finger_candidates < 2)
    why << "max_finger_candidates must be >= 2; ";
  if (min_points < 1 || max_grasps < 1)
    why << "min_points and max_grasps must be >= 1; ";
  if (!(min_thickness_m >= 0.0))
    why << "min_thickness_m must be >= 0; ";
  if (!(max_normal_sight_angle_rad >= 0.0) || !(max_normal_sight_angle_rad <= M_PI / 2.0))
    why << "max_normal_sight_angle_rad must be in [0, pi/2]; ";
  why << gripper_fit.validate();
  return why.str();
}

OrderedContour traceOrderedContour(const std::vector<Eigen::Vector3d>& plane_points, double cell_m, int close_cells)
{
  OrderedContour contour;
  if (plane_points.empty() || !(cell_m > 0.0))
    return contour;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const auto& p : plane_points)
  {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  const int pad = std::max(0, close_cells) + 1;  // empty ring: dilation and tracing never leave the grid
  double cell = cell_m;
  const double extent = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  if (extent / cell > kMaxGridCells1d - 2 * pad)
    cell = extent / (kMaxGridCells1d - 2 * pad);
  contour.cell_m = cell;
  const int cols = static_cast<int>(std::floor((hi.x() - lo.x()) / cell)) + 1 + 2 * pad;
  const int rows = static_cast<int>(std::floor((hi.y() - lo.y()) / cell)) + 1 + 2 * pad;
  const std::size_t cells = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  auto at = [cols](int c, int r) { return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c); };
  std::vector<std::uint8_t> occupied(cells, 0);
  std::vector<float> deepest(cells, std::numeric_limits<float>::infinity());
  for (const auto& p : plane_points)
  {
    const int c = std::min(cols - pad - 1, static_cast<int>((p.x() - lo.x()) / cell) + pad);
    const int r = std::min(rows - pad - 1, static_cast<int>((p.y() - lo.y()) / cell) + pad);
    occupied[at(c, r)] = 1;
    deepest[at(c, r)] = std::min(deepest[at(c, r)], static_cast<float>(p.z()));
  }
  closeBinaryGrid(occupied, cols, rows, close_cells);

  // The largest 8-connected region (stray clusters and speckle are not the object's outline).
  std::vector<int> label(cells, -1);
  int best_label = -1;
  std::size_t best_size = 0, best_first = 0;
  std::vector<std::size_t> stack;
  int next_label = 0;
  for (std::size_t start = 0; start < cells; ++start)
  {
    if (!occupied[start] || label[start] >= 0)
      continue;
    std::size_t size = 0;
    label[start] = next_label;
    stack.assign(1, start);
    while (!stack.empty())
    {
      const std::size_t index = stack.back();
      stack.pop_back();
      ++size;
      const int c = static_cast<int>(index % cols), r = static_cast<int>(index / cols);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc)
        {
          const std::size_t n = at(c + dc, r + dr);  // the empty ring keeps c + dc, r + dr inside
          if (occupied[n] && label[n] < 0)
          {
            label[n] = next_label;
            stack.push_back(n);
          }
        }
    }
    if (size > best_size)
    {
      best_size = size;
      best_label = next_label;
      best_first = start;  // first in raster order: its west neighbour is outside the region
    }
    ++next_label;
  }
  if (best_label < 0)
    return contour;
  auto inside = [&](int c, int r) { return label[at(c, r)] == best_label; };

  // Moore-neighbour tracing (clockwise in grid coordinates), stopped when the first move
  // repeats from the start cell (Jacob's criterion, so one-cell-wide necks are walked both ways).
  static const std::array<int, 8> dc = { 1, 1, 0, -1, -1, -1, 0, 1 };
  static const std::array<int, 8> dr = { 0, 1, 1, 1, 0, -1, -1, -1 };
  auto directionOf = [](int ddc, int ddr) {
    for (int d = 0; d < 8; ++d)
      if (dc[d] == ddc && dr[d] == ddr)
        return d;
    return 0;
  };
  const int start_c = static_cast<int>(best_first % cols), start_r = static_cast<int>(best_first / cols);
  std::vector<std::pair<int, int>> trace{ { start_c, start_r } };
  int c = start_c, r = start_r, back = 4;  // backtrack: the west neighbour
  int first_move = -1;
  const std::size_t max_steps = 4 * best_size + 8;
  for (std::size_t step = 0; step < max_steps; ++step)
  {
    int found = -1;
    for (int k = 1; k <= 8; ++k)
    {
      const int d = (back + k) % 8;
      if (inside(c + dc[d], r + dr[d]))
      {
        found = d;
        break;
      }
    }
    if (found < 0)
      break;  // a single cell
    if (c == start_c && r == start_r)
    {
      if (first_move < 0)
        first_move = found;
      else if (found == first_move)
        break;
    }
    const int previous = (found + 7) % 8;  // the empty neighbour examined just before
    const int bc = c + dc[previous], br = r + dr[previous];
    c += dc[found];
    r += dr[found];
    back = directionOf(bc - c, br - r);
    if (!(c == start_c && r == start_r))
      trace.emplace_back(c, r);
  }
  if (trace.size() < 3)
    return contour;

  // Cell centres on the plane, and per cell the deepest point of it or of its neighbours
  // (cells the closing filled hold no point).
  std::vector<Eigen::Vector2d> centres;
  centres.reserve(trace.size());
  std::vector<double> depth;
  depth.reserve(trace.size());
  double fallback = 0.0;
  for (const auto& p : plane_points)
    fallback = std::min(fallback, p.z());
  for (const auto& [tc, tr] : trace)
  {
    centres.emplace_back(lo.x() + (tc - pad + 0.5) * cell, lo.y() + (tr - pad + 0.5) * cell);
    float d = deepest[at(tc, tr)];
    if (!std::isfinite(d))
      for (int ddr = -1; ddr <= 1; ++ddr)
        for (int ddc = -1; ddc <= 1; ++ddc)
          d = std::min(d, deepest[at(tc + ddc, tr + ddr)]);
    depth.push_back(std::isfinite(d) ? static_cast<double>(d) : fallback);
  }
  if (signedArea(centres) < 0.0)
  {
    std::reverse(centres.begin() + 1, centres.end());  // keep the first vertex first
    std::reverse(depth.begin() + 1, depth.end());
  }
  // Counter-clockwise now: outward is to the right of the direction of travel. Centres of the
  // boundary cells lie half a cell inside the region's edge; move them out onto it.
  const std::size_t n = centres.size();
  std::vector<Eigen::Vector2d> moved(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    const Eigen::Vector2d tangent = centres[(i + 1) % n] - centres[(i + n - 1) % n];
    const double length = tangent.norm();
    moved[i] = centres[i];
    if (length > 1e-12)
      moved[i] += 0.5 * cell * Eigen::Vector2d(tangent.y(), -tangent.x()) / length;
  }
  contour.points.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    contour.points[i] = 0.25 * moved[(i + n - 1) % n] + 0.5 * moved[i] + 0.25 * moved[(i + 1) % n];
  contour.depth_m = std::move(depth);
  return contour;
}

std::optional<ContourPoint> nextContourPointAtDistance(const std::vector<Eigen::Vector2d>& contour,
                                                       const ContourPoint& from, double radius)
{
  const std::size_t n = contour.size();
  if (n < 2 || !(radius > 0.0))
    return std::nullopt;
  const Eigen::Vector2d& s = from.point;
  for (std::size_t k = 0; k < n; ++k)
  {
    const std::size_t segment = (from.segment + k) % n;
    // The first segment starts at `from` itself (the part behind it was already walked).
    const Eigen::Vector2d a = k == 0 ? s : contour[segment];
    const Eigen::Vector2d b = contour[(segment + 1) % n];
    const double da = (a - s).norm(), db = (b - s).norm();
    // Eq. 4.1: d_n <= r <= d_n+1 (leaving the circle) or d_n >= r >= d_n+1 (entering it).
    if (!((da <= radius && radius <= db) || (da >= radius && radius >= db)))
      continue;
    const Eigen::Vector2d ab = b - a;
    const double qa = ab.squaredNorm();
    if (qa < 1e-24)
      continue;
    const double qb = 2.0 * ab.dot(a - s);
    const double qc = (a - s).squaredNorm() - radius * radius;
    const double root = std::sqrt(std::max(0.0, qb * qb - 4.0 * qa * qc));
    // Leaving: the larger root; entering: the smaller one.
    double t = (da <= radius ? (-qb + root) : (-qb - root)) / (2.0 * qa);
    t = std::clamp(t, 0.0, 1.0);
    return ContourPoint{ a + t * ab, segment };
  }
  return std::nullopt;
}

std::vector<ContourPoint> contourStepPoints(const std::vector<Eigen::Vector2d>& contour, double step_m)
{
  std::vector<ContourPoint> steps;
  const std::size_t n = contour.size();
  if (n < 3 || !(step_m > 0.0))
    return steps;
  steps.push_back(ContourPoint{ contour[0], 0 });
  double perimeter = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    perimeter += (contour[(i + 1) % n] - contour[i]).norm();
  // Each step advances by a chord of step_m, at most one arc of it: the guard only stops a walk
  // that no longer advances.
  const std::size_t max_steps = static_cast<std::size_t>(perimeter / step_m) + n + 4;
  // Unwrapped segment index of the walk: the lap is over when it passes the last segment.
  std::size_t walked = 0;
  while (steps.size() <= max_steps)
  {
    const ContourPoint& current = steps.back();
    const std::optional<ContourPoint> next = nextContourPointAtDistance(contour, current, step_m);
    if (!next)
      break;
    walked += (next->segment + n - current.segment) % n;
    if (walked >= n)
      break;  // wrapped past the first vertex
    if (walked == n - 1 && (next->point - steps.front().point).norm() < 0.5 * step_m)
      break;  // the lap closes at the first step point
    steps.push_back(*next);
  }
  return steps;
}

bool insidePolygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& point)
{
  bool inside = false;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++)
  {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    if ((a.y() > point.y()) != (b.y() > point.y()))
    {
      const double x = a.x() + (point.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (point.x() < x)
        inside = !inside;
    }
  }
  return inside;
}

std::vector<FingerCandidate> fingerCandidates(const OrderedContour& contour, const std::vector<ContourPoint>& step_points,
                                              double finger_width_m, double probe_step_m, int probe_max_steps)
{
  std::vector<FingerCandidate> fingers;
  const std::vector<Eigen::Vector2d>& points = contour.points;
  const std::size_t n = points.size();
  if (n < 3)
    return fingers;
  fingers.reserve(step_points.size());
  for (const ContourPoint& start : step_points)
  {
    const std::optional<ContourPoint> end = nextContourPointAtDistance(points, start, finger_width_m);
    if (!end)
      continue;
    FingerCandidate finger;
    finger.start = start;
    finger.end = *end;
    finger.middle = 0.5 * (start.point + end->point);
    const Eigen::Vector2d along = (end->point - start.point).normalized();
    // Y = Z x X (the left normal); the sense is fixed below for all fingers at once.
    finger.inward = Eigen::Vector2d(-along.y(), along.x());
    // The grasp side: the contour vertices between the finger's start and end (Fig. 4.15).
    double variance = 0.0, depth_sum = 0.0;
    std::size_t side_count = 0;
    // (none when the finger ends on the segment it starts on)
    const std::size_t interior = (end->segment + n - start.segment) % n;
    for (std::size_t k = (start.segment + 1) % n, counted = 0; counted < interior; k = (k + 1) % n, ++counted)
    {
      const Eigen::Vector2d d = points[k] - start.point;
      variance += std::abs(cross2(along, d));
      depth_sum += contour.depth_m[k];
      ++side_count;
    }
    finger.side_variance_m = variance;
    finger.depth_m = side_count > 0 ? depth_sum / static_cast<double>(side_count) : contour.depth_m[start.segment];
    fingers.push_back(finger);
  }
  // Fig. 4.11 a: probe pairs m +- k delta n along the first finger's bisector until exactly
  // one is inside; the inside one gives the sense of the cross product for every finger.
  double sense = 0.0;
  for (const FingerCandidate& finger : fingers)
  {
    for (int k = 1; k <= probe_max_steps && sense == 0.0; ++k)
    {
      const Eigen::Vector2d offset = (k * probe_step_m) * finger.inward;
      const bool plus = insidePolygon(points, finger.middle + offset);
      const bool minus = insidePolygon(points, finger.middle - offset);
      if (plus != minus)
        sense = plus ? 1.0 : -1.0;
      else if (!plus && !minus)
        break;  // both outside: a spike thinner than the probe, try the next finger
    }
    if (sense != 0.0)
      break;
  }
  if (sense == 0.0)
    sense = signedArea(points) >= 0.0 ? 1.0 : -1.0;  // no conclusive probe (tiny outline)
  for (FingerCandidate& finger : fingers)
    finger.inward *= sense;
  return fingers;
}

// Main plane. pcl::MomentOfInertiaEstimation's OBB axes are the eigenvectors of the same
// covariance matrix (major, middle, minor), so its main plane is the PCA plane; but compute()
// also sweeps the moment of inertia and eccentricity over rotations about each axis. Measured
// here (PCL 1.13, -O2, taskset one core, 10k points of a half cylinder): compute() + getOBB()
// 30-37 ms, computePrincipalFrame 0.14-0.43 ms, the same minor axis (|dot| = 1); the 10 ms
// budget leaves no room for the former.
GraspResult BoundaryGraspPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  const Stopwatch stopwatch;
  auto finish = [&stopwatch](GraspResult result) {
    result.compute_time_s = stopwatch.elapsedSeconds();
    return result;
  };
  const BoundaryParams& p = params_;
  if (std::optional<GraspResult> bad_input = checkPlannerInput("boundary", p.validate(), gripper, view, p.min_points, p.input_limits))
    return finish(*bad_input);

  // Ch4.3.1 A-B: main plane (major and middle axis), normal toward the sensor.
  const PrincipalFrame pca = computePrincipalFrame(*view.cloud);
  if (!(std::sqrt(pca.eigenvalues(1)) >= p.min_thickness_m))
    return finish(GraspResult::fail(GraspFailure::DegenerateInput, "boundary: collinear points, no outline"));
  const Eigen::Vector3d centroid = pca.centroid.cast<double>();
  const Eigen::Vector3d sight = (view.sensor_origins.front().cast<double>() - centroid).normalized();
  Eigen::Vector3d normal = pca.axes.col(2).cast<double>().normalized();
  const Eigen::Vector3d middle = pca.axes.col(1).cast<double>().normalized();
  // Beyond the thesis: a single view of a round object (a glass seen into its bowl) can be deeper
  // along the line of sight than wide across it; its thinnest axis then lies across the view and
  // the hand would come from the side the camera did not see. Take the middle axis instead when
  // the minor one is that far from the line of sight.
  if (std::abs(normal.dot(sight)) < std::cos(p.max_normal_sight_angle_rad) &&
      std::abs(middle.dot(sight)) > std::abs(normal.dot(sight)))
    normal = middle;
  if (normal.dot(sight) < 0.0)
    normal = -normal;
  const Eigen::Vector3d axis_u = pca.axes.col(0).cast<double>().normalized();
  const Eigen::Vector3d axis_v = normal.cross(axis_u);
  std::vector<Eigen::Vector3d> plane_points;
  plane_points.reserve(view.cloud->size());
  for (const auto& point : view.cloud->points)
    if (std::isfinite(point.x) && std::isfinite(point.y) && std::isfinite(point.z))
    {
      const Eigen::Vector3d d = point.getVector3fMap().cast<double>() - centroid;
      plane_points.emplace_back(d.dot(axis_u), d.dot(axis_v), d.dot(normal));
    }
  auto toBase = [&](const Eigen::Vector2d& xy, double depth) {
    return Eigen::Vector3d(centroid + xy.x() * axis_u + xy.y() * axis_v + depth * normal);
  };

  // Ch4.3.1 B: the ordered outline (Fig. 4.5), on a grid no finer than the point spacing.
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& q : plane_points)
  {
    lo = lo.cwiseMin(q.head<2>());
    hi = hi.cwiseMax(q.head<2>());
  }
  const double cell = std::max(p.grid_cell_m, p.spacing_cell_factor * estimateSpacing(plane_points, lo, hi));
  const OrderedContour contour = traceOrderedContour(plane_points, cell, p.close_cells);
  GraspResult result;
  for (std::size_t i = 0; i < contour.points.size(); ++i)
  {
    const Eigen::Vector3f b = toBase(contour.points[i], contour.depth_m[i]).cast<float>();
    result.hull.push_back(PointXYZ(b.x(), b.y(), b.z()));
  }
  auto fail = [&](GraspFailure why, const std::string& message) {
    GraspResult failed = GraspResult::fail(why, "boundary: " + message);
    failed.hull = std::move(result.hull);
    failed.candidates = std::move(result.candidates);
    failed.candidates_evaluated = result.candidates_evaluated;
    return finish(std::move(failed));
  };
  const double finger_width = p.finger_width_m > 0.0 ? p.finger_width_m : gripper.finger_width_m;
  if (contour.points.size() < 3)
    return fail(GraspFailure::DegenerateInput, "the outline has fewer than 3 points");

  // Ch4.3.1 C: step points and finger candidates with their inside directions.
  double perimeter = 0.0;
  for (std::size_t i = 0; i < contour.points.size(); ++i)
    perimeter += (contour.points[(i + 1) % contour.points.size()] - contour.points[i]).norm();
  const double step = std::max(p.step_m, perimeter / static_cast<double>(p.max_finger_candidates));
  const std::vector<ContourPoint> steps = contourStepPoints(contour.points, step);
  const std::vector<FingerCandidate> fingers =
      fingerCandidates(contour, steps, finger_width, p.inside_probe_step_m, p.inside_probe_max_steps);
  if (fingers.size() < 2)
    return fail(GraspFailure::DegenerateInput, "the outline (" + formatNumber(signedArea(contour.points)) +
                                                   " m^2) is too small for two finger candidates of " +
                                                   formatNumber(finger_width) + " m");
  const Eigen::Vector2d gravity_centre = polygonCentroid(contour.points);

  // Ch4.3.2 A-E and 4.3.3 over every pair. Cheap tests first; operability last (a scan of the
  // contour).
  const double max_width = gripper.max_opening_m - p.opening_margin_m;
  const double open_opening = p.gripper_fit.approach_opening_m > 0.0 ? p.gripper_fit.approach_opening_m : gripper.max_opening_m;
  const double open_half_extent = 0.5 * open_opening + gripper.finger_thickness_m;
  std::size_t facing = 0, opposed = 0, in_range = 0, balanced = 0, smooth = 0;
  double narrowest_opposed = std::numeric_limits<double>::infinity();
  std::vector<PairEvaluation> stable;
  for (std::size_t i = 0; i < fingers.size(); ++i)
    for (std::size_t j = i + 1; j < fingers.size(); ++j)
    {
      const FingerCandidate& a = fingers[i];
      const FingerCandidate& b = fingers[j];
      PairEvaluation pair;
      pair.i = i;
      pair.j = j;
      // A: gamma_ij, the angle between F_i and -F_j.
      pair.force_balance_rad = std::acos(std::clamp(-a.inward.dot(b.inward), -1.0, 1.0));
      if (pair.force_balance_rad > M_PI / 2.0)
        continue;  // the forces do not oppose each other at all
      const Eigen::Vector2d mean_force = a.inward - b.inward;
      pair.closing = mean_force.normalized();
      const Eigen::Vector2d between = b.middle - a.middle;
      pair.width_m = between.dot(pair.closing);
      if (!(pair.width_m > 0.0))
        continue;  // both fingers push the same way: each faces away from the other
      ++facing;
      if (pair.force_balance_rad > p.force_balance_max_rad)
        continue;
      ++opposed;
      if (pair.width_m >= gripper.min_opening_m)
        narrowest_opposed = std::min(narrowest_opposed, pair.width_m);
      // C: grasping range. Opposed pairs within it are the graspable zone.
      if (pair.width_m > max_width || pair.width_m < gripper.min_opening_m)
        continue;
      ++in_range;
      // B: torque balance, the lever of the squeezing couple.
      pair.torque_offset_m = std::abs(cross2(pair.closing, between));
      if (pair.torque_offset_m > p.torque_offset_max_m)
        continue;
      ++balanced;
      // D: variance of both grasp sides.
      pair.variance_m = a.side_variance_m + b.side_variance_m;
      if (pair.variance_m > p.variance_max_m)
        continue;
      ++smooth;
      pair.centre = 0.5 * (a.middle + b.middle);
      // 4.3.3: the centre of gravity's distance from the grasping line.
      const Eigen::Vector2d line = between.normalized();
      pair.gravity_offset_m = std::abs(cross2(line, gravity_centre - a.middle));
      pair.penalty_m = pair.gravity_offset_m + p.force_balance_weight_m_per_rad * pair.force_balance_rad +
                       p.torque_weight * pair.torque_offset_m + p.variance_weight * pair.variance_m +
                       p.width_weight * pair.width_m;
      stable.push_back(pair);
    }
  result.candidates_evaluated = facing;
  std::stable_sort(stable.begin(), stable.end(),
                   [](const PairEvaluation& x, const PairEvaluation& y) { return x.penalty_m < y.penalty_m; });

  auto toGrasp = [&](const PairEvaluation& pair) {
    const FingerCandidate& a = fingers[pair.i];
    const FingerCandidate& b = fingers[pair.j];
    GraspCandidate grasp;
    grasp.algorithm = "boundary";
    const double depth = 0.5 * (a.depth_m + b.depth_m);
    const Eigen::Vector3d closing = pair.closing.x() * axis_u + pair.closing.y() * axis_v;
    grasp.pose = makeGraspPose(toBase(pair.centre, depth), -normal, closing);
    grasp.width_m = pair.width_m;
    grasp.score = -pair.penalty_m;
    grasp.force_balance_rad = pair.force_balance_rad;
    grasp.torque_offset_m = pair.torque_offset_m;
    grasp.variance_m = pair.variance_m;
    grasp.gravity_offset_m = pair.gravity_offset_m;
    grasp.contact_a = toBase(a.middle, a.depth_m);
    grasp.contact_b = toBase(b.middle, b.depth_m);
    return grasp;
  };

  // E: operability (Eq. 4.2), best first, on as many as can be kept.
  std::vector<GraspCandidate> grasps;
  std::size_t blocked = 0;
  for (const PairEvaluation& pair : stable)
  {
    GraspCandidate grasp = toGrasp(pair);
    if (result.candidates.size() < p.max_recorded_candidates)
      result.candidates.push_back(grasp);
    if (!operable(contour.points, pair, finger_width, open_half_extent, p.operability_tolerance_m))
    {
      ++blocked;
      continue;
    }
    grasps.push_back(grasp);
  }

  if (in_range == 0)
  {
    if (opposed == 0)
      return fail(GraspFailure::NoGraspableZone, "no two of the " + std::to_string(fingers.size()) +
                                                     " finger candidates oppose each other within force_balance_max_rad (" +
                                                     std::to_string(facing) + " pairs face each other)");
    if (!std::isfinite(narrowest_opposed))
      return fail(GraspFailure::NoGraspableZone, "every pair of opposed finger candidates is closer than the gripper's " +
                                                     formatNumber(gripper.min_opening_m) +
                                                     " m min_opening_m (an outline thinner than the gripper can hold)");
    return fail(GraspFailure::NoGraspableZone, "the narrowest pair of opposed finger candidates is " +
                                                   formatNumber(narrowest_opposed) + " m apart, wider than the " +
                                                   formatNumber(max_width) + " m the gripper can close on");
  }
  if (grasps.empty())
  {
    std::ostringstream why;
    why << in_range << " opposed finger pairs (force balance <= " << p.force_balance_max_rad
        << " rad) fit the opening; " << balanced << " pass torque balance (<= " << p.torque_offset_max_m << " m), " << smooth
        << " the variance (<= " << p.variance_max_m << " m), " << (smooth - blocked) << " operability (Eq. 4.2)";
    return fail(GraspFailure::NoStableGrasp, why.str());
  }

  // Final check with the real hand: seen points, unseen part, table.
  const std::size_t stable_count = grasps.size();
  if (p.gripper_fit.enabled)
  {
    GripperVolumeCheck check(gripper, p.gripper_fit);
    check.addSeen(*view.cloud);
    check.addObstacles(view);
    if (p.use_unseen_part)
    {
      std::optional<Eigen::Vector4f> table;
      if (view.has_table_plane)
        table = view.table_plane;
      const UnseenPart unseen = buildUnseenPart(*view.cloud, view.sensor_origins, p.unseen, table);
      if (unseen.ok())
      {
        check.addUnseen(unseen.points);
        result.unseen = unseen.points;
      }
    }
    if (view.has_table_plane)
      check.setTable(view.table_plane);
    std::string why;
    check.filter(grasps, &why, p.max_grasps);
    if (grasps.empty())
      return fail(GraspFailure::NoStableGrasp, std::to_string(stable_count) +
                                                   " grasps pass Ch4's checks but the hand does not fit at any (first: " +
                                                   why + ")");
  }
  if (grasps.size() > p.max_grasps)
    grasps.resize(p.max_grasps);
  sortGraspsBestFirst(grasps);
  result.grasps = std::move(grasps);
  std::ostringstream message;
  message << "boundary: " << result.grasps.size() << " grasps from " << fingers.size() << " finger candidates, best width "
          << formatNumber(result.grasps.front().width_m) << " m, gravity offset "
          << formatNumber(result.grasps.front().gravity_offset_m) << " m";
  result.message = message.str();
  return finish(std::move(result));
}

}  // namespace fast_grasp
