// Joins the neck of a bottle lying on the table to its body. Beyond the thesis (it segments one
// isolated object). ROS-free.
//
// A bottle lying with its neck away from the camera shows a gap at its shoulder: the body's top
// hides the shoulder sloping down behind it, so the neck comes out as a cluster of its own (or,
// with the concave split, a piece of its own), and the object list holds a 4 cm "object" that is
// part of a bottle (clutter training piles, session 24: tables 3 and 15). A neck is recognisable
// from one view: it hangs clear of the table, just beyond the end of a neighbour that lies on the
// table and is long and level, on that neighbour's long axis (within its half-width), with its
// top between the neighbour's mid-height and its top (a neck is centred on the body's axis and
// narrower).
// TableSegmentationParams::join_lying_necks turns it on (the default since session 32: a heavy
// bottle's neck picked as an object of its own drops the bottle; docs/clutter.md, "A lying
// bottle's neck joined again").
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>
#include <pcl/PointIndices.h>

#include <vector>

namespace fast_grasp
{
struct NeckJoinParams
{
  /// The body's footprint must be at least this many times longer than wide (standard
  /// deviations of its points along and across its long axis; a lying wine bottle seen from
  /// behind: ~2.5). 0: never joined.
  double min_elongation = 1.5;
  /// The neck's nearest point lies at most this far beyond the body's end along its axis (a lying
  /// wine bottle seen from behind its base: 5 cm of shoulder hidden by the body's top).
  double max_gap_m = 0.08;
  /// The body lies on the table (its lowest point at most this high), the neck does not (its
  /// lowest point higher).
  double standing_height_m = 0.025;
};

/// Joins each cluster of `clusters` (indices into `cloud`) that the rule above finds to be the
/// neck of another to that one; `plane` is the table (a, b, c, d, normal up). Returns the
/// clusters, largest first; every input point stays in exactly one cluster. `joined_into[c]`,
/// when given, receives for each input cluster the index of the output cluster that holds it.
std::vector<pcl::PointIndices> joinNecksToLyingBodies(const CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                                      const Eigen::Vector4f& plane, const NeckJoinParams& params,
                                                      std::vector<int>* joined_into = nullptr);

}  // namespace fast_grasp
