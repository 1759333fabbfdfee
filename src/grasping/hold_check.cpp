#include "fast_grasp/grasping/hold_check.h"

#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/near_range.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

namespace fast_grasp
{
bool closesBelowCentreOfMass(const GraspCandidate& grasp, const ObjectExtent& extent, double tall_object_min_height_m,
                             double side_min_height_frac)
{
  if (!(tall_object_min_height_m > 0.0) || extent.height_m < static_cast<float>(tall_object_min_height_m))
    return false;
  const Eigen::Vector3f approach = grasp.pose.linear().col(0).cast<float>();
  if (std::abs(approach.dot(extent.up)) > 0.5f)
    return false;
  const float height = extent.up.dot(grasp.pose.translation().cast<float>()) + extent.table_offset;
  return height < static_cast<float>(side_min_height_frac) * extent.height_m;
}

bool HoldCheckParams::anyRuleOn() const
{
  return lying_cylinder.enabled || resting_ball.enabled || standing_cylinder.enabled || one_seen_face.enabled ||
         (near_range.flag_grasps_on_cut && near_range.sensor_min_range_m > 0.0) || tall_object_min_height_m > 0.0 ||
         max_closing_tilt_rad > 0.0;
}

bool closingLineTooSteep(const GraspCandidate& grasp, const Eigen::Vector3f& up, double max_closing_tilt_rad)
{
  if (!(max_closing_tilt_rad > 0.0))
    return false;
  const float rise = std::abs(grasp.binormal().cast<float>().dot(up));
  return std::asin(std::min(rise, 1.0f)) > static_cast<float>(max_closing_tilt_rad);
}

DropRisk dropRisk(const GraspCandidate& grasp, const GripperModel& gripper, const ObjectView& view,
                  const ObjectExtent& extent, const LyingCylinder& lying, const RestingBall& ball,
                  const CloudNormal& near_limit_cut, const HoldCheckParams& params)
{
  if (closesBelowCentreOfMass(grasp, extent, params.tall_object_min_height_m, params.tall_side_min_height_frac))
    return DropRisk::BelowCentreOfMass;
  const double opening_m = params.approach_opening_m > 0.0 ? params.approach_opening_m : gripper.max_opening_m;
  switch (judgeGraspAcrossCylinder(grasp, gripper, lying, params.lying_cylinder, opening_m))
  {
    case GraspAcrossCylinder::ShortOfAxis:
      return DropRisk::ShortOfAxis;
    case GraspAcrossCylinder::OntoHiddenSide:
      return DropRisk::OntoHiddenSide;
    case GraspAcrossCylinder::NotAcross:
    case GraspAcrossCylinder::Holds:
      break;
  }
  if (fingertipsStopHighOnBall(grasp, gripper, ball, params.resting_ball))
    return DropRisk::HighOnBall;
  if (closesAcrossOneSeenFace(grasp, gripper, view, params.one_seen_face))
    return DropRisk::AcrossOneSeenFace;
  if (closesOnNearLimitCut(grasp, gripper, near_limit_cut, params.near_range))
    return DropRisk::OnNearLimitCut;
  return DropRisk::None;
}

void DropCounts::add(DropRisk risk)
{
  switch (risk)
  {
    case DropRisk::BelowCentreOfMass:
      ++below_centre_of_mass;
      break;
    case DropRisk::ShortOfAxis:
      ++short_of_axis;
      break;
    case DropRisk::OntoHiddenSide:
      ++onto_hidden_side;
      break;
    case DropRisk::HighOnBall:
      ++high_on_ball;
      break;
    case DropRisk::ShortOfStandingAxis:
      ++short_of_standing_axis;
      break;
    case DropRisk::SteepClosingLine:
      ++steep_closing_line;
      break;
    case DropRisk::AcrossOneSeenFace:
      ++across_one_seen_face;
      break;
    case DropRisk::OnNearLimitCut:
      ++on_near_limit_cut;
      break;
    case DropRisk::None:
      break;
  }
}

HoldCheckedPlanner::HoldCheckedPlanner(std::unique_ptr<GraspPlanner> planner, HoldCheckParams params)
  : planner_(std::move(planner)), params_(std::move(params))
{
}

GraspResult HoldCheckedPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  GraspResult result = planner_->plan(view, gripper);
  if (!result.ok() || !params_.anyRuleOn())
    return result;
  const Stopwatch watch;
  const ObjectExtent extent = objectExtent(view);
  const LyingCylinder lying = fitLyingCylinder(view, extent, params_.lying_cylinder);
  // A lying can seen end-on is also round about a centre; its own rules judge it.
  const RestingBall ball = lying.found ? RestingBall{} : fitRestingBall(view, extent, params_.resting_ball);
  const CloudNormal near_limit_cut = nearLimitCut(*view.cloud, params_.near_range);
  std::vector<GraspCandidate> kept;
  DropCounts dropped;
  float widest_standing_section_m = 0.0f;
  for (auto& grasp : result.grasps)
  {
    DropRisk risk = dropRisk(grasp, gripper, view, extent, lying, ball, near_limit_cut, params_);
    // A lying round object or a ball is judged by its own fit above.
    if (risk == DropRisk::None && !lying.found && !ball.found)
      if (const auto section = standingSectionMissed(grasp, gripper, view, extent, params_.standing_cylinder))
      {
        risk = DropRisk::ShortOfStandingAxis;
        widest_standing_section_m = std::max(widest_standing_section_m, section->radius_m);
      }
    if (risk == DropRisk::None && !ball.found && closingLineTooSteep(grasp, extent.up, params_.max_closing_tilt_rad))
      risk = DropRisk::SteepClosingLine;
    dropped.add(risk);
    if (risk == DropRisk::None)
      kept.push_back(std::move(grasp));
  }
  std::ostringstream why;
  if (dropped.below_centre_of_mass > 0)
    why << "tall object (" << std::lround(1000.0f * extent.height_m) << " mm): dropped " << dropped.below_centre_of_mass
        << " side grasps below its centre of mass (an inverted pendulum in physics)";
  if (lying.found)
    why << (dropped.below_centre_of_mass > 0 ? "; " : "") << "lying round object (radius "
        << std::lround(1000.0f * lying.radius_m) << " mm): dropped " << dropped.short_of_axis
        << " grasps whose fingertips stop short of its axis (slip out in physics) and " << dropped.onto_hidden_side
        << " whose open hand lands on its hidden side";
  if (ball.found)
  {
    why << (dropped.below_centre_of_mass > 0 || lying.found ? "; " : "");
    if (ball.horizontal_half_axes_m.x() > ball.radius_m * 1.001f)
      why << "round body (half-axes " << std::lround(1000.0f * ball.horizontal_half_axes_m.x()) << " x "
          << std::lround(1000.0f * ball.horizontal_half_axes_m.y()) << " x " << std::lround(1000.0f * ball.radius_m)
          << " mm)";
    else
      why << "ball (radius " << std::lround(1000.0f * ball.radius_m) << " mm)";
    why << ": dropped " << dropped.high_on_ball
        << " grasps whose fingertips stop high on it (the pads' tips pop it out in physics)";
  }
  if (dropped.short_of_standing_axis > 0)
    why << (dropped.below_centre_of_mass > 0 || lying.found || ball.found ? "; " : "") << "tall round object (radius up to "
        << std::lround(1000.0f * widest_standing_section_m) << " mm where they close): dropped "
        << dropped.short_of_standing_axis
        << " side grasps whose fingertips stop short of its axis (the pads close on a chord near their tips and "
           "squeeze it out in physics)";
  if (dropped.steep_closing_line > 0)
    why << (why.tellp() > 0 ? "; " : "") << "dropped " << dropped.steep_closing_line
        << " grasps whose closing line tilts more than " << std::lround(params_.max_closing_tilt_rad * 180.0 / M_PI)
        << " deg from the table (the object turns out of the pads in physics)";
  if (dropped.across_one_seen_face > 0)
    why << (why.tellp() > 0 ? "; " : "") << "dropped " << dropped.across_one_seen_face
        << " narrow grasps across one seen face whose depth the camera never saw (the far finger lands inside "
           "the hidden body)";
  if (dropped.on_near_limit_cut > 0)
    why << (why.tellp() > 0 ? "; " : "") << "dropped " << dropped.on_near_limit_cut
        << " grasps closing where the camera's near limit cut the object (the hand comes down onto what it "
           "could not see)";
  const double spent_s = result.compute_time_s + watch.elapsedSeconds();
  if (kept.empty())
  {
    // Keep what the caller can still use: the next view, the drawings.
    GraspResult none = GraspResult::fail(GraspFailure::NoStableGrasp, std::string(name()) + ": " + why.str() +
                                                                          "; none left (" + result.message + ")");
    none.candidates_evaluated = result.candidates_evaluated;
    none.hull = std::move(result.hull);
    none.graspable_zone = std::move(result.graspable_zone);
    none.candidates = std::move(result.candidates);
    none.unseen = std::move(result.unseen);
    none.next_view = result.next_view;
    // As in the fused planner: a view at the same distance would be cut again.
    if (dropped.on_near_limit_cut > 0)
      if (const auto back = nextViewBackFromNearLimit(*view.cloud, params_.near_range))
      {
        none.next_view = back;
        none.message += "; " + nextViewBackFromNearLimitNote(params_.near_range);
      }
    none.compute_time_s = spent_s;
    return none;
  }
  result.grasps = std::move(kept);
  if (dropped.total() > 0)
    result.message += (result.message.empty() ? "" : "; ") + why.str();
  result.compute_time_s = spent_s;
  return result;
}

}  // namespace fast_grasp
