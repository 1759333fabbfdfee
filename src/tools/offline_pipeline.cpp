#include "offline_pipeline.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <locale>
#include <numeric>
#include <sstream>
#include <vector>

namespace fast_grasp
{
namespace
{
PreparedView fail(PreparedView prepared, ViewStage stage, std::string status, const std::string& reason)
{
  prepared.failed_stage = stage;
  prepared.status = std::move(status);
  prepared.problem = std::string(toString(stage)) + ": " + reason;
  prepared.view.cloud.reset();
  prepared.points = 0;
  return prepared;
}

const char* statusOf(SegmentationFailure failure)
{
  switch (failure)
  {
    case SegmentationFailure::None:
      return "ok";
    case SegmentationFailure::InvalidInput:
      return "InvalidInput";
    case SegmentationFailure::NoPlane:
      return "NoPlane";
    case SegmentationFailure::NoCluster:
      return "NoCluster";
    case SegmentationFailure::ObjectOutOfReach:
      return "ObjectOutOfReach";
  }
  return "SegmentationFailed";
}

/// A cloud saved in the base frame carries no camera orientation; aim the camera at the
/// points' centroid so that the centre-of-view target choice picks what the view is centred on.
void setSensorPose(CloudXYZ& cloud, const Eigen::Vector3f& origin)
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud.points)
    sum += p.getVector3fMap().cast<double>();
  const Eigen::Vector3f centroid = (sum / static_cast<double>(std::max<std::size_t>(1, cloud.size()))).cast<float>();
  cloud.sensor_origin_ = Eigen::Vector4f(origin.x(), origin.y(), origin.z(), 0.0f);
  const Eigen::Vector3f look = centroid - origin;
  cloud.sensor_orientation_ = look.norm() > 1e-6f ? Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), look)
                                                  : Eigen::Quaternionf::Identity();
}
/// The largest buffer PCDReader::readHeader (PCL 1.13) allocates while parsing the header of
/// `path`: it resizes the data at every POINTS line to POINTS x the point size of the lines read
/// so far, before any check (a 255-byte file with COUNT 1666...6 asked for 17 GB: out-of-memory
/// while fuzzing, test/fuzz/corpus/pcd_input/crash_count_overflow_oom). The header is walked
/// as readHeader walks it: until the first line of no known keyword, DATA included.
/// kUnreadableSizeOrCount when a SIZE or COUNT value does not read as an int >= 1, and
/// kUnprintableHeaderLine when a header line (not a comment) holds a byte other than printable
/// ASCII, tab or CR: PCL counts a line's values split at space, tab and CR but reads them with a
/// stream that also splits at \v and \f, so such a line is counted one way and read another
/// (COUNT 1666...6, NUL bytes, \v: 17 GB, test/fuzz/corpus/pcd_input/oom_count_overflow_then_junk).
constexpr std::uint64_t kUnreadableSizeOrCount = std::numeric_limits<std::uint64_t>::max();
constexpr std::uint64_t kUnprintableHeaderLine = std::numeric_limits<std::uint64_t>::max() - 1;

