// grasp_offline: runs the perception core and one grasp planner on a bag frame, a PCD file or a
// scene YAML rendered on the spot, and writes the grasps (base_link, best first) as CSV or JSON.
// With a scene it can follow the principal-axis planner's next view (Ch3.2.3): render the scene
// again from the suggested camera pose and plan again, as an eye-in-hand robot would after
// moving its camera. Used for batch evaluation, debugging and by the grasp-success evaluator;
// docs/offline_tool.md has the formats.
//
// Exit codes: 0 grasps written; 1 a typed failure (one line on stderr; JSON output still
// carries the status); 2 bad arguments (usage on stderr).
#include "bag_frames.h"
#include "offline_pipeline.h"
#include "scene_description.h"

#include "fast_grasp/grasping/cshape_grasp.h"
#include "fast_grasp/grasping/grasp_features.h"
#include "fast_grasp/grasping/grasp_planner_params.h"
#include "fast_grasp/grasping/near_range.h"
#include "fast_grasp/core/gripper_model.h"
#include "fast_grasp/grasping/principal_axis_grasp.h"
#include "fast_grasp/grasping/table_grasps.h"

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace fast_grasp
{
namespace
{
constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

const char* const kUsage =
    "usage: grasp_offline --bag FILE [--topic T] [--frame N]\n"
    "                   | --pcd FILE --viewpoint x,y,z [--table a,b,c,d] [--already-segmented]\n"
    "                   | --scene FILE.yaml [--ycb-dir DIR] [--follow-next-view N]\n"
    "                     [--algorithm principal_axis|cshape|boundary|concavity|fused] [--gripper NAME_OR_FILE]\n"
    "                     [--params FILE] [--format csv|json] [--output FILE] [--max-grasps N]\n"
    "                     [--save-object FILE.pcd] [--split-touching-objects] [--all-objects]\n"
    "  --bag FILE           rosbag with an organised PointCloud2 topic and /tf_static to base_link\n"
    "  --topic T            cloud topic (default /camera/depth_registered/points; without --topic\n"
    "                       a bag that also has /head_camera/depth_registered/points is fused)\n"
    "  --frame N            index of the cloud message to use (default 0)\n"
    "  --pcd FILE           cloud in base_link (x y z fields; NaN allowed)\n"
    "  --viewpoint x,y,z    camera optical centre in base_link (required with --pcd)\n"
    "  --table a,b,c,d      table plane a*x+b*y+c*z+d=0 in base_link (replaces the fitted one)\n"
    "  --already-segmented  the PCD holds the object only: no table fit, no clustering\n"
    "  --split-touching-objects  cut clusters at concave creases so touching objects come out apart\n"
    "                       (demo.launch split_touching_objects:=true; single camera only)\n"
    "  --all-objects        plan for every object on the table, not only the target cluster: grasps\n"
    "                       whose hand would touch another object (or its unseen part) are dropped,\n"
    "                       the objects ordered by table_grasps/object_choice (--params); each grasp\n"
    "                       names its object, the first object's first grasp is the one to execute\n"
    "  --scene FILE         scene YAML (config/scenes/), rendered from its cameras as render_bag does\n"
    "  --ycb-dir DIR        YCB STL folder for ycb: meshes (default $FAST_GRASP_YCB_DIR)\n"
    "  --follow-next-view N with --scene: up to N times, render again from the planner's next view\n"
    "                       (principal_axis, Ch3.2.3; with --all-objects, when no object has a grasp:\n"
    "                       the camera turned about the table, table_grasps/next_view_turn_rad) and\n"
    "                       plan again (default 0)\n"
    "  --algorithm A        principal_axis (default), cshape, boundary, concavity or fused (all four\n"
    "                       pooled with top-down and side grasps, ranked by the physics-fitted model)\n"
    "  --gripper G          config/grippers/G.yaml or a YAML file (default lacquey_fetch)\n"
    "  --params FILE        planner parameters (default config/grasp_planners.yaml)\n"
    "  --format F           csv (default) or json\n"
    "  --output FILE        write there instead of stdout\n"
    "  --max-grasps N       write at most N grasps (default: all the planner returns)\n"
    "  --save-object FILE   also save the segmented object (base_link, with normals) as PCD\n"
    "                       (--all-objects: the object picked first)\n";

struct Options
{
  std::string bag_path;
  std::string topic;  // empty: the default camera topic, fused with the head camera if present
  int frame_index = 0;
  std::string pcd_path;
  std::optional<Eigen::Vector3f> viewpoint;
  std::optional<Eigen::Vector4f> table_plane;
  bool already_segmented = false;
  bool split_touching_objects = false;  // perception.yaml's split_concave_creases
  bool all_objects = false;
  std::string scene_path;
  std::string ycb_dir;  // empty: $FAST_GRASP_YCB_DIR
  int follow_next_view = 0;
  std::string algorithm = "principal_axis";
  std::string gripper = "lacquey_fetch";
  std::string params_path = std::string(FAST_GRASP_SOURCE_DIR) + "/config/grasp_planners.yaml";
  std::string format = "csv";
  std::string output_path;  // empty: stdout
  std::string object_pcd_path;  // empty: the segmented object is not saved
  std::size_t max_grasps = 0;  // 0: all
};

class UsageError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

double parseNumber(const std::string& flag, const std::string& text)
{
  std::size_t used = 0;
  double value = 0.0;
  try
  {
    value = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value))
    throw UsageError(flag + ": '" + text + "' is not a finite number");
  return value;
}

long long parseInteger(const std::string& flag, const std::string& text, long long minimum)
{
  const double value = parseNumber(flag, text);
  if (value != std::floor(value) || value < static_cast<double>(minimum) || value > 1e9)
    throw UsageError(flag + ": '" + text + "' must be an integer >= " + std::to_string(minimum));
  return static_cast<long long>(value);
}

std::vector<double> parseList(const std::string& flag, const std::string& text, std::size_t count)
{
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ','))
    values.push_back(parseNumber(flag, item));
  if (values.size() != count || (!text.empty() && text.back() == ','))
    throw UsageError(flag + ": expected " + std::to_string(count) + " comma-separated numbers, got '" + text + "'");
  return values;
}

