#include "fast_grasp/grasping/grasp_planner_params.h"

#include "fast_grasp/core/yaml_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>

namespace fast_grasp
{
namespace
{
/// A section's parameters that its validate() found wrong (`problem` not empty) stop the load.
void throwIfInvalid(const char* section, const std::string& problem)
{
  if (!problem.empty())
    throw std::runtime_error(std::string(section) + ": " + problem);
}

/// Reads typed keys of one section and remembers which were read, so that any other key
/// (a typo such as `sweep_step: 0.002`) is reported instead of silently ignored.
class SectionReader
{
public:
  SectionReader(const YAML::Node& section, std::string name) : section_(section), name_(std::move(name))
  {
    if (section_ && !section_.IsNull() && !section_.IsMap())
      throw std::runtime_error(name_ + ": expected a map of parameters");
  }

  template <typename T>
  void read(const char* key, T& value)
  {
    known_.insert(key);
    if (!section_ || section_.IsNull() || !section_.IsMap())
      return;
    const YAML::Node node = section_[key];
    if (!node)
      return;
    try
    {
      value = node.as<T>();
    }
    catch (const YAML::Exception&)
    {
      throw std::runtime_error(where(key) + ": cannot read '" + YAML::Dump(node) + "' as " + typeName<T>());
    }
  }

  void readPositive(const char* key, double& value)
  {
    read(key, value);
    if (!(value > 0.0) || !std::isfinite(value))
      throw std::runtime_error(where(key) + " must be a positive number");
  }

  void readNonNegative(const char* key, double& value)
  {
    read(key, value);
    if (!(value >= 0.0) || !std::isfinite(value))
      throw std::runtime_error(where(key) + " must be >= 0");
  }

  /// Counts (min_points, max_grasps) are size_t in the planners; YAML gives signed numbers.
  void readCount(const char* key, std::size_t& value, long long minimum)
  {
    long long signed_value = static_cast<long long>(value);
    read(key, signed_value);
    if (signed_value < minimum)
      throw std::runtime_error(where(key) + " must be >= " + std::to_string(minimum));
    value = static_cast<std::size_t>(signed_value);
  }

  void readCount(const char* key, int& value, int minimum)
  {
    read(key, value);
    if (value < minimum)
      throw std::runtime_error(where(key) + " must be >= " + std::to_string(minimum));
  }

  void rejectUnknownKeys() const
  {
    if (!section_ || !section_.IsMap())
      return;
    for (const auto& entry : section_)
    {
      const std::string key = entry.first.as<std::string>();
      if (known_.count(key) == 0)
        throw std::runtime_error(where(key.c_str()) + ": unknown parameter");
    }
  }

  std::string where(const char* key) const { return name_ + "/" + key; }

  /// A nested map read by another SectionReader.
  YAML::Node child(const char* key)
  {
    known_.insert(key);
    if (!section_ || section_.IsNull() || !section_.IsMap())
      return YAML::Node();
    return section_[key];
  }

private:
  template <typename T>
  static const char* typeName()
  {
    if constexpr (std::is_same_v<T, bool>)
      return "a boolean";
    else if constexpr (std::is_same_v<T, std::string>)
      return "a string";
    else if constexpr (std::is_integral_v<T>)
      return "an integer";
    else if constexpr (std::is_same_v<T, std::vector<std::string>>)
      return "a list of names";
    else if constexpr (std::is_same_v<T, std::map<std::string, double>>)
      return "a map of numbers";
    else
      return "a number";
  }

