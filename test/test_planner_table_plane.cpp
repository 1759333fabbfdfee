// A grasp planner nodelet and the table plane of a cloud's frame (grasp_planner_nodelet.h).
// CI (sessions 5 and 18) once got a grasp through the table on the hammer bag: the planner's
// first cloud came before any ~segmented_scene (the two connections are made independently, and
// across processes the cloud may overtake its scene) and was planned with no table. The
// expectations here are relations, not the planner's geometry: a cloud whose scene comes late is
// planned exactly as the same cloud whose scene came first; with no plane at all it is refused.
#include <fast_grasp/GraspArray.h>
#include <fast_grasp/SegmentedScene.h>
#include <gtest/gtest.h>
#include <nodelet/loader.h>
#include <pcl_conversions/pcl_conversions.h>
#include <pcl_ros/point_cloud.h>
#include <ros/ros.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <mutex>
#include <string>

namespace
{
using ObjectCloud = pcl::PointCloud<pcl::PointNormal>;
constexpr float kTableZ = 0.0f;

/// A 16 cm long cylinder of 2 cm radius lying on the table (z = 0) at x = 0.5 m along y, as the
/// camera at (0, 0, 0.6) sees it: the half facing the camera, 5 mm apart along it, 10 degrees
/// around, outward normals. Low: a hand closing on it from the side would enter the table.
boost::shared_ptr<ObjectCloud> lowCylinder(const ros::Time& stamp)
{
  boost::shared_ptr<ObjectCloud> cloud(new ObjectCloud);  // published zero-copy: never changed after
  const Eigen::Vector3f camera(0.0f, 0.0f, 0.6f);
  const float radius = 0.02f;
  for (int j = 0; j <= 32; ++j)
    for (int a = 0; a < 36; ++a)
    {
      const float angle = static_cast<float>(a) * static_cast<float>(M_PI) / 18.0f;
      const Eigen::Vector3f normal(std::cos(angle), 0.0f, std::sin(angle));
      const Eigen::Vector3f point = Eigen::Vector3f(0.5f, -0.08f + 0.005f * j, kTableZ + radius) + radius * normal;
      if (normal.dot(camera - point) <= 0.0f)
        continue;  // the far side
      pcl::PointNormal p;
      p.x = point.x();
      p.y = point.y();
      p.z = point.z();
      p.normal_x = normal.x();
      p.normal_y = normal.y();
      p.normal_z = normal.z();
      cloud->push_back(p);
    }
  cloud->header.frame_id = "base_link";
  pcl_conversions::toPCL(stamp, cloud->header.stamp);
  cloud->sensor_origin_ = Eigen::Vector4f(camera.x(), camera.y(), camera.z(), 1.0f);
  return cloud;
}

fast_grasp::SegmentedScene tableScene(const ros::Time& stamp)
{
  fast_grasp::SegmentedScene scene;
  scene.header.frame_id = "base_link";
  scene.header.stamp = stamp;
  scene.ok = true;
  scene.table_plane = { 0.0f, 0.0f, 1.0f, -kTableZ };
  return scene;
}

/// GraspArrays of one planner by stamp, with the wall time each came.
class GraspLog
{
public:
  GraspLog(ros::NodeHandle& nh, const std::string& topic)
  {
    sub_ = nh.subscribe<fast_grasp::GraspArray>(topic, 10, [this](const fast_grasp::GraspArray::ConstPtr& msg) {
      std::lock_guard<std::mutex> lock(mutex_);
      arrays_[msg->header.stamp] = { *msg, ros::WallTime::now() };
    });
  }
  bool waitFor(const ros::Time& stamp, double timeout_s, fast_grasp::GraspArray& array, ros::WallTime& came)
  {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < deadline)
    {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto it = arrays_.find(stamp);
        if (it != arrays_.end())
        {
          array = it->second.first;
          came = it->second.second;
          return true;
        }
      }
      ros::WallDuration(0.01).sleep();
    }
    return false;
  }
  ros::Subscriber& subscriber() { return sub_; }

private:
  std::mutex mutex_;
  std::map<ros::Time, std::pair<fast_grasp::GraspArray, ros::WallTime>> arrays_;
  ros::Subscriber sub_;
};

bool waitUntil(const std::function<bool()>& condition, double timeout_s)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline && !condition())
    ros::WallDuration(0.01).sleep();
  return condition();
}

/// The same plan: status, grasp count and the best grasp's pose and width.
void expectSamePlan(const fast_grasp::GraspArray& a, const fast_grasp::GraspArray& b)
{
  EXPECT_EQ(a.status, b.status);
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  if (a.grasps.empty())
    return;
  const auto& pa = a.grasps.front().pose;
  const auto& pb = b.grasps.front().pose;
  EXPECT_NEAR(pa.position.x, pb.position.x, 1e-9);
  EXPECT_NEAR(pa.position.y, pb.position.y, 1e-9);
  EXPECT_NEAR(pa.position.z, pb.position.z, 1e-9);
  EXPECT_NEAR(pa.orientation.w, pb.orientation.w, 1e-9);
  EXPECT_NEAR(pa.orientation.z, pb.orientation.z, 1e-9);
  EXPECT_NEAR(a.grasps.front().width_m, b.grasps.front().width_m, 1e-9);
}
}  // namespace

