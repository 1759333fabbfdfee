// bench_segmentation: how many labelled objects of real Kinect tabletop scenes come out of the
// table segmentation as exactly one cluster, and the ms per frame, one core.
//
// Input: the mOSD learn set (../shared/data/mosd-learn, not in the repository: organised
// 640x480 PCDs with fields label x y z rgba; labels 1-9 table, label / 10 = object id). Per
// scene the timed work (thread CPU time: one core's share, not inflated by other processes) is
// what the deployed pipeline does to a frame: preprocessCloud (every
// 2nd row and column, 5 mm voxel grid; --sampling deployed, the default) and segmentTable()
// with the deployed parameters of config/perception.yaml. Each voxel takes the label most of
// the sampled pixels in it carry (not timed). --sampling uniform reads every pixel and keeps
// one real point per 5 mm (pcl::UniformSampling, sessions 7-15's protocol). The table up axis
// is taken from the table-labelled points (the scenes give no camera pose). Each labelled object is matched to the
// cluster holding most of its points: "right" when that cluster's precision >= 0.9 and the
// object's recall >= 0.8, "merged" when the precision is lower (the cluster holds other
// objects), "split" otherwise. Objects with fewer than --min-points down-sampled points are
// not counted; "fits" = the object's narrowest horizontal width of seen points is within the
// gripper opening (--opening, default the Robotiq 2F-85's 0.085 m).
//
// Scenes are split for development (even numbers: tune on these) and held out (odd numbers:
// report, never tune), --split dev | heldout | all.
//
//   rosrun fast_grasp bench_segmentation [--data DIR] [--split S] [--min-points N] [--opening M] [--scenes a,b]
// Last line: `segmentation: right P % (fits: Q %) merged M % split S % median X ms per frame`.
#include "bench_stats.h"
#include "command_line.h"
#include "fast_grasp/perception/cloud_preprocess.h"
#include "fast_grasp/perception/concave_split.h"
#include "fast_grasp/perception/table_segmentation.h"

#include <pcl/filters/uniform_sampling.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <unordered_map>
#include <sstream>
#include <string>
#include <vector>

