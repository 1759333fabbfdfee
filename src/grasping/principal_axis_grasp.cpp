#include "fast_grasp/grasping/principal_axis_grasp.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/principal_axis_next_view.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

namespace fast_grasp
{
namespace
{
constexpr float kInfinity = std::numeric_limits<float>::infinity();
// Grid rows/columns are capped so a huge or mis-scaled cloud cannot allocate without bound;
// beyond this the cell grows instead.
constexpr int kMaxGridCells1d = 4000;
// The contour's occupancy grid is 2-D and only drawn (GraspResult::hull): at 4000 x 4000 cells
// its three passes took 15 s per plan under ASan (fuzzing, a 6 m cloud). Its cells grow in
// whole rows of the grid beyond this per side, so objects up to 1 m at 2 mm keep their drawing.
constexpr int kMaxContourCells1d = 500;

/// Right-handed object frame (Eq. 3.3 / 3.8, see the class comment for the X sign).
struct ObjectFrame
{
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Vector3f x = Eigen::Vector3f::UnitX();
  Eigen::Vector3f y = Eigen::Vector3f::UnitY();
  Eigen::Vector3f z = Eigen::Vector3f::UnitZ();

  Eigen::Vector3f toObject(const Eigen::Vector3f& p) const
  {
    const Eigen::Vector3f d = p - origin;
    return Eigen::Vector3f(d.dot(x), d.dot(y), d.dot(z));
  }
  Eigen::Vector3d toBase(double ox, double oy, double oz) const
  {
    return (origin.cast<double>() + ox * x.cast<double>() + oy * y.cast<double>() + oz * z.cast<double>());
  }
};

/// Builds the frame whose Z is the sight line toward `sensor` made perpendicular to the
/// principal axis `axis`; false when the axis points (nearly) at the sensor.
bool makeObjectFrame(const Eigen::Vector3f& centroid, const Eigen::Vector3f& axis, const Eigen::Vector3f& sensor,
                     double min_axis_view_angle_rad, ObjectFrame& frame)
{
  const Eigen::Vector3f sight = sensor - centroid;
  const float sight_norm = sight.norm();
  if (!(sight_norm > 1e-6f))
    return false;
  const Eigen::Vector3f across = sight - sight.dot(axis) * axis;
  if (across.norm() < sight_norm * static_cast<float>(std::sin(min_axis_view_angle_rad)))
    return false;
  frame.origin = centroid;
  frame.y = axis;
  frame.z = across.normalized();
  frame.x = frame.y.cross(frame.z);
  return true;
}

/// One row of the XOY projection grid: the row's left-most and right-most points (the
/// crossings of any sweep line falling in the row) and the Eq. 3.9 contact-region sums.
struct GridRow
{
  float min_x = kInfinity;
  float max_x = -kInfinity;
  float z_at_min = 0.0f;
  float z_at_max = 0.0f;
  int count = 0;
  bool filled = false;  // has points, or was bridged by gap closing
  double left_z_sum = 0.0;
  double right_z_sum = 0.0;
  int left_count = 0;
  int right_count = 0;
};

struct ProjectionGrid
{
  double y_min = 0.0;
  double y_max = 0.0;
  double cell = 0.0;
  double inverse_cell = 0.0;
  std::vector<GridRow> rows;

