#include "fast_grasp/grasping/cshape_grasp.h"
#include "fast_grasp/grasping/planner_input.h"

#include "fast_grasp/grasping/grasp_geometry.h"

#include <pcl/filters/uniform_sampling.h>
#include <pcl/filters/voxel_grid.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <random>
#include <sstream>

namespace fast_grasp
{
namespace
{
/// A neighbour in the frame of one normal: depth s along the approach (0 at the normal's
/// point), tangent coordinates (u, v); rotating (u, v) by the C-shape angle gives the
/// coordinate x across the C plane and y along the closing direction.
struct LocalPoint
{
  float s = 0.0f;
  float u = 0.0f;
  float v = 0.0f;
  int index = -1;  // >= 0: a seen point (its index in the cloud searched); -1: unseen part
};

/// The normal's coarse neighbourhood: a run of LocalPoints in a buffer that only grows.
struct LocalSpan
{
  const LocalPoint* first = nullptr;
  std::size_t count = 0;
  const LocalPoint* begin() const { return first; }
  const LocalPoint* end() const { return first + count; }
  std::size_t size() const { return count; }
};

/// A neighbour inside the C-shape's slab |x| <= w/2 for one orientation.
struct SlabPoint
{
  float x = 0.0f;
  float y = 0.0f;
  float s = 0.0f;
  int index = -1;
};

/// A run of slab points in a buffer that only grows (re-sizing a std::vector per orientation
/// value-initialised it every time: 11 % of a plan on the cracker box bag).
struct SlabSpan
{
  const SlabPoint* first = nullptr;
  std::size_t count = 0;
  const SlabPoint* begin() const { return first; }
  const SlabPoint* end() const { return first + count; }
};

/// Why a C-shape configuration was rejected, for the failure message.
struct RejectionCounts
{
  std::size_t blocked = 0;            // something stands in front of the normal's point
  std::size_t object_collision = 0;   // the C-shape intersects seen points
  std::size_t unseen_collision = 0;   // the C-shape intersects only the unseen part
  std::size_t too_wide = 0;           // closing region wider than the max opening
  std::size_t too_narrow = 0;         // narrower than the min opening
  std::size_t few_side_points = 0;    // cannot fit the two grasp sides
  std::size_t variance = 0;           // step 7
  std::size_t force_balance = 0;      // step 8
  std::size_t wrong_side = 0;         // approach would come from behind the sensor's view
  std::size_t table = 0;              // the gripper body would reach into the table
  std::size_t hand = 0;               // the real hand (fingers + palm boxes) does not fit
};

/// Gripper constants of Eq. 6.1 in float, computed once per plan. The collision volume is
/// the C inflated by a clearance (thinner mouth, thicker ring, wider C): grazing contacts
/// between sparse points (faces seen at grazing angles) are then still caught.
struct CShapeGeometry
{
  float r1 = 0.0f;
  float r2 = 0.0f;
  float half_w = 0.0f;
  float r1_sq = 0.0f;
  float tip_reach = 0.0f;  // how far in front of the centre the fingertips reach at |y| = r1
  // Inflated by the clearance, for collision only.
  float collision_r1 = 0.0f;
  float collision_r2 = 0.0f;
  float collision_half_w = 0.0f;
  float collision_r1_sq = 0.0f;
  float collision_r2_sq = 0.0f;
  float collision_tip_reach = 0.0f;

  CShapeGeometry(const GripperModel& gripper, double clearance_m)
    : r1(static_cast<float>(gripper.cshape_r1_m))
    , r2(static_cast<float>(gripper.cshape_r2_m))
    , half_w(static_cast<float>(0.5 * gripper.cshape_w_m))
    , r1_sq(r1 * r1)
    , tip_reach(std::sqrt(std::max(0.0f, r2 * r2 - r1_sq)))
    , collision_r1(std::max(0.0f, r1 - static_cast<float>(clearance_m)))
    , collision_r2(r2 + static_cast<float>(clearance_m))
    , collision_half_w(half_w + static_cast<float>(clearance_m))
    , collision_r1_sq(collision_r1 * collision_r1)
    , collision_r2_sq(collision_r2 * collision_r2)
    , collision_tip_reach(std::sqrt(std::max(0.0f, collision_r2_sq - collision_r1_sq)))
  {
  }

  /// Eq. 6.1 relative to the centre: x across the C plane, y closing, ds depth in front of
  /// the centre. C_c = (annulus r1..r2 minus the mouth C_red: |y| <= r1 in front of the
  /// centre) x [-w/2, w/2], with the collision clearance applied.
  bool inside(float x, float y, float ds) const
  {
    if (std::abs(x) > collision_half_w)
      return false;
    const float rho_sq = y * y + ds * ds;
    if (rho_sq > collision_r2_sq || rho_sq < collision_r1_sq)
      return false;
    return !(std::abs(y) <= collision_r1 && ds >= 0.0f);
  }

  /// The closing region (nominal size): inside the inner circle or in the mouth up to the
  /// fingertips, within the C width.
  bool enveloped(float x, float y, float ds) const
  {
    if (std::abs(x) > half_w || std::abs(y) > r1)
      return false;
    if (ds >= 0.0f)
      return ds <= tip_reach;
    return y * y + ds * ds < r1_sq;
  }
};

/// Shallowest C-centre depth relative to the normal's point (<= 0): a centre in front of the
/// point leaves it in the mouth, min_fingertip_overlap_m behind the fingertips.
float fingertipMinDepth(const GripperModel& gripper, const CShapeParams& params)
{
  const double r1 = gripper.cshape_r1_m;
  const double r2 = gripper.cshape_r2_m;
  const double tip_reach = std::sqrt(std::max(0.0, r2 * r2 - r1 * r1));
  if (params.min_fingertip_overlap_m < 0.0)
    return 0.0f;
  return static_cast<float>(std::min(0.0, params.min_fingertip_overlap_m - tip_reach));
}

/// The table plane and the gripper body checked against it (CShapeParams::check_table_clearance):
/// the nominal C of Eq. 6.1 and the hand box behind it. Both are convex-hull-exact: the lowest
/// point of a shape along a direction is a vertex of its convex hull, so it is computed in
/// closed form per configuration (a few flops) instead of sampling the body.
struct TableCheck
{
  bool active = false;
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  // unit, away from the table
  float offset = 0.0f;                                 // plane: normal . x + offset = 0
  float clearance = 0.0f;
  float r1 = 0.0f;
  float r2 = 0.0f;
  float half_w = 0.0f;
  float tip_reach = 0.0f;
  float palm_thickness = 0.0f;
  float palm_half_across = 0.0f;
  /// Shallowest centre depth a placement may take (<= 0; see CShapeParams::min_fingertip_overlap_m).
  float min_depth = 0.0f;

