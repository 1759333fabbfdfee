// Boundary ("caging") grasp planner of thesis Chapter 4: finger candidates along the ordered
// contour of the object's projection on its main plane, paired and filtered by force balance,
// torque balance, grasping range, variance and operability (Eq. 4.2), ranked by the distance
// of the centre of gravity from the grasping line (Ch4.3.3). ROS-free: C++17, Eigen, PCL.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <Eigen/Core>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
struct BoundaryParams
{
  /// Smallest cell of the occupancy grid whose traced outline stands in for the thesis's
  /// concave hull (PCL's ConcaveHull takes ~120 ms at 10k points, DESIGN.md). The cell used is
  /// the larger of this and spacing_cell_factor x the estimated point spacing, so a voxelised
  /// cloud (5 mm leaf in config/perception.yaml) does not fall apart into single cells.
  double grid_cell_m = 0.002;
  double spacing_cell_factor = 1.0;
  /// Dilations (then as many erosions) of the occupancy before tracing: bridges gaps of up to
  /// 2 x close_cells cells between scan lines and sensor holes so they do not become contour.
  int close_cells = 1;
  /// r of Eq. 4.1: distance between consecutive step points (finger-candidate starts) along
  /// the contour. Smaller finds grasps nearer the centroid at quadratic pair cost.
  double step_m = 0.005;
  /// The pairs grow with the square of the step points: on outlines longer than
  /// max_finger_candidates x step_m (3 m by default, far beyond a graspable object) the step
  /// grows so there are at most this many (600 give 180k pairs, ~2 ms).
  std::size_t max_finger_candidates = 600;
  /// w_f of Ch4.3.1 C.2: chord length of a finger candidate; 0 = the gripper's finger_width_m.
  double finger_width_m = 0.0;
  /// delta of Fig. 4.11: probe step along a finger's perpendicular bisector when finding the
  /// inside direction, and how many steps are tried before the next finger is used.
  double inside_probe_step_m = 0.002;
  int inside_probe_max_steps = 20;
  /// Ch4.3.2 A: largest gamma_ij, the angle between F_i and -F_j (0 = forces exactly opposed).
  /// 0.35 rad (20 deg) is the principal-axis planner's force-balance limit: a pad with a
  /// friction coefficient >= tan(20 deg) ~ 0.36 still holds.
  double force_balance_max_rad = 0.35;
  /// Ch4.3.2 B: largest offset of the two contact centres across the closing direction, the
  /// lever of the couple the squeezing forces make. Half the Lacquey's 22 mm pad keeps at least
  /// half of each pad opposite the other.
  double torque_offset_max_m = 0.011;
  /// Ch4.3.2 C: the contacts must be at most max_opening_m - opening_margin_m apart: the traced
  /// contour may be up to half a cell off each side and the open finger needs room to descend.
  double opening_margin_m = 0.005;
  /// Ch4.3.2 D: largest nu = sum over both grasp sides of the contour points' distances to the
  /// finger line. A 22 mm side holds ~5-11 contour points; the grid's staircase alone gives
  /// up to ~0.5 mm each on a slanted edge (~0.01 m for a pair), so 0.03 leaves ~1 mm per point
  /// for real shape.
  double variance_max_m = 0.03;
  /// Ch4.3.2 E (Eq. 4.2): contour points closer than this to the contact line along the closing
  /// direction are the grasp side itself, not an obstacle of the closing finger.
  double operability_tolerance_m = 0.003;
  /// Score = -(gravity offset + weights x the other metrics), in metres: the thesis picks the
  /// grasp nearest to the centre of gravity; the weights only break near-ties. The width term
  /// prefers the narrower of two equally centred grasps (more opening left for pose error).
  double force_balance_weight_m_per_rad = 0.02;
  double torque_weight = 1.0;
  double variance_weight = 0.1;
  double width_weight = 0.05;
  /// Fewer finite points are DegenerateInput; a spread (sqrt of the second PCA eigenvalue)
  /// below min_thickness_m marks collinear points, which have no outline.
  std::size_t min_points = 10;
  double min_thickness_m = 0.0005;
  /// Beyond the thesis: when the main plane's normal (the minor axis) is farther than this from
  /// the line of sight, the plane of the major axis and the one of the other two axes nearer to
  /// the line of sight is used, so the hand still comes from the seen side (a glass seen into its
  /// bowl is deeper along the sight line than wide). pi/2 = always the thesis's OBB plane.
  double max_normal_sight_angle_rad = 1.0472;  // 60 degrees
  /// At most this many grasps are returned and candidates kept for markers (best first). The
  /// final hand check (one pass over every seen and unseen point per grasp) is most of a plan's
  /// time at 10k points, so it stops after max_grasps fit: 10, as the C-shape planner.
  std::size_t max_grasps = 10;
  std::size_t max_recorded_candidates = 200;
  /// Final check with the real hand (gripper_volume.h) against the seen points, the table and,
  /// with use_unseen_part, the unseen part behind the object (Eq. 6.8's shadow), as the other
  /// planners do.
  bool use_unseen_part = true;
  /// The shadow points need only be dense enough that no hand part (fingers >= 12 mm thick on
  /// the shipped grippers) passes between them: 5 mm along the rays on a grid of >= 4 mm. At
  /// 10k points this cut the shadow from ~8000 to ~2000 points and a plan from ~9.5 to ~2.5 ms
  /// (mug.bag resampled, one core).
  static UnseenPartParams defaultUnseenParams()
  {
    UnseenPartParams unseen;
    unseen.step_m = 0.005;
    unseen.min_grid_cell_m = 0.004;
    return unseen;
  }
  UnseenPartParams unseen = defaultUnseenParams();
  GripperFitParams gripper_fit;

