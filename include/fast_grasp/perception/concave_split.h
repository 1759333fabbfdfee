// Separates touching objects: a Euclidean cluster is cut where its surface has a concave crease.
// Beyond the thesis (it segments one isolated object). ROS-free.
//
// Two objects that touch (boxes side by side, one standing on another, a cup leaning on a
// bottle) meet at a concave crease, while the surface of one object is convex or smoothly
// curved almost everywhere. This is the local convexity criterion of LCCP (Stein et al., CVPR
// 2014) applied to neighbouring points instead of supervoxels: points a, b with normals na, nb
// (facing the camera) are joined when the link is convex, (na - nb) . (a - b) > 0, or nearly
// flat, angle(na, nb) < concave_tolerance_rad. PCL's own LCCP (supervoxels first) was measured on
// the mOSD scenes and split single objects into pieces (bench_segmentation --method lccp); the
// point version needs no supervoxels and runs in a few milliseconds on one core.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <memory>
#include <random>
#include <vector>

namespace fast_grasp
{
struct ConcaveSplitParams
{
  /// Neighbours per point: the PCA normal's support and the links that may join two points.
  int k_neighbours = 10;
  /// Only neighbours closer than this are linked (5 mm voxels: the 8-neighbourhood plus noise).
  double link_radius_m = 0.009;
  /// A concave link whose normals differ by more than this is a crease (below: sensor noise on a
  /// flat face). Both its ends are crease points, which join no piece until the pieces are found.
  double concave_tolerance_rad = 0.35;
  /// Connected non-crease points form a piece; pieces with fewer points are not objects. Crease
  /// points and small pieces then take the piece most of their k neighbours belong to.
  int min_piece_points = 40;
  /// A smaller piece of at least this many points is an object too when it stands on the table
  /// (its lowest point within standing_height_m of it): a battery or a bottle cap lying against a
  /// cup is one, a crease band or a sliver on a face of one box is higher up. 0 = off.
  int min_standing_piece_points = 15;
  /// A piece is a container's inside (joined to its outer wall) when more than this share of its
  /// bent point pairs are concave: bend_samples random pairs bend_min_distance_m to
  /// bend_max_distance_m apart, bent when their normals differ by more than bent_pair_rad.
  double concave_piece_fraction = 0.7;
  double bent_pair_rad = 0.2;
  double bend_min_distance_m = 0.02;
  double bend_max_distance_m = 0.06;
  int bend_samples = 2000;
  /// A piece stands (is an object on its own) when its lowest seen point is at most
  /// standing_height_m above the table, or when under less than floating_seen_fraction of its
  /// bottom band (points within bottom_band_m of its lowest) the camera saw the table
  /// (table_cell_m cells of the table points). Otherwise it hangs on its neighbour and joins it.
  double standing_height_m = 0.025;
  double bottom_band_m = 0.01;
  double floating_seen_fraction = 0.5;
  double table_cell_m = 0.01;
};

/// Cuts each cluster (indices into `cloud`) at its concave creases, then merges back the pieces
/// that are parts of another piece of the same cluster. `viewpoint` orients the normals (the
/// camera); `plane` is the table (a, b, c, d, normal up) and `table` its seen points. Returns the pieces, largest first; every input point is in
/// exactly one piece (a cluster that yields fewer than two pieces of min_piece_points is kept whole).
std::vector<pcl::PointIndices> splitAtConcaveCreases(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                     const Eigen::Vector3f& viewpoint, const Eigen::Vector4f& plane,
                                                     const CloudXYZ& table, const ConcaveSplitParams& params);

/// Each point's normal from the plane through its k nearest neighbours in `points` (PCA), turned
/// toward `viewpoint` (zero where no plane fits); `neighbours`, when given, receives each point's
/// k nearest neighbours (indices into `points`, itself included).
std::vector<Eigen::Vector3f> cameraFacingNormals(const std::shared_ptr<const CloudXYZ>& points, int k,
                                                 const Eigen::Vector3f& viewpoint,
                                                 std::vector<pcl::Indices>* neighbours = nullptr);

/// Whether the surface of `members` (indices into `points` and its camera-facing `normals`) curves
/// inward, as a container's inside does and no object seen from outside: more than
/// concave_piece_fraction of its bent point pairs (bend_samples pairs drawn with `rng`,
/// bend_min_distance_m to bend_max_distance_m apart, normals differing by more than bent_pair_rad)
/// are concave. False when no drawn pair is bent.
bool curvesInward(const CloudXYZ& points, const std::vector<Eigen::Vector3f>& normals,
                  const std::vector<std::size_t>& members, const ConcaveSplitParams& params, std::mt19937& rng);

}  // namespace fast_grasp
