// Unloading a nodelet while its inputs stream (issue 12, ThreadSanitizer on the nodelets). Every
// fast_grasp nodelet declares its subscribers before (perception: in a base class of) the members
// its callbacks use, and under ThreadSanitizer (scripts/tsan_rostests.sh nodelet_unload) the
// implicit destructors were reported destroying those members against running callbacks. The
// NodeletLifetime tests below show natively that the manager does not in fact destroy a nodelet
// under a callback from its queues: TSan could not see the reference count that orders them
// (docs/tests.md). The destructors now shut the inputs down first, an ordering TSan sees.
#include <fast_grasp/SegmentedScene.h>
#include <gtest/gtest.h>
#include <boost/function.hpp>
#include <boost/make_shared.hpp>
#include <nodelet/loader.h>
#include <nodelet/nodelet.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pcl_ros/point_cloud.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/String.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace
{
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// A 40 x 40 cm table at z = 0 (1 cm grid) under a 6 x 6 x 10 cm box, in base_link.
boost::shared_ptr<Cloud> tableWithBox(const ros::Time& stamp)
{
  boost::shared_ptr<Cloud> cloud(new Cloud);  // roscpp publishes boost pointers zero-copy
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      cloud->push_back(pcl::PointXYZ(0.3f + 0.01f * i, -0.2f + 0.01f * j, 0.0f));
  for (int i = 0; i <= 6; ++i)
    for (int k = 1; k <= 10; ++k)
    {
      cloud->push_back(pcl::PointXYZ(0.47f + 0.01f * i, -0.03f, 0.01f * k));
      cloud->push_back(pcl::PointXYZ(0.47f, -0.03f + 0.01f * i, 0.01f * k));
    }
  cloud->header.frame_id = "base_link";
  pcl_conversions::toPCL(stamp, cloud->header.stamp);
  cloud->sensor_origin_ = Eigen::Vector4f(0.0f, 0.0f, 0.8f, 1.0f);
  return cloud;
}

bool waitFor(const std::function<bool()>& condition, double timeout_s)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline)
  {
    if (condition())
      return true;
    ros::WallDuration(0.01).sleep();
  }
  return condition();
}

// --- What nodelet's manager guarantees about a nodelet's lifetime -----------------------------
// A probe nodelet created in this process (nodelet::Loader's create_instance constructor, no
// plugin) whose subscription and timer callbacks record, under one mutex, which instances are
// alive and which run a callback. The manager wraps every nodelet's two callback queues with a
// weak reference to the nodelet (nodelet::detail::CallbackQueue's tracked object): a worker thread
// locks it before it calls a callback and holds it until the callback returns. These tests pin
// that down natively, so the cases ThreadSanitizer reported (docs/tests.md) are known to be about
// ordering TSan cannot see (the reference count lives in Debian's uninstrumented libnodeletlib),
// not callbacks on deleted objects.
struct ProbeLedger
{
  std::mutex mutex;
  std::condition_variable changed;
  std::set<const void*> alive;
  std::map<const void*, int> running;  // callbacks inside, per instance
  int callbacks_on_deleted = 0;        // a callback began on an instance not alive
  int deleted_under_callback = 0;      // an instance destroyed while one of its callbacks ran
  int initialised = 0;
  int destroyed = 0;
  long visits = 0;  // callbacks that ran on a live instance
  std::thread::id last_destructor_thread;
  // With hold_first_callback, the first subscription callback waits inside until the test releases it.
  bool hold_first_callback = false;
  bool first_callback_started = false;
  bool release_first_callback = false;
};
ProbeLedger ledger;

class ProbeNodelet : public nodelet::Nodelet
{
public:
  ProbeNodelet()
  {
    std::lock_guard<std::mutex> lock(ledger.mutex);
    ledger.alive.insert(this);
  }
  ~ProbeNodelet() override
  {
    std::lock_guard<std::mutex> lock(ledger.mutex);
    if (ledger.running[this] > 0)
      ++ledger.deleted_under_callback;
    ledger.alive.erase(this);
    ledger.running.erase(this);
    ++ledger.destroyed;
    ledger.last_destructor_thread = std::this_thread::get_id();
    ledger.changed.notify_all();
  }

private:
  void onInit() override
  {
    // The multi-threaded queue: several workers may run this nodelet's callbacks at once.
    ros::NodeHandle& nh = getMTNodeHandle();
    sub_ = nh.subscribe<std_msgs::String>("probe_input", 50, [this](const std_msgs::String::ConstPtr&) { visit(true); });
    timer_ = nh.createWallTimer(ros::WallDuration(0.001), [this](const ros::WallTimerEvent&) { visit(false); });
    // Through the ledger's mutex the destructor, wherever it runs, comes after these writes in a
    // way ThreadSanitizer sees (the manager's own ordering is a reference count it cannot see).
    std::lock_guard<std::mutex> lock(ledger.mutex);
    ++ledger.initialised;
  }