std::uint64_t pcdHeaderAllocation(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  std::size_t fields = 0;
  std::vector<std::uint64_t> sizes;
  std::uint32_t point_step = 0;  // PCL keeps it in a uint32 computed from int offsets
  std::uint64_t largest = 0;
  const auto starts = [](const std::string& word, const char* keyword) { return word.rfind(keyword, 0) == 0; };
  for (std::string line; std::getline(file, line);)
  {
    if (line.empty())
      continue;
    std::istringstream words(line);
    words.imbue(std::locale::classic());
    std::string keyword;
    words >> keyword;
    if (!keyword.empty() && keyword[0] != '#')
      for (const char c : line)
        if (!((c >= 0x20 && c < 0x7f) || c == '\t' || c == '\r'))
        {
          // Only lines readHeader takes as header lines matter; the first other line ends it.
          static const char* const kKeywords[] = { "VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT",
                                                   "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA" };
          for (const char* k : kKeywords)
            if (keyword.rfind(k, 0) == 0)
              return kUnprintableHeaderLine;
          break;
        }
    std::size_t values = 0;  // the words after the keyword
    std::istringstream count_words(line);
    for (std::string word; count_words >> word;)
      ++values;
    values = values > 0 ? values - 1 : 0;
    if (starts(keyword, "#") || starts(keyword, "VERSION") || starts(keyword, "TYPE") || starts(keyword, "WIDTH") ||
        starts(keyword, "HEIGHT") || starts(keyword, "VIEWPOINT") || starts(keyword, "DATA"))
      continue;
    if (starts(keyword, "FIELDS") || starts(keyword, "COLUMNS"))
    {
      fields = values;
      sizes.assign(fields, 4);
      point_step = static_cast<std::uint32_t>(4 * fields);
    }
    else if (starts(keyword, "SIZE") || starts(keyword, "COUNT"))
    {
      if (values != fields)
        break;  // readHeader fails here
      // PCL reads the values as ints from one stream and sums them in int: the low 32 bits of
      // this unsigned (wrapping) sum. What PCL makes of a value that is no int (overflow, junk)
      // depends on the stream state it leaves (COUNT 1666...6 followed by NUL bytes: 17 GB,
      // test/fuzz/corpus/pcd_input/oom_count_overflow_then_junk): no such header is worth
      // modelling, it is refused (kUnreadableSizeOrCount).
      std::uint64_t step = 0;
      for (std::size_t i = 0; i < fields; ++i)
      {
        int value = 0;
        if (!(words >> value) || value < 1)
          return kUnreadableSizeOrCount;
        if (starts(keyword, "SIZE"))
          sizes[i] = static_cast<std::uint64_t>(static_cast<std::int64_t>(value));
        step += starts(keyword, "SIZE") ? sizes[i] : static_cast<std::uint64_t>(static_cast<std::int64_t>(value)) * sizes[i];
      }
      point_step = static_cast<std::uint32_t>(step);
    }
    else if (starts(keyword, "POINTS"))
    {
      std::size_t points = 0;
      words >> points;
      largest = std::max<std::uint64_t>(largest, points * point_step);
    }
    else
      break;
  }
  return largest;
}

