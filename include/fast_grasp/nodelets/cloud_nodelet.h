// Shared ROS wrapper for the perception nodelets (in the spirit of GraspPlannerNodelet and
// pcl_ros's PCLNodelet): the subclasses only read and validate their parameters, advertise
// their outputs and process() one input. Everything else — lazy subscription, the
// initialization-failure report, the exception guard around the callback, ~status and
// /diagnostics, the zero-copy address topics — lives here once.
#pragma once

#include "fast_grasp/nodelets/callback_gate.h"
#include "fast_grasp/nodelets/nodelet_status.h"
#include "fast_grasp/nodelets/pcl_ros_mapping.h"

#include <nodelet_topic_tools/nodelet_lazy.h>
#include <pcl_ros/point_cloud.h>
#include <ros/ros.h>
#include <std_msgs/UInt64.h>

#include <boost/shared_ptr.hpp>

#include <cstdint>
#include <exception>
#include <string>
#include <type_traits>

namespace fast_grasp
{
/// Runs `work()`. Exceptions must not escape into the nodelet manager's callback queue:
/// one is logged (as the nodelet `name`) and reported on `status` instead.
template <typename Work>
void reportExceptions(const std::string& name, NodeletStatus& status, Work&& work)
{
  try
  {
    work();
  }
  catch (const std::exception& e)
  {
    ROS_ERROR_THROTTLE_NAMED(5.0, name, "unexpected exception: %s", e.what());
    status.error(std::string("unexpected exception: ") + e.what());
  }
}

/// Publisher queue of the perception outputs. In the same manager a subscriber gets the pointer
/// whatever the queue; a listener in another process (the planners' own manager, rviz, the soak
/// monitor) is sent the frame over TCP, and with a queue of 1 a listener a frame behind lost it
/// silently (scripts/soak.py counted such losses at 30 Hz on a loaded machine). The subscribers'
/// own queues still decide which frames they process.
constexpr int kOutputQueueSize = 5;

/// Start-up shared by every perception nodelet, whatever its inputs.
class CloudNodeletBase : public nodelet_topic_tools::NodeletLazy
{
protected:
  /// Reads and validates the private parameters (called once, in onInit). Empty when they
  /// are usable, else why not: the nodelet then logs "Initialization failed: <why>", reports
  /// "initialization failed: <why>" on ~status, advertises nothing and so never subscribes.
  virtual std::string readParameters(ros::NodeHandle& private_nh) = 0;
  /// Advertises the outputs (with NodeletLazy::advertise for those that drive the lazy
  /// subscription) and sets up what needs valid parameters, e.g. a tf listener.
  virtual void advertiseOutputs(ros::NodeHandle& private_nh) = 0;

  bool paramsOk() const { return params_ok_; }

  /// The first thing every concrete nodelet's destructor does. Its own members (parameters,
  /// publishers, tf buffer) are destroyed before this base's input subscriber; the manager never
  /// destroys a nodelet under a callback from its queues, but ThreadSanitizer cannot see that
  /// ordering (docs/tests.md), so the destructor makes it explicit: unsubscribing and closing the
  /// gate wait for a running callback. Afterwards a late connection callback no longer subscribes.
  void stopInputs()
  {
    // NodeletLazy's one-shot "never subscribed" warning calls a virtual of this object:
    // ThreadSanitizer reported it against the destructor's vptr writes (an ordering it cannot
    // see, docs/tests.md); stopping it first orders the two where TSan sees it.
    timer_ever_subscribed_.stop();
    gate_.close();  // after ros::shutdown() unsubscribing no longer waits (callback_gate.h)
    boost::mutex::scoped_lock lock(connection_mutex_);
    inputs_stopped_ = true;
    unsubscribe();
  }
  /// For subscribe(), which NodeletLazy calls with connection_mutex_ held: false until onInit has
  /// advertised every output, and again once the destructor began.
  bool mayStartInputs() const { return outputs_ready_ && !inputs_stopped_; }