  const YAML::Node section_;
  const std::string name_;
  std::set<std::string> known_;
};

/// The unseen-part keys every planner with an unseen part shares (`use_unseen_part`,
/// `unseen_*` = UnseenPartParams), so they mean the same in each section.
void readUnseenPart(SectionReader& reader, bool& use_unseen_part, UnseenPartParams& unseen)
{
  reader.read("use_unseen_part", use_unseen_part);
  reader.read("unseen_extension_m", unseen.extension_m);
  reader.read("unseen_step_m", unseen.step_m);
  reader.read("unseen_grid_cell_m", unseen.grid_cell_m);
  reader.read("unseen_min_grid_cell_m", unseen.min_grid_cell_m);
  reader.read("unseen_depth_jump_m", unseen.depth_jump_m);
  reader.read("unseen_max_grid_cells_per_side", unseen.max_grid_cells_per_side);
  reader.read("unseen_table_clearance_m", unseen.table_clearance_m);
}

/// The `gripper_fit:` map of every planner (GripperFitParams).
GripperFitParams gripperFitFromYaml(SectionReader& parent, const char* planner)
{
  GripperFitParams p;
  SectionReader reader(parent.child("gripper_fit"), std::string(planner) + "/gripper_fit");
  reader.read("enabled", p.enabled);
  reader.readNonNegative("approach_opening_m", p.approach_opening_m);
  reader.readNonNegative("palm_clearance_m", p.palm_clearance_m);
  reader.readNonNegative("max_backoff_m", p.max_backoff_m);
  reader.readNonNegative("table_clearance_m", p.table_clearance_m);
  reader.readCount("min_points_between_fingers", p.min_points_between_fingers, 1);
  reader.readNonNegative("closing_margin_m", p.closing_margin_m);
  reader.readNonNegative("max_table_tilt_rad", p.max_table_tilt_rad);
  reader.readNonNegative("tilt_step_rad", p.tilt_step_rad);
  reader.readNonNegative("max_advance_m", p.max_advance_m);
  reader.readNonNegative("finger_graze_margin_m", p.finger_graze_margin_m);
  reader.rejectUnknownKeys();
  return p;
}
}  // namespace

PrincipalAxisParams principalAxisParamsFromYaml(const YAML::Node& section)
{
  PrincipalAxisParams p;
  SectionReader reader(section, "principal_axis");
  reader.readPositive("sweep_step_m", p.sweep_step_m);
  reader.readPositive("grid_cell_m", p.grid_cell_m);
  reader.readCount("gap_close_rows", p.gap_close_rows, 0);
  reader.readCount("crossing_window_rows", p.crossing_window_rows, 0);
  reader.readNonNegative("side_depth_m", p.side_depth_m);
  reader.readNonNegative("end_clearance_m", p.end_clearance_m);
  reader.readPositive("force_balance_max_rad", p.force_balance_max_rad);
  reader.readPositive("xoz_max_offset_m", p.xoz_max_offset_m);
  reader.readNonNegative("min_axis_view_angle_rad", p.min_axis_view_angle_rad);
  reader.readNonNegative("min_thickness_m", p.min_thickness_m);
  reader.readCount("min_points", p.min_points, 1);
  reader.read("two_camera_mode", p.two_camera_mode);
  reader.readPositive("virtual_view_step_rad", p.virtual_view_step_rad);
  reader.read("next_view_from_above", p.next_view_from_above);
  reader.readNonNegative("next_view_min_turn_rad", p.next_view_min_turn_rad);
  reader.readNonNegative("next_view_max_face_rms_ratio", p.next_view_max_face_rms_ratio);
  reader.readCount("max_grasps", p.max_grasps, 1);
  p.gripper_fit = gripperFitFromYaml(reader, "principal_axis");
  reader.rejectUnknownKeys();
  return p;
}

CShapeParams cshapeParamsFromYaml(const YAML::Node& section)
{
  CShapeParams p;
  SectionReader reader(section, "cshape");
  reader.read("angle_increment_rad", p.angle_increment_rad);
  reader.read("normal_downsample_radius_m", p.normal_downsample_radius_m);
  reader.read("obstacle_leaf_m", p.obstacle_leaf_m);
  reader.read("local_axis_radius_m", p.local_axis_radius_m);
  reader.read("max_grasps", p.max_grasps);
  reader.read("time_budget_s", p.time_budget_s);
  long long seed = p.seed;
  reader.read("seed", seed);
  if (seed < 0 || seed > static_cast<long long>(std::numeric_limits<std::uint32_t>::max()))
    throw std::runtime_error(reader.where("seed") + " must be in [0, 2^32)");
  p.seed = static_cast<std::uint32_t>(seed);
  reader.read("variance_threshold_m", p.variance_threshold_m);
  reader.read("side_bins", p.side_bins);
  reader.read("min_side_bins", p.min_side_bins);
  reader.read("force_balance_threshold_rad", p.force_balance_threshold_rad);
  reader.read("contact_tolerance_m", p.contact_tolerance_m);
  reader.read("collision_clearance_m", p.collision_clearance_m);
  std::string depth_rule = p.depth_rule == CShapeParams::DepthRule::CShapeCentre ? "cshape_centre" : "contact_depth";
  reader.read("depth_rule", depth_rule);
  if (depth_rule == "contact_depth")
    p.depth_rule = CShapeParams::DepthRule::ContactDepth;
  else if (depth_rule == "cshape_centre")
    p.depth_rule = CShapeParams::DepthRule::CShapeCentre;
  else
    throw std::runtime_error(reader.where("depth_rule") + ": '" + depth_rule +
                             "' is neither contact_depth nor cshape_centre");
  readUnseenPart(reader, p.use_unseen_part, p.unseen);
  reader.read("check_table_clearance", p.check_table_clearance);
  reader.read("table_clearance_m", p.table_clearance_m);
  reader.read("min_fingertip_overlap_m", p.min_fingertip_overlap_m);
  reader.read("from_above_weight_rad", p.from_above_weight_rad);
  reader.read("coarse_screen_factor", p.coarse_screen_factor);
  reader.read("variance_weight_rad_per_m", p.variance_weight_rad_per_m);
  reader.read("torque_weight_rad_per_m", p.torque_weight_rad_per_m);
  reader.read("unseen_width_weight_rad_per_m", p.unseen_width_weight_rad_per_m);
  reader.read("shallow_weight_rad_per_m", p.shallow_weight_rad_per_m);
  reader.readCount("min_points", p.min_points, 1);
  reader.read("min_thickness_m", p.min_thickness_m);
  reader.readCount("max_recorded_candidates", p.max_recorded_candidates, 0);
  p.gripper_fit = gripperFitFromYaml(reader, "cshape");
  reader.rejectUnknownKeys();
  // The planner owns the rules on its parameters; apply them here so a bad file fails at load.
  throwIfInvalid("cshape", p.validate());
  return p;
}

BoundaryParams boundaryParamsFromYaml(const YAML::Node& section)
{
  BoundaryParams p;
  SectionReader reader(section, "boundary");
  reader.readPositive("grid_cell_m", p.grid_cell_m);
  reader.readNonNegative("spacing_cell_factor", p.spacing_cell_factor);
  reader.readCount("close_cells", p.close_cells, 0);
  reader.readPositive("step_m", p.step_m);
  reader.readCount("max_finger_candidates", p.max_finger_candidates, 2);
  reader.readNonNegative("finger_width_m", p.finger_width_m);
  reader.readPositive("inside_probe_step_m", p.inside_probe_step_m);
  reader.readCount("inside_probe_max_steps", p.inside_probe_max_steps, 1);
  reader.readNonNegative("force_balance_max_rad", p.force_balance_max_rad);
  reader.readNonNegative("torque_offset_max_m", p.torque_offset_max_m);
  reader.readNonNegative("opening_margin_m", p.opening_margin_m);
  reader.readNonNegative("variance_max_m", p.variance_max_m);
  reader.readNonNegative("operability_tolerance_m", p.operability_tolerance_m);
  reader.readNonNegative("force_balance_weight_m_per_rad", p.force_balance_weight_m_per_rad);
  reader.readNonNegative("torque_weight", p.torque_weight);
  reader.readNonNegative("variance_weight", p.variance_weight);
  reader.readNonNegative("width_weight", p.width_weight);
  reader.readCount("min_points", p.min_points, 1);
  reader.readNonNegative("min_thickness_m", p.min_thickness_m);
  reader.readNonNegative("max_normal_sight_angle_rad", p.max_normal_sight_angle_rad);
  reader.readCount("max_grasps", p.max_grasps, 1);
  reader.readCount("max_recorded_candidates", p.max_recorded_candidates, 0);
  readUnseenPart(reader, p.use_unseen_part, p.unseen);
  p.gripper_fit = gripperFitFromYaml(reader, "boundary");
  reader.rejectUnknownKeys();
  throwIfInvalid("boundary", p.validate());
  return p;
}

ConcavityParams concavityParamsFromYaml(const YAML::Node& section)
{
  ConcavityParams p;
  SectionReader reader(section, "concavity");
  reader.readNonNegative("voxel_leaf_m", p.voxel_leaf_m);
  reader.readCount("max_analysis_points", p.max_analysis_points, 100);
  reader.readPositive("min_concavity_m", p.min_concavity_m);
  reader.readPositive("cluster_tolerance_m", p.cluster_tolerance_m);
  reader.readCount("min_region_points", p.min_region_points, 1);
  reader.readCount("max_regions", p.max_regions, 1);
  reader.readNonNegative("max_approach_view_angle_rad", p.max_approach_view_angle_rad);
  reader.readPositive("grid_cell_m", p.grid_cell_m);
  reader.readPositive("step_m", p.step_m);
  reader.readNonNegative("hand_width_m", p.hand_width_m);
  reader.readNonNegative("boundary_tolerance_m", p.boundary_tolerance_m);
  reader.readPositive("gap_m", p.gap_m);
  reader.readCount("side_bins", p.side_bins, 2);
  reader.readCount("min_side_bins", p.min_side_bins, 2);
  reader.readNonNegative("side_depth_m", p.side_depth_m);
  reader.readPositive("force_balance_max_rad", p.force_balance_max_rad);
  reader.readNonNegative("view_alignment_weight", p.view_alignment_weight);
  reader.readNonNegative("duplicate_distance_m", p.duplicate_distance_m);
  readUnseenPart(reader, p.use_unseen_part, p.unseen);
  reader.readCount("min_points", p.min_points, 1);
  reader.readNonNegative("min_thickness_m", p.min_thickness_m);
  reader.readCount("max_grasps", p.max_grasps, 1);
  reader.readCount("max_recorded_candidates", p.max_recorded_candidates, 0);
  p.gripper_fit = gripperFitFromYaml(reader, "concavity");
  reader.rejectUnknownKeys();
  throwIfInvalid("concavity", p.validate());
  return p;
}

namespace
{
/// Throws unless every name is one of the thesis planners (a list the fused planner pools or the
/// hold check wraps: never "fused" itself).
void requireThesisPlanners(const std::vector<std::string>& names, const std::string& key)
{
  for (const std::string& name : names)
    if (name != "principal_axis" && name != "cshape" && name != "boundary" && name != "concavity")
      throw std::runtime_error(key + ": '" + name + "' is none of principal_axis, cshape, boundary, concavity");
}
}  // namespace

FusedParams fusedParamsFromYaml(const YAML::Node& section)
{
  FusedParams p;
  SectionReader reader(section, "fused");
  reader.read("planners", p.planners);
  requireThesisPlanners(p.planners, "fused/planners");
  reader.readCount("top_down_directions", p.top_down_directions, 0);
  reader.readCount("side_directions", p.side_directions, 0);
  reader.readNonNegative("side_spread_rad", p.side_spread_rad);
  reader.readNonNegative("tall_object_min_height_m", p.tall_object_min_height_m);
  reader.read("side_high_fracs", p.side_high_fracs);
  reader.readNonNegative("tall_side_min_height_frac", p.tall_side_min_height_frac);
  reader.read("end_grasps", p.end_grasps);
  reader.readNonNegative("deepen_pooled_max_m", p.deepen_pooled_max_m);
  reader.readCount("max_pooled_points", p.max_pooled_points, 0);
  reader.readCount("max_grasps", p.max_grasps, 1);
  reader.readNonNegative("min_success_probability", p.min_success_probability);
  reader.readNonNegative("finger_graze_penalty", p.finger_graze_penalty);
  reader.read("return_drop_risk_grasps", p.return_drop_risk_grasps);
  std::map<std::string, double> pooled_max_grasps;
  reader.read("pooled_max_grasps", pooled_max_grasps);
  for (const auto& [name, count] : pooled_max_grasps)
  {
    if (std::find(p.planners.begin(), p.planners.end(), name) == p.planners.end())
      throw std::runtime_error("fused/pooled_max_grasps: '" + name + "' is not one of fused/planners");
    if (!(count >= 1.0 && count <= 1000.0) || count != std::floor(count))
      throw std::runtime_error("fused/pooled_max_grasps/" + name + " must be a whole number in [1, 1000]");
    p.pooled_max_grasps[name] = static_cast<std::size_t>(count);
  }
  p.gripper_fit = gripperFitFromYaml(reader, "fused");
  {
    SectionReader lying(reader.child("lying_cylinder"), "fused/lying_cylinder");
    lying.read("enabled", p.lying_cylinder.enabled);
    lying.readNonNegative("min_length_to_height", p.lying_cylinder.min_length_to_height);
    lying.readNonNegative("max_normal_spread_ratio", p.lying_cylinder.max_normal_spread_ratio);
    lying.readNonNegative("max_median_residual_frac", p.lying_cylinder.max_median_residual_frac);
    lying.readNonNegative("max_median_normal_angle_rad", p.lying_cylinder.max_median_normal_angle_rad);
    lying.readCount("min_points", p.lying_cylinder.min_points, 3);
    lying.read("min_fingertip_reach_m", p.lying_cylinder.min_fingertip_reach_m);
    lying.read("max_open_hand_depth_m", p.lying_cylinder.max_open_hand_depth_m);
    lying.read("open_hand_approach_m", p.lying_cylinder.open_hand_approach_m);
    lying.rejectUnknownKeys();
  }
  {
    SectionReader face(reader.child("one_seen_face"), "fused/one_seen_face");
    face.read("enabled", p.one_seen_face.enabled);
    face.readNonNegative("max_width_m", p.one_seen_face.max_width_m);
    face.readNonNegative("min_facing_cos", p.one_seen_face.min_facing_cos);
    face.readNonNegative("min_facing_share", p.one_seen_face.min_facing_share);
    face.rejectUnknownKeys();
  }
  {
    SectionReader flat(reader.child("wide_flat_top"), "fused/wide_flat_top");
    flat.read("enabled", p.wide_flat_top.enabled);
    flat.readNonNegative("top_band_m", p.wide_flat_top.top_band_m);
    flat.readNonNegative("min_up_cos", p.wide_flat_top.min_up_cos);
    flat.readNonNegative("min_top_share", p.wide_flat_top.min_top_share);
    flat.readNonNegative("min_height_m", p.wide_flat_top.min_height_m);
    flat.read("min_excess_over_opening_m", p.wide_flat_top.min_excess_over_opening_m);
    flat.rejectUnknownKeys();
  }
  {
    SectionReader wide(reader.child("wide_lying_body"), "fused/wide_lying_body");
    wide.read("enabled", p.wide_lying_body.enabled);
    wide.readNonNegative("min_elongation", p.wide_lying_body.mirror.min_elongation);
    wide.readNonNegative("max_free_fraction", p.wide_lying_body.mirror.max_free_fraction);
    wide.read("min_excess_over_opening_m", p.wide_lying_body.min_excess_over_opening_m);
    wide.rejectUnknownKeys();
  }
  SectionReader model(reader.child("model"), "fused/model");
  model.read("bias", p.model.bias);
  std::map<std::string, double> weights;
  model.read("weights", weights);
  model.read("fitted_on", p.model.fitted_on);
  model.rejectUnknownKeys();
  if (!weights.empty())
  {
    const auto& names = graspFeatureNames();
    p.model.weights.assign(names.size(), 0.0);
    for (const auto& [feature, weight] : weights)
    {
      const auto it = std::find(names.begin(), names.end(), feature);
      if (it == names.end())
        throw std::runtime_error("fused/model/weights: unknown feature '" + feature + "'");
      p.model.weights[static_cast<std::size_t>(it - names.begin())] = weight;
    }
  }
  reader.rejectUnknownKeys();
  throwIfInvalid("fused", p.validate());
  return p;
}

TableGraspParams tableGraspParamsFromYaml(const YAML::Node& section)
{
  TableGraspParams p;
  SectionReader reader(section, "table_grasps");
  std::string choice = toString(p.object_choice);
  reader.read("object_choice", choice);
  if (!parseObjectChoice(choice, p.object_choice))
    throw std::runtime_error("table_grasps/object_choice: '" + choice + "' is none of best_grasp, topmost, nearest_to_base");
  reader.readNonNegative("neighbour_clearance_m", p.neighbour_clearance_m);
  reader.readNonNegative("approach_distance_m", p.approach_distance_m);
  reader.read("neighbour_unseen_parts", p.neighbour_unseen_parts);
  reader.readPositive("unseen_extension_m", p.unseen.extension_m);
  reader.readNonNegative("next_view_turn_rad", p.next_view_turn_rad);
  reader.read("return_drop_risk_grasps", p.return_drop_risk_grasps);
  reader.rejectUnknownKeys();
  throwIfInvalid("table_grasps", p.validate());
  return p;
}

HoldCheckConfig holdCheckConfigFromYaml(const YAML::Node& section)
{
  HoldCheckConfig config;
  SectionReader reader(section, "hold_check");
  reader.read("planners", config.planners);
  requireThesisPlanners(config.planners, "hold_check/planners");
  reader.read("tall_objects", config.tall_objects);
  reader.readNonNegative("max_closing_tilt_rad", config.max_closing_tilt_rad);
  if (!(config.max_closing_tilt_rad <= M_PI / 2.0))
    throw std::runtime_error("hold_check/max_closing_tilt_rad must be in [0, pi/2] (0 = no check)");
  {
    SectionReader ball(reader.child("resting_ball"), "hold_check/resting_ball");
    ball.read("enabled", config.resting_ball.enabled);
    ball.readPositive("max_median_residual_frac", config.resting_ball.max_median_residual_frac);
    ball.readPositive("max_median_normal_angle_rad", config.resting_ball.max_median_normal_angle_rad);
    ball.readCount("min_points", config.resting_ball.min_points, 3);
    ball.readNonNegative("min_fingertip_depth_m", config.resting_ball.min_fingertip_depth_m);
    ball.readPositive("max_length_to_height", config.resting_ball.max_length_to_height);
    ball.readNonNegative("flat_max_height_to_breadth", config.resting_ball.flat_max_height_to_breadth);
    ball.readNonNegative("flat_min_fingertip_past_centre_frac", config.resting_ball.flat_min_fingertip_past_centre_frac);
    ball.rejectUnknownKeys();
    throwIfInvalid("hold_check", config.resting_ball.validate());
  }
  {
    SectionReader standing(reader.child("standing_cylinder"), "hold_check/standing_cylinder");
    StandingCylinderParams& s = config.standing_cylinder;
    standing.read("enabled", s.enabled);
    standing.readNonNegative("min_height_m", s.min_height_m);
    standing.readPositive("band_half_height_m", s.band_half_height_m);
    standing.readCount("min_points", s.min_points, 5);
    standing.readPositive("max_median_residual_frac", s.max_median_residual_frac);
    standing.readPositive("max_median_normal_angle_rad", s.max_median_normal_angle_rad);
    standing.readNonNegative("min_arc_rad", s.min_arc_rad);
    standing.readNonNegative("max_shortfall_frac", s.max_shortfall_frac);
    standing.rejectUnknownKeys();
    throwIfInvalid("hold_check", s.validate());
  }
  reader.rejectUnknownKeys();
  return config;
}

NearRangeParams nearRangeParamsFromYaml(const YAML::Node& section)
{
  NearRangeParams p;
  SectionReader reader(section, "near_range");
  reader.readNonNegative("sensor_min_range_m", p.sensor_min_range_m);
  reader.read("add_blind_space", p.add_blind_space);
  reader.read("flag_grasps_on_cut", p.flag_grasps_on_cut);
  reader.readPositive("margin_m", p.margin_m);
  reader.readCount("min_points", p.min_points, 1);
  reader.readPositive("extension_m", p.extension_m);
  reader.readPositive("step_m", p.step_m);
  reader.read("toward_camera", p.toward_camera);
  reader.read("next_view_step_back_m", p.next_view_step_back_m);
  reader.rejectUnknownKeys();
  throwIfInvalid("near_range", p.validate());
  return p;
}

PlannerInputLimits plannerInputLimitsFromYaml(const YAML::Node& root)
{
  PlannerInputLimits limits;
  // The other top-level keys are the planner sections and the nodelets' own settings.
  SectionReader reader(root, "(top level)");
  reader.readPositive("max_object_extent_m", limits.max_object_extent_m);
  return limits;
}

void setInputLimits(GraspPlannerConfig& config, const PlannerInputLimits& limits)
{
  config.principal_axis.input_limits = limits;
  config.cshape.input_limits = limits;
  config.boundary.input_limits = limits;
  config.concavity.input_limits = limits;
  config.fused.input_limits = limits;
}

GraspPlannerConfig loadGraspPlannerConfig(const std::string& yaml_path)
{
  YAML::Node root;
  try
  {
    root = loadYamlFile(yaml_path);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("cannot read planner parameters '" + yaml_path + "': " + e.what());
  }
  if (root && !root.IsNull() && !root.IsMap())
    throw std::runtime_error("planner parameters '" + yaml_path + "': expected a map at the top level");
  GraspPlannerConfig config;
  try
  {
    if (root && root.IsMap())
    {
      config.principal_axis = principalAxisParamsFromYaml(root["principal_axis"]);
      config.cshape = cshapeParamsFromYaml(root["cshape"]);
      config.boundary = boundaryParamsFromYaml(root["boundary"]);
      config.concavity = concavityParamsFromYaml(root["concavity"]);
      config.fused = fusedParamsFromYaml(root["fused"]);
      config.table_grasps = tableGraspParamsFromYaml(root["table_grasps"]);
      config.hold_check = holdCheckConfigFromYaml(root["hold_check"]);
      config.near_range = nearRangeParamsFromYaml(root["near_range"]);
      setInputLimits(config, plannerInputLimitsFromYaml(root));
    }
  }
  catch (const std::runtime_error& e)
  {
    throw std::runtime_error("planner parameters '" + yaml_path + "': " + e.what());
  }
  return config;
}

const std::vector<std::string>& graspAlgorithmNames()
{
  static const std::vector<std::string> names{ "principal_axis", "cshape", "boundary", "concavity", "fused" };
  return names;
}

namespace
{
/// The thesis planner named `algorithm`, without the hold check; nullptr for another name.
std::unique_ptr<GraspPlanner> makeThesisPlanner(const std::string& algorithm, const GraspPlannerConfig& config)
{
  if (algorithm == "principal_axis")
    return std::make_unique<PrincipalAxisGraspPlanner>(config.principal_axis);
  if (algorithm == "cshape")
    return std::make_unique<CShapeGraspPlanner>(config.cshape);
  if (algorithm == "boundary")
    return std::make_unique<BoundaryGraspPlanner>(config.boundary);
  if (algorithm == "concavity")
    return std::make_unique<ConcavityGraspPlanner>(config.concavity);
  return nullptr;
}
}  // namespace

GraspPlannerConfig tablePlannerConfig(GraspPlannerConfig config)
{
  config.fused.return_drop_risk_grasps = config.table_grasps.return_drop_risk_grasps;
  return config;
}

std::unique_ptr<GraspPlanner> makeGraspPlanner(const std::string& algorithm, const GraspPlannerConfig& config)
{
  if (auto planner = makeThesisPlanner(algorithm, config))
  {
    const auto& checked = config.hold_check.planners;
    if (std::find(checked.begin(), checked.end(), algorithm) == checked.end())
      return planner;
    HoldCheckParams hold;
    hold.lying_cylinder = config.fused.lying_cylinder;
    hold.one_seen_face = config.fused.one_seen_face;
    hold.near_range = config.near_range;
    hold.approach_opening_m = config.fused.gripper_fit.approach_opening_m;
    if (config.hold_check.tall_objects)
    {
      hold.tall_object_min_height_m = config.fused.tall_object_min_height_m;
      hold.tall_side_min_height_frac = config.fused.tall_side_min_height_frac;
    }
    hold.resting_ball = config.hold_check.resting_ball;
    hold.standing_cylinder = config.hold_check.standing_cylinder;
    hold.max_closing_tilt_rad = config.hold_check.max_closing_tilt_rad;
    return std::make_unique<HoldCheckedPlanner>(std::move(planner), hold);
  }
  if (algorithm == "fused")
  {
    // Each pooled planner with its own section, but its max_grasps from fused/pooled_max_grasps
    // where that names it.
    GraspPlannerConfig pooled_config = config;
    for (const auto& [name, count] : config.fused.pooled_max_grasps)
    {
      if (name == "principal_axis")
        pooled_config.principal_axis.max_grasps = count;
      else if (name == "cshape")
        pooled_config.cshape.max_grasps = static_cast<int>(count);
      else if (name == "boundary")
        pooled_config.boundary.max_grasps = count;
      else if (name == "concavity")
        pooled_config.concavity.max_grasps = count;
    }
    std::vector<std::unique_ptr<GraspPlanner>> pooled;
    for (const std::string& name : config.fused.planners)
      if (name != "fused")  // fusedParamsFromYaml rejects it; never recurse
        if (auto planner = makeThesisPlanner(name, pooled_config))  // unchecked: fused ranks them itself
          pooled.push_back(std::move(planner));
    FusedParams fused = config.fused;
    fused.near_range = config.near_range;  // one camera for the whole file
    return std::make_unique<FusedGraspPlanner>(std::move(pooled), fused);
  }
  return nullptr;
}

}  // namespace fast_grasp