  void visit(bool from_subscription)
  {
    {
      std::unique_lock<std::mutex> lock(ledger.mutex);
      if (ledger.alive.count(this) == 0)
      {
        ++ledger.callbacks_on_deleted;
        return;
      }
      ++ledger.running[this];
      ++ledger.visits;
      if (from_subscription && ledger.hold_first_callback && !ledger.first_callback_started)
      {
        ledger.first_callback_started = true;
        ledger.changed.notify_all();
        // Bounded: were the nodelet destroyed under this callback, its subscriber's shutdown would
        // wait here and unload() would not return; the ledger then records the deletion instead.
        ledger.changed.wait_for(lock, std::chrono::seconds(10), [] { return ledger.release_first_callback; });
      }
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));  // widen the window
    std::lock_guard<std::mutex> lock(ledger.mutex);
    --ledger.running[this];
  }

  ros::Subscriber sub_;
  ros::WallTimer timer_;
};

/// A manager whose only nodelet type is the probe (a plain function pointer would pick the
/// Loader(bool provide_ros_api) constructor).
std::unique_ptr<nodelet::Loader> probeManager()
{
  const boost::function<boost::shared_ptr<nodelet::Nodelet>(const std::string&)> create =
      [](const std::string&) { return boost::make_shared<ProbeNodelet>(); };
  return std::make_unique<nodelet::Loader>(create);
}
}  // namespace

TEST(NodeletUnload, UnloadsWhileItsInputsStreamAndLoadsAgain)
{
  ros::NodeHandle nh;
  nodelet::Loader manager{ ros::NodeHandle("~") };  // ~num_worker_threads worker threads
  ros::Publisher joints_pub = nh.advertise<sensor_msgs::JointState>("joint_states", 10);
  ros::Publisher scene_pub = nh.advertise<fast_grasp::SegmentedScene>("segmented_scene", 10);
  ros::Publisher cloud_pub = nh.advertise<Cloud>("table_input", 2);
  std::atomic<unsigned long> segmented{ 0 };
  // Listening to an output is what makes the lazy TableSegmentation subscribe to its input.
  ros::Subscriber segmented_sub = nh.subscribe<fast_grasp::SegmentedScene>(
      "table_segmentation/segmented_scene", 10, [&](const fast_grasp::SegmentedScene::ConstPtr&) { ++segmented; });
  // The planners say on ~status (latched) when their parameters failed: they would not subscribe.
  std::mutex statuses_mutex;
  std::vector<std::string> statuses;
  std::vector<ros::Subscriber> status_subs;
  for (const char* topic : { "arm_planner/status", "grasp_planner/status", "table_segmentation/status" })
    status_subs.push_back(nh.subscribe<std_msgs::String>(topic, 10, [&](const std_msgs::String::ConstPtr& msg) {
      std::lock_guard<std::mutex> lock(statuses_mutex);
      statuses.push_back(msg->data);
    }));
  ros::AsyncSpinner spinner(1);
  spinner.start();

  std::atomic<bool> stop{ false };
  std::thread streamer([&] {
    sensor_msgs::JointState joints;
    joints.name = { "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                    "wrist_3_joint" };
    joints.position.assign(6, 0.0);
    fast_grasp::SegmentedScene scene;
    scene.ok = true;
    scene.table_plane = { 0.0f, 0.0f, 1.0f, 0.0f };
    scene.header.frame_id = "base_link";
    while (!stop)
    {
      const ros::Time now = ros::Time::now();
      joints.header.stamp = now;
      joints_pub.publish(joints);
      scene.header.stamp = now;
      scene_pub.publish(scene);
      cloud_pub.publish(tableWithBox(now));  // a new cloud each time: never changed once published
      ros::WallDuration(0.002).sleep();
    }
  });

  const std::vector<std::pair<std::string, std::string>> nodelets = {
    { "/arm_planner", "fast_grasp/ArmPlanner" },
    { "/grasp_planner", "fast_grasp/PrincipalAxisGrasp" },
    { "/table_segmentation", "fast_grasp/TableSegmentation" },
  };
  nodelet::M_string remappings = { { "/input", "/table_input" } };
  const nodelet::V_string no_args;
  for (int round = 0; round < 5; ++round)
  {
    SCOPED_TRACE("round " + std::to_string(round));
    for (const auto& [name, type] : nodelets)
      ASSERT_TRUE(manager.load(name, type, remappings, no_args)) << name;
    // Every input connected and frames processed: callbacks are running when the unload comes.
    const unsigned long segmented_before = segmented;
    // (roscpp counts one listener per process and topic: the two planners share /segmented_scene's)
    ASSERT_TRUE(waitFor([&] { return joints_pub.getNumSubscribers() >= 1 && scene_pub.getNumSubscribers() >= 1 &&
                                     cloud_pub.getNumSubscribers() >= 1 && segmented >= segmented_before + 3; },
                        120.0))
        << "joint_states listeners " << joints_pub.getNumSubscribers() << ", segmented_scene listeners "
        << scene_pub.getNumSubscribers() << ", table_input listeners " << cloud_pub.getNumSubscribers()
        << ", frames segmented " << segmented - segmented_before;
    {
      std::lock_guard<std::mutex> lock(statuses_mutex);
      for (const std::string& status : statuses)
        EXPECT_EQ(status.find("initialization failed"), std::string::npos) << status;
    }
    for (const auto& [name, type] : nodelets)
      EXPECT_TRUE(manager.unload(name)) << name;
    EXPECT_TRUE(manager.listLoadedNodelets().empty());
  }
  stop = true;
  streamer.join();
}

// Unloaded while one of its callbacks runs: unload() returns at once, the nodelet stays alive
// until that callback has returned and is then destroyed by the worker thread that ran it.
TEST(NodeletLifetime, AnUnloadWhileACallbackRunsDestroysTheNodeletAfterIt)
{
  ros::NodeHandle nh;
  const std::unique_ptr<nodelet::Loader> manager = probeManager();
  ros::Publisher pub = nh.advertise<std_msgs::String>("probe_input", 10);
  {
    std::lock_guard<std::mutex> lock(ledger.mutex);
    ledger.hold_first_callback = true;
  }
  const int destroyed_before = ledger.destroyed;
  ASSERT_TRUE(manager->load("/probe_held", "probe", {}, {}));
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() >= 1; }, 30.0));
  pub.publish(std_msgs::String());
  {
    std::unique_lock<std::mutex> lock(ledger.mutex);
    ASSERT_TRUE(ledger.changed.wait_for(lock, std::chrono::seconds(30), [] { return ledger.first_callback_started; }));
  }
  EXPECT_TRUE(manager->unload("/probe_held"));  // returns while the callback is blocked
  {
    std::unique_lock<std::mutex> lock(ledger.mutex);
    EXPECT_EQ(ledger.destroyed, destroyed_before) << "destroyed under its running callback";
    ledger.release_first_callback = true;
    ledger.changed.notify_all();
    EXPECT_TRUE(ledger.changed.wait_for(lock, std::chrono::seconds(30),
                                        [&] { return ledger.destroyed == destroyed_before + 1; }));
    EXPECT_NE(ledger.last_destructor_thread, std::this_thread::get_id()) << "the worker thread destroys it";
    EXPECT_EQ(ledger.deleted_under_callback, 0);
    EXPECT_EQ(ledger.callbacks_on_deleted, 0);
    ledger.hold_first_callback = false;
  }
}