  NodeletStatus status_;
  /// Input callbacks hold a pass (CloudNodelet::inputCallback, CloudFusion's pipeline).
  CallbackGate gate_;

private:
  void onInit() final
  {
    primePclRosFieldMappings();
    NodeletLazy::onInit();
    ros::NodeHandle& pnh = *pnh_;
    status_.init(*nh_, pnh, getName());
    const std::string bad = readParameters(pnh);
    params_ok_ = bad.empty();
    if (!params_ok_)
    {
      NODELET_ERROR("Initialization failed: %s", bad.c_str());
      status_.error("initialization failed: " + bad);
      return;
    }
    advertiseOutputs(pnh);
    advertiseAddressTopics(pnh);
    startInputsIfListenedTo();
    onInitPostProcess();
  }

  /// A listener already waiting for an output makes NodeletLazy call subscribe() from a worker
  /// thread as soon as that output is advertised, while this thread still assigns the later
  /// publishers the input callback uses (ThreadSanitizer: TableSegmentation's process() publishing
  /// on segmented_scene_pub_ while onInit assigned it, test_nodelet_unload). subscribe() refuses
  /// until every output exists, and NodeletLazy then already counts the inputs as subscribed:
  /// they are subscribed here instead.
  void startInputsIfListenedTo()
  {
    boost::mutex::scoped_lock lock(connection_mutex_);
    outputs_ready_ = true;
    if (connection_status_ == nodelet_topic_tools::SUBSCRIBED)
      subscribe();
  }

  /// CloudNodelet's zero-copy check topics.
  virtual void advertiseAddressTopics(ros::NodeHandle& /*private_nh*/) {}

  bool params_ok_ = false;
  bool outputs_ready_ = false;   // guarded by NodeletLazy::connection_mutex_
  bool inputs_stopped_ = false;  // guarded by NodeletLazy::connection_mutex_
};

template <typename T>
struct IsPclCloud : std::false_type
{
};
template <typename PointT>
struct IsPclCloud<pcl::PointCloud<PointT>> : std::true_type
{
};

/// A perception nodelet with one input, "input" (queue 1), subscribed while someone listens
/// to an output. InputT is a pcl::PointCloud<PointT>, passed zero-copy inside a manager
/// (pcl_ros/point_cloud.h), or a sensor_msgs::PointCloud2.
///
/// With ~publish_address, ~sent_address carries the address of each cloud published through
/// publishSentAddress() and, for pcl::PointCloud inputs, ~received_address that of each
/// input cloud: the zero-copy rostest checks that the two ends of a hand-over match.
template <typename InputT>
class CloudNodelet : public CloudNodeletBase
{
public:
  using Input = InputT;
  using InputConstPtr = boost::shared_ptr<const InputT>;

protected:
  /// Handles one input. Report the outcome on status_; exceptions are caught by the caller.
  virtual void process(const InputConstPtr& input) = 0;

  /// With ~publish_address, publishes the address of an output cloud on ~sent_address.
  void publishSentAddress(const void* cloud) { publishAddress(sent_address_pub_, cloud); }

private:
  static constexpr bool kZeroCopyInput = IsPclCloud<InputT>::value;

  void advertiseAddressTopics(ros::NodeHandle& private_nh) final
  {
    private_nh.param("publish_address", publish_address_, publish_address_);
    if (!publish_address_)
      return;
    if (kZeroCopyInput)
      received_address_pub_ = private_nh.advertise<std_msgs::UInt64>("received_address", 10);
    sent_address_pub_ = private_nh.advertise<std_msgs::UInt64>("sent_address", 10);
  }

  void subscribe() override
  {
    if (paramsOk() && mayStartInputs())
      input_sub_ = nh_->subscribe("input", 1, &CloudNodelet::inputCallback, this);
  }

  void unsubscribe() override { input_sub_.shutdown(); }

  void inputCallback(const InputConstPtr& input)
  {
    const CallbackGate::Pass pass = gate_.enter();
    if (!pass)
      return;
    reportExceptions(getName(), status_, [&] {
      if (kZeroCopyInput)
        publishAddress(received_address_pub_, input.get());
      process(input);
    });
  }

  void publishAddress(ros::Publisher& pub, const void* cloud)
  {
    if (!publish_address_)
      return;
    std_msgs::UInt64 address;
    address.data = reinterpret_cast<std::uintptr_t>(cloud);
    pub.publish(address);
  }

  bool publish_address_ = false;
  ros::Subscriber input_sub_;
  ros::Publisher received_address_pub_;
  ros::Publisher sent_address_pub_;
};

}  // namespace fast_grasp