/// Why PCL's PCD reader must not be given a file whose header PCDReader::readHeader parsed
/// into `header`, or "" when it may. PCL 1.13 trusts the header: it sizes the data buffer when
/// it meets POINTS (with the point size known at that line), keeps parsing after DATA until an
/// unknown line, and its body readers then write WIDTH x HEIGHT points of the final layout into
/// that buffer, each value with the size of its TYPE. A header that declares fields after POINTS
/// (test/fuzz/corpus/pcd_input/crash_fields_after_points: a heap overflow inside the
/// uninstrumented libpcl_io that ASan only noticed later in its quarantine), a SIZE line after
/// TYPE, or a WIDTH x HEIGHT that wraps in 32 bits makes that buffer too small.
std::string pcdHeaderProblem(const std::string& path, const pcl::PCLPointCloud2& header, int data_type,
                             unsigned int data_index)
{
  if (header.fields.empty())
    return "declares no fields";
  const std::uint64_t points = static_cast<std::uint64_t>(header.width) * header.height;
  if (points == 0)
    return "holds no points";
  // The layout SIZE, TYPE and COUNT declare, packed in FIELDS order (what PCDWriter writes,
  // padding included as '_' fields), must be the one PCL derived.
  std::uint64_t packed = 0;
  for (const auto& f : header.fields)
  {
    const std::uint64_t value_bytes = pcl::getFieldSize(f.datatype);
    if (value_bytes == 0)
      return "field '" + f.name + "': its SIZE and TYPE name no known type";
    if (f.offset != packed)
      return "its FIELDS, SIZE, TYPE and COUNT lines disagree (field '" + f.name + "' at byte " +
             std::to_string(f.offset) + ", the fields before it end at byte " + std::to_string(packed) + ")";
    packed += value_bytes * f.count;
  }
  if (packed != header.point_step)
    return "its FIELDS, SIZE, TYPE and COUNT lines disagree (" + std::to_string(packed) + " bytes of fields, " +
           std::to_string(header.point_step) + "-byte points)";
  if (header.data.size() != points * header.point_step)
    return "its POINTS line comes before the lines that define a point, or WIDTH x HEIGHT is not POINTS (" +
           std::to_string(header.data.size()) + " data bytes allocated, " + std::to_string(points) + " points of " +
           std::to_string(header.point_step) + " bytes need " + std::to_string(points * header.point_step) + ")";
  // PCDReader allocates what the header declares before it reads the data: a 200-byte file
  // declaring a billion points asked for 4 GB (out-of-memory while fuzzing). The declared
  // points must fit the file: 2 bytes each in ascii ("0\n"), point_step in binary, and
  // binary_compressed holds its compressed and uncompressed sizes, then the compressed block.
  std::error_code size_error;
  const std::uint64_t file_bytes = std::filesystem::file_size(path, size_error);
  if (size_error)
    return "cannot tell its size (" + size_error.message() + ")";
  const std::uint64_t data_bytes = points * header.point_step;
  const std::string declares = "declares " + std::to_string(points) + " points, more than its " +
                               std::to_string(file_bytes) + " bytes hold";
  if (data_type == 0 && 2 * points > file_bytes)
    return declares;
  if (data_type == 1 && data_index + data_bytes > file_bytes)
    return declares;
  if (data_type == 2)
  {
    std::uint32_t block_sizes[2] = { 0, 0 };  // compressed, uncompressed
    std::ifstream file(path, std::ios::binary);
    file.seekg(data_index);
    file.read(reinterpret_cast<char*>(block_sizes), sizeof(block_sizes));
    // LZF expands at most ~100x; PCL allocates the block's own uncompressed size.
    if (!file || data_index + 8 + static_cast<std::uint64_t>(block_sizes[0]) > file_bytes ||
        data_bytes > 100 * static_cast<std::uint64_t>(block_sizes[0]))
      return declares;
    if (block_sizes[1] != data_bytes)
      return "its compressed block holds " + std::to_string(block_sizes[1]) + " bytes, " + std::to_string(points) +
             " points of " + std::to_string(header.point_step) + " bytes need " + std::to_string(data_bytes);
  }
  return "";
}
}  // namespace

const char* toString(ViewStage stage)
{
  switch (stage)
  {
    case ViewStage::None:
      return "none";
    case ViewStage::Preprocess:
      return "preprocess";
    case ViewStage::Segmentation:
      return "segmentation";
    case ViewStage::Normals:
      return "normals";
  }
  return "unknown";
}

ViewPreparationParams deployedViewPreparationParams()
{
  ViewPreparationParams params;
  params.preprocess.min_z_m = -0.5;
  params.preprocess.max_z_m = 1.5;
  params.segmentation.max_object_distance_m = 0.80;
  return params;
}

SensorCloud sensorCloudFromBagFrame(const BagFrame& frame)
{
  SensorCloud sensor;
  sensor.rgb_cloud = frame.cloud;
  sensor.cloud_to_base = frame.camera_to_base;
  return sensor;
}

