// Shared ROS wrapper for every grasp algorithm: the subclasses only build their planner
// from parameters. Everything else — input checks, ObjectView assembly, messages,
// markers, status — lives here once.
#pragma once

#include "fast_grasp/GraspArray.h"
#include "fast_grasp/SegmentedScene.h"
#include "fast_grasp/core/grasp_types.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/planner_input.h"
#include "fast_grasp/grasping/table_grasps.h"
#include "fast_grasp/perception/normal_estimation.h"
#include "fast_grasp/nodelets/callback_gate.h"
#include "fast_grasp/nodelets/nodelet_status.h"

#include <nodelet/nodelet.h>
#include <pcl_ros/point_cloud.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace fast_grasp
{
class GraspPlannerNodelet : public nodelet::Nodelet
{
public:
  /// Shuts the inputs down first, waiting for a callback that is running: the members it uses
  /// (planner_, table_planes_, scene_mutex_) are declared after the subscribers and so would be
  /// destroyed before them while a manager worker thread still plans (docs/tests.md, ThreadSanitizer).
  ~GraspPlannerNodelet() override;

  using InputCloud = pcl::PointCloud<pcl::PointNormal>;
  /// ~all_objects input: every object of the frame, labelled (TableSegmentation's ~objects).
  using ObjectsCloud = pcl::PointCloud<pcl::PointXYZL>;

protected:
  /// Builds the algorithm from the private parameters (called once, in onInit).
  virtual std::unique_ptr<GraspPlanner> makePlanner(ros::NodeHandle& private_nh) = 0;
  ros::NodeHandle& privateHandle() { return private_nh_; }
  /// Every section of config/grasp_planners.yaml under the private namespace (~cshape/*,
  /// ~fused/*, ~hold_check/*, ~max_object_extent_m, ...), read as loadGraspPlannerConfig reads
  /// the file (a missing section: its defaults), for makeGraspPlanner; with ~all_objects the
  /// table's (tablePlannerConfig with ~table_grasps). Throws std::runtime_error naming a bad key
  /// or value.
  static GraspPlannerConfig plannerConfig(const ros::NodeHandle& private_nh);

private:
  void onInit() override;
  void cloudCallback(const boost::shared_ptr<const InputCloud>& cloud);
  /// ~all_objects: normals per label, every object planned (table_grasps.h), the grasps of all
  /// objects published in pick order, each with its object_id.
  void objectsCallback(const boost::shared_ptr<const ObjectsCloud>& objects);
  /// This frame's table plane (by stamp), else the latest; when none came yet but a table
  /// segmentation publishes, waits up to ~table_plane_wait_s for the first one (the scene
  /// callback runs on the multi-threaded queue, so it can arrive meanwhile). False: no plane.
  bool tablePlaneFor(std::uint64_t stamp_us, Eigen::Vector4f& plane);
  /// The cloud's table plane into `view`; "" when planning may go on, else why not
  /// (~require_table_plane and no plane: grasps could go through the table).
  std::string fillTablePlane(std::uint64_t stamp_us, ObjectView& view);
  void sceneCallback(const fast_grasp::SegmentedScene::ConstPtr& scene);
  /// Sensor origins in the cloud's frame: tf look-ups of ~sensor_frames, else the
  /// cloud's own sensor_origin_. Empty string on success, else why not.
  std::string lookUpSensorOrigins(const pcl::PCLHeader& header, const Eigen::Vector4f& sensor_origin,
                                  std::vector<Eigen::Vector3f>& origins);
  /// Both callbacks' opening: false (and the status says why) until onInit succeeded.
  bool initialised();
  /// A GraspArray with no grasps and status `why` on ~grasps, and `why` on the status topic.
  void publishFailure(const std_msgs::Header& header, const std::string& why);
  /// Hull, graspable zone, unseen part, candidates and the best grasp as the gripper; with
  /// `chosen_object` (~all_objects) that object's points too, in yellow.
  void publishMarkers(const GraspResult& result, const std_msgs::Header& header,
                      const CloudNormal* chosen_object = nullptr);
  /// ~next_view whenever the planner suggests one (principal axis Ch3.2.3, fused) or, with
  /// ~all_objects, no object on the table has a grasp (table_grasps.h tableNextView).
  void publishNextView(const std::optional<Eigen::Isometry3d>& next_view, const std_msgs::Header& header);

  CallbackGate gate_;  // first: destroyed last (callback_gate.h)
  // The scene's own queue and thread (not the manager's multi-threaded queue): a cloud callback
  // waiting for the first plane (tablePlaneFor) must not hold up the scene that carries it, and
  // a nodelet unloaded during a cloud callback is destroyed by the worker running it, after the
  // manager may have freed its other queue: unsubscribing from that one crashed
  // (Subscription::removeCallback, test_nodelet_unload, session 33). This queue lives as long as
  // the nodelet; declared before scene_sub_ and the spinner, it is destroyed after them.
  ros::CallbackQueue scene_queue_;
  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  ros::Subscriber cloud_sub_;
  ros::Subscriber objects_sub_;
  ros::Subscriber scene_sub_;
  std::unique_ptr<ros::AsyncSpinner> scene_spinner_;  // one thread on scene_queue_
  ros::Publisher grasps_pub_;
  ros::Publisher markers_pub_;
  ros::Publisher next_view_pub_;
  NodeletStatus status_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  std::unique_ptr<GraspPlanner> planner_;
  GripperModel gripper_;
  bool all_objects_ = false;
  TableGraspParams table_params_;
  NearRangeParams near_range_;  // the camera's blind zone, added to every view's obstacles
  NormalParams normal_params_;
  std::vector<std::string> sensor_frames_;
  double tf_timeout_s_ = 0.5;
  int max_input_points_ = 200000;
  int max_marker_candidates_ = 100;
  double table_plane_wait_s_ = 0.5;
  bool require_table_plane_ = true;

  std::mutex scene_mutex_;
  std::condition_variable plane_arrived_;  // a first table plane came (with scene_mutex_)
  /// Table planes of the last few frames by stamp (µs, as PCL headers keep them): a cloud is
  /// planned with its own frame's plane, never with none because that frame's plane was still
  /// in flight; the latest plane stands in only when its own never came (separate processes).
  /// The scenes come on the nodelet's multi-threaded queue: at start-up the planner's
  /// connection to ~cloud_in can be made before the one to ~segmented_scene (or, across
  /// processes, the cloud overtake its scene), and the first cloud was planned with no table:
  /// the hammer bag got a grasp through the table (CI, sessions 5 and 18).
  std::map<std::uint64_t, Eigen::Vector4f> table_planes_;
  static constexpr std::size_t kKeptPlanes = 8;
};

}  // namespace fast_grasp