  // Per point, twice per viewpoint: a multiply, not a division and floor (it is the hot loop).
  int rowOf(double y) const
  {
    const double offset = (y - y_min) * inverse_cell;
    const int last = static_cast<int>(rows.size()) - 1;
    return offset <= 0.0 ? 0 : std::min(static_cast<int>(offset), last);
  }
};

// Why a grid instead of the thesis's concave hull: PCL's 2-D ConcaveHull takes 120 ms on a
// 10k-point cloud on this machine (ConvexHull 2 ms, PCA 0.25 ms) against a 10 ms budget per
// plan, and the sweep lines of Eq. 3.4 only need the left-most and right-most crossing of
// each line with the contour, which are the extremes of the points in the line's row.
// Building the grid is O(n). Measured here at ~10k points (test ReportsComputeTime...):
// a single-view plan 0.4-1.4 ms, a two-camera plan (10 virtual viewpoints) 3.6-8 ms,
// depending on the load of the shared 2-core machine.
bool buildGrid(const std::vector<Eigen::Vector3f>& points, double cell_m, int gap_close_rows, int crossing_window_rows,
               double side_depth_m, ProjectionGrid& grid, std::vector<Eigen::Vector2f>* boundary_xy)
{
  if (points.empty() || !(cell_m > 0.0))
    return false;
  double y_min = std::numeric_limits<double>::infinity(), y_max = -y_min;
  double x_min = y_min, x_max = -y_min;
  for (const auto& p : points)
  {
    y_min = std::min(y_min, double(p.y()));
    y_max = std::max(y_max, double(p.y()));
    x_min = std::min(x_min, double(p.x()));
    x_max = std::max(x_max, double(p.x()));
  }
  double cell = cell_m;
  const double extent = std::max(y_max - y_min, x_max - x_min);
  if (extent / cell > kMaxGridCells1d - 2)
    cell = extent / (kMaxGridCells1d - 2);
  grid.y_min = y_min;
  grid.y_max = y_max;
  grid.cell = cell;
  grid.inverse_cell = 1.0 / cell;
  grid.rows.assign(static_cast<std::size_t>(std::floor((y_max - y_min) / cell)) + 1, GridRow{});

  std::vector<int> point_rows(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const auto& p = points[i];
    const int r = grid.rowOf(p.y());
    point_rows[i] = r;
    GridRow& row = grid.rows[static_cast<std::size_t>(r)];
    if (p.x() < row.min_x)
    {
      row.min_x = p.x();
      row.z_at_min = p.z();
    }
    if (p.x() > row.max_x)
    {
      row.max_x = p.x();
      row.z_at_max = p.z();
    }
    ++row.count;
    row.filled = true;
  }
  // Bridge short runs of empty rows (sensor holes) by interpolating the neighbours.
  int previous = -1;
  for (int r = 0; r < static_cast<int>(grid.rows.size()); ++r)
  {
    if (grid.rows[r].count == 0)
      continue;
    const int gap = r - previous - 1;
    if (previous >= 0 && gap > 0 && gap <= gap_close_rows)
    {
      const GridRow& a = grid.rows[previous];
      const GridRow& b = grid.rows[r];
      for (int k = previous + 1; k < r; ++k)
      {
        const float t = float(k - previous) / float(r - previous);
        GridRow& row = grid.rows[k];
        row.min_x = a.min_x + t * (b.min_x - a.min_x);
        row.max_x = a.max_x + t * (b.max_x - a.max_x);
        row.z_at_min = a.z_at_min + t * (b.z_at_min - a.z_at_min);
        row.z_at_max = a.z_at_max + t * (b.z_at_max - a.z_at_max);
        row.filled = true;
      }
    }
    previous = r;
  }

  // A row's outermost point goes missing when the scan is sparse or noisy (depth noise moves
  // points across 2 mm rows): measured on a 60 mm cylinder with 3 mm noise, single rows read
  // 45-59 mm wide. Taking each row's extremes over a few neighbouring rows restores them; on
  // a side leaning by k it overstates the width by at most 2 k window cell.
  if (crossing_window_rows > 0)
  {
    const std::vector<GridRow> raw = grid.rows;
    const int count = static_cast<int>(raw.size());
    for (int r = 0; r < count; ++r)
    {
      GridRow& row = grid.rows[r];
      if (!row.filled)
        continue;
      for (int k = std::max(0, r - crossing_window_rows); k <= std::min(count - 1, r + crossing_window_rows); ++k)
      {
        const GridRow& other = raw[k];
        if (!other.filled)
          continue;
        if (other.min_x < row.min_x)
        {
          row.min_x = other.min_x;
          row.z_at_min = other.z_at_min;
        }
        if (other.max_x > row.max_x)
        {
          row.max_x = other.max_x;
          row.z_at_max = other.z_at_max;
        }
      }
    }
  }
  // Eq. 3.9 contact regions: points near their own row's (windowed) extremes.
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const auto& p = points[i];
    GridRow& row = grid.rows[static_cast<std::size_t>(point_rows[i])];
    if (p.x() <= row.min_x + side_depth_m)
    {
      row.left_z_sum += p.z();
      ++row.left_count;
    }
    if (p.x() >= row.max_x - side_depth_m)
    {
      row.right_z_sum += p.z();
      ++row.right_count;
    }
  }

