// bench_perception: median milliseconds per perception stage on every frame of the bundled
// bags, one core. Stages: preprocess (reach filter and voxel grid, reading the PointCloud2
// buffer in place as the CloudPreprocess nodelet does), RANSAC (table plane and height
// classification), clustering (Euclidean clusters, stacked-part merge, target choice),
// normals (k-NN normals of the object and their Ch6 down-sampling). Parameters are those of
// config/perception.yaml. For reference it also times pcl::fromROSMsg of each frame, the
// conversion the in-place path avoids.
//   rosrun fast_grasp bench_perception [bag ...]   (default: every single-object bags/*.bag of the
//   source tree; clutter_* bags only when named, so the documented numbers stay comparable)
#include "bench_stats.h"
#include "command_line.h"
#include "fast_grasp/perception/cloud_preprocess.h"
#include "fast_grasp/perception/normal_estimation.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <pcl_conversions/pcl_conversions.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace
{
using fast_grasp::median;

struct StageTimes
{
  std::vector<double> preprocess_ms, ransac_ms, clustering_ms, normals_ms, total_ms;
};
}  // namespace

int main(int argc, char** argv)
{
  static const char* const kUsage =
      "usage: bench_perception [BAG...]\n"
      "  median ms per perception stage on each bag (default: every bundled single-object bag)\n";
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  std::vector<std::string> bags;
  for (int i = 1; i < argc; ++i)
  {
    if (argv[i][0] == '-')
      fast_grasp::exitWithUsage(std::string("unknown flag ") + argv[i], kUsage);
    bags.emplace_back(argv[i]);
  }
  if (bags.empty())
  {
    const std::filesystem::path dir = std::filesystem::path(FAST_GRASP_SOURCE_DIR) / "bags";
    if (std::filesystem::is_directory(dir))
      for (const auto& entry : std::filesystem::directory_iterator(dir))
        // clutter_* (issue 11): several objects per frame; docs/benchmarks' numbers are over the
        // single-object bags, so the clutter bags run only when named
        if (entry.path().extension() == ".bag" && entry.path().stem().string().rfind("clutter_", 0) != 0)
          bags.push_back(entry.path().string());
    std::sort(bags.begin(), bags.end());
  }
  if (bags.empty())
  {
    std::fprintf(stderr, "no bags given and none found in %s/bags\n", FAST_GRASP_SOURCE_DIR);
    return 1;
  }
  // Same values as config/perception.yaml.
  fast_grasp::PreprocessParams preprocess_params;
  preprocess_params.min_z_m = -0.5;
  preprocess_params.max_z_m = 1.5;
  fast_grasp::TableSegmentationParams segmentation_params;
  segmentation_params.max_object_distance_m = 0.80;
  fast_grasp::NormalParams normal_params;
  const double downsample_radius_m = 0.01;
  const int repeats = 5;  // each frame is processed this many times; the median damps noise

  std::printf("%-24s %5s %8s %8s %8s %8s %8s %8s %7s %6s\n", "bag", "frame", "points", "prep_ms", "ransac",
              "cluster", "normals", "total", "object", "status");
  StageTimes all;
  std::vector<double> all_voxel_ms;       // the voxel grid's share of preprocess, every run
  std::vector<double> all_conversion_ms;  // pcl::fromROSMsg, not part of the pipeline
  for (const std::string& path : bags)
  {
    rosbag::Bag bag;
    try
    {
      bag.open(path, rosbag::bagmode::Read);
    }
    catch (const rosbag::BagException& e)
    {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), e.what());
      continue;
    }
    tf2::BufferCore tf_buffer(ros::Duration(3600.0));
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{ "/tf_static", "/tf" })))
      if (const auto tf = m.instantiate<tf2_msgs::TFMessage>())
        for (const auto& t : tf->transforms)
          tf_buffer.setTransform(t, "bag", m.getTopic() == "/tf_static");
    int frame = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(bag))
    {
      const auto msg = m.instantiate<sensor_msgs::PointCloud2>();
      if (!msg)
        continue;
      Eigen::Isometry3f camera_to_base;
      try
      {
        camera_to_base = tf2::transformToEigen(
                             tf_buffer.lookupTransform("base_link", msg->header.frame_id, msg->header.stamp))
                             .cast<float>();
      }
      catch (const tf2::TransformException& e)
      {
        std::fprintf(stderr, "%s frame %d: %s\n", path.c_str(), frame, e.what());
        continue;
      }
      StageTimes frame_times;
      std::vector<double>& voxel_ms_samples = all_voxel_ms;
      std::string status = "ok";
      std::size_t object_points = 0;
      for (int r = 0; r < repeats; ++r)
      {
        const fast_grasp::Stopwatch preprocess_watch;
        // As the nodelet does: filter straight from the message buffer.
        fast_grasp::RawCloudView raw;
        raw.data = msg->data.data();
        raw.size_bytes = msg->data.size();
        raw.width = msg->width;
        raw.height = msg->height;
        raw.point_step = msg->point_step;
        raw.row_step = msg->row_step;
        for (const auto& field : msg->fields)
        {
          if (field.name == "x")
            raw.x_offset = field.offset;
          else if (field.name == "y")
            raw.y_offset = field.offset;
          else if (field.name == "z")
            raw.z_offset = field.offset;
        }
        const fast_grasp::PreprocessResult pre = fast_grasp::preprocessCloud(raw, camera_to_base, preprocess_params);
        voxel_ms_samples.push_back(1e3 * pre.voxel_time_s);
        {
          const fast_grasp::Stopwatch conversion_watch;
          pcl::PointCloud<pcl::PointXYZ> converted;
          pcl::fromROSMsg(*msg, converted);
          all_conversion_ms.push_back(1e3 * conversion_watch.elapsedSeconds());
        }
        const double preprocess_ms = 1e3 * preprocess_watch.elapsedSeconds();
        double ransac_ms = 0.0, clustering_ms = 0.0, normals_ms = 0.0;
        if (!pre.ok)
          status = "preprocess: " + pre.reason;
        else
        {
          const fast_grasp::TableSegmentationResult seg = fast_grasp::segmentTable(pre.cloud, segmentation_params);
          ransac_ms = 1e3 * seg.ransac_time_s;
          clustering_ms = 1e3 * seg.clustering_time_s;
          object_points = seg.object->size();
          if (!seg.ok())
            status = std::string(fast_grasp::toString(seg.failure));
          else
          {
            const fast_grasp::Stopwatch normals_watch;
            const fast_grasp::NormalResult normals = fast_grasp::estimateNormals(
                seg.object, pre.cloud->sensor_origin_.head<3>(), normal_params);
            if (normals.ok)
              fast_grasp::downsampleNormals(*normals.cloud, downsample_radius_m);
            else
              status = "normals: " + normals.reason;
            normals_ms = 1e3 * normals_watch.elapsedSeconds();
          }
        }
        frame_times.preprocess_ms.push_back(preprocess_ms);
        frame_times.ransac_ms.push_back(ransac_ms);
        frame_times.clustering_ms.push_back(clustering_ms);
        frame_times.normals_ms.push_back(normals_ms);
        frame_times.total_ms.push_back(preprocess_ms + ransac_ms + clustering_ms + normals_ms);
      }
      const double p = median(frame_times.preprocess_ms), s = median(frame_times.ransac_ms),
                   c = median(frame_times.clustering_ms), n = median(frame_times.normals_ms),
                   t = median(frame_times.total_ms);
      all.preprocess_ms.push_back(p);
      all.ransac_ms.push_back(s);
      all.clustering_ms.push_back(c);
      all.normals_ms.push_back(n);
      all.total_ms.push_back(t);
      std::printf("%-24s %5d %8u %8.2f %8.2f %8.2f %8.2f %8.2f %7zu %s\n",
                  std::filesystem::path(path).stem().string().c_str(), frame, msg->width * msg->height, p, s, c, n, t,
                  object_points, status.c_str());
      ++frame;
    }
  }
  std::printf("median over %zu frames: preprocess %.2f ms, ransac %.2f ms, clustering %.2f ms, normals %.2f ms\n",
              all.total_ms.size(), median(all.preprocess_ms), median(all.ransac_ms), median(all.clustering_ms),
              median(all.normals_ms));
  std::printf("(of preprocess: voxel grid %.2f ms; not in the pipeline: pcl::fromROSMsg %.2f ms)\n",
              median(all_voxel_ms), median(all_conversion_ms));
  std::printf("total median: %.2f ms\n", median(all.total_ms));
  return all.total_ms.empty() ? 1 : 0;
}
