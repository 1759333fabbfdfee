#include "fast_grasp/grasping/gripper_volume.h"

#include <algorithm>
#include <limits>
#include <sstream>

namespace fast_grasp
{
std::array<GripperBox, 3> openGripperBoxes(const GripperModel& gripper, double opening_m)
{
  const float half_depth = static_cast<float>(0.5 * gripper.finger_depth_m);
  const float thickness = static_cast<float>(gripper.finger_thickness_m);
  const float half_width = static_cast<float>(0.5 * gripper.finger_width_m);
  const float inner = static_cast<float>(0.5 * opening_m);
  const float palm = static_cast<float>(gripper.palm_thickness_m);
  const float palm_half_width = static_cast<float>(0.5 * gripper.palmWidth());
  std::array<GripperBox, 3> boxes;
  boxes[0] = { { -half_depth, inner, -half_width }, { half_depth, inner + thickness, half_width } };
  boxes[1] = { { -half_depth, -inner - thickness, -half_width }, { half_depth, -inner, half_width } };
  boxes[2] = { { -half_depth - palm, -inner - thickness, -palm_half_width },
               { -half_depth, inner + thickness, palm_half_width } };
  return boxes;
}

GripperBox closingRegionBox(const GripperModel& gripper, double width_m, double margin_m)
{
  const Eigen::Vector3f half(static_cast<float>(0.5 * gripper.finger_depth_m), static_cast<float>(0.5 * width_m + margin_m),
                             static_cast<float>(0.5 * gripper.finger_width_m));
  return { -half, half };
}

std::string GripperFitParams::validate() const
{
  std::ostringstream why;
  if (!(approach_opening_m >= 0.0))
    why << "gripper_fit/approach_opening_m must be >= 0 (0 = max opening); ";
  if (!(palm_clearance_m >= 0.0))
    why << "gripper_fit/palm_clearance_m must be >= 0; ";
  if (!(max_backoff_m >= 0.0))
    why << "gripper_fit/max_backoff_m must be >= 0 (0 = automatic); ";
  if (!(table_clearance_m >= 0.0))
    why << "gripper_fit/table_clearance_m must be >= 0; ";
  if (min_points_between_fingers < 1)
    why << "gripper_fit/min_points_between_fingers must be >= 1; ";
  if (!(closing_margin_m >= 0.0))
    why << "gripper_fit/closing_margin_m must be >= 0; ";
  if (!(max_table_tilt_rad >= 0.0 && max_table_tilt_rad <= M_PI))
    why << "gripper_fit/max_table_tilt_rad must be in [0, pi]; ";
  if (!(tilt_step_rad > 0.0))
    why << "gripper_fit/tilt_step_rad must be > 0; ";
  if (!(finger_graze_margin_m >= 0.0 && finger_graze_margin_m <= 0.05))
    why << "gripper_fit/finger_graze_margin_m must be in [0, 0.05]; ";
  if (!(max_advance_m >= 0.0 && max_advance_m <= 0.2))
    why << "gripper_fit/max_advance_m must be in [0, 0.2]; ";
  return why.str();
}

GripperVolumeCheck::GripperVolumeCheck(const GripperModel& gripper, GripperFitParams params)
  : gripper_(gripper)
  , params_(params)
  , open_boxes_(openGripperBoxes(gripper, params.approach_opening_m > 0.0 ? params.approach_opening_m
                                                                          : gripper.max_opening_m))
{
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant(static_cast<float>(params_.finger_graze_margin_m));
  for (std::size_t i = 0; i < graze_boxes_.size(); ++i)
    graze_boxes_[i] = { open_boxes_[i].min - margin, open_boxes_[i].max + margin };
}

void GripperVolumeCheck::addUnseen(const CloudXYZ& cloud)
{
  appendFinite(cloud, unseen_);
}

void GripperVolumeCheck::addObstacles(const ObjectView& view)
{
  if (view.obstacles)
    appendFinite(*view.obstacles, unseen_);
}

double GripperVolumeCheck::maxBackoff() const
{
  constexpr double kMinFingerOverlapM = 0.005;
  return params_.max_backoff_m > 0.0 ? params_.max_backoff_m
                                     : std::max(0.0, 0.5 * gripper_.finger_depth_m - kMinFingerOverlapM);
}

void GripperVolumeCheck::setTable(const Eigen::Vector4f& plane)
{
  const float length = plane.head<3>().norm();
  if (!plane.allFinite() || length < 1e-6f)
    return;
  table_ = plane / length;
  // Above = the side most seen points are on.
  if (seen_.cols() > 0)
  {
    const float mean_height = (table_.head<3>().transpose() * seen_).mean() + table_(3);
    if (mean_height < 0.0f)
      table_ = -table_;
  }
  has_table_ = true;
}

GripperFit GripperVolumeCheck::fit(const Eigen::Isometry3d& pose, double width_m) const
{
  GripperFit result;
  result.pose = pose;
  const Eigen::Matrix3f to_local = pose.linear().cast<float>().transpose();
  const Eigen::Vector3f origin = pose.translation().cast<float>();
  const GripperBox& palm = open_boxes_[2];
  const float clearance = static_cast<float>(params_.palm_clearance_m);
  const float max_backoff = static_cast<float>(maxBackoff());

  // Every obstacle point in grasp coordinates, once: backing the hand out by b along its own
  // X only adds b to each point's x, so one transform serves every check below.
  const Eigen::Index seen_count = seen_.cols();
  Eigen::Matrix3Xf local(3, seen_count + unseen_.cols());
  local.leftCols(seen_count).noalias() = to_local * (seen_.colwise() - origin);
  local.rightCols(unseen_.cols()).noalias() = to_local * (unseen_.colwise() - origin);

  // Obstacle points in the palm's footprint (the prism the palm sweeps along X). Points
  // farther behind than the largest back-off can never meet the palm.
  std::vector<float> footprint_x;
  const float behind_limit = palm.min.x() - max_backoff - clearance;
  for (Eigen::Index i = 0; i < local.cols(); ++i)
  {
    const float x = local(0, i);
    if (x >= behind_limit && x <= palm.max.x() + clearance && std::abs(local(1, i)) <= palm.max.y() &&
        std::abs(local(2, i)) <= palm.max.z())
      footprint_x.push_back(x);
  }

  // Back off until no footprint point lies in the (clearance-grown) palm slab. Each pass moves
  // the palm face in front of every point it hit, so the back-off only grows and the loop ends
  // after at most as many passes as there are points (in practice one or two).
  float backoff = 0.0f;
  for (std::size_t pass = 0; pass <= footprint_x.size(); ++pass)
  {
    float needed = backoff;
    for (const float x : footprint_x)
      if (x + backoff >= palm.min.x() - clearance && x + backoff <= palm.max.x() + clearance)
        needed = std::max(needed, palm.max.x() + clearance - x);
    if (needed == backoff)
      break;
    backoff = needed;
    if (backoff > max_backoff)
    {
      std::ostringstream why;
      why << "the palm would enter the object: backing out " << backoff << " m exceeds gripper_fit/max_backoff_m "
          << max_backoff;
      result.why = why.str();
      result.backoff_m = backoff;
      return result;
    }
  }
  // The table: the hand's lowest corner moves by -backoff * (normal . approach); a hand
  // approaching from above is raised by backing out further, any other one is rejected.
  result.lowest_above_table_m = std::numeric_limits<double>::infinity();
  if (has_table_)
  {
    const Eigen::Vector3f normal = table_.head<3>();
    const Eigen::Vector3f normal_local = to_local * normal;  // the normal in grasp coordinates
    float lowest = std::numeric_limits<float>::infinity();
    for (const GripperBox& box : open_boxes_)
      for (int corner = 0; corner < 8; ++corner)
        lowest = std::min(lowest, normal_local.dot(box.corner(corner)));
    lowest += normal.dot(origin) + table_(3);  // at backoff 0
    const float descent = normal_local.x();   // height change per metre along the approach
    const float table_clearance = static_cast<float>(params_.table_clearance_m);
    if (lowest - backoff * descent < table_clearance)
    {
      if (descent < -1e-3f)
        backoff = std::max(backoff, (table_clearance - lowest) / -descent + 1e-5f);
      if (descent >= -1e-3f || backoff > max_backoff)
      {
        // Report the height the hand can reach, not the one the needed back-off would give.
        std::ostringstream why;
        if (descent < -1e-3f)
          why << "the open hand stays " << lowest - max_backoff * descent << " m above the table at the largest "
              << "back-off gripper_fit/max_backoff_m " << max_backoff << " (needs " << table_clearance
              << " m, table_clearance_m; backing out " << backoff << " m would give it)";
        else
          why << "the open hand would reach " << lowest - backoff * descent << " m above the table (< gripper_fit/"
              << "table_clearance_m " << table_clearance << ") and backing out does not raise it";
        result.why = why.str();
        result.backoff_m = backoff;
        result.blocked_by_table = true;
        return result;
      }
    }
    result.lowest_above_table_m = lowest - backoff * descent;
  }
  result.backoff_m = backoff;
  result.pose.translation() = pose.translation() - static_cast<double>(backoff) * pose.linear().col(0);

  // The whole open hand at the fitted pose, and what the closed fingers would hold.
  const GripperBox closing = closingRegionBox(gripper_, width_m, params_.closing_margin_m);
  const Eigen::Vector3f shift(backoff, 0.0f, 0.0f);
  const bool count_grazing = params_.finger_graze_margin_m > 0.0;
  for (Eigen::Index i = 0; i < local.cols(); ++i)
  {
    const Eigen::Vector3f q = local.col(i) + shift;
    const bool in_hand = open_boxes_[0].contains(q) || open_boxes_[1].contains(q) || open_boxes_[2].contains(q);
    if (count_grazing && !in_hand)
      result.points_grazing_fingers += graze_boxes_[0].contains(q) || graze_boxes_[1].contains(q);
    if (i < seen_count)
    {
      result.seen_in_gripper += in_hand;
      result.points_between_fingers += closing.contains(q);
    }
    else
      result.unseen_in_gripper += in_hand;
  }

  std::ostringstream why;
  if (result.seen_in_gripper > 0)
    why << result.seen_in_gripper << " object points inside the open fingers; ";
  if (result.unseen_in_gripper > 0)
    why << result.unseen_in_gripper << " unseen-part points inside the open hand; ";
  if (result.points_between_fingers < static_cast<std::size_t>(params_.min_points_between_fingers))
    why << "only " << result.points_between_fingers << " object points between the fingers after backing out "
        << backoff << " m; ";
  result.why = why.str();
  result.ok = result.why.empty();
  return result;
}

GripperFit GripperVolumeCheck::fitDeepest(const Eigen::Isometry3d& pose, double width_m) const
{
  constexpr double kAdvanceStepM = 0.005;
  const int steps = static_cast<int>(std::floor(params_.max_advance_m / kAdvanceStepM + 1e-9));
  for (int k = steps; k > 0; --k)
  {
    Eigen::Isometry3d deeper = pose;
    deeper.translation() += static_cast<double>(k) * kAdvanceStepM * pose.linear().col(0);
    GripperFit fitted = fit(deeper, width_m);
    if (fitted.ok)
      return fitted;
  }
  return fit(pose, width_m);
}

GripperFit GripperVolumeCheck::fitOrTilt(const Eigen::Isometry3d& pose, double width_m) const
{
  GripperFit first = fitDeepest(pose, width_m);
  if (first.ok || !first.blocked_by_table || !has_table_ || params_.max_table_tilt_rad <= 0.0)
    return first;
  // Turn the approach about the closing line toward "down" (-table normal) projected onto the
  // plane the turn keeps: the contacts and the closing direction do not move.
  const Eigen::Vector3d closing = pose.linear().col(1);
  const Eigen::Vector3d approach = pose.linear().col(0);
  const Eigen::Vector3d down = -table_.head<3>().cast<double>();
  Eigen::Vector3d goal = down - down.dot(closing) * closing;
  if (goal.norm() < 1e-3)
    return first;  // closing line vertical: no turn about it points the hand down
  goal.normalize();
  const double angle_to_goal = std::atan2(approach.cross(goal).dot(closing), approach.dot(goal));
  const double reach = std::min(std::abs(angle_to_goal), params_.max_table_tilt_rad);
  const double sign = angle_to_goal < 0.0 ? -1.0 : 1.0;
  for (double tilt = params_.tilt_step_rad;; tilt += params_.tilt_step_rad)
  {
    tilt = std::min(tilt, reach);
    Eigen::Isometry3d turned = pose;
    turned.linear() = Eigen::AngleAxisd(sign * tilt, closing).toRotationMatrix() * pose.linear();
    GripperFit fitted = fitDeepest(turned, width_m);
    if (fitted.ok)
      return fitted;
    if (tilt >= reach)
      break;
  }
  return first;
}

std::size_t GripperVolumeCheck::filter(std::vector<GraspCandidate>& grasps, std::string* why,
                                       std::size_t max_kept, std::size_t* blocked_by_table) const
{
  if (blocked_by_table)
    *blocked_by_table = 0;
  if (!params_.enabled)
  {
    if (grasps.size() > max_kept)
      grasps.resize(max_kept);
    return 0;
  }
  std::size_t dropped = 0;
  std::vector<GraspCandidate> kept;
  kept.reserve(std::min(grasps.size(), max_kept));
  for (GraspCandidate& grasp : grasps)
  {
    if (kept.size() >= max_kept)
      break;
    const GripperFit fitted = fitOrTilt(grasp.pose, grasp.width_m);
    if (fitted.ok)
    {
      grasp.pose = fitted.pose;
      kept.push_back(std::move(grasp));
      continue;
    }
    if (dropped++ == 0 && why)
      *why = fitted.why;
    if (blocked_by_table && fitted.blocked_by_table)
      ++*blocked_by_table;
  }
  grasps = std::move(kept);
  return dropped;
}

}  // namespace fast_grasp