Options parseOptions(int argc, char** argv)
{
  Options options;
  bool have_topic = false;
  bool have_frame = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string flag = argv[i];
    if (flag == "--already-segmented")
    {
      options.already_segmented = true;
      continue;
    }
    if (flag == "--split-touching-objects")
    {
      options.split_touching_objects = true;
      continue;
    }
    if (flag == "--all-objects")
    {
      options.all_objects = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0)
      throw UsageError("unexpected argument '" + flag + "'");
    if (i + 1 >= argc)
      throw UsageError(flag + " needs a value");
    const std::string value = argv[++i];
    if (flag == "--bag")
      options.bag_path = value;
    else if (flag == "--topic")
    {
      options.topic = value;
      have_topic = true;
    }
    else if (flag == "--frame")
    {
      options.frame_index = static_cast<int>(parseInteger(flag, value, 0));
      have_frame = true;
    }
    else if (flag == "--pcd")
      options.pcd_path = value;
    else if (flag == "--scene")
      options.scene_path = value;
    else if (flag == "--ycb-dir")
      options.ycb_dir = value;
    else if (flag == "--follow-next-view")
      options.follow_next_view = static_cast<int>(parseInteger(flag, value, 0));
    else if (flag == "--viewpoint")
    {
      const auto v = parseList(flag, value, 3);
      options.viewpoint = Eigen::Vector3f(v[0], v[1], v[2]);
    }
    else if (flag == "--table")
    {
      const auto v = parseList(flag, value, 4);
      if (std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) < 1e-9)
        throw UsageError("--table: (a, b, c) must not be zero");
      options.table_plane = Eigen::Vector4f(v[0], v[1], v[2], v[3]);
    }
    else if (flag == "--algorithm")
      options.algorithm = value;
    else if (flag == "--gripper")
      options.gripper = value;
    else if (flag == "--params")
      options.params_path = value;
    else if (flag == "--format")
      options.format = value;
    else if (flag == "--output")
      options.output_path = value;
    else if (flag == "--save-object")
      options.object_pcd_path = value;
    else if (flag == "--max-grasps")
      options.max_grasps = static_cast<std::size_t>(parseInteger(flag, value, 1));
    else
      throw UsageError("unknown option '" + flag + "'");
  }
  const int inputs = !options.bag_path.empty() + !options.pcd_path.empty() + !options.scene_path.empty();
  if (inputs != 1)
    throw UsageError("give exactly one of --bag, --pcd and --scene");
  if (options.pcd_path.empty() && (options.viewpoint || options.table_plane || options.already_segmented))
    throw UsageError("--viewpoint, --table and --already-segmented go with --pcd");
  if (options.bag_path.empty() && (have_topic || have_frame))
    throw UsageError("--topic and --frame go with --bag");
  if (options.scene_path.empty() && (!options.ycb_dir.empty() || options.follow_next_view > 0))
    throw UsageError("--ycb-dir and --follow-next-view go with --scene");
  if (options.all_objects && options.already_segmented)
    throw UsageError("--all-objects needs a table to segment (no --already-segmented)");
  if (!options.pcd_path.empty() && !options.viewpoint)
    throw UsageError("--pcd needs --viewpoint x,y,z (the camera's optical centre in base_link)");
  const std::vector<std::string>& algorithms = graspAlgorithmNames();
  if (std::find(algorithms.begin(), algorithms.end(), options.algorithm) == algorithms.end())
    throw UsageError("--algorithm: '" + options.algorithm + "' is none of principal_axis, cshape, boundary, concavity, fused");
  if (options.format != "csv" && options.format != "json")
    throw UsageError("--format: '" + options.format + "' is neither csv nor json");
  return options;
}

