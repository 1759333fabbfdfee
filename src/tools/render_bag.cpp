// render_bag: renders a scene YAML (config/scenes/*.yaml) into an Xtion-style rosbag plus a
// ground-truth sidecar. See docs/renderer.md.
//
//   render_bag <scene.yaml> <out.bag> [--ycb-dir DIR] [--truth FILE] [--preview FILE.pgm]
//
// Bag contents: /tf_static (latched, base_link -> <prefix>_link -> <prefix>_rgb_optical_frame),
// /clock (100 Hz sim time from t = 1.0 s), and per camera /<prefix>/depth_registered/points
// (organized 640x480 sensor_msgs/PointCloud2, x y z rgb, point_step 32) at 30 Hz.
#include "scene_description.h"

#include "fast_grasp/render/xtion_renderer.h"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <rosbag/bag.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
using fast_grasp::ScenePart;
using fast_grasp::TriangleMesh;

constexpr double kStartTimeS = 1.0;
constexpr double kFrameRateHz = 30.0;
constexpr double kClockRateHz = 100.0;

struct Options
{
  std::string scene_path;
  std::string bag_path;
  std::string truth_path;
  std::string preview_path;
  std::string ycb_dir;
};


// Organized XYZRGB cloud laid out exactly like openni2 / depth_image_proc's registered cloud.
sensor_msgs::PointCloud2 toMessage(const fast_grasp::RenderedFrame& frame, const std::string& frame_id,
                                   const ros::Time& stamp)
{
  sensor_msgs::PointCloud2 msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame_id;
  msg.height = static_cast<uint32_t>(frame.height);
  msg.width = static_cast<uint32_t>(frame.width);
  const char* names[] = { "x", "y", "z", "rgb" };
  const uint32_t offsets[] = { 0, 4, 8, 16 };
  for (int i = 0; i < 4; ++i)
  {
    sensor_msgs::PointField field;
    field.name = names[i];
    field.offset = offsets[i];
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    msg.fields.push_back(field);
  }
  msg.is_bigendian = false;
  msg.point_step = 32;
  msg.row_step = msg.point_step * msg.width;
  msg.is_dense = false;
  msg.data.assign(static_cast<size_t>(msg.row_step) * msg.height, 0);  // padding stays zero
  for (size_t i = 0; i < frame.points.size(); ++i)
  {
    uint8_t* p = &msg.data[i * msg.point_step];
    std::memcpy(p, frame.points[i].data(), 3 * sizeof(float));
    std::memcpy(p + 16, &frame.rgb[i], sizeof(uint32_t));  // packed as PCL's PointXYZRGB float rgb
  }
  return msg;
}

geometry_msgs::TransformStamped transformMsg(const std::string& parent, const std::string& child,
                                             const Eigen::Isometry3d& pose, const ros::Time& stamp)
{
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = pose.translation().x();
  t.transform.translation.y = pose.translation().y();
  t.transform.translation.z = pose.translation().z();
  const Eigen::Quaterniond q(pose.linear());
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  return t;
}

struct Visible
{
  pcl::PointCloud<pcl::PointXYZ> points;  // base_link
};

