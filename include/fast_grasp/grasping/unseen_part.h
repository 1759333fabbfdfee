// The unseen part of an object seen from one (or two) viewpoints, thesis Ch6 step 4
// (Fig. 6.9, Eq. 6.8): the boundary points of the single-view cloud are extended away from
// the camera along the camera rays, so the space the camera could not see behind the object
// becomes an obstacle point set. The C-shape planner rejects grippers entering it; the arm
// planner blocks it in its OctoMap. ROS-free.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
struct UnseenPartParams
{
  /// How far behind each boundary point the shadow is extruded along its camera ray.
  /// Should exceed the object's hidden depth; the gripper reach is what matters in practice.
  double extension_m = 0.10;
  /// Spacing of shadow points along a ray; 0 = the boundary grid cell size.
  /// Must stay below the thinnest gripper part checked against it (C-shape r2 - r1).
  double step_m = 0.0;
  /// Cell size of the 2-D boundary grid, measured at the object's distance; 0 = automatic
  /// (2.5 x the mean point spacing estimated from the projected area, so interiors have no
  /// empty cells).
  double grid_cell_m = 0.0;
  /// Lower bound on the automatic cell size (coarser boundaries, fewer shadow points).
  double min_grid_cell_m = 0.0;
  /// A neighbouring cell at least this much farther from the camera makes the nearer cell an
  /// occluding edge (e.g. a handle in front of a body), which also casts a shadow.
  double depth_jump_m = 0.02;
  /// Caps the grid size (cells per side); the cell grows when the cloud would need more.
  int max_grid_cells_per_side = 256;
  /// Shadow points farther than this below the table plane are dropped (they are inside the
  /// table, not behind the object). Only used when a table plane is given.
  double table_clearance_m = 0.002;
};

struct UnseenPart
{
  /// Shadow points in the cloud's frame (the C_unseen of Eq. 6.8).
  pcl::PointCloud<pcl::PointXYZ> points;
  /// Indices into the input cloud of the boundary points that were extended.
  std::vector<int> boundary_indices;
  /// The grid cell size actually used (metres at the object's distance).
  double grid_cell_m = 0.0;
  /// Lower bound on the automatic cell size (coarser boundaries, fewer shadow points).
  double min_grid_cell_m = 0.0;
  /// Empty when built; otherwise why not (no finite point, no sensor origin, ...).
  std::string failure;

  bool ok() const { return failure.empty(); }
};

/// Builds the unseen part of `cloud` as seen from `sensor_origins` (same frame as the cloud).
/// Boundaries are found on a 2-D grid of the camera's image plane (silhouette and occluding
/// edges), which is O(n) instead of per-point neighbourhood boundary estimation. With several
/// sensors, a shadow point survives only if it is hidden from every sensor (in the shadow
/// of each, i.e. behind the seen surface or outside nobody's view). `table_plane` (a, b, c, d
/// with (a, b, c) pointing away from the table) removes shadow points inside the table.
template <typename PointT>
UnseenPart buildUnseenPart(const pcl::PointCloud<PointT>& cloud, const std::vector<Eigen::Vector3f>& sensor_origins,
                           const UnseenPartParams& params = {},
                           const std::optional<Eigen::Vector4f>& table_plane = std::nullopt);

/// Beyond the thesis: mirror completion (Bohg et al. 2011, "Mind the gap"). An object lying
/// along the table is taken as mirror symmetric about the vertical plane through its long
/// axis, placed where its top is level (the median across-axis position of the seen points
/// whose normal is within ~6 deg of vertical across the axis and ~25 deg of up; most of them
/// must lie in the top quarter of the object's height, else it is no closed body: a pan's
/// level part is its inside). A bottle lying on its broad face is seen 7.5-8 of its 9.8 cm
/// wide (its far side turns away from the camera); its mirrored near side is where the far
/// side is.
struct MirrorCompletionParams
{
  /// Only footprints at least this many times longer than wide are mirrored.
  double min_elongation = 1.5;
  /// ... and only if at most this fraction of the mirrored points fall where the camera saw
  /// free space (else the object is not symmetric that way).
  double max_free_fraction = 0.1;
};

struct MirrorCompletion
{
  /// The seen points mirrored across the plane, less those where the camera saw free space.
  pcl::PointCloud<pcl::PointXYZ> mirrored;
  /// Horizontal unit vectors along the footprint's long axis and across it.
  Eigen::Vector3f along = Eigen::Vector3f::UnitX();
  Eigen::Vector3f across = Eigen::Vector3f::UnitY();
  /// The completed object's width across the plane: the median over 1 cm slices along its
  /// length of the seen points' extent joined with their mirror image's (a bottle's body, not
  /// its cap); and its seen length along the axis.
  double width_m = 0.0;
  double length_m = 0.0;
  /// Empty when completed; otherwise why not (not elongated, no level top, not symmetric, ...).
  std::string failure;

  bool ok() const { return failure.empty(); }
};

/// Completes `cloud` (with normals, seen from `sensor_origin`, resting on `table_plane` whose
/// (a, b, c) points up) by its mirror image, or says why it is not mirror symmetric that way.
MirrorCompletion completeByMirror(const pcl::PointCloud<pcl::PointNormal>& cloud, const Eigen::Vector3f& sensor_origin,
                                  const Eigen::Vector4f& table_plane, const MirrorCompletionParams& params = {});

}  // namespace fast_grasp
