// A body whose top is one flat face wider than the hand's opening in every direction: a cereal
// box or a book lying flat. Nothing closes across it: a top-down grasp would have to span the
// face, a side grasp would need a finger under the body. What a planner offers instead pinches
// an edge or a corner a few millimetres wide (the seen side face and the top's rim between the
// fingers) and lifts nothing.
//
// Beyond the thesis (its objects fit the hand). Clutter training piles, fused planner (session
// 32): the cracker box lying flat (16 x 21 cm top) was pinched 4-15 mm wide at its edges and
// never held; refusing it removed 6 failed attempts from 200 tables (5 pinches, and one on a
// bottle a failed pinch had moved) and no success. Lying on its side or standing, it is grasped
// across its 6 cm. The footprint rule of wide_lying_body (fused_grasp.h) mirrors a lying
// round body's near side and needs an elongated footprint; a flat top is seen whole from above
// and needs no completion: its narrowest width is measured.
//
// The top face: the seen points within top_band_m (5 mm) of the highest one whose normals face
// up (within acos(min_up_cos) of the table's normal). When they are at least min_top_share of
// the seen points, their narrowest extent over horizontal directions (5 degree steps) is the
// top's width, wide when it exceeds the opening by more than min_excess_over_opening_m (2 cm in
// the config: a 7 cm box and a small neighbour merged into one cluster are not one wide top);
// objects lower than min_height_m (3 cm) are not judged. A tilted box shows a strip of its top
// in the band; a bowl's rim has normals across it; a box under a neighbour shows part of its
// top: none of them is judged wide. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <Eigen/Core>

#include <string>

namespace fast_grasp
{
struct WideFlatTopParams
{
  /// Judge objects at all (false: never wide).
  bool enabled = false;
  /// Seen points within this of the highest one (along the table's normal) are the top. Thin:
  /// a 1 cm phone lying beside a 1.6 cm marker is not one top with it.
  double top_band_m = 0.005;
  /// ... if their normals are within acos(this) of the table's normal.
  double min_up_cos = 0.9;
  /// The top face holds at least this share of the seen points (a flat top seen from above).
  double min_top_share = 0.3;
  /// Objects whose top is lower are not judged: thin things lying flat touch in a pile and come
  /// out as one cluster whose parts are each graspable (a 1 cm phone and a 1.4 cm battery beside
  /// it: one 11 cm "top", training piles seed 5 table 5, where the phone had been picked).
  double min_height_m = 0.03;
  /// Wide: the top's narrowest width exceeds the gripper's opening by more than this.
  double min_excess_over_opening_m = 0.0;
  std::string validate() const;
};

struct FlatTop
{
  double top_share = 0.0;      // ... as a share of all seen points
  double min_width_m = 0.0;    // its narrowest horizontal extent (0 when it is not a flat top)
  bool flat = false;           // top_share >= min_top_share and the top is min_height_m high
};

/// The flat top of `cloud` (with normals toward the sensor) resting on `table_plane` (a, b, c, d
/// with (a, b, c) the unit normal, pointing up).
FlatTop measureFlatTop(const pcl::PointCloud<pcl::PointNormal>& cloud, const Eigen::Vector4f& table_plane,
                       const WideFlatTopParams& params);

/// Whether the object's flat top is wider than `max_opening_m` (+ the excess) at its narrowest.
bool isWideFlatTop(const FlatTop& top, double max_opening_m, const WideFlatTopParams& params);

}  // namespace fast_grasp