/// A typed failure before or outside the planner: status token and one-line reason.
struct Failure
{
  std::string stage;   // input | config | preprocess | segmentation | normals | planning | output
  std::string status;  // InputError, ConfigError, NoPlane, NoGraspableZone, ...
  std::string reason;
};

class FailureError : public std::runtime_error
{
public:
  explicit FailureError(Failure failure) : std::runtime_error(failure.reason), failure_(std::move(failure)) {}
  const Failure& failure() const { return failure_; }

private:
  Failure failure_;
};

[[noreturn]] void failInput(const std::string& reason)
{
  throw FailureError({ "input", "InputError", reason });
}

std::vector<SensorCloud> readBagInput(const Options& options)
{
  static const std::string kCameraTopic = "/camera/depth_registered/points";
  static const std::string kHeadTopic = "/head_camera/depth_registered/points";
  if (!fs::is_regular_file(options.bag_path))
    failInput("no such file: " + options.bag_path);
  try
  {
    const std::string topic = options.topic.empty() ? kCameraTopic : options.topic;
    const std::vector<BagFrame> frames = readBagFrames(options.bag_path, topic);
    if (static_cast<std::size_t>(options.frame_index) >= frames.size())
      failInput("--frame " + std::to_string(options.frame_index) + " but " + options.bag_path + " has " +
                std::to_string(frames.size()) + " frame(s) on " + topic);
    const BagFrame& frame = frames[static_cast<std::size_t>(options.frame_index)];
    std::vector<SensorCloud> clouds{ sensorCloudFromBagFrame(frame) };
    if (options.topic.empty() && bagHasTopic(options.bag_path, kHeadTopic))
    {
      // Two-camera mode (Ch3.5): the head camera's frame closest in time to the hand camera's.
      const std::vector<BagFrame> head = readBagFrames(options.bag_path, kHeadTopic);
      clouds.push_back(sensorCloudFromBagFrame(closestFrame(head, frame.stamp_s)));
    }
    return clouds;
  }
  catch (const FailureError&)
  {
    throw;
  }
  catch (const std::exception& e)  // rosbag and readBagFrames report everything by exception
  {
    failInput(e.what());
  }
}

std::vector<SensorCloud> readPcdInput(const Options& options)
{
  if (!fs::is_regular_file(options.pcd_path))
    failInput("no such file: " + options.pcd_path);
  std::string problem;
  const CloudXYZ::Ptr cloud = readPcdCloud(options.pcd_path, problem);
  if (!cloud)
    failInput(problem);
  SensorCloud sensor;
  sensor.xyz_cloud = cloud;
  sensor.sensor_origin = options.viewpoint;  // the points are in base_link already
  return { sensor };
}

/// A scene YAML ready to render: the description and a renderer built once for every view.
struct SceneInput
{
  SceneDescription scene;
  std::unique_ptr<XtionRenderer> renderer;
};

SceneInput loadSceneInput(const Options& options)
{
  if (!fs::is_regular_file(options.scene_path))
    failInput("no such file: " + options.scene_path);
  std::string ycb_dir = options.ycb_dir;
  if (ycb_dir.empty() && std::getenv("FAST_GRASP_YCB_DIR"))
    ycb_dir = std::getenv("FAST_GRASP_YCB_DIR");
  try
  {
    SceneInput input;
    input.scene = loadSceneDescription(options.scene_path, ycb_dir);
    input.renderer = std::make_unique<XtionRenderer>(input.scene.parts);
    return input;
  }
  catch (const std::exception& e)  // yaml-cpp and the mesh loader report by exception
  {
    failInput(options.scene_path + ": " + e.what());
  }
}

