// Unloading a nodelet while its inputs stream (issue 12, ThreadSanitizer on the nodelets): the
// manager removes the nodelet's callback queues and deletes it while a worker thread may still
// run one of its callbacks. Every fast_grasp nodelet declares its subscribers before (perception:
// in a base class of) the members its callbacks use, so the implicit destructor destroyed those
// members first, under the running callback; the destructors now shut the inputs down first,
// which waits for it. Natively the old code rarely crashed; under ThreadSanitizer
// (scripts/tsan_rostests.sh nodelet_unload) it reported the races (docs/tests.md).
#include <fast_grasp/SegmentedScene.h>
#include <gtest/gtest.h>
#include <nodelet/loader.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pcl_ros/point_cloud.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/String.h>

#include <atomic>
#include <functional>
#include <mutex>
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

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodelet_unload_check");
  return RUN_ALL_TESTS();
}
