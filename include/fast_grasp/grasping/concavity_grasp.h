// Concavity grasp planner of thesis Chapter 5, adapted to a single-view partial point cloud.
// ROS-free: C++17, Eigen, PCL.
//
// The thesis (Ch5.2) meshes a full cloud, tetrahedralises the free space between the mesh and
// its convex hull and runs the Fast Marching Method to get, per vertex, the shortest free-space
// path to the hull (the concavity). We have one view of the object, not a mesh, and ~10 ms:
//
// 1. Concavity (Ch5.2.1). pcl::ConvexHull (3-D) of the seen points (voxel-down-sampled), and
//    for each point the depth below the hull along its camera ray: the ray from the sensor to
//    the point enters the hull at t_in (the largest entry parameter over the hull facets facing
//    the sensor) and reaches the point at |p - s|, so concavity = |p - s| - t_in. Why along the
//    ray: the seen point is the first surface the ray meets, so the ray segment between the
//    hull and the point lies entirely in the free space between the surface and the hull the
//    thesis measures in; it is a free-space path from the point to the hull, needs no mesh or
//    tetrahedralisation, and is exact for a groove or a bowl seen along its depth (the cases
//    the tests derive by hand). It over-states the thesis's shortest path where the camera
//    looks into a concavity obliquely. The nearest-facet-plane distance would be the
//    alternative, but the hull of a partial view also has "back" facets across the hidden side
//    that no free-space path reaches, so it under-states concavity behind a thin wall. Points
//    on a convex surface lie on the hull: concavity 0. With several sensors the smallest depth
//    over the sensors outside the hull counts. A flat cloud (no hull) has concavity 0.
// 2. Extraction (Ch5.2.2): points with concavity >= min_concavity_m, Euclidean clusters
//    (pcl::EuclideanClusterExtraction), regions ranked by points x mean concavity, at most
//    max_regions. When there is no salient concavity (convex objects: boxes, bottles) the whole
//    object is the one region, so convex objects are still grasped; the same happens when no
//    concave region gives a grasp. GraspResult::message says which.
// 3. Frame (Ch5.2.3): PCA of the region (the eigenvectors the thesis's OBB of
//    pcl::MomentOfInertiaEstimation is built on, without its extra moment passes). The thesis
//    chooses the OBB face pair least likely to collide; with one view the hand must come from
//    the seen side, so the OBB axes within max_approach_view_angle_rad of the line of sight
//    (at least the nearest) are approach axes (the hand approaches against them) and the
//    region is projected onto the other two axes for each.
// 4. Boundary (Ch5.2.4): the projection rasterised into grid_cell_m cells, closed (3x3 dilation
//    then erosion), and its boundary cells instead of PCL's 2-D ConcaveHull (120 ms at 10 k
//    points, DESIGN.md). The thesis's outer-layer test (Eq. 5.1: a hull point within
//    d_threshold of the enlarged cloud's hull) becomes a test on the whole object along each
//    candidate's closing line: the boundary point must lie within boundary_tolerance_m of an
//    end of the object's extent there, i.e. free space for a finger beside it.
// 5. Ordering and step points (Ch5.2.5): boundary points chained from an extreme by nearest
//    neighbour (Fig. 5.12; a new chain starts where the next point is more than 2.5 cells
//    away), step points where the step circle of radius step_m crosses the chain (Eqs. 5.2 and
//    5.3, solved in parametric form, which has no division by a zero slope), repeated until the
//    rest of the chain lies within the hand width of the last step point (Fig. 5.13). At each
//    step point P0 the point Q one hand width (the finger width) along the boundary gives the
//    candidate P0Q (Fig. 5.15); its in-plane normal is the closing direction and the band of
//    object points within half a hand width of the perpendicular bisector is the candidate's
//    cloud (Figs. 5.16-5.17). Along the closing line the band splits at gaps wider than gap_m
//    (the two arms of a U are two parts); the part at P0 is what the fingers close on: its
//    extent is the width, its extremes per slice of the band the two grasp sides.
// 6. Force balance (Ch5.2.6, Eq. 5.4): each side fitted as closing = k * along + b; the metric
//    (GraspCandidate::force_balance_rad) is |atan k1| + |atan k2|, the angle between the two
//    side lines for the symmetric case of Fig. 5.19, which also penalises parallel sides leaning
//    against the (fixed) closing direction, as the other planners do. Smaller is better.
// 7. Manipulability (Ch5.2.6): the thesis's manipulability analysis is the collision check of
//    the hand (length and width) approaching the object (Fig. 5.21); here it is the one hand
//    volume of gripper_volume.h against the seen points, the unseen part (unseen_part.h) and
//    the table, backing the hand out along -approach as the other planners do. Arm
//    manipulability needs the arm, which the planner has not: the score adds a small penalty on
//    the angle between the approach and the line of sight (approaches facing the seen side).
// Grasps are ranked by force balance (the thesis's criterion within and across regions) with
// that alignment term as a tie-break; the best max_grasps that fit the hand are returned.
#pragma once

