// fast_grasp/CloudFusion: thesis Ch3.5.1, the "big" partial point cloud. Synchronises the hand
// and head camera clouds (both already in the base frame) and publishes their concatenation,
// zero-copy. The planner gets the two sensor origins from tf (~sensor_frames), so the fused
// cloud keeps the hand cloud's sensor_origin_ only.
#include "fast_grasp/nodelets/cloud_nodelet.h"

#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <pcl/point_types.h>
#include <pluginlib/class_list_macros.hpp>

#include <algorithm>
#include <memory>
#include <string>

namespace fast_grasp
{
namespace
{
/// Why two clouds cannot be fused, or empty when they can.
template <typename PointT>
std::string fusionProblem(const pcl::PointCloud<PointT>* hand, const pcl::PointCloud<PointT>* head,
                          std::size_t max_output_points)
{
  if (!hand || !head)
    return "null input cloud";
  if (hand->header.frame_id.empty() || head->header.frame_id.empty())
    return "input cloud with an empty frame_id";
  if (hand->header.frame_id != head->header.frame_id)
    return "frame mismatch: hand cloud in '" + hand->header.frame_id + "', head cloud in '" +
           head->header.frame_id + "' (both must already be in the base frame)";
  if (hand->points.empty() && head->points.empty())
    return "both input clouds are empty";
  if (hand->points.size() + head->points.size() > max_output_points)
    return "fused cloud would hold " + std::to_string(hand->points.size() + head->points.size()) +
           " points, more than ~max_output_points " + std::to_string(max_output_points);
  return {};
}

struct FusionSettings
{
  int queue_size = 5;
  bool exact_sync = false;
  double max_interval_s = 0.0;  // 0: no bound on the stamp difference
  std::size_t max_output_points = 2000000;
};

/// Type-erased fusion pipeline so ~point_type can pick the PCL point type at start-up.
class FusionPipeline
{
public:
  virtual ~FusionPipeline() = default;
  virtual void subscribe(ros::NodeHandle& private_nh) = 0;
  virtual void unsubscribe() = 0;
};

template <typename PointT>
class TypedFusionPipeline : public FusionPipeline
{
public:
  using Cloud = pcl::PointCloud<PointT>;
  using CloudConstPtr = boost::shared_ptr<const Cloud>;

  TypedFusionPipeline(const FusionSettings& settings, ros::Publisher& output_pub, NodeletStatus& status,
                      CallbackGate& gate, const std::string& name)
    : settings_(settings), output_pub_(output_pub), status_(status), gate_(gate), name_(name)
  {
  }

  void subscribe(ros::NodeHandle& private_nh) override
  {
    hand_sub_.subscribe(private_nh, "hand", static_cast<std::uint32_t>(settings_.queue_size));
    head_sub_.subscribe(private_nh, "head", static_cast<std::uint32_t>(settings_.queue_size));
    if (settings_.exact_sync)
    {
      exact_ = std::make_unique<ExactSync>(ExactPolicy(settings_.queue_size), hand_sub_, head_sub_);
      exact_->registerCallback(&TypedFusionPipeline::callback, this);
    }
    else
    {
      ApproximatePolicy policy(settings_.queue_size);
      if (settings_.max_interval_s > 0.0)
        policy.setMaxIntervalDuration(ros::Duration(settings_.max_interval_s));
      // As const: a non-const policy would pick Synchronizer's three-input constructor.
      approximate_ = std::make_unique<ApproximateSync>(static_cast<const ApproximatePolicy&>(policy), hand_sub_, head_sub_);
      approximate_->registerCallback(&TypedFusionPipeline::callback, this);
    }
  }

  void unsubscribe() override
  {
    hand_sub_.unsubscribe();
    head_sub_.unsubscribe();
    approximate_.reset();
    exact_.reset();
  }

  /// For the NODELET_* logging macros, which name messages with getName().
  const std::string& getName() const { return name_; }

private:
  using ApproximatePolicy = message_filters::sync_policies::ApproximateTime<Cloud, Cloud>;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Cloud, Cloud>;
  using ApproximateSync = message_filters::Synchronizer<ApproximatePolicy>;
  using ExactSync = message_filters::Synchronizer<ExactPolicy>;

  void callback(const CloudConstPtr& hand, const CloudConstPtr& head)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    reportExceptions(name_, status_, [&] { fuse(hand, head); });
  }