  if (boundary_xy)
  {
    // Occupancy with a one-cell border, closed (3x3 dilation then erosion) so holes of one
    // cell between scan lines do not show up as contour.
    const int step = std::max(
        { 1, static_cast<int>(std::ceil(static_cast<double>(grid.rows.size()) / kMaxContourCells1d)),
          static_cast<int>(std::ceil((std::floor((x_max - x_min) / cell) + 1) / kMaxContourCells1d)) });
    const double contour_cell = cell * step;
    const int cols = static_cast<int>(std::floor((x_max - x_min) / contour_cell)) + 3;
    const int rows = static_cast<int>((grid.rows.size() + step - 1) / step) + 2;
    std::vector<std::uint8_t> occupied(static_cast<std::size_t>(cols * rows), 0);
    auto at = [cols](int c, int r) { return static_cast<std::size_t>(r * cols + c); };
    for (const auto& p : points)
    {
      const int c = std::clamp(static_cast<int>(std::floor((p.x() - x_min) / contour_cell)), 0, cols - 3) + 1;
      occupied[at(c, grid.rowOf(p.y()) / step + 1)] = 1;
    }
    auto morph = [&](const std::vector<std::uint8_t>& in, bool dilate) {
      std::vector<std::uint8_t> out(in.size(), 0);
      for (int r = 1; r < rows - 1; ++r)
        for (int c = 1; c < cols - 1; ++c)
        {
          bool any = false, all = true;
          for (int dr = -1; dr <= 1; ++dr)
            for (int dc = -1; dc <= 1; ++dc)
            {
              const bool v = in[at(c + dc, r + dr)] != 0;
              any = any || v;
              all = all && v;
            }
          out[at(c, r)] = static_cast<std::uint8_t>(dilate ? any : all);
        }
      return out;
    };
    // Dilation may reach the border ring only from inside; erosion restores the extent.
    std::vector<std::uint8_t> dilated = morph(occupied, true);
    // Cells at the original extent keep their value: erosion must not eat the real edge, so
    // treat the border ring as occupied wherever the dilation touched its inner neighbour.
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        if (r == 0 || c == 0 || r == rows - 1 || c == cols - 1)
        {
          const int rc = std::clamp(r, 1, rows - 2), cc = std::clamp(c, 1, cols - 2);
          dilated[at(c, r)] = dilated[at(cc, rc)];
        }
    std::vector<std::uint8_t> closed = morph(dilated, false);
    for (std::size_t i = 0; i < closed.size(); ++i)
      closed[i] = static_cast<std::uint8_t>(closed[i] || occupied[i]);
    boundary_xy->clear();
    for (int r = 1; r < rows - 1; ++r)
      for (int c = 1; c < cols - 1; ++c)
      {
        if (!closed[at(c, r)])
          continue;
        if (closed[at(c - 1, r)] && closed[at(c + 1, r)] && closed[at(c, r - 1)] && closed[at(c, r + 1)])
          continue;
        boundary_xy->emplace_back(static_cast<float>(x_min + (c - 1 + 0.5) * contour_cell),
                                  static_cast<float>(y_min + (r - 1 + 0.5) * contour_cell));
      }
  }
  return true;
}

std::vector<SweepLine> sweepLines(const ProjectionGrid& grid, double sweep_step_m)
{
  std::vector<SweepLine> lines;
  if (grid.rows.empty() || !(sweep_step_m > 0.0))
    return lines;
  const std::size_t count = static_cast<std::size_t>(std::floor((grid.y_max - grid.y_min) / sweep_step_m + 1e-9)) + 1;
  lines.reserve(count);
  for (std::size_t n = 0; n < count; ++n)
  {
    SweepLine line;
    line.y_m = grid.y_min + static_cast<double>(n) * sweep_step_m;  // Eq. 3.4
    // Row from the offset itself: (y_min + n step) - y_min can round just below a row start.
    const int row_index = std::min(static_cast<int>(grid.rows.size()) - 1,
                                   static_cast<int>(std::floor(static_cast<double>(n) * sweep_step_m / grid.cell + 1e-9)));
    const GridRow& row = grid.rows[static_cast<std::size_t>(row_index)];
    if (row.filled)
    {
      line.hit = true;
      line.left_x_m = row.min_x;
      line.right_x_m = row.max_x;
      line.left_z_m = row.z_at_min;
      line.right_z_m = row.z_at_max;
    }
    lines.push_back(line);
  }
  return lines;
}

/// One grasp candidate on one sweep line (object-frame quantities).
struct Candidate
{
  std::size_t line = 0;
  int first_row = 0;
  int last_row = 0;
  double y = 0.0;
  double left_x = 0.0, right_x = 0.0;
  double left_z = 0.0, right_z = 0.0;  // mean crossing depth of the band's lines
  double force_balance_rad = 0.0;
  double xoz_offset_m = std::numeric_limits<double>::quiet_NaN();
  bool xoy_ok = false;
  bool xoz_ok = false;
};

/// Everything one viewpoint (real or virtual) yields.
struct ViewEvaluation
{
  ObjectFrame frame;
  ProjectionGrid grid;
  std::vector<SweepLine> lines;
  std::vector<Candidate> candidates;  // one per graspable line with a full finger band
  std::vector<Eigen::Vector2f> boundary_xy;
  double narrowest_width_m = std::numeric_limits<double>::infinity();
  std::size_t graspable_lines = 0;
};

void evaluateView(const std::vector<Eigen::Vector3f>& base_points, const ObjectFrame& frame,
                  const PrincipalAxisParams& params, const GripperModel& gripper, bool with_boundary,
                  ViewEvaluation& view, std::vector<Eigen::Vector3f>& scratch)
{
  view.frame = frame;
  scratch.resize(base_points.size());
  for (std::size_t i = 0; i < base_points.size(); ++i)
    scratch[i] = frame.toObject(base_points[i]);
  if (!buildGrid(scratch, params.grid_cell_m, params.gap_close_rows, params.crossing_window_rows,
                 params.side_depth_m, view.grid, with_boundary ? &view.boundary_xy : nullptr))
    return;
  view.lines = sweepLines(view.grid, params.sweep_step_m);

  // Step 6 band: the lines a finger of finger_width_m covers, at least one either side so
  // each side line fit has three points.
  const int half_band =
      std::max(1, static_cast<int>(std::lround(0.5 * gripper.finger_width_m / params.sweep_step_m)));
  const int line_count = static_cast<int>(view.lines.size());
  std::vector<Eigen::Vector2d> left_side, right_side;
  for (int n = 0; n < line_count; ++n)
  {
    const SweepLine& centre = view.lines[n];
    if (!centre.hit)
      continue;
    const bool clear_of_ends = n - half_band >= 0 && n + half_band < line_count &&
                               view.lines[n - half_band].y_m >= view.grid.y_min + params.end_clearance_m &&
                               view.lines[n + half_band].y_m <= view.grid.y_max - params.end_clearance_m;
    view.narrowest_width_m = std::min(view.narrowest_width_m, centre.widthM());
    if (centre.widthM() > gripper.max_opening_m || centre.widthM() < gripper.min_opening_m)
      continue;
    ++view.graspable_lines;
    left_side.clear();
    right_side.clear();
    bool band_fits = true;
    double left_z = 0.0, right_z = 0.0;
    for (int m = std::max(0, n - half_band); m <= std::min(line_count - 1, n + half_band); ++m)
    {
      const SweepLine& line = view.lines[m];
      if (!line.hit || line.widthM() > gripper.max_opening_m)
      {
        band_fits = false;
        break;
      }
      // Fit x = k y + b (Eq. 3.5 with x and y swapped): sides along the principal axis give k = 0.
      left_side.emplace_back(line.y_m, line.left_x_m);
      right_side.emplace_back(line.y_m, line.right_x_m);
      left_z += line.left_z_m;
      right_z += line.right_z_m;
    }
    if (!band_fits || !clear_of_ends || left_side.size() < 2)
      continue;
    Candidate candidate;
    candidate.line = static_cast<std::size_t>(n);
    candidate.y = centre.y_m;
    candidate.left_x = centre.left_x_m;
    candidate.right_x = centre.right_x_m;
    candidate.left_z = left_z / static_cast<double>(left_side.size());
    candidate.right_z = right_z / static_cast<double>(right_side.size());
    candidate.force_balance_rad =
        std::abs(fitLine(left_side).angleRad()) + std::abs(fitLine(right_side).angleRad());
    candidate.xoy_ok = candidate.force_balance_rad <= params.force_balance_max_rad;

    // Step 7 / Eqs. 3.9-3.10: mean depth of the left and right contact regions of the band.
    candidate.first_row = view.grid.rowOf(left_side.front().x());
    candidate.last_row = view.grid.rowOf(left_side.back().x());
    double left_sum = 0.0, right_sum = 0.0;
    int left_count = 0, right_count = 0;
    for (int r = candidate.first_row; r <= candidate.last_row; ++r)
    {
      const GridRow& row = view.grid.rows[static_cast<std::size_t>(r)];
      left_sum += row.left_z_sum;
      right_sum += row.right_z_sum;
      left_count += row.left_count;
      right_count += row.right_count;
    }
    if (left_count > 0 && right_count > 0)
    {
      candidate.xoz_offset_m = std::abs(left_sum / left_count - right_sum / right_count);
      candidate.xoz_ok = candidate.xoz_offset_m < params.xoz_max_offset_m;
    }
    view.candidates.push_back(candidate);
  }
}

GraspCandidate toGrasp(const Candidate& candidate, const ObjectFrame& frame)
{
  GraspCandidate grasp;
  grasp.algorithm = "principal_axis";
  grasp.width_m = candidate.right_x - candidate.left_x;
  grasp.force_balance_rad = candidate.force_balance_rad;
  grasp.xoz_offset_m = candidate.xoz_offset_m;
  grasp.contact_a = frame.toBase(candidate.left_x, candidate.y, candidate.left_z);
  grasp.contact_b = frame.toBase(candidate.right_x, candidate.y, candidate.right_z);
  const Eigen::Vector3d centre = 0.5 * (grasp.contact_a + grasp.contact_b);
  grasp.pose = makeGraspPose(centre, -frame.z.cast<double>(), frame.x.cast<double>());
  return grasp;
}

/// Penalty in [0, inf): the thesis's ranking key first; the small terms only break near-ties
/// (lower XOZ offset, then a grasp nearer the centroid along the axis).
double rankPenalty(double primary, double secondary, double y_m, double half_length_m)
{
  const double secondary_term = std::isfinite(secondary) ? secondary : 10.0;
  return primary + 0.1 * secondary_term + 0.01 * std::abs(y_m) / std::max(half_length_m, 1e-6);
}

/// Object-frame (x, z) of the points in `candidate`'s finger band (its grid rows): the best
/// grasping area whose main plane the XOZ-failure next view turns to (Ch3.2.3).
std::vector<Eigen::Vector2d> fingerBandXz(const std::vector<Eigen::Vector3f>& object_points,
                                          const ProjectionGrid& grid, const Candidate& candidate)
{
  std::vector<Eigen::Vector2d> band_xz;
  for (const Eigen::Vector3f& q : object_points)
  {
    const int r = grid.rowOf(q.y());
    if (r >= candidate.first_row && r <= candidate.last_row)
      band_xz.emplace_back(q.x(), q.z());
  }
  return band_xz;
}

/// Object-frame (x, z) of the points at least `end_clearance_m` from both ends along the
/// principal axis: the seen face without the caps, where the contour turns.
std::vector<Eigen::Vector2d> clearOfEndsXz(const std::vector<Eigen::Vector3f>& object_points,
                                           const ProjectionGrid& grid, double end_clearance_m)
{
  std::vector<Eigen::Vector2d> face_xz;
  for (const Eigen::Vector3f& q : object_points)
    if (q.y() >= grid.y_min + end_clearance_m && q.y() <= grid.y_max - end_clearance_m)
      face_xz.emplace_back(q.x(), q.z());
  return face_xz;
}

}  // namespace