CloudXYZ::Ptr readPcdCloud(const std::string& path, std::string& error)
{
  // PCL 1.13's PCDReader::read dereferences past a header it failed to parse (segfault on an
  // empty or non-PCD file) and trusts the header it parsed, so the header is read and checked
  // on its own first (pcdHeaderProblem); PCL then parses the file.
  pcl::PCDReader reader;
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int data_type = 0;
  unsigned int data_index = 0;
  // readHeader also throws (std::exception) on some malformed headers instead of failing
  // (std::terminate while fuzzing, test/fuzz/corpus/pcd_input/crash_header_throws).
  std::error_code size_error;
  const std::uint64_t file_bytes = std::filesystem::file_size(path, size_error);
  // binary_compressed data expands at most ~100x (LZF).
  const std::uint64_t header_allocation = size_error ? 0 : pcdHeaderAllocation(path);
  if (header_allocation == kUnprintableHeaderLine)
  {
    error = path + ": a header line holds a control or non-ASCII byte";
    return nullptr;
  }
  if (header_allocation == kUnreadableSizeOrCount)
  {
    error = path + ": a SIZE or COUNT value of its header is not a whole number from 1 to 2^31 - 1";
    return nullptr;
  }
  if (header_allocation > 100 * file_bytes + 4096)
  {
    error = path + ": its header makes PCL allocate " + std::to_string(header_allocation) +
            " bytes for a file of " + std::to_string(file_bytes) + " (POINTS x the FIELDS, SIZE and COUNT before it)";
    return nullptr;
  }
  try
  {
    if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_index) < 0)
    {
      error = "not a PCD file (unreadable header): " + path;
      return nullptr;
    }
    const std::string problem = pcdHeaderProblem(path, blob, data_type, data_index);
    if (!problem.empty())
    {
      error = path + ": " + problem;
      return nullptr;
    }
    if (reader.read(path, blob) < 0)
    {
      error = "cannot read PCD file " + path;
      return nullptr;
    }
  }
  catch (const std::exception& e)
  {
    error = "not a PCD file (" + std::string(e.what()) + "): " + path;
    return nullptr;
  }
  // The checked header is what PCL parsed again, so the data holds every point; PCD data has
  // no row padding (readHeader leaves row_step at 0 when WIDTH precedes the fields).
  if (blob.data.size() != static_cast<std::uint64_t>(blob.width) * blob.height * blob.point_step)
  {
    error = path + ": PCL read " + std::to_string(blob.data.size()) + " data bytes, not what its header declares";
    return nullptr;
  }
  blob.row_step = blob.point_step * blob.width;
  for (const char* field : { "x", "y", "z" })
  {
    bool found = false;
    for (const auto& f : blob.fields)
      found = found || f.name == field;
    if (!found)
    {
      error = path + " has no '" + field + "' field";
      return nullptr;
    }
  }
  for (const auto& f : blob.fields)
  {
    // pcl::fromPCLPointCloud2 copies x, y, z of any type as floats.
    if ((f.name == "x" || f.name == "y" || f.name == "z") && f.datatype != pcl::PCLPointField::FLOAT32)
    {
      error = path + ": field '" + f.name + "' is not a float";
      return nullptr;
    }
  }
  auto cloud = std::make_shared<CloudXYZ>();
  pcl::fromPCLPointCloud2(blob, *cloud);
  return cloud;
}

