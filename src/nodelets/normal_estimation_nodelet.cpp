// fast_grasp/NormalEstimation: k-NN normals of the object cloud oriented toward the camera, and
// their k-d-tree down-sampling (thesis Ch6.2 steps 2-3). Thin wrapper around estimateNormals().
#include "fast_grasp/perception/cloud_checks.h"
#include "fast_grasp/nodelets/cloud_nodelet.h"
#include "fast_grasp/nodelets/shared_cloud.h"
#include "fast_grasp/nodelets/tf_wait.h"
#include "fast_grasp/perception/normal_estimation.h"

#include <pcl_conversions/pcl_conversions.h>
#include <pluginlib/class_list_macros.hpp>
#include <visualization_msgs/Marker.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <sstream>
#include <string>

namespace fast_grasp
{
class NormalEstimationNodelet : public CloudNodelet<CloudXYZ>
{
public:
  ~NormalEstimationNodelet() override { stopInputs(); }  // before the members below go (CloudNodeletBase::stopInputs)

private:
  std::string readParameters(ros::NodeHandle& pnh) override;
  void advertiseOutputs(ros::NodeHandle& pnh) override;
  void process(const InputConstPtr& msg) override;

  NormalParams params_;
  double downsample_radius_m_ = 0.01;
  std::string sensor_frame_ = "camera_rgb_optical_frame";
  double tf_timeout_s_ = 0.1;
  int max_input_points_ = 2000000;

  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Publisher output_pub_;
  ros::Publisher downsampled_pub_;
  ros::Publisher normal_markers_pub_;  // rviz only; not a lazy trigger
};

std::string NormalEstimationNodelet::readParameters(ros::NodeHandle& pnh)
{
  pnh.param("k_neighbours", params_.k_neighbours, params_.k_neighbours);
  int threads = static_cast<int>(params_.threads);
  pnh.param("threads", threads, threads);
  pnh.param("min_points", params_.min_points, params_.min_points);
  pnh.param("downsample_radius_m", downsample_radius_m_, downsample_radius_m_);
  pnh.param("sensor_frame", sensor_frame_, sensor_frame_);
  pnh.param("tf_timeout_s", tf_timeout_s_, tf_timeout_s_);
  pnh.param("max_input_points", max_input_points_, max_input_points_);

  std::string bad;
  if (params_.k_neighbours < 3)
    bad = "k_neighbours must be >= 3";
  else if (threads < 1)
    bad = "threads must be >= 1";
  else if (!(downsample_radius_m_ >= 0.0))
    bad = "downsample_radius_m must be >= 0 (0 disables down-sampling)";
  else if (!(tf_timeout_s_ >= 0.0))
    bad = "tf_timeout_s must be >= 0";
  else if (max_input_points_ < 1)
    bad = "max_input_points must be >= 1";
  params_.threads = static_cast<unsigned int>(std::max(threads, 1));
  if (!bad.empty())
    return bad;
  NODELET_DEBUG("k_neighbours %d, downsample_radius_m %.4f, sensor_frame %s", params_.k_neighbours,
                downsample_radius_m_, sensor_frame_.c_str());
  return {};
}

void NormalEstimationNodelet::advertiseOutputs(ros::NodeHandle& pnh)
{
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, *nh_);
  output_pub_ = advertise<CloudNormal>(pnh, "output", kOutputQueueSize);
  downsampled_pub_ = advertise<CloudNormal>(pnh, "downsampled", kOutputQueueSize);
  normal_markers_pub_ = pnh.advertise<visualization_msgs::Marker>("normal_markers", 1);
}

void NormalEstimationNodelet::process(const InputConstPtr& msg)
{
  // Zero-copy view for the core: the std::shared_ptr keeps the boost one alive.
  const CloudXYZ::ConstPtr cloud = toStd(msg);
  const CloudCheck check = checkCloud<PointXYZ>(cloud, static_cast<std::size_t>(max_input_points_));
  if (!check.ok)
  {
    NODELET_ERROR_THROTTLE(5.0, "rejected input: %s", check.reason.c_str());
    status_.error(check.reason);
    return;
  }

  // The viewpoint comes from tf (the camera's optical centre at the cloud's stamp); the
  // cloud's own sensor_origin_ (set by CloudPreprocess) is the fallback.
  Eigen::Vector3f viewpoint = msg->sensor_origin_.head<3>();
  std::string viewpoint_note;
  try
  {
    const ros::Time stamp = pcl_conversions::fromPCL(msg->header.stamp);
    const auto transform =
        lookupTransformWallTimeout(tf_buffer_, msg->header.frame_id, sensor_frame_, stamp, tf_timeout_s_);
    viewpoint = Eigen::Vector3f(transform.transform.translation.x, transform.transform.translation.y,
                                transform.transform.translation.z);
  }
  catch (const tf2::TransformException& e)
  {
    viewpoint_note = "no transform from '" + sensor_frame_ + "' to '" + msg->header.frame_id +
                     "', using the cloud's sensor_origin_ as viewpoint (" + e.what() + ")";
    NODELET_WARN_THROTTLE(5.0, "%s", viewpoint_note.c_str());
  }

  const NormalResult result = estimateNormals(cloud, viewpoint, params_);
  if (!result.ok)
  {
    NODELET_WARN_THROTTLE(5.0, "%s", result.reason.c_str());
    status_.error(result.reason);
    return;
  }
  result.cloud->header = msg->header;
  const CloudNormal::Ptr sparse = downsampleNormals(*result.cloud, downsample_radius_m_);
  sparse->header = msg->header;

  // Zero-copy hand-over to roscpp (boost pointers sharing ownership with the core's).
  const boost::shared_ptr<CloudNormal> dense = toBoost(result.cloud);
  const boost::shared_ptr<CloudNormal> downsampled = toBoost(sparse);
  output_pub_.publish(dense);
  downsampled_pub_.publish(downsampled);
  if (normal_markers_pub_.getNumSubscribers() > 0)
  {
    // The down-sampled normals as 2 cm line segments, for rviz.
    visualization_msgs::Marker lines;
    lines.header = pcl_conversions::fromPCL(sparse->header);
    lines.ns = "normals";
    lines.type = visualization_msgs::Marker::LINE_LIST;
    lines.pose.orientation.w = 1.0;
    lines.scale.x = 0.001;
    lines.color.g = 1.0f;
    lines.color.b = 1.0f;
    lines.color.a = 1.0f;
    for (const auto& p : sparse->points)
    {
      geometry_msgs::Point a, b;
      a.x = p.x;
      a.y = p.y;
      a.z = p.z;
      b.x = p.x + 0.02 * p.normal_x;
      b.y = p.y + 0.02 * p.normal_y;
      b.z = p.z + 0.02 * p.normal_z;
      lines.points.push_back(a);
      lines.points.push_back(b);
    }
    normal_markers_pub_.publish(lines);
  }
  publishSentAddress(dense.get());
  std::ostringstream summary;
  summary << dense->size() << " normals (" << downsampled->size() << " down-sampled at " << downsample_radius_m_
          << " m) from " << msg->size() << " points";
  if (!viewpoint_note.empty())
    status_.warn(summary.str() + "; " + viewpoint_note);
  else
    status_.ok(summary.str());
}

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::NormalEstimationNodelet, nodelet::Nodelet)