std::vector<SweepLine> sweepProjectedContour(const std::vector<Eigen::Vector3f>& object_points, double sweep_step_m,
                                             double grid_cell_m, int gap_close_rows, int crossing_window_rows,
                                             std::vector<Eigen::Vector2f>* boundary_xy)
{
  ProjectionGrid grid;
  if (!(sweep_step_m > 0.0) ||
      !buildGrid(object_points, grid_cell_m, gap_close_rows, crossing_window_rows, 0.0, grid, boundary_xy))
    return {};
  return sweepLines(grid, sweep_step_m);
}

std::vector<Eigen::Vector3f> virtualViewpoints(const Eigen::Vector3f& centroid, const Eigen::Vector3f& axis,
                                               const Eigen::Vector3f& origin_a, const Eigen::Vector3f& origin_b,
                                               double step_rad)
{
  std::vector<Eigen::Vector3f> viewpoints;
  const float axis_norm = axis.norm();
  if (!(step_rad > 0.0) || !(axis_norm > 1e-9f))
    return viewpoints;
  const Eigen::Vector3d unit_axis = (axis / axis_norm).cast<double>();
  const Eigen::Vector3d a = (origin_a - centroid).cast<double>();
  const Eigen::Vector3d b = (origin_b - centroid).cast<double>();
  const Eigen::Vector3d a_across = a - a.dot(unit_axis) * unit_axis;
  const Eigen::Vector3d b_across = b - b.dot(unit_axis) * unit_axis;
  if (a_across.norm() < 1e-6 || b_across.norm() < 1e-6)
    return viewpoints;
  const Eigen::Vector3d cross = a_across.cross(b_across);
  const double angle = std::atan2(cross.norm(), a_across.dot(b_across));  // [0, pi]
  const double sign = cross.dot(unit_axis) >= 0.0 ? 1.0 : -1.0;
  const std::size_t count = static_cast<std::size_t>(std::floor(angle / step_rad + 1e-9)) + 1;
  viewpoints.reserve(count);
  for (std::size_t i = 0; i < count; ++i)
  {
    const Eigen::AngleAxisd rotation(sign * static_cast<double>(i) * step_rad, unit_axis);  // Eq. 3.6
    viewpoints.push_back((centroid.cast<double>() + rotation * a).cast<float>());
  }
  return viewpoints;
}