  TableCheck() = default;
  TableCheck(const ObjectView& view, const GripperModel& gripper, const CShapeParams& params)
    : active(params.check_table_clearance && view.has_table_plane && view.table_plane.allFinite() &&
             view.table_plane.head<3>().norm() > 1e-6f)
    , clearance(static_cast<float>(params.table_clearance_m))
    , r1(static_cast<float>(gripper.cshape_r1_m))
    , r2(static_cast<float>(gripper.cshape_r2_m))
    , half_w(static_cast<float>(0.5 * gripper.cshape_w_m))
    , tip_reach(std::sqrt(std::max(0.0f, r2 * r2 - r1 * r1)))
    , palm_thickness(static_cast<float>(gripper.palm_thickness_m))
    , palm_half_across(static_cast<float>(std::max(0.5 * gripper.palmWidth(), 0.5 * gripper.cshape_w_m)))
    , min_depth(fingertipMinDepth(gripper, params))
  {
    if (!active)
      return;
    const float length = view.table_plane.head<3>().norm();
    normal = view.table_plane.head<3>() / length;
    offset = view.table_plane(3) / length;
  }

  /// Signed height above the table of the lowest point of the gripper body with its C centre
  /// at `centre` (approach, closing, across: the C's orthonormal axes).
  float lowestHeight(const Eigen::Vector3f& centre, const Eigen::Vector3f& approach, const Eigen::Vector3f& closing,
                     const Eigen::Vector3f& across) const
  {
    const float a = normal.dot(approach);
    const float b = normal.dot(closing);
    const float c = std::abs(normal.dot(across));
    // The C in its plane (depth s along the approach, y along the closing direction) is the
    // annulus r1..r2 minus the mouth (|y| <= r1, s >= 0); its convex hull's extreme points are
    // the outer arc outside the mouth (s <= tip_reach) and the fingertips (tip_reach, +-r1).
    // The lowest point of a circle of radius r2 is at -r2 (a, b) / |(a, b)|; if that lies in
    // the mouth, the lowest point of the arc is a fingertip.
    const float ab = std::hypot(a, b);
    float c_low = 0.0f;
    if (ab > 1e-9f)
      c_low = -r2 * a / ab <= tip_reach ? -r2 * ab : a * tip_reach - std::abs(b) * r1;
    c_low -= c * half_w;
    // The hand box: depth -r2 - palm_thickness .. -r2, closing +-r2, across +-palm_half_across.
    const float palm_low = std::min(-a * r2, -a * (r2 + palm_thickness)) - std::abs(b) * r2 - c * palm_half_across;
    return normal.dot(centre) + offset + std::min(c_low, palm_low);
  }

  /// The deepest centre depth along `approach` from `point` (depths in [min_depth,
  /// depth_bound]) whose body keeps the clearance: +inf when any depth does (or deeper is
  /// higher, left to the final check), below min_depth when none does. The lowest point moves
  /// linearly with depth.
  float maxDepth(const Eigen::Vector3f& point, const Eigen::Vector3f& approach, const Eigen::Vector3f& closing,
                 const Eigen::Vector3f& across, float depth_bound) const
  {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    if (!active)
      return kInf;
    const float low_0 = lowestHeight(point, approach, closing, across);
    const float slope = normal.dot(approach);
    // 10 um inside the limit, so clear() at exactly this depth is not lost to float rounding
    // (a C stopped short by the table sits exactly at the limit).
    constexpr float kMargin = 1e-5f;
    if (slope < -1e-6f)
      return (low_0 - clearance - kMargin) / -slope;
    return std::max(low_0 + slope * min_depth, low_0 + slope * depth_bound) >= clearance ? kInf : -kInf;
  }

  /// False when no orientation of the C about `approach` (axes u, v of its normal plane) at
  /// any depth in [min_depth, depth_bound] keeps the clearance, so the normal can be skipped before
  /// its neighbourhood search. Sampled every 5 deg over the half turn (the body is symmetric
  /// under a half turn); between samples the body rotates by at most 2.5 deg, moving its points
  /// by at most their distance from the approach axis, sqrt(r2^2 + across^2), times that angle.
  bool anyOrientationClear(const Eigen::Vector3f& point, const Eigen::Vector3f& approach, const Eigen::Vector3f& u,
                           const Eigen::Vector3f& v, float depth_bound) const
  {
    if (!active)
      return true;
    constexpr int kSamples = 36;
    const float step = static_cast<float>(M_PI) / kSamples;
    const float margin = std::hypot(r2, std::max(palm_half_across, half_w)) * 0.5f * step;
    const float slope = normal.dot(approach);
    for (int k = 0; k < kSamples; ++k)
    {
      const float cos_t = std::cos(k * step);
      const float sin_t = std::sin(k * step);
      const float low_0 = lowestHeight(point, approach, -sin_t * u + cos_t * v, cos_t * u + sin_t * v);
      if (std::max(low_0 + slope * min_depth, low_0 + slope * depth_bound) + margin >= clearance)
        return true;
    }
    return false;
  }

  /// True when the body at `centre` keeps the clearance (always true without a table).
  bool clear(const Eigen::Vector3f& centre, const Eigen::Vector3f& approach, const Eigen::Vector3f& closing,
             const Eigen::Vector3f& across) const
  {
    return !active || lowestHeight(centre, approach, closing, across) >= clearance;
  }
};

/// Per-call scratch and inputs of the search, so plan() stays const and thread-safe.
struct SearchContext
{
  const CShapeParams& params;
  const GripperModel& gripper;
  CShapeGeometry geometry;
  /// Full-resolution seen points and their normals (oriented toward a sensor).
  CloudXYZ::Ptr seen;
  std::vector<Eigen::Vector3f> normals;
  /// Obstacles for the coarse screen: voxel centroids of the seen points, then the unseen
  /// part from index `first_unseen` on.
  CloudXYZ::Ptr obstacles;
  std::size_t first_unseen = 0;
  std::vector<Eigen::Vector3f> sensors;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  TableCheck table;
  /// The real hand's volume against the seen points and the unseen part (final check).
  std::optional<GripperVolumeCheck> hand;
  /// Unit gravity for the from-above score term (zero when the view's is unusable).
  Eigen::Vector3f gravity = Eigen::Vector3f::Zero();
  RejectionCounts rejected;
  std::size_t configurations = 0;
  std::size_t zone_found = 0;  // configurations that fit (collision-free, within the opening)
  std::size_t fine_checks = 0;  // coarse survivors re-checked at full resolution
  std::vector<GraspCandidate> candidates;

  // Scratch buffers reused for every normal.
  std::vector<LocalPoint> coarse_buffer;
  LocalSpan coarse_local;  // in coarse_buffer
  std::vector<SlabPoint> slab;