// The pixels of frame that see parts labelled `label` (default: the target), in base_link.
void collectVisible(const fast_grasp::RenderedFrame& frame, const Eigen::Isometry3d& optical_pose, Visible& out,
                    int label = fast_grasp::kSceneTargetLabel)
{
  const Eigen::Isometry3f pose = optical_pose.cast<float>();
  for (size_t i = 0; i < frame.points.size(); ++i)
    if (frame.part_label[i] == label && std::isfinite(frame.points[i].z()))
    {
      const Eigen::Vector3f p = pose * frame.points[i];
      out.points.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
}

void emitVec(YAML::Emitter& out, const Eigen::Vector3d& v)
{
  out << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}

void emitPose(YAML::Emitter& out, const std::string& frame, const Eigen::Isometry3d& pose)
{
  const Eigen::Quaterniond q(pose.linear());
  out << YAML::Flow << YAML::BeginMap << YAML::Key << "frame" << YAML::Value << frame;
  out << YAML::Key << "position" << YAML::Value;
  emitVec(out, pose.translation());
  out << YAML::Key << "orientation_xyzw" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.x() << q.y() << q.z()
      << q.w() << YAML::EndSeq << YAML::EndMap;
}

// key: [[x, y, z], ...]; coordinates rounded to round_m when it is > 0.
void emitPoints(YAML::Emitter& out, const std::string& key, const pcl::PointCloud<pcl::PointXYZ>& points,
                float round_m = 0.0f)
{
  const auto rounded = [round_m](float v) { return round_m > 0.0f ? std::round(v / round_m) * round_m : v; };
  out << YAML::Key << key << YAML::Value << YAML::BeginSeq;
  for (const auto& p : points.points)
    out << YAML::Flow << YAML::BeginSeq << rounded(p.x) << rounded(p.y) << rounded(p.z) << YAML::EndSeq;
  out << YAML::EndSeq;
}

void emitVisible(YAML::Emitter& out, const std::string& prefix, const Visible& visible)
{
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const auto& p : visible.points)
  {
    const Eigen::Vector3d v(p.x, p.y, p.z);
    centroid += v;
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const size_t n = visible.points.size();
  if (n > 0)
    centroid /= static_cast<double>(n);
  else
    lo = hi = Eigen::Vector3d::Zero();
  out << YAML::Key << prefix + "visible_points" << YAML::Value << n;
  out << YAML::Key << prefix + "visible_centroid" << YAML::Value;
  emitVec(out, centroid);
  out << YAML::Key << prefix + "visible_extent" << YAML::Value;
  emitVec(out, hi - lo);
  emitPoints(out, prefix + "visible_points_1cm", fast_grasp::voxelCentroids(visible.points, 0.01f));
}

// Every scene object in scene order (issue 11 clutter bags): pose, part label, its own noise-free
// visible points in frame 0 of the first camera, and its whole surface at kSurfaceLeafM.
constexpr float kSurfaceLeafM = 0.005f;
constexpr float kSurfaceSpacingM = 0.0025f;

void emitObjects(YAML::Emitter& out, const fast_grasp::SceneDescription& scene, const fast_grasp::RenderedFrame& frame)
{
  out << YAML::Key << "objects" << YAML::Value << YAML::BeginSeq;
  for (const fast_grasp::SceneObject& object : scene.objects)
  {
    Visible visible;
    collectVisible(frame, scene.cameras[0].optical_pose, visible, object.label);
    const Eigen::Quaterniond q(object.pose.linear());
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << object.name;
    out << YAML::Key << "target" << YAML::Value << object.target;
    out << YAML::Key << "label" << YAML::Value << object.label;
    out << YAML::Key << "source" << YAML::Value << YAML::DoubleQuoted << object.source;
    out << YAML::Key << "position" << YAML::Value;
    emitVec(out, object.pose.translation());
    out << YAML::Key << "orientation_xyzw" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.x() << q.y() << q.z()
        << q.w() << YAML::EndSeq;
    out << YAML::Key << "height_m" << YAML::Value << object.height_m;
    out << YAML::Key << "visible_points" << YAML::Value << visible.points.size();
    emitPoints(out, "visible_points_1cm", fast_grasp::voxelCentroids(visible.points, 0.01f));
    // rounded to 0.1 mm: a tenth of the voxel's half size, and a shorter file
    emitPoints(out, "surface_points_5mm", fast_grasp::surfacePoints(scene.parts, object.label, kSurfaceSpacingM, kSurfaceLeafM),
               1e-4f);
    out << YAML::EndMap;
    std::cout << "  " << object.name << " (label " << object.label << (object.target ? ", target" : "")
              << "): " << visible.points.size() << " visible points" << std::endl;
  }
  out << YAML::EndSeq;
}

void writePreview(const fast_grasp::RenderedFrame& frame, const std::string& path)
{
  // 8-bit depth image (near = bright, NaN = black) for a quick look at a scene.
  std::ofstream file(path, std::ios::binary);
  file << "P5\n" << frame.width << " " << frame.height << "\n255\n";
  for (const auto& p : frame.points)
  {
    const double z = p.z();
    const uint8_t value = std::isfinite(z) ? static_cast<uint8_t>(std::clamp(255.0 - (z - 0.4) * 110.0, 16.0, 255.0)) : 0;
    file.put(static_cast<char>(value));
  }
}

boost::shared_ptr<ros::M_string> latchedHeader(const std::string& topic)
{
  auto header = boost::make_shared<ros::M_string>();
  (*header)["topic"] = topic;
  (*header)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
  (*header)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
  (*header)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
  (*header)["callerid"] = "/render_bag";
  (*header)["latching"] = "1";  // rosbag play republishes /tf_static latched
  return header;
}

int run(const Options& options)
{
  const fast_grasp::SceneDescription scene = fast_grasp::loadSceneDescription(options.scene_path, options.ycb_dir);
  const fast_grasp::XtionRenderer renderer(scene.parts);
  std::cout << scene.name << ": " << renderer.triangleCount() << " triangles, " << scene.frames << " frame(s), "
            << scene.cameras.size() << " camera(s)" << std::endl;

  rosbag::Bag bag;
  bag.open(options.bag_path, rosbag::bagmode::Write);
  if (scene.compression == "bz2")
    bag.setCompression(rosbag::compression::BZ2);
  else if (scene.compression == "lz4")
    bag.setCompression(rosbag::compression::LZ4);
  else if (scene.compression != "none")
    throw std::runtime_error("compression must be bz2, lz4 or none");

  const ros::Time start(kStartTimeS);
  tf2_msgs::TFMessage tf_static;
  for (const auto& camera : scene.cameras)
  {
    const Eigen::Isometry3d link_from_optical = fast_grasp::linkFromOptical();
    const Eigen::Isometry3d link_pose = camera.optical_pose * link_from_optical.inverse();
    tf_static.transforms.push_back(transformMsg("base_link", camera.prefix + "_link", link_pose, start));
    tf_static.transforms.push_back(
        transformMsg(camera.prefix + "_link", camera.prefix + "_rgb_optical_frame", link_from_optical, start));
  }
  bag.write("/tf_static", start, tf_static, latchedHeader("/tf_static"));

  const double last_frame_s = kStartTimeS + (scene.frames - 1) / kFrameRateHz;
  const int clock_ticks = static_cast<int>(std::ceil((last_frame_s + 0.1 - kStartTimeS) * kClockRateHz));
  int next_tick = 0;
  auto writeClockUntil = [&](double until_s) {
    for (; next_tick <= clock_ticks && kStartTimeS + next_tick / kClockRateHz <= until_s + 1e-9; ++next_tick)
    {
      rosgraph_msgs::Clock clock;
      clock.clock = ros::Time(kStartTimeS + next_tick / kClockRateHz);
      bag.write("/clock", clock.clock, clock);
    }
  };
  for (int f = 0; f < scene.frames; ++f)
  {
    const double t = kStartTimeS + f / kFrameRateHz;
    writeClockUntil(t);
    for (size_t c = 0; c < scene.cameras.size(); ++c)
    {
      const auto& camera = scene.cameras[c];
      const fast_grasp::RenderedFrame frame = renderer.render(camera.optical_pose, fast_grasp::renderSeed(scene, c, f));
      if (f == 0 && c == 0 && !options.preview_path.empty())
        writePreview(frame, options.preview_path);
      bag.write("/" + camera.prefix + "/depth_registered/points", ros::Time(t),
                toMessage(frame, camera.prefix + "_rgb_optical_frame", ros::Time(t)));
    }
  }
  writeClockUntil(last_frame_s + 0.1);
  bag.close();

  // Ground truth: noise-free object pixels of frame 0, in base_link.
  const fast_grasp::SceneObject& target = *std::find_if(scene.objects.begin(), scene.objects.end(), [](const fast_grasp::SceneObject& o) { return o.target; });
  YAML::Emitter out;
  out.SetDoublePrecision(6);
  out.SetFloatPrecision(6);
  out << YAML::BeginMap;
  out << YAML::Key << "scene" << YAML::Value << scene.name;
  const std::string bag_name = options.bag_path.substr(options.bag_path.find_last_of('/') + 1);
  out << YAML::Key << "bag" << YAML::Value << bag_name;
  out << YAML::Key << "frames" << YAML::Value << scene.frames;
  out << YAML::Key << "seed" << YAML::Value << scene.seed;
  out << YAML::Key << "object" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << target.name;
  out << YAML::Key << "source" << YAML::Value << YAML::DoubleQuoted << target.source;
  out << YAML::Key << "position" << YAML::Value;
  emitVec(out, target.pose.translation());
  const Eigen::Quaterniond q(target.pose.linear());
  out << YAML::Key << "orientation_xyzw" << YAML::Value << YAML::Flow << YAML::BeginSeq << q.x() << q.y() << q.z()
      << q.w() << YAML::EndSeq;
  out << YAML::Key << "height_m" << YAML::Value << target.height_m;
  out << YAML::EndMap;
  out << YAML::Key << "distractors" << YAML::Value << YAML::BeginSeq;
  for (const auto& o : scene.objects)
    if (!o.target)
    {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << o.name << YAML::Key << "position"
          << YAML::Value;
      emitVec(out, o.pose.translation());
      out << YAML::EndMap;
    }
  out << YAML::EndSeq;
  out << YAML::Key << "table_plane" << YAML::Value << YAML::Flow << YAML::BeginSeq << scene.table_plane[0]
      << scene.table_plane[1] << scene.table_plane[2] << scene.table_plane[3] << YAML::EndSeq;
  out << YAML::Key << "camera_pose" << YAML::Value;
  emitPose(out, scene.cameras[0].prefix + "_rgb_optical_frame", scene.cameras[0].optical_pose);
  out << YAML::Key << "topic" << YAML::Value << "/" + scene.cameras[0].prefix + "/depth_registered/points";
  const fast_grasp::RenderedFrame noise_free = renderer.renderNoiseFree(scene.cameras[0].optical_pose);
  Visible first;
  collectVisible(noise_free, scene.cameras[0].optical_pose, first);
  emitVisible(out, "", first);
  std::cout << "  visible target points (noise-free, frame 0): " << first.points.size() << std::endl;
  if (scene.cameras.size() == 2)
  {
    const auto& head = scene.cameras[1];
    out << YAML::Key << "head_camera_pose" << YAML::Value;
    emitPose(out, head.prefix + "_rgb_optical_frame", head.optical_pose);
    out << YAML::Key << "head_topic" << YAML::Value << "/" + head.prefix + "/depth_registered/points";
    Visible second;
    collectVisible(renderer.renderNoiseFree(head.optical_pose), head.optical_pose, second);
    emitVisible(out, "head_", second);
    Visible both = first;
    both.points += second.points;
    emitVisible(out, "union_", both);
    std::cout << "  visible from head camera: " << second.points.size() << ", union: " << both.points.size()
              << std::endl;
  }
  emitObjects(out, scene, noise_free);
  out << YAML::EndMap;
  std::ofstream truth(options.truth_path);
  truth << "# Ground truth for " << bag_name << " (written by render_bag; see docs/renderer.md)\n"
        << out.c_str() << "\n";
  if (!truth)
    throw std::runtime_error("cannot write " + options.truth_path);
  if (first.points.empty())
    std::cerr << "warning: the target is not visible in frame 0" << std::endl;
  return 0;
}

void usage(std::ostream& out = std::cerr)
{
  out << "usage: render_bag <scene.yaml> <out.bag> [--ycb-dir DIR] [--truth FILE] [--preview FILE.pgm]\n"
               "  --ycb-dir: folder of YCB STL files for 'ycb:NAME' meshes (default $FAST_GRASP_YCB_DIR)\n"
               "  --truth:   ground-truth sidecar (default: <out>.truth.yaml beside the bag)\n";
}
}  // namespace

