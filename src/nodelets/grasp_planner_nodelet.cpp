#include "fast_grasp/nodelets/grasp_planner_nodelet.h"

#include <geometry_msgs/PoseStamped.h>
#include <tf2_eigen/tf2_eigen.h>

#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/perception/cloud_checks.h"
#include "fast_grasp/nodelets/grasp_conversions.h"
#include "fast_grasp/nodelets/pcl_ros_mapping.h"
#include "fast_grasp/nodelets/shared_cloud.h"
#include "fast_grasp/nodelets/tf_wait.h"
#include "fast_grasp/nodelets/xmlrpc_yaml.h"

#include <geometry_msgs/TransformStamped.h>
#include <pcl_conversions/pcl_conversions.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace fast_grasp
{
namespace
{
std_msgs::ColorRGBA colour(float r, float g, float b, float a = 1.0f)
{
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

template <typename PointT>
visualization_msgs::Marker pointsMarker(const pcl::PointCloud<PointT>& cloud, const std::string& ns,
                                        const std_msgs::ColorRGBA& c, double size_m)
{
  visualization_msgs::Marker m;
  m.ns = ns;
  m.type = visualization_msgs::Marker::POINTS;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = size_m;
  m.color = c;
  m.points.reserve(cloud.size());
  for (const auto& p : cloud.points)
  {
    geometry_msgs::Point q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    m.points.push_back(q);
  }
  return m;
}

visualization_msgs::Marker boxInGraspFrame(const GraspCandidate& grasp, const Eigen::Vector3d& centre,
                                           const Eigen::Vector3d& size, const std::string& ns, int id,
                                           const std_msgs::ColorRGBA& c)
{
  visualization_msgs::Marker m;
  m.ns = ns;
  m.id = id;
  m.type = visualization_msgs::Marker::CUBE;
  Eigen::Isometry3d pose = grasp.pose;
  pose.translation() = grasp.pose * centre;
  m.pose = tf2::toMsg(pose);
  m.scale.x = size.x();
  m.scale.y = size.y();
  m.scale.z = size.z();
  m.color = c;
  return m;
}
}  // namespace

GraspPlannerConfig GraspPlannerNodelet::plannerConfig(const ros::NodeHandle& private_nh)
{
  GraspPlannerConfig config;
  config.principal_axis = principalAxisParamsFromYaml(paramAsYaml(private_nh, "principal_axis"));
  config.cshape = cshapeParamsFromYaml(paramAsYaml(private_nh, "cshape"));
  config.boundary = boundaryParamsFromYaml(paramAsYaml(private_nh, "boundary"));
  config.concavity = concavityParamsFromYaml(paramAsYaml(private_nh, "concavity"));
  config.fused = fusedParamsFromYaml(paramAsYaml(private_nh, "fused"));
  config.hold_check = holdCheckConfigFromYaml(paramAsYaml(private_nh, "hold_check"));
  config.near_range = nearRangeParamsFromYaml(paramAsYaml(private_nh, "near_range"));
  YAML::Node top_level(YAML::NodeType::Map);
  if (private_nh.hasParam("max_object_extent_m"))
    top_level["max_object_extent_m"] = paramAsYaml(private_nh, "max_object_extent_m");
  setInputLimits(config, plannerInputLimitsFromYaml(top_level));
  bool all_objects = false;
  private_nh.param("all_objects", all_objects, false);
  if (!all_objects)
    return config;
  config.table_grasps = tableGraspParamsFromYaml(private_nh.hasParam("table_grasps") ? paramAsYaml(private_nh, "table_grasps")
                                                                                     : YAML::Node());
  return tablePlannerConfig(config);
}

GraspPlannerNodelet::~GraspPlannerNodelet()
{
  gate_.close();  // after ros::shutdown() the subscribers' shutdown no longer waits (callback_gate.h)
  scene_sub_.shutdown();
  if (scene_spinner_)
    scene_spinner_->stop();
  cloud_sub_.shutdown();
  objects_sub_.shutdown();
}

void GraspPlannerNodelet::onInit()
{
  primePclRosFieldMappings();
  nh_ = getNodeHandle();
  private_nh_ = getPrivateNodeHandle();
  status_.init(nh_, private_nh_, getName());

  std::string gripper_file;
  private_nh_.param<std::string>("gripper_file", gripper_file, "");
  try
  {
    gripper_ = loadGripperModel(gripper_file);
  }
  catch (const std::exception& e)
  {
    // A planner without a gripper cannot serve anything: say why, loudly, and stay idle.
    NODELET_FATAL("Initialization failed: %s", e.what());
    status_.error(std::string("initialization failed: ") + e.what());
    return;
  }
  private_nh_.param("sensor_frames", sensor_frames_, std::vector<std::string>{});
  private_nh_.param("tf_timeout_s", tf_timeout_s_, 0.5);
  private_nh_.param("max_input_points", max_input_points_, 200000);
  private_nh_.param("max_marker_candidates", max_marker_candidates_, 100);
  private_nh_.param("all_objects", all_objects_, false);
  private_nh_.param("table_plane_wait_s", table_plane_wait_s_, 0.5);
  private_nh_.param("require_table_plane", require_table_plane_, true);
  private_nh_.param("normal_k_neighbours", normal_params_.k_neighbours, normal_params_.k_neighbours);
  try
  {
    planner_ = makePlanner(private_nh_);
    near_range_ = nearRangeParamsFromYaml(paramAsYaml(private_nh_, "near_range"));
    if (all_objects_)
    {
      table_params_ = tableGraspParamsFromYaml(private_nh_.hasParam("table_grasps") ? paramAsYaml(private_nh_, "table_grasps")
                                                                                      : YAML::Node());
      if (normal_params_.k_neighbours < 3)
        throw std::runtime_error("normal_k_neighbours must be >= 3");
    }
  }
  catch (const std::exception& e)
  {
    // Bad planner parameters: refuse to start (and say so) rather than plan with guesses.
    NODELET_FATAL("Initialization failed: %s", e.what());
    status_.error(std::string("initialization failed: ") + e.what());
    return;
  }

  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  grasps_pub_ = private_nh_.advertise<fast_grasp::GraspArray>("grasps", 5);
  markers_pub_ = private_nh_.advertise<visualization_msgs::MarkerArray>("markers", 2);
  next_view_pub_ = private_nh_.advertise<geometry_msgs::PoseStamped>("next_view", 2, /*latch=*/true);
  // Its own queue and thread (the member's comment says why not the manager's queues).
  ros::NodeHandle scene_nh(getNodeHandle());
  scene_nh.setCallbackQueue(&scene_queue_);
  scene_sub_ = scene_nh.subscribe("segmented_scene", 5, &GraspPlannerNodelet::sceneCallback, this);
  scene_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &scene_queue_);
  scene_spinner_->start();
  if (all_objects_)
    objects_sub_ = nh_.subscribe<ObjectsCloud>("objects_in", 2, &GraspPlannerNodelet::objectsCallback, this);
  else
    cloud_sub_ = nh_.subscribe<InputCloud>("cloud_in", 2, &GraspPlannerNodelet::cloudCallback, this);
  NODELET_DEBUG("%s ready: gripper %s (max opening %.3f m)", planner_->name(), gripper_.name.c_str(),
                gripper_.max_opening_m);
}

void GraspPlannerNodelet::sceneCallback(const fast_grasp::SegmentedScene::ConstPtr& scene)
{
  const CallbackGate::Pass pass = gate_.enter();
  if (!pass)
    return;
  if (!scene->ok)
    return;
  Eigen::Vector4f plane(scene->table_plane[0], scene->table_plane[1], scene->table_plane[2], scene->table_plane[3]);
  if (!plane.allFinite() || plane.head<3>().norm() < 0.5f)
    return;
  {
    std::lock_guard<std::mutex> lock(scene_mutex_);
    table_planes_[scene->header.stamp.toNSec() / 1000] = plane;
    while (table_planes_.size() > kKeptPlanes)
      table_planes_.erase(table_planes_.begin());
  }
  plane_arrived_.notify_all();
}

bool GraspPlannerNodelet::tablePlaneFor(std::uint64_t stamp_us, Eigen::Vector4f& plane)
{
  std::unique_lock<std::mutex> lock(scene_mutex_);
  if (table_planes_.empty() && scene_sub_.getNumPublishers() > 0 && table_plane_wait_s_ > 0.0)
    plane_arrived_.wait_for(lock, std::chrono::duration<double>(table_plane_wait_s_),
                            [this] { return !table_planes_.empty(); });
  if (table_planes_.empty())
    return false;
  const auto own = table_planes_.find(stamp_us);
  plane = own != table_planes_.end() ? own->second : table_planes_.rbegin()->second;
  return true;
}

std::string GraspPlannerNodelet::fillTablePlane(std::uint64_t stamp_us, ObjectView& view)
{
  view.has_table_plane = tablePlaneFor(stamp_us, view.table_plane);
  if (view.has_table_plane || !require_table_plane_)
    return "";
  std::ostringstream why;
  why << "NoTablePlane: no table plane on ~segmented_scene (" << scene_sub_.getNumPublishers()
      << " publishers) within table_plane_wait_s " << table_plane_wait_s_
      << " s; without it grasps may go through the table (require_table_plane: false plans anyway)";
  return why.str();
}

std::string GraspPlannerNodelet::lookUpSensorOrigins(const pcl::PCLHeader& header, const Eigen::Vector4f& sensor_origin,
                                                     std::vector<Eigen::Vector3f>& origins)
{
  origins.clear();
  const ros::Time stamp = pcl_conversions::fromPCL(header).stamp;
  for (const auto& frame : sensor_frames_)
  {
    try
    {
      const geometry_msgs::TransformStamped t =
          lookupTransformWallTimeout(*tf_buffer_, header.frame_id, frame, stamp, tf_timeout_s_);
      origins.emplace_back(t.transform.translation.x, t.transform.translation.y, t.transform.translation.z);
    }
    catch (const tf2::TransformException& e)
    {
      return "no transform from sensor frame '" + frame + "' to '" + header.frame_id + "': " + e.what();
    }
  }
  if (origins.empty())
  {
    const Eigen::Vector3f origin = sensor_origin.head<3>();
    // A zero origin means nobody upstream set it (pcl_ros serialisation drops it across
    // processes): better to refuse than to orient the object frame from the base.
    if (!origin.allFinite() || origin.isZero())
      return "cloud has no sensor origin and ~sensor_frames is empty";
    origins.push_back(origin);
  }
  return "";
}

bool GraspPlannerNodelet::initialised()
{
  if (!planner_)
    status_.error("not initialised (see the log)");
  return static_cast<bool>(planner_);
}

void GraspPlannerNodelet::publishFailure(const std_msgs::Header& header, const std::string& why)
{
  fast_grasp::GraspArray msg;
  msg.header = header;
  msg.status = why;
  grasps_pub_.publish(msg);
  status_.error(why);
}

void GraspPlannerNodelet::cloudCallback(const boost::shared_ptr<const InputCloud>& cloud)
{
  const CallbackGate::Pass pass = gate_.enter();
  if (!pass)
    return;
  if (!initialised())
    return;
  std_msgs::Header header;
  if (cloud)
    header = pcl_conversions::fromPCL(cloud->header);
  auto publishFailure = [&](const std::string& why) { this->publishFailure(header, why); };
  try
  {
    const CloudNormal::ConstPtr input = toStd(cloud);  // zero-copy
    const CloudCheck check = checkCloud<PointNormal>(input, static_cast<std::size_t>(max_input_points_));
    if (!check.ok)
      return publishFailure("EmptyInput: " + check.reason);
    if (cloud->header.frame_id.empty())
      return publishFailure("DegenerateInput: cloud has an empty frame_id");

    ObjectView view;
    view.cloud = input;
    const std::string origin_problem = lookUpSensorOrigins(cloud->header, cloud->sensor_origin_, view.sensor_origins);
    if (!origin_problem.empty())
      return publishFailure("MissingTransform: " + origin_problem);
    const std::string plane_problem = fillTablePlane(cloud->header.stamp, view);  // PCL stamps are µs
    if (!plane_problem.empty())
      return publishFailure(plane_problem);
    // Needs the camera pose the cloud carries (zero-copy from CloudPreprocess).
    const std::size_t at_near_limit = addNearRangeBlindSpace(view, near_range_);
    const std::string cut_note = at_near_limit == 0 ? std::string()
                                                    : "; the object reaches the camera's near limit (" +
                                                          std::to_string(at_near_limit) +
                                                          " points): hands kept out of what it hides beyond";

    const GraspResult result = planner_->plan(view, gripper_);
    grasps_pub_.publish(toMsg(result, header));
    publishMarkers(result, header);
    publishNextView(result.next_view, header);
    std::ostringstream summary;
    if (result.ok())
    {
      const GraspCandidate& best = result.grasps.front();
      summary << result.grasps.size() << " grasps from " << check.finite_points << " points in "
              << result.compute_time_s * 1e3 << " ms; best width " << best.width_m << " m, score " << best.score
              << cut_note;
      status_.ok(summary.str());
    }
    else
    {
      status_.warn(statusText(result) + cut_note);
    }
  }
  catch (const std::exception& e)
  {
    publishFailure(std::string("InternalError: ") + e.what());
  }
}

void GraspPlannerNodelet::objectsCallback(const boost::shared_ptr<const ObjectsCloud>& objects)
{
  const CallbackGate::Pass pass = gate_.enter();
  if (!pass)
    return;
  if (!initialised())
    return;
  std_msgs::Header header;
  if (objects)
    header = pcl_conversions::fromPCL(objects->header);
  auto publishFailure = [&](const std::string& why) { this->publishFailure(header, why); };
  try
  {
    const CloudCheck check = checkCloud<pcl::PointXYZL>(toStd(objects), static_cast<std::size_t>(max_input_points_));
    if (!check.ok)
      return publishFailure("EmptyInput: " + check.reason);
    if (objects->header.frame_id.empty())
      return publishFailure("DegenerateInput: cloud has an empty frame_id");
    ObjectView shared;  // what every object's view has in common
    const std::string origin_problem = lookUpSensorOrigins(objects->header, objects->sensor_origin_, shared.sensor_origins);
    if (!origin_problem.empty())
      return publishFailure("MissingTransform: " + origin_problem);
    const std::string plane_problem = fillTablePlane(objects->header.stamp, shared);
    if (!plane_problem.empty())
      return publishFailure(plane_problem);

    // One cloud per label, normals per object (a touching neighbour's points would tilt them).
    std::map<std::uint32_t, CloudXYZ::Ptr> by_label;
    for (const auto& p : objects->points)
    {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        continue;
      CloudXYZ::Ptr& cloud = by_label[p.label];
      if (!cloud)
      {
        cloud = std::make_shared<CloudXYZ>();
        cloud->sensor_origin_ = objects->sensor_origin_;  // the camera pose, for the blind zone
        cloud->sensor_orientation_ = objects->sensor_orientation_;
      }
      cloud->push_back(PointXYZ(p.x, p.y, p.z));
    }
    std::vector<ObjectView> views;
    std::vector<std::uint32_t> labels;
    std::size_t objects_at_near_limit = 0;
    for (const auto& [label, cloud] : by_label)
    {
      const NormalResult normals = estimateNormals(cloud, shared.sensor_origins.front(), normal_params_);
      if (!normals.ok || !normals.cloud || normals.cloud->empty())
        continue;  // too few points for an object: not one to grasp
      ObjectView view = shared;
      view.cloud = normals.cloud;
      objects_at_near_limit += addNearRangeBlindSpace(view, near_range_) > 0 ? 1 : 0;
      views.push_back(view);
      labels.push_back(label);
    }
    if (views.empty())
      return publishFailure("DegenerateInput: no labelled object has enough points for normals");

    const TableGraspResult table = planTableGrasps(views, *planner_, gripper_, table_params_);
    fast_grasp::GraspArray msg;
    msg.header = header;
    msg.compute_time_s = table.compute_time_s;
    for (const std::size_t index : table.order)
      for (const GraspCandidate& g : table.objects[index].result.grasps)
      {
        fast_grasp::Grasp grasp = toMsg(g);
        grasp.object_id = labels[index];
        msg.grasps.push_back(grasp);
      }
    std::ostringstream summary;
    summary << table.order.size() << " of " << views.size() << " objects with a grasp ("
            << toString(table_params_.object_choice) << ")";
    if (objects_at_near_limit > 0)
      summary << "; " << objects_at_near_limit << " reach the camera's near limit: hands kept out of what they hide beyond";
    if (table.ok())
    {
      const ObjectGrasps& first = table.chosen();
      summary << "; first: object " << labels[first.object] << ", " << first.result.grasps.size() << " grasps, best score "
              << first.result.grasps.front().score << "; " << msg.grasps.size() << " grasps in " << table.compute_time_s * 1e3
              << " ms";
      msg.status = "ok";
      grasps_pub_.publish(msg);
      publishMarkers(first.result, header, views[first.object].cloud.get());
      status_.ok(summary.str());
    }
    else
    {
      for (const ObjectGrasps& o : table.objects)
        summary << "; object " << labels[o.object] << ": " << statusText(o.result);
      if (table.next_view)
        summary << "; next view: the camera turned " << std::lround(table_params_.next_view_turn_rad * 180.0 / M_PI)
                << " deg about the table, on ~next_view";
      msg.status = "NoStableGrasp: " + summary.str();
      grasps_pub_.publish(msg);
      publishNextView(table.next_view, header);
      status_.warn(msg.status);
    }
  }
  catch (const std::exception& e)
  {
    publishFailure(std::string("InternalError: ") + e.what());
  }
}

void GraspPlannerNodelet::publishNextView(const std::optional<Eigen::Isometry3d>& next_view,
                                          const std_msgs::Header& header)
{
  if (!next_view)
    return;
  geometry_msgs::PoseStamped pose;
  pose.header = header;
  pose.pose = tf2::toMsg(*next_view);
  next_view_pub_.publish(pose);
}

void GraspPlannerNodelet::publishMarkers(const GraspResult& result, const std_msgs::Header& header,
                                         const CloudNormal* chosen_object)
{
  if (markers_pub_.getNumSubscribers() == 0)
    return;
  visualization_msgs::MarkerArray array;
  visualization_msgs::Marker clear;
  clear.action = visualization_msgs::Marker::DELETEALL;
  array.markers.push_back(clear);

  // rviz flags empty POINTS markers as errors: only draw what this algorithm produced.
  if (!result.hull.empty())
    array.markers.push_back(pointsMarker(result.hull, "hull", colour(0.1f, 0.9f, 0.1f), 0.004));
  if (!result.graspable_zone.empty())
    array.markers.push_back(pointsMarker(result.graspable_zone, "graspable_zone", colour(0.1f, 0.3f, 1.0f), 0.006));
  if (!result.unseen.empty())
    array.markers.push_back(pointsMarker(result.unseen, "unseen_part", colour(0.5f, 0.5f, 0.5f, 0.4f), 0.004));
  // ~all_objects: which of the table's objects is picked first (its grasp is drawn below).
  if (chosen_object && !chosen_object->empty())
    array.markers.push_back(pointsMarker(*chosen_object, "chosen_object", colour(1.0f, 0.85f, 0.0f, 0.9f), 0.008));

  // Candidates as arrows along their approach, red (worst) to green (best).
  const std::size_t shown = std::min<std::size_t>(result.candidates.size(), static_cast<std::size_t>(max_marker_candidates_));
  double lo = 0.0, hi = 1.0;
  if (shown > 0)
  {
    const auto range = std::minmax_element(result.candidates.begin(), result.candidates.begin() + shown,
                                           [](const GraspCandidate& a, const GraspCandidate& b) { return a.score < b.score; });
    lo = range.first->score;
    hi = range.second->score;
  }
  for (std::size_t i = 0; i < shown; ++i)
  {
    const GraspCandidate& g = result.candidates[i];
    visualization_msgs::Marker arrow;
    arrow.ns = "candidates";
    arrow.id = static_cast<int>(i);
    arrow.type = visualization_msgs::Marker::ARROW;
    arrow.pose.orientation.w = 1.0;
    arrow.scale.x = 0.003;
    arrow.scale.y = 0.006;
    arrow.scale.z = 0.01;
    const float t = hi > lo ? static_cast<float>((g.score - lo) / (hi - lo)) : 1.0f;
    arrow.color = colour(1.0f - t, t, 0.1f, 0.8f);
    arrow.points = { tf2::toMsg(Eigen::Vector3d(g.position() - 0.06 * g.approach())), tf2::toMsg(g.position()) };
    array.markers.push_back(arrow);
  }

  // The chosen grasp, drawn as the gripper: two fingers and the palm in the grasp frame.
  if (result.ok())
  {
    const GraspCandidate& best = result.grasps.front();
    const double half_gap = 0.5 * std::min(gripper_.max_opening_m, best.width_m + 0.02);
    const Eigen::Vector3d finger(gripper_.finger_depth_m, gripper_.finger_thickness_m, gripper_.finger_width_m);
    const auto blue = colour(0.2f, 0.4f, 1.0f, 0.7f);
    const double y = half_gap + 0.5 * gripper_.finger_thickness_m;
    array.markers.push_back(boxInGraspFrame(best, Eigen::Vector3d(0, y, 0), finger, "gripper", 0, blue));
    array.markers.push_back(boxInGraspFrame(best, Eigen::Vector3d(0, -y, 0), finger, "gripper", 1, blue));
    const double palm_x = -0.5 * gripper_.finger_depth_m - 0.5 * gripper_.palm_thickness_m;
    array.markers.push_back(boxInGraspFrame(
        best, Eigen::Vector3d(palm_x, 0, 0),
        Eigen::Vector3d(gripper_.palm_thickness_m, 2 * y + gripper_.finger_thickness_m, gripper_.finger_width_m * 2),
        "gripper", 2, blue));
  }
  for (auto& m : array.markers)
    m.header = header;
  markers_pub_.publish(array);
}

}  // namespace fast_grasp