  /// The top-level keys of config/grasp_planners.yaml (loadGraspPlannerConfig, the nodelets).
  PlannerInputLimits input_limits;

  /// Empty when usable, else why not.
  std::string validate() const;
};

/// The outer outline of a set of points on a plane, in serial order (Fig. 4.5), counter-
/// clockwise about the plane's Z; depth_m[i] is the plane-Z of the deepest (most negative Z)
/// point of the grid cell under points[i]: where the object is widest below its seen surface.
struct OrderedContour
{
  std::vector<Eigen::Vector2d> points;
  std::vector<double> depth_m;
  double cell_m = 0.0;
};

/// Traces the outline of the largest 8-connected region of the occupancy grid (cell
/// `cell_m`, closed by `close_cells`) of `plane_points` (x, y on the plane, z the height
/// along its normal): Moore-neighbour tracing of the boundary cells, their centres moved half
/// a cell outward onto the region's edge and smoothed by [1 2 1] / 4. Empty when there are
/// fewer than 3 boundary cells.
OrderedContour traceOrderedContour(const std::vector<Eigen::Vector3d>& plane_points, double cell_m, int close_cells);

/// A point on a closed polyline: `point` lies on the segment from vertex `segment` to vertex
/// `segment + 1` (modulo the vertex count).
struct ContourPoint
{
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  std::size_t segment = 0;
};

/// Eq. 4.1: the first point after `from` (in serial order, at most one lap) where the contour
/// crosses the circle of `radius` about `from`: the first segment whose end distances
/// d_n, d_n+1 bracket the radius, intersected with the circle. nullopt when none does.
std::optional<ContourPoint> nextContourPointAtDistance(const std::vector<Eigen::Vector2d>& contour,
                                                       const ContourPoint& from, double radius);

/// Ch4.3.1 C.1: step points every `step_m` along the closed contour, starting at its first
/// vertex and ending where the lap closes (a step point nearer than step_m / 2 to the first
/// is not repeated). A 0.10 x 0.04 m rectangle from a corner at 0.01 m gives 28 points.
std::vector<ContourPoint> contourStepPoints(const std::vector<Eigen::Vector2d>& contour, double step_m);

/// Fig. 4.10: ray-crossing parity (a ray along +x; half-open edges, so a vertex on the ray
/// counts once and one deterministic ray suffices instead of the thesis's random ones).
bool insidePolygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& point);

/// Ch4.3.1 C.2-C.3: one finger candidate from `start` to the contour point w_f ahead, with its
/// inside grasping direction (unit, in the plane) and the variance term of its side.
struct FingerCandidate
{
  ContourPoint start;
  ContourPoint end;
  Eigen::Vector2d middle = Eigen::Vector2d::Zero();
  Eigen::Vector2d inward = Eigen::Vector2d::Zero();
  double side_variance_m = 0.0;  // sum of the side's contour-point distances to the finger line
  double depth_m = 0.0;          // mean contour depth along the side
};

/// Finger candidates at `step_points`, grasping directions by the thesis's rule: probe the
/// first finger's bisector (steps of `probe_step_m`) until one probe is inside the contour and
/// the other outside, then give every finger the same cross-product sense (Y = X x Z or Z x X,
/// Fig. 4.11 b). Fingers whose end cannot be found are left out.
std::vector<FingerCandidate> fingerCandidates(const OrderedContour& contour, const std::vector<ContourPoint>& step_points,
                                              double finger_width_m, double probe_step_m, int probe_max_steps);

/// Boundary planner. Main plane: the plane of the two largest principal axes of the object
/// points, which are the axes of PCL's OBB (MomentOfInertiaEstimation takes them from the
/// same covariance; see boundary_grasp.cpp for why PCA is called directly), its normal turned
/// toward the sensor (the middle axis instead when the minor one lies across the line of sight,
/// max_normal_sight_angle_rad). Grasps approach along -normal (from the seen side, perpendicular to the
/// main plane, as in the thesis) and close along the pair's mean force direction in the plane;
/// the origin sits on the contacts' depth. Metrics: force_balance_rad = gamma_ij,
/// torque_offset_m = the contacts' offset across the closing direction, variance_m = nu,
/// gravity_offset_m = the distance of the contour's area centroid from the grasping line.
/// plan() is const and thread-safe.
class BoundaryGraspPlanner : public GraspPlanner
{
public:
  explicit BoundaryGraspPlanner(BoundaryParams params = {}) : params_(std::move(params)) {}
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return "boundary"; }
  const BoundaryParams& params() const { return params_; }

private:
  BoundaryParams params_;
};

}  // namespace fast_grasp