/// The scene's cameras rendered as render_bag renders a bag's first frame (same seeds, so view
/// 0 is the bundled bag's frame 0), the hand camera (the first) placed at `hand_pose`; view k > 0
/// gets its own noise seed. A second (head) camera stays where the scene puts it (Ch3.5).
std::vector<SensorCloud> renderSceneViews(const SceneInput& input, const Eigen::Isometry3d& hand_pose, int view)
{
  std::vector<SensorCloud> clouds;
  for (std::size_t c = 0; c < input.scene.cameras.size(); ++c)
  {
    const Eigen::Isometry3d pose = c == 0 ? hand_pose : input.scene.cameras[c].optical_pose;
    const std::uint64_t seed = renderSeed(input.scene, c, 0, c == 0 ? view : 0);
    SensorCloud sensor;
    sensor.rgb_cloud = organisedCloud(input.renderer->render(pose, seed));
    sensor.cloud_to_base = pose.cast<float>();
    clouds.push_back(sensor);
  }
  return clouds;
}

GripperModel loadGripper(const std::string& name_or_file)
{
  const bool is_path = name_or_file.find('/') != std::string::npos ||
                       fs::path(name_or_file).extension() == ".yaml" || fs::is_regular_file(name_or_file);
  const std::string path =
      is_path ? name_or_file : std::string(FAST_GRASP_SOURCE_DIR) + "/config/grippers/" + name_or_file + ".yaml";
  try
  {
    GripperModel gripper = loadGripperModel(path);
    const std::string problem = gripper.validate();
    if (!problem.empty())
      throw std::runtime_error(path + ": " + problem);
    return gripper;
  }
  catch (const std::exception& e)
  {
    throw FailureError({ "config", "ConfigError", std::string("gripper: ") + e.what() });
  }
}

GraspPlannerConfig loadPlannerConfig(const Options& options)
{
  try
  {
    return loadGraspPlannerConfig(options.params_path);
  }
  catch (const std::exception& e)
  {
    throw FailureError({ "config", "ConfigError", e.what() });
  }
}

// ---- output --------------------------------------------------------------------------------