PreparedView prepareView(const std::vector<SensorCloud>& clouds, const ViewPreparationParams& params, std::mt19937& rng)
{
  PreparedView prepared;
  if (clouds.empty())
    return fail(prepared, ViewStage::Preprocess, "PreprocessFailed", "no input cloud");

  // Preprocess each camera on its own (its own transform and voxel grid) and concatenate; the
  // merged cloud keeps the first camera's pose, which aims the target-cluster choice.
  CloudXYZ::Ptr merged;
  std::vector<std::size_t> first_index_of_camera;  // provenance: camera c owns [first[c], first[c+1])
  for (std::size_t c = 0; c < clouds.size(); ++c)
  {
    const SensorCloud& sensor = clouds[c];
    if (static_cast<bool>(sensor.rgb_cloud) == static_cast<bool>(sensor.xyz_cloud))
      return fail(prepared, ViewStage::Preprocess, "PreprocessFailed", "camera " + std::to_string(c) +
                                                                           ": expected exactly one cloud");
    const PreprocessResult pre = sensor.rgb_cloud
                                     ? preprocessCloud(*sensor.rgb_cloud, sensor.cloud_to_base, params.preprocess)
                                     : preprocessCloud(*sensor.xyz_cloud, sensor.cloud_to_base, params.preprocess);
    if (!pre.ok || !pre.cloud)
      return fail(prepared, ViewStage::Preprocess, "PreprocessFailed",
                  (clouds.size() > 1 ? "camera " + std::to_string(c) + ": " : std::string()) + pre.reason);
    if (sensor.sensor_origin)
    {
      if (!sensor.sensor_origin->allFinite())
        return fail(prepared, ViewStage::Preprocess, "PreprocessFailed", "sensor origin is not finite");
      setSensorPose(*pre.cloud, *sensor.sensor_origin);
    }
    prepared.view.sensor_origins.push_back(pre.cloud->sensor_origin_.head<3>());
    first_index_of_camera.push_back(merged ? merged->size() : 0);
    if (!merged)
      merged = pre.cloud;
    else
      *merged += *pre.cloud;  // concatenation keeps merged's sensor pose (PCL copies none)
  }
  first_index_of_camera.push_back(merged->size());
  auto cameraOf = [&first_index_of_camera](std::size_t merged_index) {
    const auto after = std::upper_bound(first_index_of_camera.begin(), first_index_of_camera.end(), merged_index);
    return static_cast<std::size_t>(after - first_index_of_camera.begin()) - 1;
  };

  std::vector<int> object_indices;
  std::vector<std::vector<int>> other_clusters;  // all_objects: every cluster but the target
  if (params.segment_table)
  {
    // The concave-crease split orients normals toward one camera; points only a second camera
    // saw face away from it and would read as creases, so fused views are clustered whole. The
    // occlusion join looks along one camera's lines of sight too.
    TableSegmentationParams segmentation = params.segmentation;
    const bool one_camera = first_index_of_camera.size() <= 2;
    segmentation.split_concave_creases = segmentation.split_concave_creases && one_camera;
    segmentation.join_occluded_pieces = segmentation.join_occluded_pieces && one_camera;
    const TableSegmentationResult seg = segmentTable(merged, segmentation);
    if (!seg.ok())
      return fail(prepared, ViewStage::Segmentation, statusOf(seg.failure), seg.reason);
    if (seg.target_index < 0 || static_cast<std::size_t>(seg.target_index) >= seg.clusters.size())
      return fail(prepared, ViewStage::Segmentation, "NoCluster", "no target cluster chosen");
    object_indices = seg.clusters[static_cast<std::size_t>(seg.target_index)].indices;
    if (params.all_objects)
      for (std::size_t c = 0; c < seg.clusters.size(); ++c)
        if (static_cast<int>(c) != seg.target_index)
          other_clusters.push_back(seg.clusters[c].indices);
    prepared.view.table_plane = seg.plane;
    prepared.view.has_table_plane = seg.has_plane;
  }
  else
  {
    object_indices.resize(merged->size());
    std::iota(object_indices.begin(), object_indices.end(), 0);
  }

  // One cluster's points with normals, each normal facing the camera that saw its point.
  auto objectCloud = [&](const std::vector<int>& indices, std::size_t resample_to) -> NormalResult {
    CloudXYZ::Ptr object(new CloudXYZ);
    object->header = merged->header;
    object->sensor_origin_ = merged->sensor_origin_;
    object->sensor_orientation_ = merged->sensor_orientation_;
    std::vector<std::size_t> camera_of_point;
    if (resample_to > 0 && !indices.empty())
    {
      // Resample to exactly resample_to points: a random subset, or every point plus
      // jittered copies (0.3 mm, below the sensor noise) when the cloud is smaller.
      std::vector<int> order = indices;
      std::shuffle(order.begin(), order.end(), rng);
      std::normal_distribution<float> jitter(0.0f, 0.0003f);
      object->reserve(resample_to);
      for (std::size_t i = 0; i < resample_to; ++i)
      {
        const auto source = static_cast<std::size_t>(order[i % order.size()]);
        PointXYZ p = merged->points[source];
        if (i >= order.size())
        {
          p.x += jitter(rng);
          p.y += jitter(rng);
          p.z += jitter(rng);
        }
        object->push_back(p);
        camera_of_point.push_back(cameraOf(source));
      }
    }
    else
    {
      object->reserve(indices.size());
      for (const int i : indices)
      {
        object->push_back(merged->points[static_cast<std::size_t>(i)]);
        camera_of_point.push_back(cameraOf(static_cast<std::size_t>(i)));
      }
    }

    NormalResult normals = estimateNormals(object, prepared.view.sensor_origins.front(), params.normals);
    if (!normals.ok || !normals.cloud || prepared.view.sensor_origins.size() < 2)
      return normals;
    // Normals are fitted on the fused cloud (better neighbourhoods where the views overlap)
    // and face the first camera; re-orient each toward the camera that saw its point. The
    // output keeps the input order minus the points without a normal, so walk both.
    std::size_t source = 0;
    for (auto& p : normals.cloud->points)
    {
      while (source < object->size() && object->points[source].getVector3fMap() != p.getVector3fMap())
        ++source;
      if (source == object->size())
        break;  // cannot happen while estimateNormals keeps the order; leave the rest as fitted
      const Eigen::Vector3f& origin = prepared.view.sensor_origins[camera_of_point[source]];
      if (p.getNormalVector3fMap().dot(origin - p.getVector3fMap()) < 0.0f)
        p.getNormalVector3fMap() *= -1.0f;
      ++source;
    }
    return normals;
  };

  const NormalResult normals = objectCloud(object_indices, params.resample_to);
  if (!normals.ok || !normals.cloud)
    return fail(prepared, ViewStage::Normals, "NormalsFailed", normals.reason);
  CloudNormal::Ptr with_normals = normals.cloud;

  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  prepared.object_min = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  prepared.object_max = -prepared.object_min;
  for (const auto& p : with_normals->points)
  {
    sum += p.getVector3fMap().cast<double>();
    prepared.object_min = prepared.object_min.cwiseMin(p.getVector3fMap());
    prepared.object_max = prepared.object_max.cwiseMax(p.getVector3fMap());
  }
  prepared.object_centroid = (sum / static_cast<double>(with_normals->size())).cast<float>();

  if (params.table_plane)
  {
    Eigen::Vector4f plane = *params.table_plane;
    const float norm = plane.head<3>().norm();
    if (!plane.allFinite() || !(norm > 1e-9f))
      return fail(prepared, ViewStage::Segmentation, "InvalidInput", "table plane has no direction");
    plane /= norm;
    if (plane.head<3>().dot(prepared.object_centroid) + plane.w() < 0.0f)
      plane = -plane;  // the planners expect the normal to point from the table to the object
    prepared.view.table_plane = plane;
    prepared.view.has_table_plane = true;
  }

  prepared.view.cloud = with_normals;
  prepared.points = with_normals->size();
  if (params.all_objects)
  {
    // Every other cluster as a view of its own (same cameras and table); one whose normals
    // fail (too few points) is left out, as the target would have failed.
    prepared.objects.push_back(prepared.view);
    for (const std::vector<int>& cluster : other_clusters)
    {
      const NormalResult other = objectCloud(cluster, 0);
      if (!other.ok || !other.cloud)
        continue;
      ObjectView view = prepared.view;
      view.cloud = other.cloud;
      prepared.objects.push_back(view);
    }
  }
  return prepared;
}

}  // namespace fast_grasp
