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

}  // namespace fast_grasp