std::string PrincipalAxisParams::validate() const
{
  if (!(sweep_step_m > 0.0) || !(grid_cell_m > 0.0) || gap_close_rows < 0 || crossing_window_rows < 0 ||
      !(side_depth_m >= 0.0) || !(force_balance_max_rad >= 0.0) || !(xoz_max_offset_m > 0.0) ||
      !(virtual_view_step_rad > 0.0) || !(min_thickness_m >= 0.0) || !(end_clearance_m >= 0.0))
    return "a step, cell or threshold is not positive";
  return gripper_fit.validate();
}

GraspResult PrincipalAxisGraspPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  const Stopwatch stopwatch;
  auto finish = [&stopwatch](GraspResult result) {
    result.compute_time_s = stopwatch.elapsedSeconds();
    return result;
  };
  const PrincipalAxisParams& p = params_;
  if (std::optional<GraspResult> bad_input = checkPlannerInput("principal_axis", p.validate(), gripper, view, p.min_points, p.input_limits))
    return finish(*bad_input);

  // Step 1: finite points and PCA (Eqs. 3.1-3.2).
  std::vector<Eigen::Vector3f> points;
  points.reserve(view.cloud->size());
  for (const auto& point : view.cloud->points)
    if (std::isfinite(point.x) && std::isfinite(point.y) && std::isfinite(point.z))
      points.emplace_back(point.x, point.y, point.z);
  const PrincipalFrame pca = computePrincipalFrame(*view.cloud);
  if (std::sqrt(pca.eigenvalues(1)) < p.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput, "principal_axis: collinear points, no closing direction"));
  if (std::sqrt(pca.eigenvalues(2)) < p.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "principal_axis: flat cloud (zero thickness), nothing to close on"));
  // The eigenvector's sign is arbitrary: point the axis up (against gravity) so results do
  // not depend on the eigen solver, or along its largest component when it is horizontal.
  Eigen::Vector3f axis = pca.axes.col(0).normalized();
  const Eigen::Vector3f up = -view.gravity.normalized();
  if (std::abs(axis.dot(up)) > 0.1f)
  {
    if (axis.dot(up) < 0.0f)
      axis = -axis;
  }
  else
  {
    Eigen::Index largest = 0;
    axis.cwiseAbs().maxCoeff(&largest);
    if (axis(largest) < 0.0f)
      axis = -axis;
  }

  GraspResult result;
  std::vector<Eigen::Vector3f> scratch;
  std::size_t table_blocked = 0;  // stable grasps the hand-fit check dropped because of the table
  // The real hand's volume (gripper_volume.h) at the stable grasps (result.grasps, sorted),
  // best first, until max_grasps fit (the rest are cut); built only when there is something
  // to check. Returns the failure when stable grasps existed but the hand fits at none.
  auto fitGripper = [&](const char* label) -> std::optional<GraspResult> {
    std::vector<GraspCandidate>& grasps = result.grasps;
    if (grasps.empty() || !p.gripper_fit.enabled)
    {
      if (grasps.size() > p.max_grasps)
        grasps.resize(p.max_grasps);
      return std::nullopt;
    }
    GripperVolumeCheck check(gripper, p.gripper_fit);
    check.addSeen(*view.cloud);
    check.addObstacles(view);
    if (view.has_table_plane)
      check.setTable(view.table_plane);
    const std::size_t stable = grasps.size();
    std::string why;
    check.filter(grasps, &why, p.max_grasps, &table_blocked);
    if (!grasps.empty())
      return std::nullopt;
    return GraspResult::fail(GraspFailure::NoStableGrasp, std::string(label) + ": " + std::to_string(stable) +
                                                              " grasps pass XOY and XOZ but the hand does not fit at "
                                                              "any (first: " + why + ")");
  };
  const bool two_cameras = p.two_camera_mode && view.sensor_origins.size() >= 2 && view.sensor_origins[1].allFinite();

  auto fillDrawing = [&](const ViewEvaluation& evaluation) {
    result.hull.clear();
    for (const auto& xy : evaluation.boundary_xy)
    {
      const Eigen::Vector3f b = evaluation.frame.toBase(xy.x(), xy.y(), 0.0).cast<float>();
      result.hull.push_back(PointXYZ(b.x(), b.y(), b.z()));
    }
    result.graspable_zone.clear();
    for (const auto& line : evaluation.lines)
      if (line.hit && line.widthM() <= gripper.max_opening_m && line.widthM() >= gripper.min_opening_m)
        for (const auto& b : { evaluation.frame.toBase(line.left_x_m, line.y_m, line.left_z_m),
                               evaluation.frame.toBase(line.right_x_m, line.y_m, line.right_z_m) })
          result.graspable_zone.push_back(PointXYZ(float(b.x()), float(b.y()), float(b.z())));
  };
  auto halfLength = [](const ViewEvaluation& evaluation) {
    return 0.5 * (evaluation.grid.y_max - evaluation.grid.y_min);
  };

  if (!two_cameras)
  {
    // Steps 2-7 from the one sensor origin.
    ObjectFrame frame;
    if (!makeObjectFrame(pca.centroid, axis, view.sensor_origins.front(), p.min_axis_view_angle_rad, frame))
      return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                      "principal_axis: the principal axis points at the sensor; no object frame"));
    ViewEvaluation evaluation;
    evaluateView(points, frame, p, gripper, /*with_boundary=*/true, evaluation, scratch);
    fillDrawing(evaluation);
    result.candidates_evaluated = evaluation.candidates.size();
    const Candidate* best_xoy = nullptr;
    double best_xoy_penalty = std::numeric_limits<double>::infinity();
    for (const Candidate& candidate : evaluation.candidates)
    {
      GraspCandidate grasp = toGrasp(candidate, frame);
      const double penalty = rankPenalty(candidate.force_balance_rad / std::max(p.force_balance_max_rad, 1e-6),
                                         candidate.xoz_offset_m / p.xoz_max_offset_m, candidate.y,
                                         halfLength(evaluation));
      grasp.score = 1.0 / (1.0 + penalty);
      result.candidates.push_back(grasp);
      if (candidate.xoy_ok && penalty < best_xoy_penalty)
      {
        best_xoy_penalty = penalty;
        best_xoy = &candidate;
      }
      if (candidate.xoy_ok && candidate.xoz_ok)
        result.grasps.push_back(grasp);
    }
    sortGraspsBestFirst(result.grasps);
    sortGraspsBestFirst(result.candidates);
    // Where a next view is suggested, the camera turns about the principal axis
    // (principal_axis_next_view.h).
    const CameraAboutAxis camera{ view.sensor_origins.front(), pca.centroid, axis, view.gravity };
    if (std::optional<GraspResult> no_fit = fitGripper("principal_axis"))
    {
      // Stable grasps the table alone rules out: the next plan may approach from above.
      if (table_blocked > 0 && p.next_view_from_above)
      {
        if (std::optional<NextView> above = nextViewFromAbove(up, frame.x, frame.z, p.min_axis_view_angle_rad,
                                                              p.next_view_min_turn_rad, camera))
        {
          no_fit->next_view = above->camera_pose;
          no_fit->message += "; " + std::to_string(table_blocked) + " were stopped by the table: " + above->reason;
        }
      }
      no_fit->hull = std::move(result.hull);
      no_fit->graspable_zone = std::move(result.graspable_zone);
      no_fit->candidates = std::move(result.candidates);
      no_fit->candidates_evaluated = result.candidates_evaluated;
      return finish(std::move(*no_fit));
    }
    if (!result.grasps.empty())
    {
      result.message = "principal_axis: " + std::to_string(result.grasps.size()) + " grasps, best XOY " +
                       formatNumber(result.grasps.front().force_balance_rad) + " rad, XOZ " +
                       formatNumber(result.grasps.front().xoz_offset_m) + " m";
      return finish(std::move(result));
    }
    if (evaluation.graspable_lines == 0 || evaluation.candidates.empty())
    {
      result.failure = GraspFailure::NoGraspableZone;
      std::vector<double> widths;
      for (const SweepLine& line : evaluation.lines)
        if (line.hit)
          widths.push_back(line.widthM());
      double median = 0.0;
      if (!widths.empty())
      {
        std::nth_element(widths.begin(), widths.begin() + widths.size() / 2, widths.end());
        median = widths[widths.size() / 2];
      }
      result.message = "principal_axis: no graspable zone: " + std::to_string(evaluation.graspable_lines) + " of " +
                       std::to_string(widths.size()) + " sweep lines fit the " + formatNumber(gripper.max_opening_m) +
                       " m opening (median width " + formatNumber(median) + " m, narrowest " +
                       formatNumber(evaluation.narrowest_width_m) + " m) and no finger band of " +
                       formatNumber(gripper.finger_width_m) + " m lies within them clear of the ends";
      // Thesis risk 2 (the gripper cannot cover the object): a seen flat face wider than the
      // opening is looked along next.
      if (std::optional<NextView> along_face =
              nextViewAlongWideFlatFace(clearOfEndsXz(scratch, evaluation.grid, p.end_clearance_m),
                                        gripper.max_opening_m, p.next_view_max_face_rms_ratio, camera))
      {
        result.next_view = along_face->camera_pose;
        result.message += "; " + along_face->reason;
      }
      return finish(std::move(result));
    }
    result.failure = GraspFailure::NoStableGrasp;
    if (!best_xoy)
    {
      double smallest = std::numeric_limits<double>::infinity();
      for (const Candidate& candidate : evaluation.candidates)
        smallest = std::min(smallest, candidate.force_balance_rad);
      result.message = "principal_axis: XOY force balance too large (best " + formatNumber(smallest) +
                       " rad > " + formatNumber(p.force_balance_max_rad) + " rad)";
      return finish(std::move(result));
    }
    // Ch3.2.3: every XOY-stable candidate fails XOZ, the case a new viewpoint resolves: the
    // camera turns to the main plane of the best XOY candidate's finger band.
    const NextView toward_main_plane =
        nextViewForXozFailure(fingerBandXz(scratch, evaluation.grid, *best_xoy), gripper.max_opening_m, camera);
    result.next_view = toward_main_plane.camera_pose;
    result.message = "principal_axis: XOZ offset above " + formatNumber(p.xoz_max_offset_m) +
                     " m for every XOY-stable candidate; " + toward_main_plane.reason;
    return finish(std::move(result));
  }

  // Ch3.5: virtual viewpoints between the two sensor origins on the fused ("big") cloud.
  for (std::size_t i = 0; i < 2; ++i)
  {
    ObjectFrame unused;
    if (!makeObjectFrame(pca.centroid, axis, view.sensor_origins[i], p.min_axis_view_angle_rad, unused))
      return finish(GraspResult::fail(GraspFailure::DegenerateInput, "principal_axis: camera " + std::to_string(i) +
                                                                         " looks along the principal axis"));
  }
  const std::vector<Eigen::Vector3f> viewpoints =
      virtualViewpoints(pca.centroid, axis, view.sensor_origins[0], view.sensor_origins[1], p.virtual_view_step_rad);
  if (viewpoints.empty())
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "principal_axis: a sensor origin lies on the principal axis"));
  ViewEvaluation chosen_view, first_view;
  bool have_first = false;
  double best_final_penalty = std::numeric_limits<double>::infinity();
  std::size_t evaluated = 0;
  for (const Eigen::Vector3f& viewpoint : viewpoints)
  {
    ObjectFrame frame;  // Eq. 3.8 virtual object coordinate system
    if (!makeObjectFrame(pca.centroid, axis, viewpoint, p.min_axis_view_angle_rad, frame))
      continue;
    // The contour is drawn for one viewpoint only; it is rebuilt for that one below.
    ViewEvaluation evaluation;
    evaluateView(points, frame, p, gripper, /*with_boundary=*/false, evaluation, scratch);
    evaluated += evaluation.candidates.size();
    // Best XOY grasp of this viewpoint (Ch3.5.5 A).
    const Candidate* best = nullptr;
    double best_penalty = std::numeric_limits<double>::infinity();
    for (const Candidate& candidate : evaluation.candidates)
    {
      if (!candidate.xoy_ok)
        continue;
      const double penalty = rankPenalty(candidate.force_balance_rad / std::max(p.force_balance_max_rad, 1e-6),
                                         candidate.xoz_offset_m / p.xoz_max_offset_m, candidate.y,
                                         halfLength(evaluation));
      if (penalty < best_penalty)
      {
        best_penalty = penalty;
        best = &candidate;
      }
    }
    if (!have_first)
    {
      first_view = evaluation;
      have_first = true;
    }
    if (!best)
      continue;
    // Ranking across viewpoints by XOZ offset (Ch3.5.5 B, Eqs. 3.9-3.10).
    GraspCandidate grasp = toGrasp(*best, frame);
    const double final_penalty =
        rankPenalty(best->xoz_offset_m / p.xoz_max_offset_m,
                    best->force_balance_rad / std::max(p.force_balance_max_rad, 1e-6), best->y, halfLength(evaluation));
    grasp.score = 1.0 / (1.0 + final_penalty);
    result.candidates.push_back(grasp);
    if (best->xoz_ok)
    {
      result.grasps.push_back(grasp);
      if (final_penalty < best_final_penalty)
      {
        best_final_penalty = final_penalty;
        chosen_view = std::move(evaluation);
      }
    }
  }
  result.candidates_evaluated = evaluated;
  sortGraspsBestFirst(result.grasps);
  if (std::optional<GraspResult> no_fit = fitGripper("principal_axis (two cameras)"))
    return finish(std::move(*no_fit));
  ViewEvaluation& drawn = result.grasps.empty() ? first_view : chosen_view;
  if (have_first)
  {
    ViewEvaluation with_contour;
    evaluateView(points, drawn.frame, p, gripper, /*with_boundary=*/true, with_contour, scratch);
    drawn = std::move(with_contour);
  }
  fillDrawing(drawn);
  if (!result.grasps.empty())
  {
    result.message = "principal_axis (two cameras): " + std::to_string(viewpoints.size()) +
                     " virtual viewpoints, best XOZ " + formatNumber(result.grasps.front().xoz_offset_m) +
                     " m, XOY " + formatNumber(result.grasps.front().force_balance_rad) + " rad";
    return finish(std::move(result));
  }
  result.failure = result.candidates.empty() && evaluated == 0 ? GraspFailure::NoGraspableZone : GraspFailure::NoStableGrasp;
  result.message = "principal_axis (two cameras): no grasp passes over " + std::to_string(viewpoints.size()) +
                   " virtual viewpoints (" + std::to_string(result.candidates.size()) +
                   " XOY-stable, none within the XOZ threshold " + formatNumber(p.xoz_max_offset_m) + " m)";
  return finish(std::move(result));
}

}  // namespace fast_grasp