namespace
{
using LabelledCloud = pcl::PointCloud<pcl::PointXYZRGBL>;

using fast_grasp::median;

/// Least-squares normal of the table-labelled points, turned toward the camera (origin).
Eigen::Vector3f tableUp(const LabelledCloud& cloud)
{
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (const auto& p : cloud.points)
    if (p.label >= 1 && p.label <= 9 && std::isfinite(p.z))
    {
      mean += p.getVector3fMap().cast<double>();
      ++n;
    }
  if (n < 3)
    return Eigen::Vector3f(0.0f, -1.0f, 0.0f);
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : cloud.points)
    if (p.label >= 1 && p.label <= 9 && std::isfinite(p.z))
    {
      const Eigen::Vector3d d = p.getVector3fMap().cast<double>() - mean;
      cov += d * d.transpose();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
  Eigen::Vector3d up = solver.eigenvectors().col(0);
  if (up.dot(-mean) < 0.0)
    up = -up;  // the camera is above the table
  return up.cast<float>();
}

/// Narrowest width of the points across directions in the plane perpendicular to `up`.
double narrowestWidth(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& up)
{
  const Eigen::Vector3f seed = std::abs(up.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
  const Eigen::Vector3f e1 = (seed - seed.dot(up) * up).normalized(), e2 = up.cross(e1);
  double best = 1e9;
  for (int k = 0; k < 36; ++k)
  {
    const double a = M_PI * k / 36.0;
    const Eigen::Vector3f d = static_cast<float>(std::cos(a)) * e1 + static_cast<float>(std::sin(a)) * e2;
    float lo = 1e9f, hi = -1e9f;
    for (const auto& p : points)
    {
      lo = std::min(lo, d.dot(p));
      hi = std::max(hi, d.dot(p));
    }
    best = std::min(best, static_cast<double>(hi - lo));
  }
  return best;
}

/// Experiment (--method lccp): re-cut the clusters above the table by PCL's LCCP (supervoxels
/// joined across convex edges; objects meet at concave ones), so touching objects separate.
std::vector<pcl::PointIndices> lccpClusters(const fast_grasp::CloudXYZ& cloud, const std::vector<pcl::PointIndices>& clusters,
                                            float seed_m, float concavity_deg)
{
  fast_grasp::CloudXYZ::Ptr above(new fast_grasp::CloudXYZ);
  std::vector<int> index_of;
  for (const auto& c : clusters)
    for (const int i : c.indices)
    {
      above->push_back(cloud[static_cast<std::size_t>(i)]);
      index_of.push_back(i);
    }
  if (above->empty())
    return clusters;
  pcl::SupervoxelClustering<pcl::PointXYZ> super(0.005f, seed_m);
  super.setUseSingleCameraTransform(false);
  super.setInputCloud(above);
  super.setColorImportance(0.0f);
  super.setSpatialImportance(1.0f);
  super.setNormalImportance(4.0f);
  std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr> supervoxels;
  super.extract(supervoxels);
  std::multimap<std::uint32_t, std::uint32_t> adjacency;
  super.getSupervoxelAdjacency(adjacency);
  pcl::LCCPSegmentation<pcl::PointXYZ> lccp;
  lccp.setConcavityToleranceThreshold(concavity_deg);
  lccp.setSanityCheck(true);
  lccp.setSmoothnessCheck(true, 0.005f, seed_m, 0.1f);
  lccp.setKFactor(1);
  lccp.setMinSegmentSize(3);
  lccp.setInputSupervoxels(supervoxels, adjacency);
  lccp.segment();
  pcl::PointCloud<pcl::PointXYZL>::Ptr labelled = super.getLabeledCloud();
  lccp.relabelCloud(*labelled);
  // The labelled cloud is the voxelised input: give each input point its nearest voxel's label.
  pcl::search::KdTree<pcl::PointXYZL> tree;
  tree.setInputCloud(labelled);
  std::map<std::uint32_t, pcl::PointIndices> by_label;
  std::vector<int> nearest(1);
  std::vector<float> distance(1);
  for (std::size_t k = 0; k < above->size(); ++k)
  {
    pcl::PointXYZL q;
    q.x = (*above)[k].x;
    q.y = (*above)[k].y;
    q.z = (*above)[k].z;
    if (tree.nearestKSearch(q, 1, nearest, distance) > 0)
      by_label[(*labelled)[static_cast<std::size_t>(nearest[0])].label].indices.push_back(index_of[k]);
  }
  std::vector<pcl::PointIndices> out;
  for (auto& [label, indices] : by_label)
    if (indices.indices.size() >= 30)
      out.push_back(std::move(indices));
  return out;
}

/// Side-by-side image (labels left, clusters right) of the sampled points projected with the
/// Kinect's nominal intrinsics (525 px focal length), as a binary PPM.
void writeLabelImage(const std::string& path, const LabelledCloud& sampled, const std::vector<int>& cluster_of)
{
  const int w = 640, h = 480;
  std::vector<unsigned char> image(static_cast<std::size_t>(2 * w * h * 3), 0);
  auto colour = [](int id, int k) {
    if (id < 0)
      return 40;
    const unsigned hash = static_cast<unsigned>(id + 1) * 2654435761u;
    return 60 + static_cast<int>((hash >> (8 * k)) & 0xff) * 195 / 255;
  };
  for (std::size_t i = 0; i < sampled.size(); ++i)
  {
    const auto& p = sampled[i];
    const int u = static_cast<int>(525.0f * p.x / p.z + 319.5f), v = static_cast<int>(525.0f * p.y / p.z + 239.5f);
    const int label = p.label >= 10 ? static_cast<int>(p.label / 10) : (p.label >= 1 ? 0 : -1);
    for (int du = -1; du <= 1; ++du)
      for (int dv = -1; dv <= 1; ++dv)
      {
        const int x = u + du, y = v + dv;
        if (x < 0 || x >= w || y < 0 || y >= h)
          continue;
        for (int k = 0; k < 3; ++k)
        {
          image[static_cast<std::size_t>((y * 2 * w + x) * 3 + k)] = static_cast<unsigned char>(label == 0 ? 90 : colour(label * 7, k));
          image[static_cast<std::size_t>((y * 2 * w + w + x) * 3 + k)] = static_cast<unsigned char>(colour(cluster_of[i], k));
        }
      }
  }
  FILE* out = std::fopen(path.c_str(), "wb");
  if (!out)
    return;
  std::fprintf(out, "P6\n%d %d\n255\n", 2 * w, h);
  std::fwrite(image.data(), 1, image.size(), out);
  std::fclose(out);
}

/// The voxel of a point as pcl::VoxelGrid indexes it (floor of coordinate times the inverse leaf).
std::int64_t voxelKey(const Eigen::Vector3f& p, float inverse_leaf)
{
  const auto cell = [&](float v) { return static_cast<std::int64_t>(std::floor(v * inverse_leaf)) & 0x1fffff; };
  return (cell(p.x()) << 42) | (cell(p.y()) << 21) | cell(p.z());
}

/// What the deployed pipeline does to a frame, timed: preprocessCloud on the organised cloud
/// (identity transform: the scene stays in the camera frame; no reach crop) and segmentTable.
/// Each voxel point then gets the label most sampled pixels in its voxel carry (not timed).
fast_grasp::TableSegmentationResult segmentDeployed(const LabelledCloud& raw,
                                                    const fast_grasp::TableSegmentationParams& params,
                                                    LabelledCloud& labelled, double& ms, double& preprocess_ms)
{
  pcl::PointCloud<pcl::PointXYZRGB> frame;  // what the camera driver gives (not timed)
  frame.width = raw.width;
  frame.height = raw.height;
  frame.is_dense = false;
  frame.points.resize(raw.size());
  for (std::size_t i = 0; i < raw.size(); ++i)
  {
    frame.points[i].x = raw.points[i].x;
    frame.points[i].y = raw.points[i].y;
    frame.points[i].z = raw.points[i].z;
  }
  fast_grasp::PreprocessParams preprocess;  // config/perception.yaml's stride and leaf
  preprocess.reach_m = 1e3;
  const double start_ms = fast_grasp::threadCpuMs();
  const fast_grasp::PreprocessResult sampled = fast_grasp::preprocessCloud(frame, Eigen::Isometry3f::Identity(), preprocess);
  preprocess_ms = fast_grasp::threadCpuMs() - start_ms;
  fast_grasp::TableSegmentationResult result;
  if (sampled.ok)
    result = fast_grasp::segmentTable(sampled.cloud, params);
  ms = fast_grasp::threadCpuMs() - start_ms;
  labelled.clear();
  if (!sampled.ok)
    return result;
  const float inverse_leaf = 1.0f / static_cast<float>(preprocess.leaf_size_m);
  std::unordered_map<std::int64_t, std::map<std::uint32_t, int>> votes;
  const std::size_t stride = sampled.sampling_stride;
  for (std::size_t row = 0; row < raw.height; row += stride)
    for (std::size_t col = 0; col < raw.width; col += stride)
    {
      const auto& p = raw.at(static_cast<int>(col), static_cast<int>(row));
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
        ++votes[voxelKey(p.getVector3fMap(), inverse_leaf)][p.label];
    }
  for (const auto& p : sampled.cloud->points)
  {
    pcl::PointXYZRGBL q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.label = 0;
    const auto it = votes.find(voxelKey(p.getVector3fMap(), inverse_leaf));
    if (it != votes.end())
      q.label = std::max_element(it->second.begin(), it->second.end(),
                                 [](const auto& a, const auto& b) { return a.second < b.second; })
                    ->first;
    labelled.push_back(q);
  }
  return result;
}

struct Counts
{
  int objects = 0, right = 0, merged = 0, split = 0;
  int fit_objects = 0, fit_right = 0;
  int clusters = 0, spurious = 0;  // clusters, and those mostly of unlabelled or table points
};
}  // namespace

int main(int argc, char** argv)
{
  static const char* const kUsage =
      "usage: bench_segmentation [--data DIR] [--split dev|heldout|all] [--min-points N] [--opening M]\n"
      "                          [--scenes learn0,learn5]\n"
      "  labelled objects of the mOSD learn scenes that come out as exactly one cluster, and ms per frame\n"
      "  --data DIR        folder of learn*.pcd (default $FAST_GRASP_MOSD_DIR or ../shared/data/mosd-learn)\n"
      "  --split S         dev (even-numbered scenes, tune on these), heldout (odd) or all (default)\n"
      "  --min-points N    objects with fewer down-sampled points are not counted (default 50)\n"
      "  --opening M       gripper opening for the 'fits' count (default 0.085)\n"
      "  --scenes LIST     only these scenes\n"
      "  --dump-dir DIR    write DIR/<scene>.ppm: labels (left) and clusters (right) in the image\n"
      "  --sampling S      deployed (preprocessCloud: every 2nd pixel, 5 mm voxel grid; default) or uniform\n"
      "                    (every pixel, one real point per 5 mm: pcl::UniformSampling)\n"
      "  --method M        concave (the pipeline's: Euclidean clusters cut at concave creases, default),\n"
      "                    euclidean (Euclidean clusters only) or lccp (experiment: PCL's LCCP over the\n"
      "                    Euclidean clusters, --seed-m supervoxel seed size, default 0.03, --concavity-deg, default 10)\n"
      "  --tolerance-rad R, --link-radius-m M, --k N, --min-piece N, --min-standing-piece N: the concave\n"
      "                    split's parameters\n"
      "  --join-occluded 0|1 join an object's pieces a nearer object hides in the middle (default: config's)\n"
      "  --join-containers 0|1 join a container's inside to its outer wall across a gap (default: config's)\n"
      "  --min-cluster-points N, --min-height-m H: the segmentation's smallest cluster and lowest object point\n"
      "                    (default: config/perception.yaml's)\n"
      "  --plane-distance-m D  the table band: points within D of the plane are table, never object\n"
      "                    (default 0.01, config/perception.yaml's)\n";
  fast_grasp::exitOnHelpFlag(argc, argv, kUsage);
  std::string data = std::getenv("FAST_GRASP_MOSD_DIR") ? std::getenv("FAST_GRASP_MOSD_DIR") : "";
  if (data.empty())
    data = std::string(FAST_GRASP_SOURCE_DIR) + "/../shared/data/mosd-learn";
  std::size_t min_points = 50;
  double opening = 0.085;
  std::set<std::string> only;
  std::string split = "all";
  std::string method = "concave";
  std::string sampling = "deployed";
  fast_grasp::TableSegmentationParams params;  // config/perception.yaml's values
  float seed_m = 0.03f, concavity_deg = 10.0f;
  double plane_distance_m = 0.01;  // config/perception.yaml plane_distance_m
  std::string dump_dir;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    if (i + 1 >= argc)
      fast_grasp::exitWithUsage("flag " + flag + " needs a value", kUsage);
    const std::string value = argv[++i];
    if (flag == "--data")
      data = value;
    else if (flag == "--min-points")
      min_points = static_cast<std::size_t>(std::stoul(value));
    else if (flag == "--split")
    {
      split = value;
      if (split != "dev" && split != "heldout" && split != "all")
        fast_grasp::exitWithUsage("--split: '" + split + "' is none of dev, heldout, all", kUsage);
    }
    else if (flag == "--method")
      method = value;
    else if (flag == "--sampling")
    {
      sampling = value;
      if (sampling != "deployed" && sampling != "uniform")
        fast_grasp::exitWithUsage("--sampling: '" + sampling + "' is none of deployed, uniform", kUsage);
    }
    else if (flag == "--tolerance-rad")
      params.concave_split.concave_tolerance_rad = std::stod(value);
    else if (flag == "--link-radius-m")
      params.concave_split.link_radius_m = std::stod(value);
    else if (flag == "--k")
      params.concave_split.k_neighbours = std::stoi(value);
    else if (flag == "--min-piece")
      params.concave_split.min_piece_points = std::stoi(value);
    else if (flag == "--min-standing-piece")
      params.concave_split.min_standing_piece_points = std::stoi(value);
    else if (flag == "--join-occluded")
      params.join_occluded_pieces = value == "1" || value == "true";
    else if (flag == "--join-containers")
      params.join_container_insides = value == "1" || value == "true";
    else if (flag == "--min-cluster-points")
      params.min_cluster_points = std::stoi(value);
    else if (flag == "--min-height-m")
      params.min_height_above_table_m = std::stod(value);
    else if (flag == "--plane-distance-m")
      plane_distance_m = std::stod(value);
    else if (flag == "--seed-m")
      seed_m = std::stof(value);
    else if (flag == "--concavity-deg")
      concavity_deg = std::stof(value);
    else if (flag == "--dump-dir")
      dump_dir = value;
    else if (flag == "--opening")
      opening = std::stod(value);
    else if (flag == "--scenes")
    {
      std::stringstream list(value);
      std::string name;
      while (std::getline(list, name, ','))
        only.insert(name);
    }
    else
      fast_grasp::exitWithUsage("unknown flag " + flag, kUsage);
  }
  std::vector<std::string> files;
  if (std::filesystem::is_directory(data))
    for (const auto& entry : std::filesystem::directory_iterator(data))
      if (entry.path().extension() == ".pcd" && (only.empty() || only.count(entry.path().stem().string())))
        files.push_back(entry.path().string());
  if (files.empty())
  {
    std::fprintf(stderr, "bench_segmentation: no PCD files in %s (the mOSD learn set; see --help)\n", data.c_str());
    return 1;
  }
  std::sort(files.begin(), files.end(), [](const std::string& a, const std::string& b) {
    auto number = [](const std::string& s) {
      const std::string stem = std::filesystem::path(s).stem().string();
      const auto digits = stem.find_first_of("0123456789");
      return digits == std::string::npos ? 0 : std::stoi(stem.substr(digits));
    };
    return number(a) < number(b);
  });
  if (split != "all")
  {
    std::vector<std::string> kept;
    for (const std::string& f : files)
    {
      const std::string stem = std::filesystem::path(f).stem().string();
      const auto digits = stem.find_first_of("0123456789");
      const int n = digits == std::string::npos ? 0 : std::stoi(stem.substr(digits));
      if ((n % 2 == 0) == (split == "dev"))
        kept.push_back(f);
    }
    files.swap(kept);
  }