  SearchContext(const CShapeParams& p, const GripperModel& g) : params(p), gripper(g), geometry(g, p.collision_clearance_m) {}
};

/// Outcome of one normal: its best passing orientation, if any.
struct Evaluation
{
  bool passed = false;
  GraspCandidate grasp;
};

/// Collision of the C-shape at centre depth `centre_s` with the slab points.
/// Returns 0 = free, 1 = hits seen points, 2 = hits only unseen points.
int collide(const CShapeGeometry& c, SlabSpan slab, float centre_s)
{
  bool unseen_hit = false;
  for (const SlabPoint& q : slab)
    if (c.inside(q.x, q.y, q.s - centre_s))
    {
      if (q.index >= 0)
        return 1;
      unseen_hit = true;
    }
  return unseen_hit ? 2 : 0;
}

struct ClosingRegion
{
  float y_min_seen = std::numeric_limits<float>::max();
  float y_max_seen = -std::numeric_limits<float>::max();
  float y_min_all = std::numeric_limits<float>::max();
  float y_max_all = -std::numeric_limits<float>::max();
  std::size_t seen_count = 0;
};

ClosingRegion closingRegion(const CShapeGeometry& c, SlabSpan slab, float centre_s)
{
  ClosingRegion region;
  for (const SlabPoint& q : slab)
    if (c.enveloped(q.x, q.y, q.s - centre_s))
    {
      region.y_min_all = std::min(region.y_min_all, q.y);
      region.y_max_all = std::max(region.y_max_all, q.y);
      if (q.index >= 0)
      {
        region.y_min_seen = std::min(region.y_min_seen, q.y);
        region.y_max_seen = std::max(region.y_max_seen, q.y);
        ++region.seen_count;
      }
    }
  return region;
}

/// Mean local position (x, y, s) of the seen enveloped points within `tolerance` of the
/// extreme closing coordinates: where the fingers meet the object.
void contactPoints(const CShapeGeometry& c, SlabSpan slab, float centre_s,
                   const ClosingRegion& region, float tolerance, Eigen::Vector3f& contact_a, Eigen::Vector3f& contact_b)
{
  Eigen::Vector3f sum_a = Eigen::Vector3f::Zero();
  Eigen::Vector3f sum_b = Eigen::Vector3f::Zero();
  int count_a = 0;
  int count_b = 0;
  for (const SlabPoint& q : slab)
  {
    if (q.index < 0 || !c.enveloped(q.x, q.y, q.s - centre_s))
      continue;
    const Eigen::Vector3f local(q.x, q.y, q.s);
    if (q.y <= region.y_min_seen + tolerance)
    {
      sum_a += local;
      ++count_a;
    }
    if (q.y >= region.y_max_seen - tolerance)
    {
      sum_b += local;
      ++count_b;
    }
  }
  contact_a = sum_a / static_cast<float>(std::max(count_a, 1));
  contact_b = sum_b / static_cast<float>(std::max(count_b, 1));
}

/// Steps 7 and 8: the two grasp sides are the extreme closing coordinates of the enveloped
/// points in `bins` slices across the C width; a line y = k x + b is fitted to each.
/// Returns false when a side has too few slices to fit.
bool analyseSides(const SearchContext& ctx, SlabSpan slab, float centre_s, double& sigma,
                  double& variance)
{
  const int bins = std::max(ctx.params.side_bins, 1);
  const float half_w = ctx.geometry.half_w;
  constexpr float kNone = std::numeric_limits<float>::max();
  std::vector<Eigen::Vector2f> low(static_cast<std::size_t>(bins), Eigen::Vector2f(0.0f, kNone));
  std::vector<Eigen::Vector2f> high(static_cast<std::size_t>(bins), Eigen::Vector2f(0.0f, -kNone));
  for (const SlabPoint& q : slab)
  {
    if (q.index < 0 || !ctx.geometry.enveloped(q.x, q.y, q.s - centre_s))
      continue;
    int bin = static_cast<int>((q.x + half_w) / (2.0f * half_w) * static_cast<float>(bins));
    bin = std::clamp(bin, 0, bins - 1);
    if (q.y < low[bin].y())
      low[bin] = Eigen::Vector2f(q.x, q.y);
    if (q.y > high[bin].y())
      high[bin] = Eigen::Vector2f(q.x, q.y);
  }
  std::vector<Eigen::Vector2d> side_a;
  std::vector<Eigen::Vector2d> side_b;
  for (int b = 0; b < bins; ++b)
  {
    if (low[b].y() != kNone)
      side_a.emplace_back(low[b].x(), low[b].y());
    if (high[b].y() != -kNone)
      side_b.emplace_back(high[b].x(), high[b].y());
  }
  if (static_cast<int>(side_a.size()) < ctx.params.min_side_bins ||
      static_cast<int>(side_b.size()) < ctx.params.min_side_bins)
    return false;
  sigma = 0.0;
  variance = 0.0;
  for (const auto* side : { &side_a, &side_b })
  {
    const LineFit fit = fitLine(*side);
    // sigma of step 8: the angle of each side to the C axis (0 = perpendicular to closing).
    sigma += std::abs(fit.angleRad());
    if (fit.vertical)
    {
      variance = std::numeric_limits<double>::infinity();
      continue;
    }
    const double norm = std::sqrt(1.0 + fit.k * fit.k);
    for (const auto& p : *side)
      variance += std::abs(fit.k * p.x() - p.y() + fit.b) / norm;
  }
  return true;
}

/// The points of `local` inside the C slab |x| <= w/2 at orientation (cos_t, sin_t).
SlabSpan extractSlab(const CShapeGeometry& c, LocalSpan local, float cos_t, float sin_t,
                     std::vector<SlabPoint>& buffer)
{
  // Written through a pre-sized buffer: push_back in this innermost loop cost 15 % of a plan.
  // Every point is written and only those inside the slab advance the count: whether a
  // neighbour is inside is close to a coin toss, and the branch it replaces mispredicted so
  // often that this loop was a fifth of the fused planner's time (perf, session 22).
  if (buffer.size() < local.size())
    buffer.resize(local.size());
  std::size_t count = 0;
  for (const LocalPoint& q : local)
  {
    const float x = q.u * cos_t + q.v * sin_t;
    buffer[count] = { x, -q.u * sin_t + q.v * cos_t, q.s, q.index };
    count += static_cast<std::size_t>(std::abs(x) <= c.collision_half_w);
  }
  return { buffer.data(), count };
}

/// Steps 5 and 6 for one orientation: the centre by Eq. 6.9, the grasp depth by the depth
/// rule, and the collision of the C-shape there with the seen and unseen points.
struct Placement
{
  bool blocked = false;
  bool below_table = false;  // every collision-free depth reaches into the table
  int collision = 0;  // 0 free, 1 seen points, 2 unseen points only
  float grasp_s = 0.0f;
  float shortfall = 0.0f;  // how much shallower than the preferred depth (table / unseen part)
  ClosingRegion region;
  Eigen::Vector3f contact_a = Eigen::Vector3f::Zero();
  Eigen::Vector3f contact_b = Eigen::Vector3f::Zero();
};

/// Step of the shallower placements tried when the unseen part blocks the preferred one.
constexpr float kShallowStep = 0.005f;

/// `max_s`: the deepest centre depth whose gripper body keeps the table clearance (+inf
/// without a table or when deeper is higher).
Placement place(const SearchContext& ctx, SlabSpan slab,
                float max_s = std::numeric_limits<float>::infinity())
{
  const CShapeGeometry& c = ctx.geometry;
  Placement placement;
  // Eq. 6.9: push the C in until the back of its inner circle touches the object (seen or
  // unseen, Eq. 6.8). The thesis maximises min(Z1, Z2) over the convex-hull vertices of the
  // projected points; in depth s = -Z that is min(s + sqrt(r1^2 - y^2)), a concave function
  // whose minimum over the hull is attained at a hull vertex, i.e. equals its minimum over
  // all points -- so no hull is built (2 ms per hull at 10k points, per configuration).
  float centre_s = std::numeric_limits<float>::max();
  for (const SlabPoint& q : slab)
    if (std::abs(q.y) < c.collision_r1)
      centre_s = std::min(centre_s, q.s + std::sqrt(c.collision_r1_sq - q.y * q.y));
  if (centre_s < 0.0f)
  {
    // Something lies in front of the normal's point within the mouth: the C cannot reach
    // this point along this normal (and would leave the searched neighbourhood).
    placement.blocked = true;
    return placement;
  }
  if (max_s < ctx.table.min_depth)
  {
    placement.below_table = true;
    return placement;
  }
  // Every placement lies at a depth in [lowest_s, centre_s]: from 0 (the normal's point at
  // the C centre), or up to -min_depth in front of it when the table stops the C short (a
  // fingertip grasp: the point stays in the mouth). A point beside the mouth
  // (r1 < |y| <= r2) is inside a finger for all depths within sqrt(r2^2 - y^2) of its own;
  // if that covers [lowest_s, centre_s] (a seen point) or [min_depth, centre_s] (an unseen
  // point, which the shallow retries below may still avoid), no placement is free and the
  // closing-region passes below can be skipped (exact; most configurations on objects wider
  // than the C end here).
  const float lowest_s = std::max(ctx.table.min_depth, std::min(0.0f, max_s));
  placement.grasp_s = centre_s;
  bool unseen_always = false;
  for (const SlabPoint& q : slab)
  {
    const float y = std::abs(q.y);
    if (y <= c.collision_r1 || y > c.collision_r2)
      continue;
    const float reach = std::sqrt(c.collision_r2_sq - y * y);
    if (q.s + reach < centre_s)
      continue;
    if (q.index >= 0 && q.s - reach <= lowest_s)
    {
      placement.collision = 1;
      return placement;
    }
    // Unseen points only block for sure if they also cover the shallow retries (below).
    if (q.index < 0 && q.s - reach <= ctx.table.min_depth)
      unseen_always = true;
  }
  if (unseen_always)
  {
    placement.collision = 2;
    return placement;
  }
  const float tolerance = static_cast<float>(ctx.params.contact_tolerance_m);
  placement.region = closingRegion(c, slab, centre_s);
  contactPoints(c, slab, centre_s, placement.region, tolerance, placement.contact_a, placement.contact_b);
  // The preferred depth: Eq. 6.9's, or (ContactDepth) where the fingers meet the object;
  // never deeper than the table allows (a shallower C still closes on the same sides, only
  // less of the object is enveloped; Eq. 6.9's deepest placement would put the fingertips or
  // the palm into the table for objects lower than the C).
  float preferred_s = centre_s;
  if (ctx.params.depth_rule == CShapeParams::DepthRule::ContactDepth)
  {
    // The seen extremes of a rounded section sit in front of its widest part, which hides
    // near the silhouette (at 2 mm sampling a 30 mm cylinder's last seen points are ~20 deg
    // short of it, ~10 mm too shallow). So also take the depth of the inscribed circle of
    // the seen width pushed in until it touches the object -- Eq. 6.9 with the object's
    // half-width instead of r1, exact for circular sections -- and use the deeper of the two.
    // The circle is centred on the approach axis (which a round section's normal passes
    // through) with the larger seen half-width, the better-sampled side.
    const float radius = std::max(std::abs(placement.region.y_min_seen), std::abs(placement.region.y_max_seen));
    float circle_s = std::numeric_limits<float>::max();
    for (const SlabPoint& q : slab)
      if (q.index >= 0 && std::abs(q.y) < radius)
        circle_s = std::min(circle_s, q.s + std::sqrt(radius * radius - q.y * q.y));
    const float contact_mean_s = 0.5f * (placement.contact_a.z() + placement.contact_b.z());
    // Never shallower than the normal's own point unless the table demands it (below).
    preferred_s = std::min(centre_s, std::max({ contact_mean_s, circle_s, 0.0f }));
  }
  const float preferred_unlimited_s = preferred_s;
  preferred_s = std::min(preferred_s, max_s);  // >= lowest_s, checked above
  auto placeAt = [&](float s) {
    placement.grasp_s = s;
    placement.shortfall = std::max(0.0f, preferred_unlimited_s - s);
    placement.region = closingRegion(c, slab, s);
    contactPoints(c, slab, s, placement.region, tolerance, placement.contact_a, placement.contact_b);
    return placement;
  };
  if (preferred_s < centre_s)
  {
    const int preferred_collision = collide(c, slab, preferred_s);
    if (preferred_collision == 0)
      return placeAt(preferred_s);
    // Only the unseen part is in the way: the fingers reach behind the seen side. A
    // shallower C (down to the fingertip limit) closes on the seen top of the same sides
    // (a box taken by its top edge), so try it before the deeper Eq. 6.9 placement.
    if (preferred_collision == 2)
      for (float s = preferred_s - kShallowStep; s >= ctx.table.min_depth; s -= kShallowStep)
        if (collide(c, slab, s) == 0)
          return placeAt(s);
    if (centre_s > max_s)
    {
      placement.below_table = true;  // the only other depth, Eq. 6.9's, reaches into the table
      return placement;
    }
  }
  // The Eq. 6.9 placement: the thesis's, and the fallback when the shallower one collides.
  placement.collision = collide(c, slab, centre_s);
  return placement;
}

void record(SearchContext& ctx, const GraspCandidate& grasp)
{
  if (ctx.candidates.size() < ctx.params.max_recorded_candidates)
    ctx.candidates.push_back(grasp);
}

/// Steps 4-8 for one normal. Every orientation is first screened against the coarse
/// obstacles (voxel centroids + unseen part); only the survivors are re-placed and analysed
/// against the full-resolution points, so the cost per normal stays near the size of the
/// coarse neighbourhood.
Evaluation evaluateNormal(SearchContext& ctx, int point_index)
{
  Evaluation best;
  const CShapeParams& params = ctx.params;
  const CShapeGeometry& c = ctx.geometry;
  const Eigen::Vector3f p = ctx.seen->points[static_cast<std::size_t>(point_index)].getVector3fMap();
  const Eigen::Vector3f approach = -ctx.normals[static_cast<std::size_t>(point_index)];
  const Eigen::Vector3f u = approach.unitOrthogonal();
  const Eigen::Vector3f v = approach.cross(u);

  // Only the cylinder around the approach axis that some orientation can reach matters.
  const float lateral_sq = c.collision_r2_sq + c.collision_half_w * c.collision_half_w;
  // A fingertip placement's centre may stand up to -min_depth in front of the point.
  const float depth_low = ctx.table.min_depth - c.collision_r2;
  const float depth_high = c.r1 + c.collision_tip_reach;

  // The table alone rules out every orientation of this normal: skip its neighbourhood search
  // (low objects seen from above: most of a hammer's or racket's normals end here).
  const int orientations = std::max(1, static_cast<int>(std::ceil(M_PI / params.angle_increment_rad - 1e-9)));
  if (!ctx.table.anyOrientationClear(p, approach, u, v, c.collision_r2))
  {
    ctx.configurations += static_cast<std::size_t>(orientations);
    ctx.rejected.table += static_cast<std::size_t>(orientations);
    return best;
  }

  // Coarse neighbourhood: a linear scan of the coarse obstacles. The reachable cylinder
  // (bounding ball radius ~0.135 m for the Lacquey C) covers most of a graspable object, so a
  // k-d tree radius search returned nearly every obstacle anyway and cost more than the scan:
  // on the cracker box bag at 10 k points FLANN's radius search was 25 % of a plan's
  // instructions (callgrind).
  // Branchless, like extractSlab: every obstacle is written, those in the reachable cylinder
  // advance the count.
  const std::size_t obstacle_count = ctx.obstacles->size();
  if (ctx.coarse_buffer.size() < obstacle_count)
    ctx.coarse_buffer.resize(obstacle_count);
  std::size_t coarse_count = 0;
  for (std::size_t i = 0; i < obstacle_count; ++i)
  {
    const Eigen::Vector3f d = ctx.obstacles->points[i].getVector3fMap() - p;
    const float s = d.dot(approach);
    const float pu = d.dot(u);
    const float pv = d.dot(v);
    ctx.coarse_buffer[coarse_count] = { s, pu, pv, i < ctx.first_unseen ? static_cast<int>(i) : -1 };
    coarse_count += static_cast<std::size_t>((s >= depth_low) & (s <= depth_high) & (pu * pu + pv * pv <= lateral_sq));
  }
  ctx.coarse_local = { ctx.coarse_buffer.data(), coarse_count };

  // Fig. 6.8: the first C axis is the principal axis of the local patch in the tangent plane.
  const float axis_radius =
      params.local_axis_radius_m > 0.0 ? static_cast<float>(params.local_axis_radius_m) : c.r1;
  double su = 0, sv = 0, suu = 0, svv = 0, suv = 0;
  int n_axis = 0;
  for (const LocalPoint& q : ctx.coarse_local)
    if (q.index >= 0 && q.s * q.s + q.u * q.u + q.v * q.v <= axis_radius * axis_radius)
    {
      su += q.u;
      sv += q.v;
      suu += q.u * q.u;
      svv += q.v * q.v;
      suv += q.u * q.v;
      ++n_axis;
    }
  double first_angle = 0.0;
  if (n_axis >= 3)
  {
    const double cuu = suu / n_axis - (su / n_axis) * (su / n_axis);
    const double cvv = svv / n_axis - (sv / n_axis) * (sv / n_axis);
    const double cuv = suv / n_axis - (su / n_axis) * (sv / n_axis);
    first_angle = 0.5 * std::atan2(2.0 * cuv, cuu - cvv);
  }

  // Coarse screen of every orientation (the C is symmetric under a half turn).
  std::vector<std::pair<double, double>> survivors;  // (coarse sigma, angle)
  const double screen = params.coarse_screen_factor;
  for (int k = 0; k < orientations; ++k)
  {
    ++ctx.configurations;
    const double theta = first_angle + k * params.angle_increment_rad;
    const float cos_t = static_cast<float>(std::cos(theta));
    const float sin_t = static_cast<float>(std::sin(theta));
    const Eigen::Vector3f across = cos_t * u + sin_t * v;
    const Eigen::Vector3f closing_axis = -sin_t * u + cos_t * v;
    // Every placement has its centre depth in [min_depth, r2] (Eq. 6.9 with the normal's own
    // point gives s <= r1 + clearance), so max_s < min_depth means none keeps the clearance.
    const float max_s = ctx.table.maxDepth(p, approach, closing_axis, across, c.collision_r2);
    if (max_s < ctx.table.min_depth)
    {
      ++ctx.rejected.table;
      continue;
    }
    const SlabSpan slab = extractSlab(c, ctx.coarse_local, cos_t, sin_t, ctx.slab);
    const Placement placement = place(ctx, slab, max_s);
    if (placement.blocked)
      ++ctx.rejected.blocked;
    else if (placement.below_table)
      ++ctx.rejected.table;
    else if (placement.collision == 1)
      ++ctx.rejected.object_collision;
    else if (placement.collision == 2)
      ++ctx.rejected.unseen_collision;
    else if (placement.region.y_max_all - placement.region.y_min_all > ctx.gripper.max_opening_m)
      ++ctx.rejected.too_wide;
    else if (!ctx.table.clear(p + approach * placement.grasp_s, approach, closing_axis, across))
      ++ctx.rejected.table;
    else
    {
      // Rank survivors by their coarse force balance so the full-resolution stage can stop
      // at the first orientation that passes.
      double sigma = 0.0;
      double variance = 0.0;
      const bool sides = analyseSides(ctx, slab, placement.grasp_s, sigma, variance);
      if (sides && screen > 0.0 && variance > screen * params.variance_threshold_m)
        ++ctx.rejected.variance;
      else if (sides && screen > 0.0 && sigma > screen * params.force_balance_threshold_rad)
        ++ctx.rejected.force_balance;
      else
        survivors.emplace_back(sides ? sigma : std::numeric_limits<double>::max(), theta);
    }
  }
  if (survivors.empty())
    return best;
  std::stable_sort(survivors.begin(), survivors.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  // Full resolution, only for the survivors, best-ranked first: the slab is cut straight
  // from every seen point (one dot product rejects most of them; cheaper than another tree
  // when the C spans the object), plus the unseen points already found.
  for (const auto& survivor : survivors)
  {
    const double theta = survivor.second;
    const float cos_t = static_cast<float>(std::cos(theta));
    const float sin_t = static_cast<float>(std::sin(theta));
    const Eigen::Vector3f across = cos_t * u + sin_t * v;
    const Eigen::Vector3f closing_axis = -sin_t * u + cos_t * v;
    // Every test on the slab (Eq. 6.9, fingers, closing region, sides, collision) looks only
    // at |y| <= r2 + clearance, so farther points are not kept.
    if (ctx.slab.size() < ctx.seen->size() + ctx.coarse_local.size())
      ctx.slab.resize(ctx.seen->size() + ctx.coarse_local.size());
    std::size_t count = 0;
    for (std::size_t i = 0; i < ctx.seen->size(); ++i)
    {
      const Eigen::Vector3f d = ctx.seen->points[i].getVector3fMap() - p;
      const float x = d.dot(across);
      if (std::abs(x) > c.collision_half_w)
        continue;
      const float s = d.dot(approach);
      if (s < depth_low || s > depth_high)
        continue;
      const float y = d.dot(closing_axis);
      if (std::abs(y) <= c.collision_r2)
        ctx.slab[count++] = { x, y, s, static_cast<int>(i) };
    }
    for (const LocalPoint& q : ctx.coarse_local)
    {
      const float x = q.u * cos_t + q.v * sin_t;
      if (q.index < 0 && std::abs(x) <= c.collision_half_w)
        ctx.slab[count++] = { x, -q.u * sin_t + q.v * cos_t, q.s, -1 };
    }
    const SlabSpan slab{ ctx.slab.data(), count };
    ++ctx.fine_checks;
    const Placement placement =
        place(ctx, slab, ctx.table.maxDepth(p, approach, closing_axis, across, c.collision_r2));
    if (placement.blocked)
    {
      ++ctx.rejected.blocked;
      continue;
    }
    if (placement.below_table)
    {
      ++ctx.rejected.table;
      continue;
    }
    if (placement.collision != 0)
    {
      ++(placement.collision == 1 ? ctx.rejected.object_collision : ctx.rejected.unseen_collision);
      continue;
    }
    const ClosingRegion& region = placement.region;
    const double width_seen = region.y_max_seen - region.y_min_seen;
    const double width_all = region.y_max_all - region.y_min_all;
    if (region.seen_count == 0 || width_all > ctx.gripper.max_opening_m)
    {
      ++ctx.rejected.too_wide;
      continue;
    }
    if (width_seen < ctx.gripper.min_opening_m)
    {
      ++ctx.rejected.too_narrow;
      continue;
    }
    ++ctx.zone_found;

    double sigma = 0.0;
    double variance = 0.0;
    if (!analyseSides(ctx, slab, placement.grasp_s, sigma, variance))
    {
      ++ctx.rejected.few_side_points;
      continue;
    }

    // The grasp in the base frame: origin at the C centre on the normal's line.
    const Eigen::Vector3f axis_x = cos_t * u + sin_t * v;
    const Eigen::Vector3f closing = -sin_t * u + cos_t * v;
    auto toBase = [&](const Eigen::Vector3f& local) -> Eigen::Vector3d {
      return (p + local.x() * axis_x + local.y() * closing + local.z() * approach).cast<double>();
    };
    const Eigen::Vector3f centre = p + approach * placement.grasp_s;
    if (!ctx.table.clear(centre, approach, closing, axis_x))
    {
      ++ctx.rejected.table;
      continue;
    }
    GraspCandidate grasp;
    grasp.pose = makeGraspPose(centre.cast<double>(), approach.cast<double>(), closing.cast<double>());
    grasp.width_m = width_seen;
    grasp.force_balance_rad = sigma;
    grasp.variance_m = variance;
    grasp.contact_a = toBase(placement.contact_a);
    grasp.contact_b = toBase(placement.contact_b);
    grasp.algorithm = "cshape";
    // Lever of gravity about the closing line: distance of the centroid from that line.
    const Eigen::Vector3f to_centroid = ctx.centroid - centre;
    grasp.torque_offset_m = (to_centroid - to_centroid.dot(closing) * closing).norm();
    grasp.score = -(sigma + params.variance_weight_rad_per_m * std::min(variance, 1e3) +
                    params.torque_weight_rad_per_m * grasp.torque_offset_m +
                    params.unseen_width_weight_rad_per_m * (width_all - width_seen) +
                    params.shallow_weight_rad_per_m * placement.shortfall) +
                  params.from_above_weight_rad * approach.dot(ctx.gravity);

    bool from_sensor_side = false;
    for (const Eigen::Vector3f& sensor : ctx.sensors)
      from_sensor_side = from_sensor_side || approach.dot(centre - sensor) > 0.0f;
    if (!from_sensor_side)
    {
      ++ctx.rejected.wrong_side;
      continue;
    }
    record(ctx, grasp);
    if (variance > params.variance_threshold_m)
    {
      ++ctx.rejected.variance;
      continue;
    }
    if (sigma > params.force_balance_threshold_rad)
    {
      ++ctx.rejected.force_balance;
      continue;
    }
    if (ctx.hand)
    {
      // The C of Eq. 6.1 has no flat palm: fit the real hand, backing it out if its palm
      // would enter the object; the backed-off C body must still clear the table.
      const GripperFit fitted = ctx.hand->fit(grasp.pose, grasp.width_m);
      const Eigen::Vector3f fitted_centre = fitted.pose.translation().cast<float>();
      if (!fitted.ok || !ctx.table.clear(fitted_centre, approach, closing, axis_x))
      {
        ++ctx.rejected.hand;
        continue;
      }
      // Beyond the thesis (gripper_fit.max_advance_m): the C's fingertips on a round object
      // close above its equator and slip out on the lift, so the real hand is pushed deeper,
      // as deep as its own boxes clear the object, the unseen part and the table. The C body
      // is not checked there: it reaches r2 ahead of its centre, the real fingers only
      // finger_depth / 2.
      // (without max_advance_m, fitDeepest would only repeat the fit above)
      const GripperFit deeper = params.gripper_fit.max_advance_m > 0.0 ? ctx.hand->fitDeepest(grasp.pose, grasp.width_m)
                                                                        : GripperFit{};
      grasp.pose = deeper.ok ? deeper.pose : fitted.pose;
    }
    best.passed = true;
    best.grasp = grasp;
    break;  // the best-ranked orientation that passes at full resolution
  }
  return best;
}

std::string describe(const RejectionCounts& r)
{
  std::ostringstream out;
  out << r.object_collision << " hit the object (wider than the C-shape), " << r.unseen_collision
      << " hit the unseen part, " << r.too_wide << " wider than the max opening, " << r.too_narrow
      << " narrower than the min opening, " << r.blocked << " blocked in front, " << r.few_side_points
      << " without two fittable sides, " << r.variance << " above the variance threshold, " << r.force_balance
      << " above the force-balance threshold, " << r.wrong_side << " approaching from behind the sensor, " << r.table
      << " reaching into the table (gripper body below the table plane + clearance), " << r.hand
      << " where the real hand (finger and palm boxes) does not fit";
  return out.str();
}
}  // namespace

std::string CShapeParams::validate() const
{
  std::ostringstream why;
  if (!(angle_increment_rad > 0.0 && angle_increment_rad <= M_PI))
    why << "angle_increment_rad must lie in (0, pi]; ";
  if (!(normal_downsample_radius_m > 0.0))
    why << "normal_downsample_radius_m must be positive; ";
  if (!(local_axis_radius_m >= 0.0))
    why << "local_axis_radius_m must be >= 0; ";
  if (max_grasps < 1)
    why << "max_grasps must be >= 1; ";
  if (!(time_budget_s > 0.0))
    why << "time_budget_s must be positive; ";
  if (!(variance_threshold_m >= 0.0))
    why << "variance_threshold_m must be >= 0; ";
  if (side_bins < 2 || min_side_bins < 2 || min_side_bins > side_bins)
    why << "need 2 <= min_side_bins <= side_bins; ";
  if (!(force_balance_threshold_rad >= 0.0))
    why << "force_balance_threshold_rad must be >= 0; ";
  if (!(obstacle_leaf_m >= 0.0))
    why << "obstacle_leaf_m must be >= 0 (0 = automatic); ";
  if (!(collision_clearance_m >= 0.0))
    why << "collision_clearance_m must be >= 0; ";
  if (!(contact_tolerance_m >= 0.0))
    why << "contact_tolerance_m must be >= 0; ";
  if (!(table_clearance_m >= 0.0))
    why << "table_clearance_m must be >= 0; ";
  if (!std::isfinite(from_above_weight_rad))
    why << "from_above_weight_rad must be finite; ";
  if (!(coarse_screen_factor >= 0.0))
    why << "coarse_screen_factor must be >= 0 (0 = no coarse stability screen); ";
  why << gripper_fit.validate();
  if (!(min_thickness_m >= 0.0))
    why << "min_thickness_m must be >= 0; ";
  if (!(unseen.extension_m >= 0.0) || unseen.step_m < 0.0 || unseen.grid_cell_m < 0.0 || unseen.min_grid_cell_m < 0.0)
    why << "unseen part lengths must be >= 0; ";
  return why.str();
}

bool insideCShape(const CShapePose& pose, const GripperModel& gripper, const Eigen::Vector3f& point,
                  double clearance_m)
{
  const CShapeGeometry c(gripper, clearance_m);
  const Eigen::Vector3f approach = pose.approach.normalized();
  const Eigen::Vector3f closing = (pose.closing - pose.closing.dot(approach) * approach).normalized();
  const Eigen::Vector3f d = point - pose.centre;
  return c.inside(d.dot(approach.cross(closing)), d.dot(closing), d.dot(approach));
}

std::size_t countInsideCShape(const CShapePose& pose, const GripperModel& gripper, const CloudXYZ& cloud,
                              double clearance_m)
{
  std::size_t count = 0;
  for (const auto& p : cloud.points)
    if (std::isfinite(p.x) && insideCShape(pose, gripper, p.getVector3fMap(), clearance_m))
      ++count;
  return count;
}

CShapeGraspPlanner::CShapeGraspPlanner(CShapeParams params) : params_(std::move(params)) {}

GraspResult CShapeGraspPlanner::plan(const ObjectView& view, const GripperModel& gripper) const
{
  const Stopwatch stopwatch;
  auto finish = [&](GraspResult result) {
    result.compute_time_s = stopwatch.elapsedSeconds();
    return result;
  };

  // Validate before touching anything (the sensor origins give the normals' side and the unseen part).
  if (std::optional<GraspResult> bad_input = checkPlannerInput("cshape", params_.validate(), gripper, view, params_.min_points, params_.input_limits))
    return finish(*bad_input);

  SearchContext ctx(params_, gripper);
  ctx.sensors = view.sensor_origins;
  ctx.table = TableCheck(view, gripper, params_);
  if (view.gravity.allFinite() && view.gravity.norm() > 1e-6f)
    ctx.gravity = view.gravity.normalized();

  // Step 2: finite points; normals (given upstream) oriented toward a viewpoint.
  ctx.seen.reset(new CloudXYZ);
  ctx.seen->reserve(view.cloud->size());
  ctx.normals.reserve(view.cloud->size());
  for (const PointNormal& q : view.cloud->points)
  {
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      continue;
    const Eigen::Vector3f position(q.x, q.y, q.z);
    Eigen::Vector3f normal(q.normal_x, q.normal_y, q.normal_z);
    const float length = normal.norm();
    if (!std::isfinite(length) || length < 1e-6f)
      normal = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
    else
    {
      normal /= length;
      bool faces_a_sensor = false;
      for (const Eigen::Vector3f& origin : view.sensor_origins)
        faces_a_sensor = faces_a_sensor || normal.dot(origin - position) > 0.0f;
      if (!faces_a_sensor)
        normal = -normal;
    }
    ctx.seen->push_back(PointXYZ(q.x, q.y, q.z));
    ctx.normals.push_back(normal);
  }
  const PrincipalFrame frame = computePrincipalFrame(*ctx.seen);
  ctx.centroid = frame.centroid;
  if (std::sqrt(frame.eigenvalues(1)) < params_.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "object cloud is collinear: no surface to place a C-shape on"));
  if (std::sqrt(frame.eigenvalues(2)) < params_.min_thickness_m)
    return finish(GraspResult::fail(GraspFailure::DegenerateInput,
                                    "object cloud is a flat sheet (thickness " +
                                        std::to_string(std::sqrt(frame.eigenvalues(2))) +
                                        " m): zero-thickness objects cannot be grasped by a C-shape"));

