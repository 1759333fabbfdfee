// fast_grasp/ArmPlanner: OctoMap scene + unseen space, FCL collision, KDL IK and OMPL,
// tried best grasp first; publishes ~trajectory for external controllers and serves ~plan.
// With ~all_objects it takes TableSegmentation's labelled objects and, for each grasp's
// object_id, plans against a scene of everything but that object (table_grasp_motion.h).
// All planning logic lives in the ROS-free core (grasp_execution.h); this is the wrapper.
#include "fast_grasp/PlanGrasp.h"
#include "fast_grasp/SegmentedScene.h"
#include "fast_grasp/arm/grasp_execution.h"
#include "fast_grasp/arm/table_grasp_motion.h"
#include "fast_grasp/nodelets/callback_gate.h"
#include "fast_grasp/nodelets/grasp_conversions.h"
#include "fast_grasp/nodelets/nodelet_status.h"
#include "fast_grasp/nodelets/pcl_ros_mapping.h"
#include "fast_grasp/nodelets/tf_wait.h"
#include "fast_grasp/grasping/unseen_part.h"

#include <nodelet/nodelet.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pcl_ros/point_cloud.h>
#include <pluginlib/class_list_macros.hpp>
#include <geometry_msgs/PoseStamped.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <trajectory_msgs/JointTrajectory.h>
#include <visualization_msgs/MarkerArray.h>

#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

namespace fast_grasp
{
class ArmPlannerNodelet : public nodelet::Nodelet
{
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  using ObjectsCloud = pcl::PointCloud<pcl::PointXYZL>;

  /// Inputs first: the members are destroyed in reverse order of declaration, the subscribers
  /// and the ~plan service last, so a callback still running on a manager worker thread when
  /// the nodelet is unloaded (loader killed, manager shutting down) used inputs_, the mutexes
  /// and the collision model after they were gone (ThreadSanitizer, docs/tests.md). Shutting a
  /// subscriber down waits for its running callback.
  ~ArmPlannerNodelet() override
  {
    gate_.close();  // after ros::shutdown() the subscribers' shutdown no longer waits (callback_gate.h)
    for (ros::Subscriber* sub : { &joint_sub_, &scene_info_sub_, &scene_sub_, &object_sub_, &objects_sub_, &grasps_sub_ })
      sub->shutdown();
    plan_service_.shutdown();
  }