std::string jsonNumber(double value)
{
  if (!std::isfinite(value))
    return "null";
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

std::string csvNumber(double value)
{
  if (!std::isfinite(value))
    return "nan";
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

std::string jsonString(const std::string& text)
{
  std::string out = "\"";
  for (const char c : text)
  {
    switch (c)
    {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", c);
          out += escaped;
        }
        else
          out += c;
    }
  }
  return out + "\"";
}

template <typename Vector>
std::string jsonArray(const Vector& v)
{
  std::string out = "[";
  for (int i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + jsonNumber(static_cast<double>(v[i]));
  return out + "]";
}

/// Unit quaternion of a pose's orientation, w >= 0 so that equal poses print equally.
Eigen::Vector4d quaternionXyzw(const Eigen::Isometry3d& pose)
{
  Eigen::Quaterniond q(pose.linear());
  q.normalize();
  if (q.w() < 0.0)
    q.coeffs() *= -1.0;
  return q.coeffs();  // Eigen stores x, y, z, w
}

Eigen::Vector4d quaternionXyzw(const GraspCandidate& grasp)
{
  return quaternionXyzw(grasp.pose);
}

struct Report
{
  std::string status = "ok";
  std::string stage;  // empty on success
  std::string message;
  std::string algorithm;
  std::string gripper;
  std::string source;
  std::size_t points = 0;
  double compute_time_s = 0.0;
  double perception_time_s = 0.0;
  std::size_t candidates_evaluated = 0;
  /// Seen points of the object at the camera's near limit: > 0 when it was cut there and its
  /// blind space kept hands out (near_range.h).
  std::size_t points_at_near_limit = 0;
  std::vector<Eigen::Vector3f> sensor_origins;
  std::optional<Eigen::Vector4f> table_plane;
  struct ObjectSummary
  {
    Eigen::Vector3f min;
    Eigen::Vector3f max;
    Eigen::Vector3f centroid;
  };
  std::optional<ObjectSummary> object;
  std::vector<GraspCandidate> grasps;
  /// --all-objects: per grasp, the object it is for (index into `objects`), and every object.
  std::vector<std::size_t> grasp_objects;
  struct TableObject
  {
    std::size_t points = 0;
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    float top_height_m = 0.0f;
    std::string status;  // "ok" or the planner's failure
    std::string message;
    std::size_t grasps = 0;
    std::size_t blocked_by_neighbours = 0;
    std::size_t points_at_near_limit = 0;
  };
  std::vector<TableObject> objects;
  std::string object_choice;
  /// The planner's suggested camera pose (optical frame, base_link) when it found no grasp.
  std::optional<Eigen::Isometry3d> next_view;
  /// --scene: every view planned, in order (the last one is the report's).
  struct View
  {
    Eigen::Isometry3d camera_pose;
    std::string status;
    std::string message;
  };
  std::vector<View> views;
};

const char* const kCsvHeader =
    "rank,algorithm,x,y,z,qx,qy,qz,qw,approach_x,approach_y,approach_z,binormal_x,binormal_y,binormal_z,"
    "axis_x,axis_y,axis_z,width_m,score,force_balance_rad,xoz_offset_m,variance_m,torque_offset_m,"
    "gravity_offset_m";

void writeCsv(std::ostream& out, const Report& report)
{
  const bool with_objects = !report.object_choice.empty();  // --all-objects: one more column
  out << kCsvHeader << (with_objects ? ",object" : "") << "\n";
  for (std::size_t i = 0; i < report.grasps.size(); ++i)
  {
    const GraspCandidate& g = report.grasps[i];
    out << i + 1 << "," << (g.algorithm.empty() ? report.algorithm : g.algorithm);
    const Eigen::Vector4d q = quaternionXyzw(g);
    for (const Eigen::Vector3d& v : { g.position(), Eigen::Vector3d(q.head<3>()) })
      out << "," << csvNumber(v.x()) << "," << csvNumber(v.y()) << "," << csvNumber(v.z());
    out << "," << csvNumber(q.w());
    for (const Eigen::Vector3d& v : { g.approach(), g.binormal(), g.axis() })
      out << "," << csvNumber(v.x()) << "," << csvNumber(v.y()) << "," << csvNumber(v.z());
    for (const double value : { g.width_m, g.score, g.force_balance_rad, g.xoz_offset_m, g.variance_m,
                                g.torque_offset_m, g.gravity_offset_m })
      out << "," << csvNumber(value);
    if (with_objects && i < report.grasp_objects.size())
      out << "," << report.grasp_objects[i];
    out << "\n";
  }
}

void writeJson(std::ostream& out, const Report& report)
{
  out << "{\n";
  out << "  \"status\": " << jsonString(report.status) << ",\n";
  if (!report.stage.empty())
    out << "  \"stage\": " << jsonString(report.stage) << ",\n";
  out << "  \"message\": " << jsonString(report.message) << ",\n";
  out << "  \"algorithm\": " << jsonString(report.algorithm) << ",\n";
  out << "  \"gripper\": " << jsonString(report.gripper) << ",\n";
  out << "  \"source\": " << jsonString(report.source) << ",\n";
  out << "  \"frame\": \"base_link\",\n";
  out << "  \"points\": " << report.points << ",\n";
  out << "  \"compute_time_s\": " << jsonNumber(report.compute_time_s) << ",\n";
  out << "  \"perception_time_s\": " << jsonNumber(report.perception_time_s) << ",\n";
  out << "  \"candidates_evaluated\": " << report.candidates_evaluated << ",\n";
  out << "  \"points_at_near_limit\": " << report.points_at_near_limit << ",\n";
  out << "  \"sensor_origins\": [";
  for (std::size_t i = 0; i < report.sensor_origins.size(); ++i)
    out << (i ? ", " : "") << jsonArray(report.sensor_origins[i]);
  out << "],\n";
  out << "  \"table_plane\": " << (report.table_plane ? jsonArray(*report.table_plane) : "null") << ",\n";
  if (report.object)
    out << "  \"object_centroid\": " << jsonArray(report.object->centroid) << ",\n"
        << "  \"object_min\": " << jsonArray(report.object->min) << ",\n"
        << "  \"object_max\": " << jsonArray(report.object->max) << ",\n";
  if (!report.object_choice.empty())
  {
    out << "  \"object_choice\": " << jsonString(report.object_choice) << ",\n";
    out << "  \"objects\": [";
    for (std::size_t i = 0; i < report.objects.size(); ++i)
    {
      const Report::TableObject& o = report.objects[i];
      out << (i ? ",\n" : "\n") << "    {\"object\": " << i << ", \"points\": " << o.points
          << ", \"centroid\": " << jsonArray(o.centroid) << ", \"top_height_m\": " << jsonNumber(o.top_height_m)
          << ", \"status\": " << jsonString(o.status) << ", \"message\": " << jsonString(o.message)
          << ", \"grasps\": " << o.grasps << ", \"blocked_by_neighbours\": " << o.blocked_by_neighbours
          << ", \"points_at_near_limit\": " << o.points_at_near_limit << "}";
    }
    out << (report.objects.empty() ? "],\n" : "\n  ],\n");
  }
  auto jsonPose = [](const Eigen::Isometry3d& pose) {
    return "{\"position\": " + jsonArray(Eigen::Vector3d(pose.translation())) +
           ", \"quaternion_xyzw\": " + jsonArray(quaternionXyzw(pose)) + "}";
  };
  out << "  \"next_view\": " << (report.next_view ? jsonPose(*report.next_view) : "null") << ",\n";
  if (!report.views.empty())
  {
    out << "  \"views\": [";
    for (std::size_t i = 0; i < report.views.size(); ++i)
    {
      const Report::View& v = report.views[i];
      out << (i ? ",\n" : "\n") << "    {\"camera\": " << jsonPose(v.camera_pose)
          << ", \"status\": " << jsonString(v.status) << ", \"message\": " << jsonString(v.message) << "}";
    }
    out << "\n  ],\n";
  }
  out << "  \"grasps\": [";
  for (std::size_t i = 0; i < report.grasps.size(); ++i)
  {
    const GraspCandidate& g = report.grasps[i];
    out << (i ? ",\n" : "\n") << "    {\"rank\": " << i + 1;
    if (i < report.grasp_objects.size())
      out << ", \"object\": " << report.grasp_objects[i];
    out
        << ", \"algorithm\": " << jsonString(g.algorithm.empty() ? report.algorithm : g.algorithm)
        << ", \"position\": " << jsonArray(g.position())
        << ", \"quaternion_xyzw\": " << jsonArray(quaternionXyzw(g))
        << ", \"approach\": " << jsonArray(g.approach()) << ", \"binormal\": " << jsonArray(g.binormal())
        << ", \"axis\": " << jsonArray(g.axis()) << ", \"width_m\": " << jsonNumber(g.width_m)
        << ", \"score\": " << jsonNumber(g.score) << ", \"force_balance_rad\": " << jsonNumber(g.force_balance_rad)
        << ", \"xoz_offset_m\": " << jsonNumber(g.xoz_offset_m) << ", \"variance_m\": " << jsonNumber(g.variance_m)
        << ", \"torque_offset_m\": " << jsonNumber(g.torque_offset_m)
        << ", \"gravity_offset_m\": " << jsonNumber(g.gravity_offset_m)
        << ", \"drop_risk\": " << (g.drop_risk ? "true" : "false");
    if (!g.features.empty())
    {
      // the fused planner's success-model inputs, for scripts/fit_fused_model.py
      const auto& names = graspFeatureNames();
      out << ", \"features\": {";
      for (std::size_t f = 0; f < g.features.size() && f < names.size(); ++f)
        out << (f ? ", " : "") << jsonString(names[f]) << ": " << jsonNumber(g.features[f]);
      out << "}";
    }
    out << "}";
  }
  out << (report.grasps.empty() ? "]\n" : "\n  ]\n") << "}\n";
}

/// Writes the report where asked; false (with a reason on stderr) if it cannot.
bool writeReport(const Options& options, const Report& report)
{
  std::ofstream file;
  if (!options.output_path.empty())
  {
    file.open(options.output_path);
    if (!file)
    {
      std::cerr << "grasp_offline: OutputError: cannot write " << options.output_path << "\n";
      return false;
    }
  }
  std::ostream& out = options.output_path.empty() ? std::cout : file;
  if (options.format == "json")
    writeJson(out, report);
  else
    writeCsv(out, report);
  out.flush();
  if (!out)
  {
    std::cerr << "grasp_offline: OutputError: writing " << (options.output_path.empty() ? "stdout" : options.output_path)
              << " failed\n";
    return false;
  }
  return true;
}

/// --all-objects: every object planned (table_grasps.h), the grasps of all objects written in
/// pick order, each with its object; the summary and --save-object are the first object's.
int reportAllObjects(const Options& options, const PreparedView& prepared, const TableGraspResult& table,
                     const std::vector<std::size_t>& points_at_near_limit, const TableGraspParams& params,
                     Report& report, const std::function<int(const Failure&)>& finishFailure)
{
  report.compute_time_s = table.compute_time_s;
  report.next_view = table.next_view;
  report.object_choice = toString(params.object_choice);
  for (const ObjectGrasps& object : table.objects)
  {
    Report::TableObject summary;
    const ObjectView& view = prepared.objects[object.object];
    summary.points = view.cloud->size();
    summary.centroid = object.centroid;
    summary.top_height_m = object.top_height_m;
    summary.status = object.ok() ? "ok" : toString(object.result.failure == GraspFailure::None ? GraspFailure::NoStableGrasp
                                                                                                : object.result.failure);
    summary.message = object.result.message;
    summary.grasps = object.result.grasps.size();
    summary.blocked_by_neighbours = object.blocked_by_neighbours;
    summary.points_at_near_limit = points_at_near_limit.at(object.object);
    report.candidates_evaluated += object.result.candidates_evaluated;
    report.objects.push_back(summary);
  }
  if (!table.ok())
  {
    std::string reason = std::to_string(table.objects.size()) + " object(s), none with a grasp";
    if (report.views.size() > 1)
      reason = "after " + std::to_string(report.views.size()) + " views: " + reason;
    for (const Report::TableObject& o : report.objects)
      reason += "; " + o.message;
    return finishFailure({ "planning", "NoStableGrasp", reason });
  }
  const ObjectView& first = prepared.objects[table.order.front()];
  if (!options.object_pcd_path.empty() && pcl::io::savePCDFileBinary(options.object_pcd_path, *first.cloud) != 0)
    return finishFailure({ "output", "OutputError", "cannot write " + options.object_pcd_path });
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const auto& p : first.cloud->points)
  {
    lo = lo.cwiseMin(p.getVector3fMap());
    hi = hi.cwiseMax(p.getVector3fMap());
  }
  report.object = Report::ObjectSummary{ lo, hi, report.objects[table.order.front()].centroid };
  report.points = first.cloud->size();
  for (const std::size_t index : table.order)
    for (const GraspCandidate& g : table.objects[index].result.grasps)
    {
      report.grasps.push_back(g);
      report.grasp_objects.push_back(index);
    }
  report.message = std::to_string(table.order.size()) + " of " + std::to_string(table.objects.size()) +
                   " objects with a grasp, picked by " + report.object_choice + "; first: object " +
                   std::to_string(table.order.front()) + " (" + table.chosen().result.message + ")";
  if (options.max_grasps > 0 && report.grasps.size() > options.max_grasps)
  {
    report.grasps.resize(options.max_grasps);
    report.grasp_objects.resize(options.max_grasps);
  }
  return writeReport(options, report) ? kExitOk : kExitFailure;
}

int run(const Options& options)
{
  Report report;
  report.algorithm = options.algorithm;
  report.source = !options.bag_path.empty() ? options.bag_path : !options.pcd_path.empty() ? options.pcd_path : options.scene_path;
  auto finishFailure = [&](const Failure& failure) {
    report.status = failure.status;
    report.stage = failure.stage;
    report.message = failure.reason;
    report.grasps.clear();
    // The one line a caller reads; flatten any line breaks from library messages.
    std::string line = failure.reason;
    for (char& c : line)
      if (c == '\n' || c == '\r')
        c = ' ';
    std::cerr << "grasp_offline: " << failure.status << ": " << line << "\n";
    writeReport(options, report);
    return kExitFailure;
  };

  try
  {
    const GripperModel gripper = loadGripper(options.gripper);
    report.gripper = gripper.name;
    const GraspPlannerConfig config =
        options.all_objects ? tablePlannerConfig(loadPlannerConfig(options)) : loadPlannerConfig(options);
    // the name was checked in parseOptions
    const std::unique_ptr<GraspPlanner> planner = makeGraspPlanner(options.algorithm, config);
    std::optional<SceneInput> scene;
    std::vector<SensorCloud> clouds;
    Eigen::Isometry3d camera_pose = Eigen::Isometry3d::Identity();
    if (!options.scene_path.empty())
    {
      scene = loadSceneInput(options);
      camera_pose = scene->scene.cameras.front().optical_pose;
    }
    else
      clouds = options.bag_path.empty() ? readPcdInput(options) : readBagInput(options);

    ViewPreparationParams perception = deployedViewPreparationParams();
    perception.segment_table = !options.already_segmented;
    perception.segmentation.split_concave_creases = options.split_touching_objects;
    perception.table_plane = options.table_plane;
    perception.all_objects = options.all_objects;
    GraspResult result;
    for (int view = 0;; ++view)
    {
      if (scene)
        clouds = renderSceneViews(*scene, camera_pose, view);
      std::mt19937 rng(0);
      const Stopwatch perception_watch;
      PreparedView prepared = prepareView(clouds, perception, rng);
      // What the camera was too near to see is blind, not empty (near_range.h), as in the nodelets:
      // added to the views that get planned (with --all-objects, objects[0] is the target's).
      std::vector<std::size_t> points_at_near_limit;
      if (options.all_objects)
      {
        for (ObjectView& object : prepared.objects)
          points_at_near_limit.push_back(addNearRangeBlindSpace(object, config.near_range));
        if (!points_at_near_limit.empty())
          report.points_at_near_limit = points_at_near_limit.front();
      }
      else
        report.points_at_near_limit = addNearRangeBlindSpace(prepared.view, config.near_range);
      report.perception_time_s = perception_watch.elapsedSeconds();
      report.sensor_origins = prepared.view.sensor_origins;
      if (!prepared.ok())
      {
        if (scene)
          report.views.push_back({ camera_pose, prepared.status, prepared.problem });
        return finishFailure({ toString(prepared.failed_stage), prepared.status, prepared.problem });
      }
      report.points = prepared.points;
      report.table_plane.reset();
      if (prepared.view.has_table_plane)
        report.table_plane = prepared.view.table_plane;
      report.object = Report::ObjectSummary{ prepared.object_min, prepared.object_max, prepared.object_centroid };
      if (options.all_objects)
      {
        const TableGraspResult table = planTableGrasps(prepared.objects, *planner, gripper, config.table_grasps);
        if (scene)
          report.views.push_back({ camera_pose, table.ok() ? "ok" : "NoStableGrasp",
                                   table.ok() ? std::string() : "no object with a grasp" });
        // No object with a grasp: the (rendered) camera looks again from beside the table.
        if (!table.ok() && scene && table.next_view && view < options.follow_next_view)
        {
          camera_pose = *table.next_view;
          continue;
        }
        return reportAllObjects(options, prepared, table, points_at_near_limit, config.table_grasps, report,
                                [&](const Failure& f) { return finishFailure(f); });
      }
      // What the planner saw, for checking its grasps offline (test/grasp_checks.py).
      if (!options.object_pcd_path.empty() &&
          pcl::io::savePCDFileBinary(options.object_pcd_path, *prepared.view.cloud) != 0)
        return finishFailure({ "output", "OutputError", "cannot write " + options.object_pcd_path });

      const Stopwatch planning_watch;
      result = planner->plan(prepared.view, gripper);
      const double planning_s = planning_watch.elapsedSeconds();
      report.compute_time_s = result.compute_time_s > 0.0 ? result.compute_time_s : planning_s;
      report.candidates_evaluated = result.candidates_evaluated;
      report.next_view = result.next_view;
      if (scene)
        report.views.push_back({ camera_pose, result.ok() ? "ok" : toString(result.failure), result.message });
      // Ch3.2.3: move the (rendered) camera where the planner asks and look again.
      if (result.ok() || !scene || !result.next_view || view >= options.follow_next_view)
        break;
      camera_pose = *result.next_view;
    }
    if (!result.ok())
    {
      const GraspFailure why = result.failure == GraspFailure::None ? GraspFailure::NoStableGrasp : result.failure;
      std::string reason = result.message.empty() ? "no grasp" : result.message;
      if (report.views.size() > 1)
        reason = "after " + std::to_string(report.views.size()) + " views: " + reason;
      return finishFailure({ "planning", toString(why), reason });
    }
    report.message = result.message;
    report.grasps = std::move(result.grasps);
    if (options.max_grasps > 0 && report.grasps.size() > options.max_grasps)
      report.grasps.resize(options.max_grasps);
    return writeReport(options, report) ? kExitOk : kExitFailure;
  }
  catch (const FailureError& e)
  {
    return finishFailure(e.failure());
  }
  catch (const std::exception& e)  // never crash on bad input: anything unexpected is a failure
  {
    return finishFailure({ "internal", "InternalError", e.what() });
  }
}

}  // namespace
}  // namespace fast_grasp

int main(int argc, char** argv)
{
  // PCL's own console messages (e.g. the PCD reader's) would add lines to the one-line reason.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h")
    {
      std::cout << fast_grasp::kUsage;
      return fast_grasp::kExitOk;
    }
  fast_grasp::Options options;
  try
  {
    options = fast_grasp::parseOptions(argc, argv);
  }
  catch (const fast_grasp::UsageError& e)
  {
    std::cerr << "grasp_offline: " << e.what() << "\n" << fast_grasp::kUsage;
    return fast_grasp::kExitUsage;
  }
  return fast_grasp::run(options);
}