  // Obstacle resolution of the coarse screen (see below).
  const double obstacle_leaf_m =
      params_.obstacle_leaf_m > 0.0
          ? params_.obstacle_leaf_m
          : std::clamp(std::min(gripper.cshape_r2_m - gripper.cshape_r1_m, gripper.cshape_w_m) / 3.0, 1e-3, 5e-3);

  // Step 4 (Fig. 6.9, Eq. 6.8): the unseen part, built once, no denser than needed: shadow
  // points every 2 obstacle leaves along a ray and boundary cells of at least one leaf still
  // put several points into any C part (r2 - r1 >= 3 leaves thick, w >= 3 leaves wide, plus
  // the clearance), while the unseen part stops outnumbering the coarse seen points (3500
  // -> ~1000 points on a 10k-point cylinder, which halved the time of a plan).
  GraspResult result;
  CloudXYZ unseen_points;
  if (params_.use_unseen_part)
  {
    std::optional<Eigen::Vector4f> table;
    if (view.has_table_plane)
      table = view.table_plane;
    UnseenPartParams unseen_params = params_.unseen;
    if (unseen_params.step_m <= 0.0)
      unseen_params.step_m = 2.0 * obstacle_leaf_m;
    unseen_params.min_grid_cell_m = std::max(unseen_params.min_grid_cell_m, obstacle_leaf_m);
    UnseenPart unseen = buildUnseenPart(*ctx.seen, view.sensor_origins, unseen_params, table);
    if (!unseen.ok())
      return finish(GraspResult::fail(GraspFailure::DegenerateInput, "cannot build the unseen part: " + unseen.failure));
    unseen_points = std::move(unseen.points);
  }