  void fuse(const CloudConstPtr& hand, const CloudConstPtr& head)
  {
    const std::string problem = fusionProblem<PointT>(hand.get(), head.get(), settings_.max_output_points);
    if (!problem.empty())
    {
      NODELET_ERROR_THROTTLE(5.0, "%s", problem.c_str());
      status_.error(problem);
      return;
    }
    // A new cloud per message: subscribers in the same manager share it, so it is never
    // modified after publishing.
    boost::shared_ptr<Cloud> fused(new Cloud);
    fused->header = hand->header;
    fused->header.stamp = std::max(hand->header.stamp, head->header.stamp);
    fused->sensor_origin_ = hand->sensor_origin_;
    fused->sensor_orientation_ = hand->sensor_orientation_;
    fused->points.reserve(hand->points.size() + head->points.size());
    fused->points.insert(fused->points.end(), hand->points.begin(), hand->points.end());
    fused->points.insert(fused->points.end(), head->points.begin(), head->points.end());
    fused->width = static_cast<std::uint32_t>(fused->points.size());
    fused->height = 1;  // two organised grids do not make one: the result is unorganised
    fused->is_dense = hand->is_dense && head->is_dense;
    output_pub_.publish(CloudConstPtr(fused));

    const std::string counts =
        std::to_string(hand->points.size()) + " hand + " + std::to_string(head->points.size()) + " head points";
    if (hand->points.empty() || head->points.empty())
      status_.warn("one input cloud is empty; fused " + counts);
    else
      status_.ok("fused " + counts);
  }

  FusionSettings settings_;
  ros::Publisher& output_pub_;
  NodeletStatus& status_;
  CallbackGate& gate_;
  std::string name_;
  message_filters::Subscriber<Cloud> hand_sub_;
  message_filters::Subscriber<Cloud> head_sub_;
  std::unique_ptr<ApproximateSync> approximate_;
  std::unique_ptr<ExactSync> exact_;
};
}  // namespace

/// Two synchronised inputs, ~hand and ~head, so not a CloudNodelet: only the start-up is shared.
class CloudFusionNodelet : public CloudNodeletBase
{
public:
  ~CloudFusionNodelet() override { stopInputs(); }  // before the members below go (CloudNodeletBase::stopInputs)

private:
  std::string readParameters(ros::NodeHandle& pnh) override;
  void advertiseOutputs(ros::NodeHandle& pnh) override;
  void subscribe() override;
  void unsubscribe() override;

  template <typename PointT>
  void makePipeline(const FusionSettings& settings)
  {
    // The inputs start only once onInit has advertised every output (CloudNodeletBase::
    // startInputsIfListenedTo); the pipeline publishes through output_pub_, held by reference.
    pipeline_ = std::make_unique<TypedFusionPipeline<PointT>>(settings, output_pub_, status_, gate_, getName());
    output_pub_ = advertise<pcl::PointCloud<PointT>>(*pnh_, "output", 1);
  }

  std::string point_type_ = "xyz";
  FusionSettings settings_;
  ros::Publisher output_pub_;
  std::unique_ptr<FusionPipeline> pipeline_;
};

std::string CloudFusionNodelet::readParameters(ros::NodeHandle& pnh)
{
  int max_output_points = static_cast<int>(settings_.max_output_points);
  pnh.param("point_type", point_type_, point_type_);
  pnh.param("queue_size", settings_.queue_size, settings_.queue_size);
  pnh.param("exact_sync", settings_.exact_sync, settings_.exact_sync);
  pnh.param("max_interval_s", settings_.max_interval_s, settings_.max_interval_s);
  pnh.param("max_output_points", max_output_points, max_output_points);

  if (settings_.queue_size < 1)
    return "queue_size must be >= 1";
  if (!(settings_.max_interval_s >= 0.0))
    return "max_interval_s must be >= 0 (0: unbounded)";
  if (max_output_points < 1)
    return "max_output_points must be >= 1";
  if (point_type_ != "xyz" && point_type_ != "xyzrgb" && point_type_ != "xyznormal")
    return "point_type must be xyz, xyzrgb or xyznormal (got '" + point_type_ + "')";
  settings_.max_output_points = static_cast<std::size_t>(max_output_points);
  NODELET_DEBUG("point_type %s, queue_size %d, exact_sync %d, max_interval_s %.3f", point_type_.c_str(),
                settings_.queue_size, settings_.exact_sync ? 1 : 0, settings_.max_interval_s);
  return {};
}

void CloudFusionNodelet::advertiseOutputs(ros::NodeHandle& /*pnh*/)
{
  if (point_type_ == "xyz")
    makePipeline<pcl::PointXYZ>(settings_);
  else if (point_type_ == "xyzrgb")
    makePipeline<pcl::PointXYZRGB>(settings_);
  else
    makePipeline<pcl::PointNormal>(settings_);
  status_.ok("waiting for synchronised hand and head clouds");
}

void CloudFusionNodelet::subscribe()
{
  if (pipeline_ && mayStartInputs())
    pipeline_->subscribe(*pnh_);
}

void CloudFusionNodelet::unsubscribe()
{
  if (pipeline_)
    pipeline_->unsubscribe();
}

}  // namespace fast_grasp

PLUGINLIB_EXPORT_CLASS(fast_grasp::CloudFusionNodelet, nodelet::Nodelet)
