// A narrow grasp closing across one face the camera saw from in front: the thickness behind the
// face was never seen, so the narrow width is the face's noise and the far finger lands inside
// the object's hidden body.
//
// Beyond the thesis. Its unseen part (unseen_part.h, Eq. 6.8) is the silhouette extruded along
// the camera rays: a hollow tube, which stops a finger crossing the object's outline but not one
// placed just behind the middle of a seen face. Where a box stands facing the camera with its
// top out of view (cut by the image edge, or hidden by a neighbour), the concavity and top-down
// candidates pinch its front face 2-10 mm wide. In physics (clutter training tables, seeds 5 and
// 9, fused planner, session 31) grasps under 12 mm on the cracker box held 0 times in 12, those
// on the other objects 29 of 31 (a battery, a paper cup's rim, a marker, a spoon: their depth is
// seen, as a top face or a rim between the fingers).
//
// The test is on what the fingers would close on: the seen points between the open fingers
// (the closing region at full opening, finger-wide) span less than max_width_m along the
// closing line, the grasp closes to less than that too, and most of those points face along
// the closing line, one way (normals are turned toward the sensor, so one seen face has them
// all on one side). A rim, a top face or a lying bar between the fingers has normals across
// the closing line; a grasp whose width assumes the hidden side (an end-on grasp across a
// lying can, 7 cm) is not narrow. ROS-free.
#pragma once

#include "fast_grasp/core/grasp_types.h"

#include <string>

namespace fast_grasp
{
struct OneSeenFaceParams
{
  /// Judge grasps at all (false: nothing is judged).
  bool enabled = false;
  /// A grasp closing to less than this, across seen points spanning less than this along the
  /// closing line, is narrow enough to be a pinch on one face.
  double max_width_m = 0.012;
  /// A point faces along the closing line when its normal is within acos(this) of it.
  double min_facing_cos = 0.8;
  /// ... and at least this share of the points between the fingers face it, one way.
  double min_facing_share = 0.8;

  std::string validate() const;
};

/// Whether `grasp` closes across one seen face whose depth is unseen (see above). `view`'s
/// normals must be turned toward the sensor (ObjectView's convention).
bool closesAcrossOneSeenFace(const GraspCandidate& grasp, const GripperModel& gripper, const ObjectView& view,
                             const OneSeenFaceParams& params);

}  // namespace fast_grasp