  // Coarse obstacles for the per-orientation screen: voxel centroids, dense enough that no
  // C-shape part (thickness r2 - r1, width w) fits between them, plus the unseen part
  // (scanned linearly per normal, see evaluateNormal).
  ctx.obstacles.reset(new CloudXYZ);
  {
    pcl::VoxelGrid<PointXYZ> voxel_grid;
    voxel_grid.setInputCloud(ctx.seen);
    const float leaf = static_cast<float>(obstacle_leaf_m);
    voxel_grid.setLeafSize(leaf, leaf, leaf);
    voxel_grid.filter(*ctx.obstacles);
  }
  ctx.first_unseen = ctx.obstacles->size();
  *ctx.obstacles += unseen_points;
  if (view.obstacles)
    *ctx.obstacles += *view.obstacles;  // the neighbours count as unseen: the C-shape stays out
  if (params_.gripper_fit.enabled)
  {
    ctx.hand.emplace(gripper, params_.gripper_fit);
    ctx.hand->addSeen(*ctx.seen);
    ctx.hand->addUnseen(unseen_points);
    ctx.hand->addObstacles(view);
    if (view.has_table_plane && params_.check_table_clearance)
      ctx.hand->setTable(view.table_plane);
  }

  // Step 3: down-sampled normals, one per voxel, each the normal of a real input point (the
  // thesis takes the point nearest to the voxel centroid through a k-d tree; PCL's
  // UniformSampling takes the point nearest to the voxel centre in one pass, no tree).
  std::vector<int> normal_indices;
  {
    pcl::UniformSampling<PointXYZ> sampler(true);
    sampler.setInputCloud(ctx.seen);
    sampler.setRadiusSearch(params_.normal_downsample_radius_m);
    CloudXYZ sampled;
    sampler.filter(sampled);
    std::vector<bool> removed(ctx.seen->size(), false);
    for (int index : *sampler.getRemovedIndices())
      removed[static_cast<std::size_t>(index)] = true;
    for (std::size_t i = 0; i < ctx.seen->size(); ++i)
      if (!removed[i] && ctx.normals[i].allFinite())
        normal_indices.push_back(static_cast<int>(i));
  }
  if (normal_indices.empty())
    return finish(GraspResult::fail(GraspFailure::DegenerateInput, "object cloud has no valid normal"));