  params.plane_distance_m = plane_distance_m;
  params.cluster_tolerance_m = 0.02;
  params.max_object_distance_m = 0.0;  // no robot here: every cluster counts
  params.split_concave_creases = method == "concave";  // lccp re-cuts the Euclidean clusters
  if (method != "euclidean" && method != "concave" && method != "lccp")
    fast_grasp::exitWithUsage("--method: '" + method + "' is none of concave, euclidean, lccp", kUsage);
  Counts total;
  std::vector<double> frame_ms;
  // Of frame_ms (--sampling deployed): preprocessCloud, the table's RANSAC, the clusters.
  std::vector<double> preprocess_frame_ms, ransac_frame_ms, clustering_frame_ms;
  std::printf("%-10s %7s %5s %5s %6s %5s %8s\n", "scene", "objects", "right", "merged", "split", "fits", "ms");
  for (const std::string& file : files)
  {
    LabelledCloud::Ptr raw(new LabelledCloud);
    if (pcl::io::loadPCDFile(file, *raw) < 0)
    {
      std::fprintf(stderr, "bench_segmentation: cannot read %s\n", file.c_str());
      continue;
    }
    params.up_axis = tableUp(*raw);  // ground truth stands in for the camera pose: not timed
    LabelledCloud sampled;
    fast_grasp::TableSegmentationResult result;
    double ms = 0.0;
    fast_grasp::CloudXYZ xyz;  // the segmented points, for lccp
    if (sampling == "deployed")
    {
      double preprocess_ms = 0.0;
      result = segmentDeployed(*raw, params, sampled, ms, preprocess_ms);
      preprocess_frame_ms.push_back(preprocess_ms);
      ransac_frame_ms.push_back(1e3 * result.ransac_time_s);
      clustering_frame_ms.push_back(1e3 * result.clustering_time_s);
      for (const auto& p : sampled.points)
        xyz.push_back(pcl::PointXYZ(p.x, p.y, p.z));
    }
    else
    {
      const double start_ms = fast_grasp::threadCpuMs();
      // One real point per 5 mm voxel, so every point keeps its label.
      LabelledCloud::Ptr finite(new LabelledCloud);
      for (const auto& p : raw->points)
        if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
          finite->push_back(p);
      pcl::UniformSampling<pcl::PointXYZRGBL> uniform;
      uniform.setInputCloud(finite);
      uniform.setRadiusSearch(0.005);
      uniform.filter(sampled);
      fast_grasp::CloudXYZ::Ptr cloud(new fast_grasp::CloudXYZ);
      cloud->reserve(sampled.size());
      for (const auto& p : sampled.points)
        cloud->push_back(pcl::PointXYZ(p.x, p.y, p.z));
      result = fast_grasp::segmentTable(cloud, params);
      ms = fast_grasp::threadCpuMs() - start_ms;
      xyz = *cloud;
    }
    if (method == "lccp")
      result.clusters = lccpClusters(xyz, result.clusters, seed_m, concavity_deg);
    frame_ms.push_back(ms);

    // Ground truth: object id per sampled point.
    std::map<int, std::vector<std::size_t>> objects;
    for (std::size_t i = 0; i < sampled.size(); ++i)
      if (sampled[i].label >= 10)
        objects[static_cast<int>(sampled[i].label / 10)].push_back(i);
    std::vector<int> cluster_of(sampled.size(), -1);
    for (std::size_t c = 0; c < result.clusters.size(); ++c)
      for (const int i : result.clusters[c].indices)
        cluster_of[static_cast<std::size_t>(i)] = static_cast<int>(c);
    if (!dump_dir.empty())
      writeLabelImage(dump_dir + "/" + std::filesystem::path(file).stem().string() + ".ppm", sampled, cluster_of);
    Counts scene;
    for (const auto& [id, members] : objects)
    {
      if (members.size() < min_points)
        continue;
      std::map<int, std::size_t> overlap;
      for (const std::size_t i : members)
        if (cluster_of[i] >= 0)
          ++overlap[cluster_of[i]];
      int best = -1;
      std::size_t best_overlap = 0;
      for (const auto& [c, n] : overlap)
        if (n > best_overlap)
        {
          best = c;
          best_overlap = n;
        }
      const double recall = static_cast<double>(best_overlap) / static_cast<double>(members.size());
      const double precision = best < 0 ? 0.0
                                        : static_cast<double>(best_overlap) /
                                              static_cast<double>(result.clusters[static_cast<std::size_t>(best)].indices.size());
      std::vector<Eigen::Vector3f> points;
      for (const std::size_t i : members)
        points.push_back(sampled[i].getVector3fMap());
      const bool fits = narrowestWidth(points, params.up_axis) <= opening;
      const bool right = precision >= 0.9 && recall >= 0.8;
      ++scene.objects;
      scene.right += right;
      scene.merged += !right && best >= 0 && precision < 0.9;
      scene.split += !right && !(best >= 0 && precision < 0.9);
      scene.fit_objects += fits;
      scene.fit_right += fits && right;
    }
    // A cluster that is mostly not object points (table noise, a wall, a cup's shadow) would be
    // planned on as an object: the price of a lower min_cluster_points or min_height.
    for (const auto& cluster : result.clusters)
    {
      std::size_t on_objects = 0;
      for (const int i : cluster.indices)
        on_objects += sampled[static_cast<std::size_t>(i)].label >= 10;
      ++scene.clusters;
      scene.spurious += 2 * on_objects < cluster.indices.size();
    }
    std::printf("%-10s %7d %5d %5d %6d %5d %8.1f%s\n", std::filesystem::path(file).stem().c_str(), scene.objects,
                scene.right, scene.merged, scene.split, scene.fit_objects, ms, result.ok() ? "" : "  (no cluster)");
    total.objects += scene.objects;
    total.right += scene.right;
    total.merged += scene.merged;
    total.split += scene.split;
    total.fit_objects += scene.fit_objects;
    total.fit_right += scene.fit_right;
    total.clusters += scene.clusters;
    total.spurious += scene.spurious;
  }
  auto pct = [](int a, int b) { return b > 0 ? 100.0 * a / b : 0.0; };
  std::printf("split %s: %d scenes, %d labelled objects (%d fit the %.3f m opening)\n", split.c_str(), static_cast<int>(frame_ms.size()),
              total.objects, total.fit_objects, opening);
  std::printf("clusters: %d, of them %d mostly not object points (spurious)\n", total.clusters, total.spurious);
  if (!preprocess_frame_ms.empty())
    std::printf("medians: preprocessCloud %.1f ms CPU, table RANSAC %.1f ms wall, clusters %.1f ms wall\n",
                median(preprocess_frame_ms), median(ransac_frame_ms), median(clustering_frame_ms));
  // Frame times are this thread's CPU time: what one core spends on the frame.
  std::printf("segmentation: right %.0f %% (fits: %.0f %%) merged %.0f %% split %.0f %% median %.1f ms per frame\n",
              pct(total.right, total.objects), pct(total.fit_right, total.fit_objects), pct(total.merged, total.objects),
              pct(total.split, total.objects), median(frame_ms));
  return 0;
}