// A worker thread that picked a nodelet's queue just before the nodelet was deleted does not
// call into it: 200 loads and unloads while messages stream and 1 ms timers fire.
TEST(NodeletLifetime, NoCallbackStartsOnADeletedNodelet)
{
  ros::NodeHandle nh;
  const std::unique_ptr<nodelet::Loader> manager = probeManager();
  ros::Publisher pub = nh.advertise<std_msgs::String>("probe_input", 100);
  std::atomic<bool> stop{ false };
  std::thread streamer([&] {
    while (!stop)
    {
      pub.publish(std_msgs::String());
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  });
  const int destroyed_before = ledger.destroyed;
  const int initialised_before = ledger.initialised;
  const long visits_before = ledger.visits;
  int rounds = 0;
  for (; rounds < 200; ++rounds)
  {
    const std::string name = "/probe_" + std::to_string(rounds % 3);
    if (!manager->load(name, "probe", {}, {}))
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(rounds % 7));
    if (!manager->unload(name))
      break;
  }
  stop = true;
  streamer.join();
  ASSERT_EQ(rounds, 200) << "a load or unload failed";
  std::unique_lock<std::mutex> lock(ledger.mutex);
  EXPECT_TRUE(ledger.changed.wait_for(lock, std::chrono::seconds(30),
                                      [&] { return ledger.destroyed == destroyed_before + 200; }));
  EXPECT_EQ(ledger.initialised - initialised_before, 200);
  EXPECT_GT(ledger.visits - visits_before, 200) << "the callbacks hardly ran: nothing was checked";
  std::cout << "callbacks run: " << ledger.visits - visits_before << "\n";
  EXPECT_EQ(ledger.deleted_under_callback, 0);
  EXPECT_EQ(ledger.callbacks_on_deleted, 0);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodelet_unload_check");
  return RUN_ALL_TESTS();
}
