#include "fast_grasp/grasping/fused_grasp.h"

#include "fast_grasp/grasping/hold_check.h"
#include "fast_grasp/grasping/near_range.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

namespace fast_grasp
{
namespace
{
/// Extent of the finite points along `direction`: (min, max).
std::pair<float, float> extentAlong(const CloudNormal& cloud, const Eigen::Vector3f& direction)
{
  float lo = std::numeric_limits<float>::max(), hi = -lo;
  for (const auto& p : cloud.points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (!q.allFinite())
      continue;
    const float s = direction.dot(q);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  return { lo, hi };
}

/// `view` with every k-th point of its cloud, so that at most `max_points` remain (0 = all).
ObjectView thinned(const ObjectView& view, std::size_t max_points)
{
  if (max_points == 0 || view.cloud->size() <= max_points)
    return view;
  const std::size_t stride = (view.cloud->size() + max_points - 1) / max_points;
  CloudNormal::Ptr cloud(new CloudNormal);
  cloud->reserve(view.cloud->size() / stride + 1);
  for (std::size_t i = 0; i < view.cloud->size(); i += stride)
    cloud->push_back(view.cloud->points[i]);
  cloud->header = view.cloud->header;
  cloud->sensor_origin_ = view.cloud->sensor_origin_;  // the camera (near_range.h judges by it)
  cloud->sensor_orientation_ = view.cloud->sensor_orientation_;
  ObjectView out = view;
  out.cloud = cloud;
  return out;
}

struct Generated
{
  GraspCandidate grasp;
  std::string source;
  /// The hand is checked against the seen points and the table, not the unseen part: an
  /// end-on grasp's far finger passes the hidden side, where the unseen part's shadows (10 cm
  /// along the camera rays) always reach; its width already assumes that hidden side.
  bool without_unseen = false;
};

/// An end-on grasp (Generated::without_unseen) is checked without the unseen part, for its far
/// finger's sake; its palm still must not enter it. Beyond the seen end of an object whose end
/// faces away from the camera the unseen part is what the object itself hides there (a lying
/// bottle's neck behind its body, seen from its base): in physics the hand met it before
/// closing (training half, session 20: two lying water bottles, now grasped from their base).
/// A part outside the camera's field of view casts no shadow and is not caught (a 30 cm wine
/// bottle's neck, twice in 100 training views).
bool palmEntersUnseen(const Eigen::Isometry3d& pose, const GripperModel& gripper, const GripperFitParams& fit,
                      const CloudXYZ& unseen)
{
  const GripperBox palm =
      openGripperBoxes(gripper, fit.approach_opening_m > 0.0 ? fit.approach_opening_m : gripper.max_opening_m)[2];
  const Eigen::Isometry3f to_grasp = pose.inverse().cast<float>();
  for (const auto& p : unseen.points)
  {
    const Eigen::Vector3f q = p.getVector3fMap();
    if (q.allFinite() && palm.contains(to_grasp * q))
      return true;
  }
  return false;
}

/// FusedParams::tall_object_min_height_m: the object counts as tall.
bool isTall(const ObjectExtent& extent, const FusedParams& p)
{
  return p.tall_object_min_height_m > 0.0 && extent.height_m >= static_cast<float>(p.tall_object_min_height_m);
}

/// Top-down grasps: one per closing direction at the centroid and at +-a quarter of the object's
/// length along its major horizontal axis (a hammer's handle, a clamp's jaw). The width is what
/// lies between the fingers (a finger-wide slab), not the whole object's extent, and the palm
/// starts palm_clearance_m above the highest point under it.
void topDownCandidates(const ObjectView& view, const ObjectExtent& extent, const GripperModel& gripper,
                       const FusedParams& p, std::vector<Generated>& out)
{
  if (p.top_down_directions == 0)
    return;
  const auto [e1, e2] = tablePlaneBasis(extent.up);
  const float finger_depth = static_cast<float>(gripper.finger_depth_m);
  const float half_finger = 0.5f * static_cast<float>(gripper.finger_width_m) + 0.005f;
  const float half_palm_z = 0.5f * static_cast<float>(gripper.palmWidth());
  const float half_palm_y = 0.5f * static_cast<float>(gripper.max_opening_m) + static_cast<float>(gripper.finger_thickness_m);
  std::vector<Eigen::Vector3f> points;
  points.reserve(view.cloud->size());
  for (const auto& q : view.cloud->points)
  {
    const Eigen::Vector3f v = q.getVector3fMap();
    if (v.allFinite())
      points.push_back(v);
  }
  const Eigen::Vector3f& major = extent.major_axis;
  const float length = extent.length_m;
  const float centroid_height = extent.centroid_height_m();
  for (const float offset : { 0.0f, -0.25f, 0.25f })
  {
    const Eigen::Vector3f through = extent.centroid + offset * length * major;
    for (std::size_t i = 0; i < p.top_down_directions; ++i)
    {
      const float angle = static_cast<float>(M_PI) * static_cast<float>(i) / static_cast<float>(p.top_down_directions);
      const Eigen::Vector3f closing = std::cos(angle) * e1 + std::sin(angle) * e2;
      const Eigen::Vector3f across = extent.up.cross(closing);  // the fingers' width direction
      float lo = std::numeric_limits<float>::max(), hi = -lo, top = -lo;
      std::size_t in_slab = 0;
      for (const Eigen::Vector3f& v : points)
      {
        const Eigen::Vector3f d = v - through;
        const float z = std::abs(d.dot(across)), y = d.dot(closing);
        if (z <= half_finger)
        {
          lo = std::min(lo, y);
          hi = std::max(hi, y);
          ++in_slab;
        }
        if (z <= half_palm_z && std::abs(y) <= half_palm_y)
          top = std::max(top, extent.up.dot(v) + extent.table_offset);
      }
      const double width = static_cast<double>(hi - lo);
      if (in_slab < 5 || width > gripper.max_opening_m - 0.005)
        continue;
      // The palm palm_clearance_m above the top, unless that puts the fingertips closer to the
      // table than table_clearance_m (a flat object): then the fingertips set the height.
      const float centre_height =
          std::max(top + static_cast<float>(p.gripper_fit.palm_clearance_m) + 0.001f - 0.5f * finger_depth,
                   static_cast<float>(p.gripper_fit.table_clearance_m) + 0.001f + 0.5f * finger_depth);
      Eigen::Vector3f centre = through + (centre_height - centroid_height) * extent.up;
      centre += 0.5f * (lo + hi) * closing;  // the closing line through the middle of what is between the fingers
      Generated g;
      g.source = "top_down";
      g.grasp.pose = makeGraspPose(centre.cast<double>(), (-extent.up).cast<double>(), closing.cast<double>());
      g.grasp.width_m = std::max(width, gripper.min_opening_m);
      out.push_back(g);
    }
  }
}

/// Side grasps at the centroid's height, approaching horizontally from the camera's side; on a
/// tall object also at FusedParams::side_high_fracs of its height, as wide as the seen points
/// in a finger-wide band there.
void sideCandidates(const ObjectView& view, const ObjectExtent& extent, const GripperModel& gripper,
                    const FusedParams& p, std::vector<Generated>& out)
{
  if (p.side_directions == 0 || view.sensor_origins.empty())
    return;
  Eigen::Vector3f look = extent.centroid - view.sensor_origins.front();
  look -= look.dot(extent.up) * extent.up;
  if (look.norm() < 1e-3f)
    return;  // camera straight above: no side to come from
  look.normalize();
  const float centroid_height = extent.centroid_height_m();
  const float lowest_centre = 0.5f * static_cast<float>(gripper.palmWidth()) +
                              static_cast<float>(p.gripper_fit.table_clearance_m) + 0.002f;
  // (closing-line height, half-height of the band whose points set the width; 0 = all points)
  std::vector<std::pair<float, float>> heights{ { std::max(centroid_height, lowest_centre), 0.0f } };
  if (isTall(extent, p))
  {
    const float half_band = 0.5f * static_cast<float>(gripper.finger_width_m) + 0.005f;
    for (const double frac : p.side_high_fracs)
      heights.emplace_back(std::max(static_cast<float>(frac) * extent.height_m, lowest_centre), half_band);
  }
  std::vector<Eigen::Vector3f> band;
  band.reserve(view.cloud->size());
  for (const auto& [centre_height, half_band] : heights)
  {
    band.clear();
    for (const auto& q : view.cloud->points)
    {
      const Eigen::Vector3f v = q.getVector3fMap();
      if (v.allFinite() && (half_band == 0.0f || std::abs(extent.up.dot(v) + extent.table_offset - centre_height) <= half_band))
        band.push_back(v);
    }
    if (band.size() < 5)
      continue;
    for (std::size_t i = 0; i < p.side_directions; ++i)
    {
      const float t = p.side_directions == 1 ? 0.0f
                                             : -1.0f + 2.0f * static_cast<float>(i) / static_cast<float>(p.side_directions - 1);
      const Eigen::Vector3f approach = Eigen::AngleAxisf(t * static_cast<float>(p.side_spread_rad), extent.up) * look;
      const Eigen::Vector3f closing = extent.up.cross(approach).normalized();
      float lo = std::numeric_limits<float>::max(), hi = -lo, front = lo, back = -lo;
      for (const Eigen::Vector3f& v : band)
      {
        lo = std::min(lo, closing.dot(v));
        hi = std::max(hi, closing.dot(v));
        front = std::min(front, approach.dot(v));
        back = std::max(back, approach.dot(v));
      }
      const double width = static_cast<double>(hi - lo);
      if (width > gripper.max_opening_m - 0.005)
        continue;
      // The far side is unseen: the middle of what was seen along the approach (the top, where
      // visible, spans the depth), but no deeper than a round object as deep as it is wide.
      const float depth_centre = std::min(0.5f * (front + back), front + 0.5f * static_cast<float>(width));
      Eigen::Vector3f centre = extent.centroid;
      centre += (centre_height - centroid_height) * extent.up;
      centre += (depth_centre - approach.dot(centre)) * approach;
      centre += (0.5f * (lo + hi) - closing.dot(centre)) * closing;
      Generated g;
      g.source = "side";
      g.grasp.pose = makeGraspPose(centre.cast<double>(), approach.cast<double>(), closing.cast<double>());
      g.grasp.width_m = std::max(width, gripper.min_opening_m);
      out.push_back(g);
    }
  }
}

/// End-on grasps (FusedParams::end_grasps): horizontal approaches along the footprint's major
/// axis from both ends, the fingers around the last finger_depth_m less the palm clearance,
/// the closing line at half the object's height: a round object lying down is widest there
/// (the seen points' centroid lies above it, on the side facing the camera), a box anywhere.
void endCandidates(const ObjectView& view, const ObjectExtent& extent, const GripperModel& gripper,
                   const FusedParams& p, std::vector<Generated>& out)
{
  // Only objects lower than the opening: the hidden far side is assumed one object-height from
  // the near edge, which says nothing about a tall object (an upright cracker box's hidden back).
  if (!p.end_grasps || extent.height_m > static_cast<float>(gripper.max_opening_m) - 0.005f)
    return;
  const float centroid_height = extent.centroid_height_m();
  const float lowest_centre = 0.5f * static_cast<float>(gripper.palmWidth()) +
                              static_cast<float>(p.gripper_fit.table_clearance_m) + 0.002f;
  const float centre_height = std::max(0.5f * extent.height_m, lowest_centre);
  const float palm_clearance = static_cast<float>(p.gripper_fit.palm_clearance_m) + 0.001f;
  const float surrounded = static_cast<float>(gripper.finger_depth_m) - palm_clearance;
  if (surrounded <= 0.0f)
    return;
  for (const float sign : { 1.0f, -1.0f })
  {
    const Eigen::Vector3f approach = sign * extent.major_axis;
    const Eigen::Vector3f closing = extent.up.cross(approach).normalized();
    const float front = extentAlong(*view.cloud, approach).first;
    // Across all heights of the surrounded end: the camera sees a lying object's top and one
    // side, so only all of them span its width (the points at the closing line's height are
    // the near side's alone).
    float lo = std::numeric_limits<float>::max(), hi = -lo;
    std::size_t in_fingers = 0;
    for (const auto& q : view.cloud->points)
    {
      const Eigen::Vector3f v = q.getVector3fMap();
      if (!v.allFinite() || approach.dot(v) > front + surrounded)
        continue;
      lo = std::min(lo, closing.dot(v));
      hi = std::max(hi, closing.dot(v));
      ++in_fingers;
    }
    if (in_fingers < 5 || hi - lo > static_cast<float>(gripper.max_opening_m) - 0.005f)
      continue;
    // The far side is unseen: the near edge (the camera's side) is where it was seen, the far
    // one at least as far as the object is high (a round object lying down is as wide as high).
    if (!view.sensor_origins.empty())
    {
      const bool camera_on_hi = closing.dot(view.sensor_origins.front() - extent.centroid) > 0.0f;
      const float wide = std::min(extent.height_m, static_cast<float>(gripper.max_opening_m) - 0.005f);
      if (camera_on_hi)
        lo = std::min(lo, hi - wide);
      else
        hi = std::max(hi, lo + wide);
    }
    const double width = static_cast<double>(hi - lo);
    Eigen::Vector3f centre = extent.centroid + (centre_height - centroid_height) * extent.up;
    centre += (front - palm_clearance + 0.5f * static_cast<float>(gripper.finger_depth_m) - approach.dot(centre)) * approach;
    centre += (0.5f * (lo + hi) - closing.dot(centre)) * closing;
    Generated g;
    // its own source: it holds or fails for other reasons than the camera-side grasps (its
    // fingers close across the length's end, beside the unseen part), and the model ranks it so
    g.source = "end";
    g.grasp.pose = makeGraspPose(centre.cast<double>(), approach.cast<double>(), closing.cast<double>());
    g.grasp.width_m = std::max(width, gripper.min_opening_m);
    g.without_unseen = true;
    out.push_back(g);
  }
}
}  // namespace

std::string FusedParams::validate() const
{
  std::ostringstream why;
  if (max_grasps < 1)
    why << "max_grasps must be >= 1; ";
  if (!(side_spread_rad >= 0.0 && side_spread_rad <= M_PI))
    why << "side_spread_rad must be in [0, pi]; ";
  if (!(tall_object_min_height_m >= 0.0 && tall_object_min_height_m <= 1.0))
    why << "tall_object_min_height_m must be in [0, 1] m; ";
  if (side_high_fracs.size() > 8)
    why << "side_high_fracs takes at most 8 heights; ";
  for (const double frac : side_high_fracs)
    if (!(frac > 0.0 && frac < 1.0))
      why << "side_high_fracs must lie in (0, 1); ";
  if (!(tall_side_min_height_frac >= 0.0 && tall_side_min_height_frac <= 1.0))
    why << "tall_side_min_height_frac must be in [0, 1]; ";
  if (!(deepen_pooled_max_m >= 0.0 && deepen_pooled_max_m <= 0.2))
    why << "deepen_pooled_max_m must be in [0, 0.2] m; ";
  if (!(min_success_probability >= 0.0 && min_success_probability <= 1.0))
    why << "min_success_probability must be in [0, 1]; ";
  if (!(finger_graze_penalty >= 0.0 && finger_graze_penalty <= 1.0))
    why << "finger_graze_penalty must be in [0, 1]; ";
  if (!(wide_lying_body.mirror.min_elongation >= 1.0) ||
      !(wide_lying_body.mirror.max_free_fraction >= 0.0 && wide_lying_body.mirror.max_free_fraction <= 1.0) ||
      !(wide_lying_body.min_excess_over_opening_m >= -0.1 && wide_lying_body.min_excess_over_opening_m <= 0.1))
    why << "wide_lying_body: min_elongation must be >= 1, max_free_fraction in [0, 1], min_excess_over_opening_m in [-0.1, 0.1] m; ";
  why << gripper_fit.validate() << lying_cylinder.validate() << one_seen_face.validate() << wide_flat_top.validate()
      << model.validate();
  return why.str();
}

FusedGraspPlanner::FusedGraspPlanner(std::vector<std::unique_ptr<GraspPlanner>> planners, FusedParams params)
  : planners_(std::move(planners)), params_(std::move(params))
{
}

GraspResult FusedGraspPlanner::plan(const ObjectView& full_view, const GripperModel& gripper) const
{
  const Stopwatch watch;
  if (auto bad = checkPlannerInput(name(), params_.validate(), gripper, full_view, 10, params_.input_limits))
  {
    bad->compute_time_s = watch.elapsedSeconds();
    return *bad;
  }
  std::ostringstream summary;
  if (params_.wide_lying_body.enabled && full_view.has_table_plane && !full_view.sensor_origins.empty())
  {
    const MirrorCompletion body = completeByMirror(*full_view.cloud, full_view.sensor_origins.front(),
                                                   full_view.table_plane, params_.wide_lying_body.mirror);
    if (body.ok())
    {
      summary << "lying body " << std::lround(1000.0 * body.width_m) << " mm wide once mirrored; ";
      if (body.width_m > gripper.max_opening_m + params_.wide_lying_body.min_excess_over_opening_m)
      {
        std::ostringstream why;
        why << "fused: a body lying along the table, " << std::lround(1000.0 * body.width_m)
            << " mm wide once its hidden far side is mirrored from its near side, is wider than the hand's "
            << std::lround(1000.0 * gripper.max_opening_m)
            << " mm opening: nothing closes across it near its mass, and a grasp on its end drops it";
        GraspResult refused = GraspResult::fail(GraspFailure::NoStableGrasp, why.str());
        refused.compute_time_s = watch.elapsedSeconds();
        return refused;
      }
    }
  }
  if (params_.wide_flat_top.enabled && full_view.has_table_plane)
  {
    const FlatTop top = measureFlatTop(*full_view.cloud, full_view.table_plane, params_.wide_flat_top);
    if (isWideFlatTop(top, gripper.max_opening_m, params_.wide_flat_top))
    {
      std::ostringstream why;
      why << "fused: its top is one flat face " << std::lround(1000.0 * top.min_width_m)
          << " mm wide at its narrowest, wider than the hand's " << std::lround(1000.0 * gripper.max_opening_m)
          << " mm opening: nothing closes across it, and a pinch on its edge lifts nothing";
      GraspResult refused = GraspResult::fail(GraspFailure::NoStableGrasp, why.str());
      refused.compute_time_s = watch.elapsedSeconds();
      return refused;
    }
  }
  const ObjectView view = thinned(full_view, params_.max_pooled_points);
  const ObjectExtent extent = objectExtent(view);
  std::vector<Generated> pool;
  GraspResult result;
  CloudXYZ unseen;  // the pooled planners' unseen part (Ch. 6), for the deeper copies' hand check
  for (const auto& planner : planners_)
  {
    GraspResult part = planner->plan(view, gripper);
    if (unseen.empty() && !part.unseen.empty())
      unseen = std::move(part.unseen);
    result.candidates_evaluated += part.candidates_evaluated;
    summary << planner->name() << ": " << part.grasps.size() << "; ";
    if (!part.ok() && !part.message.empty() && result.message.size() < 600)
      result.message += std::string(result.message.empty() ? "" : " | ") + part.message;
    if (!result.next_view && part.next_view)
      result.next_view = part.next_view;
    for (auto& grasp : part.grasps)
      pool.push_back({ std::move(grasp), planner->name() });
  }

  // Our own candidates, through the same hand check the planners' grasps passed.
  std::vector<Generated> generated;
  topDownCandidates(view, extent, gripper, params_, generated);
  sideCandidates(view, extent, gripper, params_, generated);
  endCandidates(view, extent, gripper, params_, generated);
  if (params_.gripper_fit.enabled && (!generated.empty() || params_.deepen_pooled_max_m > 0.0))
  {
    // Like the planners' hands, ours stay out of the seen points, the unseen part and the table
    // (end-on grasps out of the first and the last only: Generated::without_unseen).
    const auto hand_check = [&](GripperFitParams fit, bool with_unseen = true) {
      fit.finger_graze_margin_m = 0.0;  // counted once, on the grasps returned (below)
      GripperVolumeCheck check(gripper, fit);
      check.addSeen(*view.cloud);
      check.addObstacles(view);  // the neighbours always: seen or not, they are there
      if (with_unseen)
        check.addUnseen(unseen);
      if (view.has_table_plane)
        check.setTable(view.table_plane);
      return check;
    };
    const GripperVolumeCheck check = hand_check(params_.gripper_fit);
    if (params_.deepen_pooled_max_m > 0.0)
    {
      GripperFitParams deepen = params_.gripper_fit;
      deepen.max_advance_m = params_.deepen_pooled_max_m;
      deepen.max_table_tilt_rad = 0.0;
      const GripperVolumeCheck deeper_check = hand_check(deepen);
      const std::size_t planned = pool.size();
      pool.reserve(2 * planned + generated.size());  // the copies never move pool[i] under its reference
      std::size_t deepened = 0;
      for (std::size_t i = 0; i < planned; ++i)
      {
        const Eigen::Isometry3d& pose = pool[i].grasp.pose;
        const GripperFit fitted = deeper_check.fitDeepest(pose, pool[i].grasp.width_m);
        // a copy only where the hand really went deeper (one 5 mm step, less a back-off)
        if (!fitted.ok || (fitted.pose.translation() - pose.translation()).dot(pose.linear().col(0)) < 0.004)
          continue;
        Generated copy = pool[i];
        copy.grasp.pose = fitted.pose;
        pool.push_back(std::move(copy));
        ++deepened;
      }
      summary << "deepened: " << deepened << "; ";
    }
    std::optional<GripperVolumeCheck> seen_only_check;
    if (std::any_of(generated.begin(), generated.end(), [](const Generated& g) { return g.without_unseen; }))
      seen_only_check.emplace(hand_check(params_.gripper_fit, false));
    std::size_t kept = 0, palm_in_unseen = 0;
    for (auto& g : generated)
    {
      const GripperFit fitted = (g.without_unseen ? *seen_only_check : check).fitOrTilt(g.grasp.pose, g.grasp.width_m);
      if (!fitted.ok)
        continue;
      if (g.without_unseen && palmEntersUnseen(fitted.pose, gripper, params_.gripper_fit, unseen))
      {
        ++palm_in_unseen;
        continue;
      }
      g.grasp.pose = fitted.pose;
      pool.push_back(std::move(g));
      ++kept;
    }
    summary << "top_down + side + end: " << kept << " of " << generated.size() << " fit; ";
    if (palm_in_unseen > 0)
      summary << "end-on with the palm in the unseen part: " << palm_in_unseen << "; ";
  }
  result.candidates_evaluated += generated.size();

  for (auto& g : pool)
    g.grasp.features = graspFeatures(g.grasp, g.source, view, extent, gripper);
  // Support: how many other candidates (any source) close on nearly the same line. A grasp that
  // several methods or neighbouring directions agree on is less sensitive to where the hand
  // really ends up.
  const std::size_t support_index = graspFeatureNames().size() - 1;
  for (std::size_t i = 0; i < pool.size(); ++i)
  {
    std::size_t near = 0;
    const Eigen::Isometry3d& a = pool[i].grasp.pose;
    for (std::size_t j = 0; j < pool.size(); ++j)
    {
      const Eigen::Isometry3d& b = pool[j].grasp.pose;
      if (j != i && (a.translation() - b.translation()).norm() < 0.015 &&
          std::abs(a.linear().col(1).dot(b.linear().col(1))) > std::cos(0.35))
        ++near;
    }
    pool[i].grasp.features[support_index] = std::log1p(static_cast<double>(near)) / std::log(20.0);
  }
  for (auto& g : pool)
  {
    g.grasp.score = params_.model.probability(g.grasp.features);
    g.grasp.algorithm = "fused/" + g.source;
  }
  // Side grasps closing below a tall object's centre of mass, grasps whose fingertips stop
  // short of a lying round object's axis, narrow grasps across one seen face and grasps closing
  // on the near limit's cut rank after every other candidate (kept: with nothing else they are
  // still a grasp), flagged drop_risk so that the table's object choice sees it too.
  const LyingCylinder lying = fitLyingCylinder(view, extent, params_.lying_cylinder);
  HoldCheckParams rules;  // the same rules the hold check drops by (hold_check.h)
  rules.lying_cylinder = params_.lying_cylinder;
  rules.approach_opening_m = params_.gripper_fit.approach_opening_m;
  rules.tall_object_min_height_m = params_.tall_object_min_height_m;
  rules.tall_side_min_height_frac = params_.tall_side_min_height_frac;
  rules.one_seen_face = params_.one_seen_face;
  rules.near_range = params_.near_range;
  // The cut is a line of points that thinning would halve: taken from the full view, once.
  const CloudNormal near_limit_cut = nearLimitCut(*full_view.cloud, params_.near_range);
  const CloudNormal no_cut;
  DropCounts demoted;
  for (auto& g : pool)
  {
    // An end-on grasp is not judged by the cut: there the cut is a lying body's near end, and
    // the body goes on along the approach (the palm meets its true end and pushes it along its
    // axis while the fingers close across it). Judged, a lying wine bottle's end-on grasps that
    // held gave way to pinches from above that closed on nothing (training piles, session 34:
    // 7 -> 13 failures).
    const DropRisk risk =
        dropRisk(g.grasp, gripper, view, extent, lying, RestingBall{}, g.without_unseen ? no_cut : near_limit_cut, rules);
    g.grasp.drop_risk = risk != DropRisk::None;
    demoted.add(risk);
  }
  const char* demoted_fate = params_.return_drop_risk_grasps ? "ranked last" : "not returned";
  if (demoted.below_centre_of_mass > 0)
    summary << "below a tall object's centre of mass, " << demoted_fate << ": " << demoted.below_centre_of_mass << "; ";
  if (lying.found)
    summary << "lying round object (radius " << std::lround(1000.0f * lying.radius_m)
            << " mm), fingertips short of its axis, " << demoted_fate << ": " << demoted.short_of_axis
            << "; open hand onto its hidden side, " << demoted_fate << ": " << demoted.onto_hidden_side << "; ";
  if (demoted.across_one_seen_face > 0)
    summary << "narrow across one seen face (its depth unseen), " << demoted_fate << ": " << demoted.across_one_seen_face << "; ";
  if (demoted.on_near_limit_cut > 0)
    summary << "closing where the camera's near limit cut the object, " << demoted_fate << ": " << demoted.on_near_limit_cut << "; ";
  std::stable_sort(pool.begin(), pool.end(), [](const Generated& a, const Generated& b) {
    return a.grasp.drop_risk != b.grasp.drop_risk ? b.grasp.drop_risk : a.grasp.score > b.grasp.score;
  });
  double best = 0.0;
  for (const auto& g : pool)
    best = std::max(best, g.grasp.score);
  // Everything above saw the thinned view, and the pooled planners built their unseen parts
  // from it: coarser silhouettes, sparser shadows. A hand that cleared those can still enter
  // the object's hidden back (the cracker box bag at max_pooled_points 500: a concavity grasp's
  // finger 462 samples into the box's back). So when the view was thinned, each grasp returned
  // is checked once more against the full view's points and its own unseen part (end-on
  // grasps against the points alone, as before: a copy of the check before the unseen part).
  // The same check counts the points that graze an open finger (gripper_fit/
  // finger_graze_margin_m); that needs it on views that were not thinned too.
  const bool thinned_view = view.cloud != full_view.cloud;
  const bool count_grazing = params_.gripper_fit.finger_graze_margin_m > 0.0;
  std::optional<GripperVolumeCheck> final_check, final_seen_only_check;
  if (params_.gripper_fit.enabled && (thinned_view || count_grazing))
  {
    final_check.emplace(gripper, params_.gripper_fit);
    final_check->addSeen(*full_view.cloud);
    final_check->addObstacles(full_view);
    std::optional<Eigen::Vector4f> table;
    if (full_view.has_table_plane)
    {
      table = full_view.table_plane;
      final_check->setTable(full_view.table_plane);
    }
    if (std::any_of(pool.begin(), pool.end(), [](const Generated& g) { return g.without_unseen; }))
      final_seen_only_check = *final_check;  // a copy only when an end-on grasp is pooled
    if (thinned_view)
    {
      // Default grid: cells from the full view's own point spacing. (A 5 mm floor on the cell,
      // tried for the benchmark's dense 10 k points, gave no measurable speed-up and a blockier
      // shadow that dropped the tea box's three holding top-down grasps on the training half.)
      const UnseenPart full_unseen = buildUnseenPart(*full_view.cloud, full_view.sensor_origins, UnseenPartParams{}, table);
      if (full_unseen.ok())
        final_check->addUnseen(full_unseen.points);
    }
    else
      final_check->addUnseen(unseen);
  }
  // A grasp whose open finger would brush an obstacle point (gripper_fit/finger_graze_margin_m)
  // ranks as if the model gave it finger_graze_penalty less, within its tier (no drop risk /
  // drop risk); it is not dropped: brushing is a contact, not a drop (5 of the 6 training
  // grasps that brushed the object held it). A deferred grasp is placed as soon as the next
  // candidate scores below its penalised score, so only candidates that could still make the
  // list are fitted, and the choice does not depend on max_grasps.
  std::size_t dropped_at_full_resolution = 0, grazing_count = 0;
  std::vector<GraspCandidate> deferred;  // grazing, best first
  const auto place_deferred = [&](double down_to_score) {
    std::size_t k = 0;
    while (k < deferred.size() && deferred[k].score - params_.finger_graze_penalty >= down_to_score &&
           result.grasps.size() < params_.max_grasps)
      result.grasps.push_back(std::move(deferred[k++]));
    deferred.erase(deferred.begin(), deferred.begin() + static_cast<std::ptrdiff_t>(k));
  };
  bool risk_tier = false;
  for (auto& g : pool)
  {
    if (g.grasp.score < params_.min_success_probability)
      continue;  // (not break: demoted candidates follow, in their own score order)
    if (g.grasp.drop_risk && !params_.return_drop_risk_grasps)
      break;  // the rest of the pool carries a risk too (sorted so)
    if (g.grasp.drop_risk && !risk_tier)
    {
      risk_tier = true;
      place_deferred(-std::numeric_limits<double>::infinity());
    }
    place_deferred(g.grasp.score);
    if (result.grasps.size() >= params_.max_grasps)
      break;
    if (final_check)
    {
      const GripperFit fitted = (g.without_unseen ? *final_seen_only_check : *final_check).fit(g.grasp.pose, g.grasp.width_m);
      if (thinned_view)
      {
        if (!fitted.ok)
        {
          ++dropped_at_full_resolution;
          continue;
        }
        g.grasp.pose = fitted.pose;
      }
      if (fitted.points_grazing_fingers > 0)
      {
        ++grazing_count;
        deferred.push_back(std::move(g.grasp));
        continue;
      }
    }
    result.grasps.push_back(std::move(g.grasp));
  }
  place_deferred(-std::numeric_limits<double>::infinity());
  if (thinned_view && final_check)
    summary << "dropped at full resolution: " << dropped_at_full_resolution << "; ";
  if (grazing_count > 0)
    summary << "an open finger within gripper_fit/finger_graze_margin_m of a point, ranked "
            << params_.finger_graze_penalty << " lower: " << grazing_count << "; ";
  result.compute_time_s = watch.elapsedSeconds();
  if (result.grasps.empty())
  {
    std::ostringstream why;
    why << "fused: " << pool.size() << " pooled candidates (" << summary.str() << ")";
    if (!pool.empty())
      why << ", best success probability " << best << " < min_success_probability " << params_.min_success_probability;
    if (!result.message.empty())
      why << "; " << result.message;
    auto next_view = result.next_view;
    // Grasps closed on the near limit's cut: a view turned about the object at the same
    // distance (the principal-axis planner's) is cut again; farther back it is not.
    if (demoted.on_near_limit_cut > 0)
      if (const auto back = nextViewBackFromNearLimit(*full_view.cloud, params_.near_range))
      {
        next_view = back;
        why << "; " << nextViewBackFromNearLimitNote(params_.near_range);
      }
    result = GraspResult::fail(GraspFailure::NoStableGrasp, why.str());
    result.next_view = next_view;
    result.compute_time_s = watch.elapsedSeconds();
    return result;
  }
  std::ostringstream message;
  message << "fused: " << result.grasps.size() << " grasps from " << pool.size() << " pooled candidates (" << summary.str()
          << "), best success probability " << best << " (" << result.grasps.front().algorithm << ")";
  result.message = message.str();
  result.next_view.reset();
  return result;
}

}  // namespace fast_grasp
