// pcl_ros's field mapping (nodelets/pcl_ros_mapping.h): clouds of one point type deserialised in
// several threads at once, as a manager's worker threads do with their first clouds from another
// process. Primed first, as every nodelet's onInit does, the threads only read the mapping. Without
// the priming ThreadSanitizer reports the first deserialisations writing the mapping while others
// read it (scripts/tsan_rostests.sh pcl_ros_mapping; docs/tests.md); natively each thread must
// still get its cloud back point for point.
#include "fast_grasp/nodelets/pcl_ros_mapping.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

namespace
{
std::vector<std::uint8_t> serialised(const pcl::PointCloud<pcl::PointNormal>& cloud)
{
  std::vector<std::uint8_t> buffer(ros::serialization::serializationLength(cloud));
  ros::serialization::OStream out(buffer.data(), static_cast<std::uint32_t>(buffer.size()));
  ros::serialization::serialize(out, cloud);
  return buffer;
}
}  // namespace

TEST(PclRosMapping, ThreadsDeserialiseTheirFirstCloudsTogetherAfterPriming)
{
  fast_grasp::primePclRosFieldMappings();
  pcl::PointCloud<pcl::PointNormal> cloud;
  for (int i = 0; i < 100; ++i)
  {
    pcl::PointNormal p;
    p.x = 0.01f * i;
    p.y = -0.02f * i;
    p.z = 0.5f + 0.001f * i;
    p.normal_x = 0.0f;
    p.normal_y = 0.6f;
    p.normal_z = 0.8f;
    p.curvature = 0.001f * i;
    cloud.push_back(p);
  }
  const std::vector<std::uint8_t> buffer = serialised(cloud);

  constexpr int kThreads = 8;
  std::atomic<int> ready{ 0 };
  std::vector<pcl::PointCloud<pcl::PointNormal>> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      std::vector<std::uint8_t> own(buffer);
      ++ready;
      while (ready < kThreads)
        std::this_thread::yield();  // all start deserialising together
      ros::serialization::IStream in(own.data(), static_cast<std::uint32_t>(own.size()));
      ros::serialization::deserialize(in, results[static_cast<std::size_t>(t)]);
    });
  for (auto& thread : threads)
    thread.join();
  for (const auto& result : results)
  {
    ASSERT_EQ(result.size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i)
    {
      EXPECT_EQ(result[i].x, cloud[i].x);
      EXPECT_EQ(result[i].z, cloud[i].z);
      EXPECT_EQ(result[i].normal_y, cloud[i].normal_y);
      EXPECT_EQ(result[i].curvature, cloud[i].curvature);
    }
  }
}