int main(int argc, char** argv)
{
  Options options;
  if (const char* env = std::getenv("FAST_GRASP_YCB_DIR"))
    options.ycb_dir = env;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if ((arg == "--ycb-dir" || arg == "--truth" || arg == "--preview") && i + 1 < argc)
    {
      const std::string value = argv[++i];
      (arg == "--ycb-dir" ? options.ycb_dir : arg == "--truth" ? options.truth_path : options.preview_path) = value;
    }
    else if (arg == "-h" || arg == "--help")
    {
      usage(std::cout);
      return 0;
    }
    else if (arg.rfind("-", 0) == 0)
    {
      std::cerr << "unknown flag " << arg << "\n";
      usage();
      return 2;
    }
    else
      positional.push_back(arg);
  }
  if (positional.size() != 2)
  {
    usage();
    return 2;
  }
  options.scene_path = positional[0];
  options.bag_path = positional[1];
  if (options.truth_path.empty())
  {
    std::string stem = options.bag_path;
    if (stem.size() > 4 && stem.substr(stem.size() - 4) == ".bag")
      stem.resize(stem.size() - 4);
    options.truth_path = stem + ".truth.yaml";
  }
  try
  {
    return run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "render_bag: " << options.scene_path << ": " << e.what() << std::endl;
    return 1;
  }
}