  // Random normal order (seeded), stop at max_grasps or the time budget.
  std::mt19937 rng(params_.seed);
  std::shuffle(normal_indices.begin(), normal_indices.end(), rng);
  std::vector<GraspCandidate> grasps;
  std::size_t normals_tried = 0;
  bool out_of_time = false;
  for (int index : normal_indices)
  {
    if (stopwatch.elapsedSeconds() > params_.time_budget_s)
    {
      out_of_time = true;
      break;
    }
    ++normals_tried;
    Evaluation evaluation = evaluateNormal(ctx, index);
    if (evaluation.passed)
    {
      grasps.push_back(std::move(evaluation.grasp));
      if (static_cast<int>(grasps.size()) >= params_.max_grasps)
        break;
    }
  }

  result.unseen = std::move(unseen_points);
  result.candidates = std::move(ctx.candidates);
  result.candidates_evaluated = ctx.configurations;
  std::ostringstream summary;
  summary << normals_tried << " of " << normal_indices.size() << " normals, " << ctx.configurations
          << " C-shape configurations (" << ctx.fine_checks << " re-checked at full resolution): ";
  if (grasps.empty())
  {
    if (out_of_time)
    {
      result.failure = GraspFailure::Timeout;
      summary << "time budget of " << params_.time_budget_s << " s ran out before any grasp passed; ";
    }
    else if (ctx.zone_found == 0)
    {
      result.failure = GraspFailure::NoGraspableZone;
      summary << "no C-shape fits around the object with max opening " << gripper.max_opening_m << " m"
              << (ctx.rejected.table > 0 ? " without its gripper body reaching into the table" : "") << "; ";
    }
    else
    {
      result.failure = GraspFailure::NoStableGrasp;
      summary << ctx.zone_found << " fit but none is stable; ";
    }
    summary << describe(ctx.rejected);
    result.message = summary.str();
    return finish(std::move(result));
  }
  sortGraspsBestFirst(grasps);
  result.grasps = std::move(grasps);
  summary << result.grasps.size() << " grasps, best force balance " << result.grasps.front().force_balance_rad
          << " rad" << (out_of_time ? " (time budget reached)" : "") << "; rejected: " << describe(ctx.rejected);
  result.message = summary.str();

  // The points enveloped by the best C-shape, for drawing. GraspResult::hull stays empty:
  // Eq. 6.9 is evaluated without a hull (see place()).
  const GraspCandidate& best = result.grasps.front();
  const Eigen::Isometry3d to_grasp = best.pose.inverse();
  const CShapeGeometry& c = ctx.geometry;
  for (const PointXYZ& q : ctx.seen->points)
  {
    const Eigen::Vector3d local = to_grasp * q.getVector3fMap().cast<double>();
    // Grasp frame: x approach (depth), y closing, z across the C plane.
    if (c.enveloped(static_cast<float>(local.z()), static_cast<float>(local.y()), static_cast<float>(local.x())))
      result.graspable_zone.push_back(q);
  }
  return finish(std::move(result));
}

}  // namespace fast_grasp