  void onInit() override
  {
    primePclRosFieldMappings();
    nh_ = getNodeHandle();
    private_nh_ = getPrivateNodeHandle();
    status_.init(nh_, private_nh_, getName());
    try
    {
      std::string arm_config, planners_config, urdf_file, robot_description, robot;
      private_nh_.param<std::string>("arm_config", arm_config, "");
      private_nh_.param<std::string>("planners_config", planners_config, "");
      // config/robots/<robot>.yaml; empty: the one arm.yaml names.
      private_nh_.param<std::string>("robot", robot, "");
      params_ = loadGraspExecutionParams(arm_config, planners_config, robot);
      private_nh_.param<std::string>("urdf_file", urdf_file, params_.urdf_path);
      private_nh_.param<std::string>("base_link", params_.base_link, params_.base_link);
      private_nh_.param<std::string>("tip_link", params_.tip_link, params_.tip_link);
      private_nh_.param<std::string>("planner", params_.motion.planner, params_.motion.planner);
      // Cameras that saw the object (the grasp planner's ~sensor_frames): with several, space
      // one of them saw is not unseen. Empty: the segmentation's single sensor origin.
      private_nh_.param("sensor_frames", sensor_frames_, sensor_frames_);
      // Grasps of every object on the table (a grasp planner's ~all_objects): each object's
      // grasps are planned with that object, not the segmentation's target, out of the scene.
      private_nh_.param("all_objects", all_objects_, all_objects_);
      private_nh_.param("tf_timeout_s", tf_timeout_s_, tf_timeout_s_);
      // Prefer the robot model the rest of the system uses (robot_state_publisher's).
      ArmKinematics kinematics = nh_.getParam("robot_description", robot_description) && !robot_description.empty() ?
                                     ArmKinematics::fromUrdfString(robot_description, params_.base_link, params_.tip_link) :
                                     ArmKinematics::fromUrdfFile(urdf_file, params_.base_link, params_.tip_link);
      const std::string limits_problem = applyLimits(params_, kinematics);
      if (!limits_problem.empty())
        throw std::runtime_error(limits_problem);
      collision_ = params_.robot.name.empty() ?
                       std::make_unique<RobotCollision>(kinematics, params_.link_padding_m) :
                       std::make_unique<RobotCollision>(kinematics, params_.link_padding_m,
                                                        params_.robot.object_contact_links,
                                                        params_.robot.contact_link_padding_m);
      // Shadow points as dense along the camera rays as the OctoMap's voxels, so the hidden
      // space becomes a closed wall of voxels rather than a dotted one.
      unseen_params_.step_m = params_.octomap_resolution_m;
      // Home pose by joint name (~home_pose, else the robot config's home_pose file, which
      // joint_state_publisher also loads): the start state until /joint_states arrives.
      std::map<std::string, double> home;
      private_nh_.getParam("home_pose", home);
      if (home.empty())
        home = params_.robot.home_pose_rad;
      home_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(kinematics.dof()));
      for (std::size_t j = 0; j < kinematics.dof(); ++j)
      {
        const auto it = home.find(kinematics.jointNames()[j]);
        if (it != home.end())
          home_[static_cast<Eigen::Index>(j)] = it->second;
        else if (!home.empty())
          throw std::runtime_error("home_pose lacks joint '" + kinematics.jointNames()[j] + "'");
      }
    }
    catch (const std::exception& e)
    {
      NODELET_FATAL("Initialization failed: %s", e.what());
      status_.error(std::string("initialization failed: ") + e.what());
      return;
    }
    if (!sensor_frames_.empty())
    {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh_);
    }
    trajectory_pub_ = private_nh_.advertise<trajectory_msgs::JointTrajectory>("trajectory", 2);
    // Where the trajectory's grasp point puts the grasp frame: the grasp as given or the
    // flipped / tilted variant the status names. Published just before each trajectory.
    executed_grasp_pub_ = private_nh_.advertise<geometry_msgs::PoseStamped>("executed_grasp", 2);
    markers_pub_ = private_nh_.advertise<visualization_msgs::MarkerArray>("markers", 2);
    plan_service_ = private_nh_.advertiseService("plan", &ArmPlannerNodelet::planService, this);
    joint_sub_ = nh_.subscribe("joint_states", 5, &ArmPlannerNodelet::jointCallback, this);
    scene_info_sub_ = nh_.subscribe("segmented_scene", 5, &ArmPlannerNodelet::sceneInfoCallback, this);
    scene_sub_ = nh_.subscribe<Cloud>("scene", 2, &ArmPlannerNodelet::sceneCallback, this);
    object_sub_ = nh_.subscribe<Cloud>("object", 2, &ArmPlannerNodelet::objectCallback, this);
    grasps_sub_ = nh_.subscribe("grasps", 2, &ArmPlannerNodelet::graspsCallback, this);
    if (all_objects_)
      objects_sub_ = nh_.subscribe<ObjectsCloud>("objects", 2, &ArmPlannerNodelet::objectsCallback, this);
  }

  // Latest inputs, keyed by stamp so the grasps are planned against the scene they came from.
  struct SceneInputs
  {
    boost::shared_ptr<const Cloud> scene;
    boost::shared_ptr<const Cloud> object;
    boost::shared_ptr<const ObjectsCloud> objects;  // ~all_objects only
    fast_grasp::SegmentedScene::ConstPtr info;
  };

  SceneInputs& inputsAt(const ros::Time& stamp)
  {
    // Keep the last few frames only; a new stamp older than all of them is dropped at once.
    inputs_[stamp];
    while (inputs_.size() > kKeptFrames)
      inputs_.erase(inputs_.begin());
    return inputs_[stamp];
  }
  static constexpr std::size_t kKeptFrames = 8;

  void jointCallback(const sensor_msgs::JointState::ConstPtr& msg)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    latest_joints_ = msg;
  }
  void sceneInfoCallback(const fast_grasp::SegmentedScene::ConstPtr& msg)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    inputsAt(msg->header.stamp).info = msg;
  }
  void sceneCallback(const boost::shared_ptr<const Cloud>& msg)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    inputsAt(pcl_conversions::fromPCL(msg->header).stamp).scene = msg;
  }
  void objectCallback(const boost::shared_ptr<const Cloud>& msg)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    inputsAt(pcl_conversions::fromPCL(msg->header).stamp).object = msg;
  }
  void objectsCallback(const boost::shared_ptr<const ObjectsCloud>& msg)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    inputsAt(pcl_conversions::fromPCL(msg->header).stamp).objects = msg;
  }

  /// Start state from a JointState message in chain order; empty message = latest
  /// /joint_states, else the home pose. Empty string on success, else why not.
  std::string startState(const sensor_msgs::JointState& given, Eigen::VectorXd& start)
  {
    const auto& names = collision_->kinematics().jointNames();
    sensor_msgs::JointState::ConstPtr latest;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      latest = latest_joints_;
    }
    const sensor_msgs::JointState* source = !given.name.empty() ? &given : latest.get();
    start = home_;
    if (!source)
      return "";
    for (std::size_t j = 0; j < names.size(); ++j)
    {
      const auto it = std::find(source->name.begin(), source->name.end(), names[j]);
      if (it == source->name.end() || static_cast<std::size_t>(it - source->name.begin()) >= source->position.size())
        return "start state lacks joint '" + names[j] + "'";
      start[static_cast<Eigen::Index>(j)] = source->position[static_cast<std::size_t>(it - source->name.begin())];
    }
    if (!start.allFinite())
      return "start state has non-finite joint positions";
    return "";
  }

  /// Plans against the scene stored for `stamp` (or the newest). object_id is -1 unless the
  /// grasps were planned object by object (~all_objects).
  TableGraspPlanResult plan(const fast_grasp::GraspArray& grasps, const sensor_msgs::JointState& start_msg)
  {
    TableGraspPlanResult table_result;
    GraspPlanResult& result = table_result.plan;
    Eigen::VectorXd start;
    const std::string start_problem = startState(start_msg, start);
    if (!start_problem.empty())
    {
      result.status = start_problem;
      return table_result;
    }
    SceneInputs inputs;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = inputs_.find(grasps.header.stamp);
      if (it != inputs_.end())
        inputs = it->second;
      else if (!inputs_.empty())
        inputs = inputs_.rbegin()->second;  // a ~plan request without a matching frame
    }
    std::vector<GraspCandidate> candidates;
    for (const auto& g : grasps.grasps)
      candidates.push_back(fromMsg(g));

    std::lock_guard<std::mutex> planning(planning_mutex_);  // one RobotCollision scene at a time
    if (all_objects_)
    {
      if (!inputs.objects || inputs.objects->empty())
      {
        result.status = "no labelled objects (~objects) for this frame yet";
        return table_result;
      }
      TableSceneClouds table;
      table.scene = inputs.scene.get();
      table.objects = inputs.objects.get();
      if (inputs.info && inputs.info->table_points > 0)
        table.table_plane = Eigen::Vector4f(inputs.info->table_plane[0], inputs.info->table_plane[1],
                                            inputs.info->table_plane[2], inputs.info->table_plane[3]);
      if (inputs.info && inputs.info->ok)
        table.sensor_origins = sensorOrigins(*inputs.info, inputs.objects->header.frame_id);
      table.unseen = unseen_params_;
      std::vector<std::uint32_t> object_ids;
      for (const auto& g : grasps.grasps)
        object_ids.push_back(g.object_id);
      return planTableGraspMotion(*collision_, start, candidates, object_ids, table, params_);
    }
    GraspSceneClouds clouds;
    clouds.scene = inputs.scene && !inputs.scene->empty() ? inputs.scene.get() : nullptr;
    if (inputs.info && inputs.info->table_points > 0)
      clouds.table_plane = Eigen::Vector4f(inputs.info->table_plane[0], inputs.info->table_plane[1],
                                           inputs.info->table_plane[2], inputs.info->table_plane[3]);
    UnseenPart unseen;
    if (inputs.object && !inputs.object->empty())
    {
      clouds.object = inputs.object.get();
      // The space hidden behind the object is an obstacle too: the arm must never sweep
      // through what the camera could not see (thesis Ch6, Eq. 6.8).
      if (inputs.info && inputs.info->ok)
      {
        const std::vector<Eigen::Vector3f> origins = sensorOrigins(*inputs.info, inputs.object->header.frame_id);
        unseen = buildUnseenPart(*inputs.object, origins, unseen_params_, clouds.table_plane);
        if (unseen.ok())
          clouds.unseen = &unseen.points;
      }
    }
    const std::string scene_note = buildGraspScene(*collision_, start, clouds, params_);
    result = planGraspMotion(*collision_, start, candidates, params_);
    result.status += " (" + scene_note + ")";
    return table_result;
  }

  /// Origins of ~sensor_frames in the cloud's frame at the scene's stamp; the segmentation's
  /// sensor origin when the list is empty or a look-up fails (logged).
  std::vector<Eigen::Vector3f> sensorOrigins(const fast_grasp::SegmentedScene& info, const std::string& cloud_frame)
  {
    const auto& o = info.sensor_origin;
    const std::vector<Eigen::Vector3f> fallback{ Eigen::Vector3f(o.x, o.y, o.z) };
    std::vector<Eigen::Vector3f> origins;
    for (const std::string& frame : sensor_frames_)
    {
      try
      {
        const geometry_msgs::TransformStamped t = lookupTransformWallTimeout(
            *tf_buffer_, cloud_frame.empty() ? info.header.frame_id : cloud_frame, frame, info.header.stamp, tf_timeout_s_);
        origins.emplace_back(t.transform.translation.x, t.transform.translation.y, t.transform.translation.z);
      }
      catch (const tf2::TransformException& e)
      {
        NODELET_WARN_THROTTLE(10.0, "unseen part from the segmentation's sensor origin only: %s", e.what());
        return fallback;
      }
    }
    return origins.empty() ? fallback : origins;
  }

  trajectory_msgs::JointTrajectory toTrajectoryMsg(const GraspPlanResult& result, const std_msgs::Header& header) const
  {
    trajectory_msgs::JointTrajectory traj;
    traj.header = header;
    traj.joint_names = result.joint_names;
    for (const auto& p : result.points)
    {
      trajectory_msgs::JointTrajectoryPoint point;
      point.positions.assign(p.positions.data(), p.positions.data() + p.positions.size());
      point.velocities.assign(p.velocities.data(), p.velocities.data() + p.velocities.size());
      point.accelerations.assign(p.accelerations.data(), p.accelerations.data() + p.accelerations.size());
      point.time_from_start = ros::Duration(p.time_from_start_s);
      traj.points.push_back(point);
    }
    return traj;
  }

  void publishExecutedGrasp(const GraspPlanResult& result, const std_msgs::Header& header)
  {
    geometry_msgs::PoseStamped pose;
    pose.header = header;
    const Eigen::Vector3d t = result.executed_pose.translation();
    const Eigen::Quaterniond q(result.executed_pose.linear());
    pose.pose.position.x = t.x();
    pose.pose.position.y = t.y();
    pose.pose.position.z = t.z();
    pose.pose.orientation.x = q.x();
    pose.pose.orientation.y = q.y();
    pose.pose.orientation.z = q.z();
    pose.pose.orientation.w = q.w();
    executed_grasp_pub_.publish(pose);
  }

  std::string summary(const TableGraspPlanResult& table) const
  {
    const GraspPlanResult& result = table.plan;
    std::ostringstream text;
    if (result.success)
      text << (table.object_id >= 0 ? "object " + std::to_string(table.object_id) + ", " : std::string())
           << "grasp " << result.grasp_index << ": " << (result.variant.empty() ? "" : result.variant + ", ")
           << result.points.size() << " waypoints, "
           << (result.points.empty() ? 0.0 : result.points.back().time_from_start_s) << " s, planner "
           << result.planner << ", " << result.planning_time_s * 1e3 << " ms";
    else
      text << "no plan: " << result.status;
    for (const auto& skipped : result.skipped_reasons)
      text << "; skipped " << skipped;
    return text.str();
  }

  void graspsCallback(const fast_grasp::GraspArray::ConstPtr& grasps)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    if (!collision_)
      return status_.error("not initialised (see the log)");
    if (grasps->grasps.empty())
      return status_.warn("no grasp to plan for: " + grasps->status);
    try
    {
      const TableGraspPlanResult table = plan(*grasps, sensor_msgs::JointState());
      const GraspPlanResult& result = table.plan;
      std_msgs::Header header = grasps->header;
      if (result.success)
      {
        // Status first: a listener that stops at the trajectory has its summary already.
        status_.ok(summary(table));
        publishExecutedGrasp(result, header);
        trajectory_pub_.publish(toTrajectoryMsg(result, header));
      }
      else
      {
        status_.warn(summary(table));
      }
      publishMarkers(result, header);
    }
    catch (const std::exception& e)
    {
      status_.error(std::string("planning failed: ") + e.what());
    }
  }

  bool planService(fast_grasp::PlanGrasp::Request& req, fast_grasp::PlanGrasp::Response& res)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return false;
    // Expected outcomes (no grasp reachable) are a status in the response, not a failed call.
    if (!collision_)
    {
      res.status = "not initialised";
      return true;
    }
    try
    {
      const TableGraspPlanResult table = plan(req.grasps, req.start_state);
      const GraspPlanResult& result = table.plan;
      res.success = result.success;
      res.status = summary(table);
      res.grasp_index = result.grasp_index;
      res.planner = result.planner;
      res.planning_time_s = result.planning_time_s;
      if (result.success)
      {
        res.trajectory = toTrajectoryMsg(result, req.grasps.header);
        publishExecutedGrasp(result, req.grasps.header);
        trajectory_pub_.publish(res.trajectory);
      }
    }
    catch (const std::exception& e)
    {
      res.success = false;
      res.status = std::string("planning failed: ") + e.what();
    }
    return true;
  }

  void publishMarkers(const GraspPlanResult& result, const std_msgs::Header& header)
  {
    if (markers_pub_.getNumSubscribers() == 0)
      return;
    visualization_msgs::MarkerArray array;
    visualization_msgs::Marker voxels;
    voxels.header = header;
    voxels.ns = "octomap";
    voxels.type = visualization_msgs::Marker::CUBE_LIST;
    voxels.pose.orientation.w = 1.0;
    voxels.scale.x = voxels.scale.y = voxels.scale.z = collision_->octomapResolution();
    voxels.color.r = 0.3f;
    voxels.color.g = 0.6f;
    voxels.color.b = 1.0f;
    voxels.color.a = 0.5f;
    for (const auto& c : collision_->occupiedVoxelCentres())
    {
      geometry_msgs::Point p;
      p.x = c.x();
      p.y = c.y();
      p.z = c.z();
      voxels.points.push_back(p);
    }
    array.markers.push_back(voxels);
    visualization_msgs::Marker path;
    path.header = header;
    path.ns = "tool_path";
    path.type = visualization_msgs::Marker::LINE_STRIP;
    path.pose.orientation.w = 1.0;
    path.scale.x = 0.005;
    path.color.g = 1.0f;
    path.color.a = 1.0f;
    for (const auto& q : result.waypoints)
    {
      const Eigen::Vector3d t = collision_->kinematics().fk(q).translation();
      geometry_msgs::Point p;
      p.x = t.x();
      p.y = t.y();
      p.z = t.z();
      path.points.push_back(p);
    }
    if (path.points.size() < 2)
      path.action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(path);
    markers_pub_.publish(array);
  }

  CallbackGate gate_;  // first: destroyed last
  ros::NodeHandle nh_, private_nh_;
  NodeletStatus status_;
  ros::Publisher trajectory_pub_, executed_grasp_pub_, markers_pub_;
  ros::ServiceServer plan_service_;
  ros::Subscriber joint_sub_, scene_info_sub_, scene_sub_, object_sub_, objects_sub_, grasps_sub_;
  bool all_objects_ = false;
  GraspExecutionParams params_;
  UnseenPartParams unseen_params_;
  std::vector<std::string> sensor_frames_;
  double tf_timeout_s_ = 0.2;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<RobotCollision> collision_;
  Eigen::VectorXd home_;
  std::mutex mutex_;
  std::mutex planning_mutex_;
  sensor_msgs::JointState::ConstPtr latest_joints_;
  std::map<ros::Time, SceneInputs> inputs_;
};

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::ArmPlannerNodelet, nodelet::Nodelet)