TEST(PlannerTablePlane, TheFirstCloudWaitsForItsPlaneAndIsRefusedWithoutOne)
{
  ros::NodeHandle nh;
  nodelet::Loader manager{ ros::NodeHandle("~") };  // ~num_worker_threads worker threads
  ros::Publisher scene_pub = nh.advertise<fast_grasp::SegmentedScene>("scene_in", 10);
  ros::Publisher cloud_pub = nh.advertise<ObjectCloud>("object_in", 10);
  GraspLog with_table(nh, "/with_table/grasps");
  GraspLog without_table(nh, "/without_table/grasps");
  ros::AsyncSpinner spinner(1);
  spinner.start();

  // Both planners read their parameters from the .test file (require_table_plane differs).
  ASSERT_TRUE(manager.load("/with_table", "fast_grasp/PrincipalAxisGrasp",
                           { { "/cloud_in", "/object_in" }, { "/segmented_scene", "/scene_in" } }, {}));
  ASSERT_TRUE(manager.load("/without_table", "fast_grasp/PrincipalAxisGrasp",
                           { { "/cloud_in", "/object_in_no_table" }, { "/segmented_scene", "/no_scene" } },
                           {}));
  ros::Publisher no_table_pub = nh.advertise<ObjectCloud>("object_in_no_table", 10);
  ASSERT_TRUE(waitUntil([&] {
    return scene_pub.getNumSubscribers() >= 1 && cloud_pub.getNumSubscribers() >= 1 &&
           no_table_pub.getNumSubscribers() >= 1 && with_table.subscriber().getNumPublishers() >= 1 &&
           without_table.subscriber().getNumPublishers() >= 1;
  }, 60.0));
  // The planner's scene subscription is connected to scene_pub (counted above): it waits.
  const double wait_s = 0.5;  // table_plane_wait_s in planner_table_plane.test

  fast_grasp::GraspArray array;
  ros::WallTime came;
  // 1. A table segmentation publishes but no scene ever comes: refused after the wait.
  const ros::Time lonely(100.0);
  const ros::WallTime sent_lonely = ros::WallTime::now();
  cloud_pub.publish(lowCylinder(lonely));
  ASSERT_TRUE(with_table.waitFor(lonely, 30.0, array, came));
  EXPECT_TRUE(array.grasps.empty());
  EXPECT_EQ(array.status.rfind("NoTablePlane: ", 0), 0u) << array.status;
  EXPECT_GE((came - sent_lonely).toSec(), wait_s - 0.05) << "refused without waiting for the plane";

  // 2. The cloud comes 0.2 s before its own frame's scene: it waits for it.
  const ros::Time late(200.0);
  cloud_pub.publish(lowCylinder(late));
  ros::WallDuration(0.2).sleep();
  const ros::WallTime sent_scene = ros::WallTime::now();
  scene_pub.publish(tableScene(late));
  fast_grasp::GraspArray late_plan;
  ASSERT_TRUE(with_table.waitFor(late, 30.0, late_plan, came));
  EXPECT_GE((came - sent_scene).toSec(), 0.0);
  EXPECT_EQ(late_plan.status.find("NoTablePlane"), std::string::npos) << late_plan.status;

  // 3. Control: the same cloud after its scene plans the same.
  const ros::Time in_order(300.0);
  scene_pub.publish(tableScene(in_order));
  ros::WallDuration(0.2).sleep();
  cloud_pub.publish(lowCylinder(in_order));
  fast_grasp::GraspArray control;
  ASSERT_TRUE(with_table.waitFor(in_order, 30.0, control, came));
  expectSamePlan(late_plan, control);

  // 4. require_table_plane: false and no segmentation: planned at once, without a table. The
  // plan differs from the control, so the plane matters for this cylinder and 2. shows it was used.
  const ros::Time no_table(400.0);
  const ros::WallTime sent_no_table = ros::WallTime::now();
  no_table_pub.publish(lowCylinder(no_table));
  fast_grasp::GraspArray unconstrained;
  ASSERT_TRUE(without_table.waitFor(no_table, 30.0, unconstrained, came));
  EXPECT_LT((came - sent_no_table).toSec(), 10.0);
  EXPECT_EQ(unconstrained.status.find("NoTablePlane"), std::string::npos) << unconstrained.status;
  const bool same = unconstrained.status == control.status && unconstrained.grasps.size() == control.grasps.size() &&
                    (control.grasps.empty() ||
                     std::abs(unconstrained.grasps.front().pose.position.z - control.grasps.front().pose.position.z) < 1e-6);
  EXPECT_FALSE(same) << "the table plane changes nothing for this cylinder: " << control.status << ", "
                     << control.grasps.size() << " grasps";
  std::cout << "with the table: " << control.status << ", " << control.grasps.size() << " grasps; without: "
            << unconstrained.status << ", " << unconstrained.grasps.size() << " grasps\n";
  manager.unload("/with_table");
  manager.unload("/without_table");
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "planner_table_plane_check");
  return RUN_ALL_TESTS();
}
