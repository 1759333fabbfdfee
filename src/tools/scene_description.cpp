#include "scene_description.h"

#include "fast_grasp/core/yaml_file.h"

#include <pcl/filters/voxel_grid.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
Eigen::Vector3d vec3(const YAML::Node& node, const char* key, const Eigen::Vector3d& fallback)
{
  if (!node[key])
    return fallback;
  const auto v = node[key].as<std::vector<double>>();
  if (v.size() != 3)
    throw std::runtime_error(std::string("'") + key + "' needs 3 numbers");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

std::vector<Eigen::Vector2d> pairs(const YAML::Node& node, const char* key)
{
  std::vector<Eigen::Vector2d> out;
  for (const auto& item : node[key])
  {
    const auto v = item.as<std::vector<double>>();
    if (v.size() != 2)
      throw std::runtime_error(std::string("'") + key + "' entries need 2 numbers");
    out.emplace_back(v[0], v[1]);
  }
  return out;
}

void setColour(ScenePart& part, const YAML::Node& node, const Eigen::Vector3d& fallback)
{
  const Eigen::Vector3d rgb = vec3(node, "rgb", fallback);
  part.red = static_cast<uint8_t>(std::clamp(rgb.x(), 0.0, 255.0));
  part.green = static_cast<uint8_t>(std::clamp(rgb.y(), 0.0, 255.0));
  part.blue = static_cast<uint8_t>(std::clamp(rgb.z(), 0.0, 255.0));
}

std::string directoryOf(const std::string& path)
{
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

// Builds one part's mesh in the object frame and describes where it came from.
TriangleMesh partMesh(const YAML::Node& node, const std::string& scene_path, const std::string& ycb_dir,
                      std::string& source)
{
  TriangleMesh mesh;
  if (node["mesh"])
  {
    const std::string ref = node["mesh"].as<std::string>();
    std::string path = ref;
    if (ref.rfind("ycb:", 0) == 0)
    {
      if (ycb_dir.empty())
        throw std::runtime_error("mesh '" + ref + "' needs --ycb-dir (or FAST_GRASP_YCB_DIR)");
      path = ycb_dir + "/" + ref.substr(4) + ".stl";
    }
    else if (!ref.empty() && ref[0] != '/')
      path = directoryOf(scene_path) + "/" + ref;
    std::string error;
    if (!loadMeshFile(path, mesh, error))
      throw std::runtime_error(error);
    const double scale = node["scale"] ? node["scale"].as<double>() : 1.0;
    for (auto& v : mesh.vertices)
      v *= static_cast<float>(scale);
    if (!node["centre_on_base"] || node["centre_on_base"].as<bool>())
      centreOnBase(mesh);
    source = ref.rfind("ycb:", 0) == 0 ? ref : "mesh:" + ref;
  }
  else
  {
    const std::string shape = node["shape"].as<std::string>();
    std::ostringstream description;
    description << "parametric:" << shape;
    if (shape == "box")
    {
      const Eigen::Vector3d size = vec3(node, "size_m", Eigen::Vector3d::Constant(0.1));
      mesh = makeBox(size.x(), size.y(), size.z());
      description << " " << size.x() << "x" << size.y() << "x" << size.z() << " m";
    }
    else if (shape == "cylinder")
    {
      const double r = node["radius_m"].as<double>(), h = node["height_m"].as<double>();
      mesh = makeCylinder(r, h);
      description << " r=" << r << " h=" << h << " m";
    }
    else if (shape == "sphere")
    {
      const double r = node["radius_m"].as<double>();
      mesh = makeSphere(r);
      description << " r=" << r << " m";
    }
    else if (shape == "revolution")
    {
      const auto profile = pairs(node, "profile_z_r_m");
      mesh = makeRevolution(profile, node["segments"] ? node["segments"].as<int>() : 48);
      description << " (" << profile.size() << "-point profile)";
    }
    else if (shape == "extrusion")
    {
      const auto polygon = pairs(node, "polygon_xy_m");
      const double t = node["thickness_m"].as<double>();
      mesh = makeExtrusion(polygon, t);
      description << " (" << polygon.size() << "-gon, " << t << " m thick)";
    }
    else
      throw std::runtime_error("unknown shape '" + shape + "' (box, cylinder, sphere, revolution, extrusion)");
    source = description.str();
  }
  const Eigen::Vector3d scale_xyz = vec3(node, "scale_xyz", Eigen::Vector3d::Ones());  // e.g. oval bottles
  for (auto& v : mesh.vertices)
    v = v.cwiseProduct(scale_xyz.cast<float>());
  const Eigen::Vector3d offset = vec3(node, "offset_m", Eigen::Vector3d::Zero());
  const Eigen::Vector3d rpy = vec3(node, "rpy_rad", Eigen::Vector3d::Zero());
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translate(offset.cast<float>());
  pose.rotate(Eigen::AngleAxisf(static_cast<float>(rpy.z()), Eigen::Vector3f::UnitZ()) *
              Eigen::AngleAxisf(static_cast<float>(rpy.y()), Eigen::Vector3f::UnitY()) *
              Eigen::AngleAxisf(static_cast<float>(rpy.x()), Eigen::Vector3f::UnitX()));
  mesh.transform(pose);
  return mesh;
}

}  // namespace

SceneDescription loadSceneDescription(const std::string& scene_path, const std::string& ycb_dir)
{
  const YAML::Node root = loadYamlFile(scene_path);
  SceneDescription scene;
  scene.name = root["name"].as<std::string>();
  scene.seed = root["seed"] ? root["seed"].as<uint64_t>() : 1;
  scene.frames = root["frames"] ? root["frames"].as<int>() : 1;
  if (scene.frames < 1 || scene.frames > 30)
    throw std::runtime_error("frames must be 1..30");
  scene.compression = root["compression"] ? root["compression"].as<std::string>() : "lz4";

  // Table: a box whose top face is the support plane, optionally tilted (roll about x, pitch
  // about y) so perception never gets an exactly horizontal z = 0 plane.
  const YAML::Node table = root["table"];
  const Eigen::Vector3d size = vec3(table, "size_m", Eigen::Vector3d(1.2, 0.8, 0.04));
  std::vector<double> centre_xy = table["centre_xy_m"] ? table["centre_xy_m"].as<std::vector<double>>()
                                                        : std::vector<double>{ 0.55, 0.0 };
  const double top_z = table["top_z_m"] ? table["top_z_m"].as<double>() : 0.0;
  const double roll = table["roll_rad"] ? table["roll_rad"].as<double>() : 0.0;
  const double pitch = table["pitch_rad"] ? table["pitch_rad"].as<double>() : 0.0;
  Eigen::Isometry3d table_pose = Eigen::Isometry3d::Identity();
  table_pose.translate(Eigen::Vector3d(centre_xy.at(0), centre_xy.at(1), top_z));
  table_pose.rotate(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d up = table_pose.linear().col(2);
  scene.table_plane << up, -up.dot(table_pose.translation());

  ScenePart table_part;
  table_part.mesh = makeBox(size.x(), size.y(), size.z());
  Eigen::Isometry3d table_box = table_pose * Eigen::Translation3d(0.0, 0.0, -size.z());
  table_part.mesh.transform(table_box.cast<float>());
  setColour(table_part, table, Eigen::Vector3d(150, 110, 75));
  table_part.label = kSceneBackgroundLabel;
  scene.parts.push_back(table_part);

  const double floor_drop = root["floor_drop_m"] ? root["floor_drop_m"].as<double>() : 0.75;
  ScenePart floor_part;
  floor_part.mesh = makeBox(8.0, 8.0, 0.01);
  floor_part.mesh.transform(Eigen::Isometry3f(Eigen::Translation3f(0.5f, 0.0f, static_cast<float>(top_z - floor_drop - 0.01))));
  floor_part.red = floor_part.green = floor_part.blue = 90;
  floor_part.label = kSceneBackgroundLabel;
  scene.parts.push_back(floor_part);

  int next_label = kSceneTargetLabel + 1;
  for (const auto& object : root["objects"])
  {
    SceneObject spec;
    spec.name = object["name"].as<std::string>();
    spec.target = object["target"] && object["target"].as<bool>();
    const auto xy = object["xy_m"].as<std::vector<double>>();
    const double yaw = object["yaw_rad"] ? object["yaw_rad"].as<double>() : 0.0;
    // Stand the object on the (possibly tilted) table at the given base_link x, y.
    spec.pose = table_pose * Eigen::Translation3d(xy.at(0) - centre_xy[0], xy.at(1) - centre_xy[1], 0.0) *
                Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    const int label = spec.target ? kSceneTargetLabel : next_label++;
    spec.label = label;
    std::vector<std::string> sources;
    float top = 0.0f;
    for (const auto& part_node : object["parts"])
    {
      ScenePart part;
      std::string source;
      part.mesh = partMesh(part_node, scene_path, ycb_dir, source);
      sources.push_back(source);
      top = std::max(top, part.mesh.maxCorner().z());
      part.mesh.transform(spec.pose.cast<float>());
      setColour(part, part_node, Eigen::Vector3d(200, 60, 40));
      part.transparent = part_node["transparent"] && part_node["transparent"].as<bool>();
      part.label = label;
      scene.parts.push_back(std::move(part));
    }
    if (sources.empty())
      throw std::runtime_error("object '" + spec.name + "' has no parts");
    spec.height_m = top;
    if (object["source"])
      spec.source = object["source"].as<std::string>();
    else
    {
      spec.source = sources.front();
      for (size_t i = 1; i < sources.size(); ++i)
        spec.source += " + " + sources[i];
    }
    scene.objects.push_back(spec);
  }
  if (std::count_if(scene.objects.begin(), scene.objects.end(), [](const SceneObject& o) { return o.target; }) != 1)
    throw std::runtime_error("exactly one object needs 'target: true'");

  for (const auto& camera : root["cameras"])
  {
    SceneCamera spec;
    spec.prefix = camera["prefix"] ? camera["prefix"].as<std::string>() : "camera";
    spec.optical_pose = lookAtOpticalPose(vec3(camera, "eye_m", Eigen::Vector3d::Zero()),
                                                      vec3(camera, "target_m", Eigen::Vector3d::UnitX()));
    scene.cameras.push_back(spec);
  }
  if (scene.cameras.empty() || scene.cameras.size() > 2)
    throw std::runtime_error("a scene needs one or two cameras");
  return scene;
}

std::uint64_t renderSeed(const SceneDescription& scene, std::size_t camera, int frame, int view)
{
  return scene.seed * 1000 + camera * 100 + static_cast<std::uint64_t>(frame) +
         (view > 0 ? 50 + static_cast<std::uint64_t>(view) : 0);
}

Eigen::Isometry3d linkFromOptical()
{
  Eigen::Isometry3d link_from_optical = Eigen::Isometry3d::Identity();
  link_from_optical.linear() = opticalFromLinkRotation().toRotationMatrix();
  return link_from_optical;
}

pcl::PointCloud<pcl::PointXYZRGB>::Ptr organisedCloud(const RenderedFrame& frame)
{
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZRGB>>();
  cloud->width = static_cast<std::uint32_t>(frame.width);
  cloud->height = static_cast<std::uint32_t>(frame.height);
  cloud->is_dense = false;
  cloud->points.resize(frame.points.size());
  for (std::size_t i = 0; i < frame.points.size(); ++i)
  {
    pcl::PointXYZRGB& point = cloud->points[i];
    point.getVector3fMap() = frame.points[i];
    const std::uint32_t rgb = frame.rgb[i];
    point.r = static_cast<std::uint8_t>((rgb >> 16) & 0xff);
    point.g = static_cast<std::uint8_t>((rgb >> 8) & 0xff);
    point.b = static_cast<std::uint8_t>(rgb & 0xff);
  }
  return cloud;
}

pcl::PointCloud<pcl::PointXYZ> voxelCentroids(const pcl::PointCloud<pcl::PointXYZ>& points, float leaf_m)
{
  pcl::PointCloud<pcl::PointXYZ> voxels;
  if (points.empty())
    return voxels;
  pcl::VoxelGrid<pcl::PointXYZ> grid;  // centroid per voxel
  grid.setInputCloud(points.makeShared());
  grid.setLeafSize(leaf_m, leaf_m, leaf_m);
  grid.filter(voxels);
  return voxels;
}

pcl::PointCloud<pcl::PointXYZ> surfacePoints(const std::vector<ScenePart>& parts, int label, float spacing_m,
                                             float leaf_m)
{
  pcl::PointCloud<pcl::PointXYZ> samples;
  for (const ScenePart& part : parts)
  {
    if (part.label != label)
      continue;
    const auto& v = part.mesh.vertices;
    for (const Eigen::Vector3i& t : part.mesh.triangles)
    {
      const Eigen::Vector3f a = v[t[0]], ab = v[t[1]] - a, ac = v[t[2]] - a;
      const float longest = std::max({ ab.norm(), ac.norm(), (ac - ab).norm() });
      const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing_m)));
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j)
        {
          const Eigen::Vector3f p = a + ab * (static_cast<float>(i) / n) + ac * (static_cast<float>(j) / n);
          samples.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
        }
    }
  }
  return voxelCentroids(samples, leaf_m);
}

}  // namespace fast_grasp