#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/gripper_volume.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace fast_grasp
{
struct ConcavityParams
{
  /// Concavity, hull, regions and candidate bands are computed on a voxel-down-sampled copy:
  /// the 3-D hull and the per-point ray test cost O(points x hull facets), ~5x over the 10 ms
  /// budget at 10 k points; 4 mm is about the Xtion's spacing at 0.7 m. The gripper check uses
  /// the full cloud. 0 = no down-sampling.
  double voxel_leaf_m = 0.004;
  /// When the voxel copy still has more points (a large object), the leaf grows until it has
  /// about this many: the hull, the ray test and the bands stay within the time budget. The
  /// grid cell, cluster tolerance, gap and boundary tolerance grow with the leaf.
  std::size_t max_analysis_points = 2500;
  /// A point is salient-concave at this depth below the hull: above the depth noise of the
  /// sensor (~1-3 mm at 0.6 m) and the voxel size, below the depth of a handle gap or a groove.
  double min_concavity_m = 0.01;
  /// Euclidean clustering distance of the concave points (about two voxels: neighbours only).
  double cluster_tolerance_m = 0.01;
  /// Smaller clusters are noise, not a concavity.
  std::size_t min_region_points = 8;
  /// At most this many concave regions are analysed (largest points x mean concavity first).
  std::size_t max_regions = 5;
  /// The thesis keeps one OBB face pair (the least likely to collide). With one view the hand
  /// must come from the seen side: every OBB axis within this angle of the line of sight (and
  /// always the nearest) is tried as the approach axis, the region projected onto the other
  /// two; 60 degrees lets a box seen obliquely be taken from the top and from its front face.
  double max_approach_view_angle_rad = 1.047;
  /// Cell of the projection grid that stands in for the concave hull of Ch5.2.4 (a bit more
  /// than the voxel so the projected down-sampled points leave no holes).
  double grid_cell_m = 0.005;
  /// r of Eqs. 5.2-5.3: spacing of the step points along the boundary (Fig. 5.14).
  double step_m = 0.01;
  /// Length of the candidate P0Q along the boundary (Fig. 5.15) and width of its band of
  /// points; 0 = the gripper's finger_width_m (the hand's width across the closing plane).
  double hand_width_m = 0.0;
  /// Eq. 5.1's d_threshold: a step point is on the object's outer layer when it lies within
  /// this distance of an end of the object's extent along its closing line.
  double boundary_tolerance_m = 0.008;
  /// Along a closing line, points farther apart than this belong to different parts (the arms
  /// of a U, a handle and the body): the fingers close on the part at the step point. Above
  /// the voxel spacing, below a finger's thickness.
  double gap_m = 0.01;
  /// Slices of the band along the boundary whose extreme points form the two grasp sides
  /// (a 22 mm hand width in 5 slices: ~4.4 mm each, one down-sampled point per slice).
  int side_bins = 5;
  /// A side needs extreme points in this many slices to fit its line (Eq. 5.4).
  int min_side_bins = 3;
  /// Depth (along the closing direction) of the contact regions whose mean depth along the
  /// approach places the contact points.
  double side_depth_m = 0.005;
  /// Largest accepted force balance |atan k1| + |atan k2| (0 = parallel sides normal to the
  /// closing direction); the Ch3 planner's threshold, 20 degrees.
  double force_balance_max_rad = 0.35;
  /// Score penalty per unit of (1 - cos) of the angle between approach and line of sight:
  /// small next to the force balance, it prefers approaches facing the seen side.
  double view_alignment_weight = 0.2;
  /// Candidates whose centres are closer than this and whose closing directions are within
  /// ~11 degrees are the same grasp found from both ends of the closing line: kept once.
  double duplicate_distance_m = 0.005;
  /// Treat the unseen part (the space behind the seen surface) as an obstacle in the hand
  /// check, as the C-shape planner does. Disable only to debug.
  bool use_unseen_part = true;
  UnseenPartParams unseen;
  /// Inputs with fewer finite points are DegenerateInput; so are collinear ones (second PCA
  /// spread below min_thickness_m). Flat ones are planned (their concavity is 0).
  std::size_t min_points = 10;
  double min_thickness_m = 0.0005;
  /// Grasps returned, best first. The hand check runs until this many fit (each check
  /// transforms every seen point and the unseen part), so it bounds the time too.
  std::size_t max_grasps = 10;
  /// Evaluated candidates kept in GraspResult::candidates (markers).
  std::size_t max_recorded_candidates = 200;
  /// Final check with the real hand's volume (gripper_volume.h).
  GripperFitParams gripper_fit;

  /// The top-level keys of config/grasp_planners.yaml (loadGraspPlannerConfig, the nodelets).
  PlannerInputLimits input_limits;

  /// Empty when usable, else why not.
  std::string validate() const;
};

/// Step 1: per point of `points`, its depth below the convex hull of `points` along its ray
/// from a sensor of `sensor_origins` (the smallest over the sensors outside the hull; see the
/// file comment). Returns one value per point (0 on the hull), all 0 when the points span no
/// volume (fewer than 4, collinear, coplanar) and `why` (if given) gets the reason; all 0 and a
/// reason too when every sensor lies inside the hull. Non-finite points get 0.
std::vector<float> concavityBelowConvexHull(const CloudXYZ& points, const std::vector<Eigen::Vector3f>& sensor_origins,
                                            std::string* why = nullptr);

/// Step 5 (Eqs. 5.2-5.3): walks the ordered boundary `chain` from chain[0] and returns the step
/// points, chain[0] first, each one `step_m` (straight-line distance) from the previous where
/// the circle of that radius first crosses the chain beyond it; stops when no segment crosses
/// the circle or every remaining point lies within `stop_within_m` of the last step point.
/// `segment_of` (if given) receives, per step point, the index n of the chain segment
/// (n, n + 1) it lies on (0 for chain[0]).
std::vector<Eigen::Vector2f> boundaryStepPoints(const std::vector<Eigen::Vector2f>& chain, double step_m,
                                                double stop_within_m, std::vector<std::size_t>* segment_of = nullptr);

/// The planner (name "concavity"). plan() is const and thread-safe.
class ConcavityGraspPlanner : public GraspPlanner
{
public:
  explicit ConcavityGraspPlanner(ConcavityParams params = {}) : params_(params) {}
  GraspResult plan(const ObjectView& view, const GripperModel& gripper) const override;
  const char* name() const override { return "concavity"; }
  const ConcavityParams& params() const { return params_; }

private:
  ConcavityParams params_;
};

}  // namespace fast_grasp
