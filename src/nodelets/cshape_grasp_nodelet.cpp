// fast_grasp/CShapeGrasp: thesis Ch6 C-shape planner behind the shared grasp-planner wrapper.
#include "fast_grasp/cshape_grasp.h"
#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

namespace fast_grasp
{
class CShapeGraspNodelet : public GraspPlannerNodelet
{
protected:
  std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) override
  {
    ros::NodeHandle nh(private_nh, "cshape");
    CShapeParams p;
    nh.param("angle_increment_rad", p.angle_increment_rad, p.angle_increment_rad);
    nh.param("normal_downsample_radius_m", p.normal_downsample_radius_m, p.normal_downsample_radius_m);
    nh.param("local_axis_radius_m", p.local_axis_radius_m, p.local_axis_radius_m);
    nh.param("max_grasps", p.max_grasps, p.max_grasps);
    nh.param("time_budget_s", p.time_budget_s, p.time_budget_s);
    int seed = static_cast<int>(p.seed);
    nh.param("seed", seed, seed);
    p.seed = static_cast<std::uint32_t>(seed);
    nh.param("variance_threshold_m", p.variance_threshold_m, p.variance_threshold_m);
    nh.param("side_bins", p.side_bins, p.side_bins);
    nh.param("min_side_bins", p.min_side_bins, p.min_side_bins);
    nh.param("force_balance_threshold_rad", p.force_balance_threshold_rad, p.force_balance_threshold_rad);
    nh.param("contact_tolerance_m", p.contact_tolerance_m, p.contact_tolerance_m);
    std::string depth_rule = "contact_depth";
    nh.param<std::string>("depth_rule", depth_rule, depth_rule);
    p.depth_rule = depth_rule == "cshape_centre" ? CShapeParams::DepthRule::CShapeCentre
                                                 : CShapeParams::DepthRule::ContactDepth;
    if (depth_rule != "cshape_centre" && depth_rule != "contact_depth")
      NODELET_WARN("cshape/depth_rule '%s' unknown; using contact_depth", depth_rule.c_str());
    nh.param("use_unseen_part", p.use_unseen_part, p.use_unseen_part);
    nh.param("unseen_extension_m", p.unseen.extension_m, p.unseen.extension_m);
    nh.param("unseen_step_m", p.unseen.step_m, p.unseen.step_m);
    nh.param("unseen_grid_cell_m", p.unseen.grid_cell_m, p.unseen.grid_cell_m);
    nh.param("unseen_depth_jump_m", p.unseen.depth_jump_m, p.unseen.depth_jump_m);
    nh.param("unseen_table_clearance_m", p.unseen.table_clearance_m, p.unseen.table_clearance_m);
    nh.param("variance_weight_rad_per_m", p.variance_weight_rad_per_m, p.variance_weight_rad_per_m);
    nh.param("torque_weight_rad_per_m", p.torque_weight_rad_per_m, p.torque_weight_rad_per_m);
    nh.param("min_thickness_m", p.min_thickness_m, p.min_thickness_m);
    const std::string problem = p.validate();
    if (!problem.empty())
    {
      // Refuse bad configuration at start-up rather than on every cloud.
      NODELET_ERROR("cshape parameters invalid (%s); using the defaults", problem.c_str());
      p = CShapeParams();
    }
    return std::make_unique<CShapeGraspPlanner>(p);
  }
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::CShapeGraspNodelet, nodelet::Nodelet)
