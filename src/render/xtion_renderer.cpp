#include "fast_grasp/render/xtion_renderer.h"

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/io/vtk_lib_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace fast_grasp
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

int addVertex(TriangleMesh& mesh, const Eigen::Vector3f& v)
{
  mesh.vertices.push_back(v);
  return static_cast<int>(mesh.vertices.size()) - 1;
}

void addQuad(TriangleMesh& mesh, int a, int b, int c, int d)
{
  mesh.triangles.emplace_back(a, b, c);
  mesh.triangles.emplace_back(a, c, d);
}
}  // namespace

// ------------------------------------------------------------------------------------------
// Meshes

void TriangleMesh::append(const TriangleMesh& other, const Eigen::Isometry3f& pose)
{
  const int offset = static_cast<int>(vertices.size());
  for (const auto& v : other.vertices)
    vertices.push_back(pose * v);
  for (const auto& t : other.triangles)
    triangles.push_back(t + Eigen::Vector3i::Constant(offset));
}

void TriangleMesh::transform(const Eigen::Isometry3f& pose)
{
  for (auto& v : vertices)
    v = pose * v;
}

Eigen::Vector3f TriangleMesh::minCorner() const
{
  if (vertices.empty())
    return Eigen::Vector3f::Zero();
  Eigen::Vector3f m = vertices.front();
  for (const auto& v : vertices)
    m = m.cwiseMin(v);
  return m;
}

Eigen::Vector3f TriangleMesh::maxCorner() const
{
  if (vertices.empty())
    return Eigen::Vector3f::Zero();
  Eigen::Vector3f m = vertices.front();
  for (const auto& v : vertices)
    m = m.cwiseMax(v);
  return m;
}

TriangleMesh makeBox(double size_x_m, double size_y_m, double size_z_m)
{
  TriangleMesh mesh;
  const float hx = static_cast<float>(size_x_m / 2), hy = static_cast<float>(size_y_m / 2);
  const float h = static_cast<float>(size_z_m);
  for (int i = 0; i < 8; ++i)
    addVertex(mesh, Eigen::Vector3f((i & 1) ? hx : -hx, (i & 2) ? hy : -hy, (i & 4) ? h : 0.0f));
  addQuad(mesh, 0, 1, 3, 2);  // bottom
  addQuad(mesh, 4, 5, 7, 6);  // top
  addQuad(mesh, 0, 1, 5, 4);  // -y
  addQuad(mesh, 2, 3, 7, 6);  // +y
  addQuad(mesh, 0, 2, 6, 4);  // -x
  addQuad(mesh, 1, 3, 7, 5);  // +x
  return mesh;
}

TriangleMesh makeRevolution(const std::vector<Eigen::Vector2d>& profile_z_r_m, int segments)
{
  TriangleMesh mesh;
  segments = std::max(segments, 3);
  const size_t rings = profile_z_r_m.size();
  if (rings < 2)
    return mesh;
  for (const auto& zr : profile_z_r_m)
    for (int j = 0; j < segments; ++j)
    {
      const double a = 2.0 * kPi * j / segments;
      addVertex(mesh, Eigen::Vector3f(static_cast<float>(zr.y() * std::cos(a)),
                                      static_cast<float>(zr.y() * std::sin(a)), static_cast<float>(zr.x())));
    }
  for (size_t i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j)
    {
      const int jn = (j + 1) % segments;
      const int base = static_cast<int>(i) * segments, next = static_cast<int>(i + 1) * segments;
      addQuad(mesh, base + j, base + jn, next + jn, next + j);
    }
  // Close open ends with a fan so solids (cylinders, bottles) have a top and bottom.
  auto cap = [&](size_t ring) {
    if (profile_z_r_m[ring].y() <= 0.0)
      return;
    const int centre = addVertex(mesh, Eigen::Vector3f(0.0f, 0.0f, static_cast<float>(profile_z_r_m[ring].x())));
    const int base = static_cast<int>(ring) * segments;
    for (int j = 0; j < segments; ++j)
      mesh.triangles.emplace_back(centre, base + j, base + (j + 1) % segments);
  };
  cap(0);
  cap(rings - 1);
  return mesh;
}

TriangleMesh makeCylinder(double radius_m, double height_m, int segments)
{
  return makeRevolution({ { 0.0, radius_m }, { height_m, radius_m } }, segments);
}

TriangleMesh makeSphere(double radius_m, int segments)
{
  std::vector<Eigen::Vector2d> profile;
  const int rings = std::max(segments / 2, 4);
  for (int i = 0; i <= rings; ++i)
  {
    const double polar = kPi * i / rings;  // 0 at the bottom pole
    profile.emplace_back(radius_m - radius_m * std::cos(polar), radius_m * std::sin(polar));
  }
  return makeRevolution(profile, segments);
}

TriangleMesh makeExtrusion(const std::vector<Eigen::Vector2d>& polygon_xy_m, double thickness_m)
{
  TriangleMesh mesh;
  const int n = static_cast<int>(polygon_xy_m.size());
  if (n < 3)
    return mesh;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& p : polygon_xy_m)
    centroid += p;
  centroid /= n;
  const float top = static_cast<float>(thickness_m);
  for (const auto& p : polygon_xy_m)
    addVertex(mesh, Eigen::Vector3f(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f));
  for (const auto& p : polygon_xy_m)
    addVertex(mesh, Eigen::Vector3f(static_cast<float>(p.x()), static_cast<float>(p.y()), top));
  const int c0 = addVertex(mesh, Eigen::Vector3f(static_cast<float>(centroid.x()), static_cast<float>(centroid.y()), 0.0f));
  const int c1 = addVertex(mesh, Eigen::Vector3f(static_cast<float>(centroid.x()), static_cast<float>(centroid.y()), top));
  for (int i = 0; i < n; ++i)
  {
    const int j = (i + 1) % n;
    addQuad(mesh, i, j, n + j, n + i);
    mesh.triangles.emplace_back(c0, i, j);
    mesh.triangles.emplace_back(c1, n + i, n + j);
  }
  return mesh;
}

namespace
{
/// Why VTK's STL reader (behind pcl::io::loadPolygonFile) must not be given the STL file at
/// `path`, or "" when it may. VTK 9.1 picks ASCII or binary by the share of non-text bytes in
/// the first 256 (kwsys DetectFileType, >= 5 % is binary) and its binary reader allocates the
/// triangle count of bytes 80-83 before reading: a fuzzed file starting with "solid" but holding
/// binary bytes asked for 18 GB (test/fuzz/corpus/mesh_loader/crash_stl_solid_but_binary). The
/// format is decided here: binary exactly when the file is 84 + 50 bytes per declared triangle,
/// otherwise ASCII ("solid ..."), and VTK must see the same.
std::string stlFileProblem(const std::string& path)
{
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file)
    return "cannot open it";
  const std::uint64_t bytes = static_cast<std::uint64_t>(file.tellg());
  std::string head(static_cast<std::size_t>(std::min<std::uint64_t>(bytes, 256)), '\0');
  file.seekg(0);
  if (head.empty() || !file.read(&head[0], static_cast<std::streamsize>(head.size())))
    return "empty or unreadable file";
  const std::size_t probe = head.size();
  std::size_t non_text = 0;
  for (std::size_t i = 0; i < probe; ++i)
  {
    const auto c = static_cast<unsigned char>(head[i]);
    non_text += (c >= 0x20 && c <= 0x7F) || c == '\n' || c == '\r' || c == '\t' ? 0 : 1;
  }
  const bool vtk_reads_binary = static_cast<double>(non_text) >= 0.05 * static_cast<double>(probe);
  std::uint32_t triangles = 0;
  if (bytes >= 84)
    std::memcpy(&triangles, head.data() + 80, sizeof(triangles));
  const bool binary = bytes >= 84 && 84 + 50 * static_cast<std::uint64_t>(triangles) == bytes;
  if (binary && !vtk_reads_binary)
    return "binary STL (84 + 50 x " + std::to_string(triangles) +
           " bytes) whose first 256 bytes look like text: VTK would read it as ASCII";
  if (binary)
    return "";
  const std::size_t first = head.find_first_not_of(" \t\r\n");
  const bool ascii = first != std::string::npos && head.compare(first, 5, "solid") == 0;
  if (ascii && vtk_reads_binary)
    return "starts like an ASCII STL ('solid') but holds binary bytes, and is not a binary STL either (" +
           std::to_string(bytes) + " bytes, not 84 + 50 x the " + std::to_string(triangles) +
           " triangles bytes 80-83 declare)";
  if (!ascii)
    return "neither an ASCII STL ('solid ...') nor a binary one (" + std::to_string(bytes) +
           " bytes, not 84 + 50 x the " + std::to_string(triangles) + " triangles bytes 80-83 declare)";
  return "";
}

/// Why VTK's OBJ reader must not be given the OBJ file at `path`, or "" when it may. VTK 9.1's
/// vtkOBJReader dereferences a null texture-coordinate array when a face vertex names a texture
/// coordinate ("4/1", or the empty "4/") and the file has no "vt" line (a SEGV while fuzzing,
/// test/fuzz/corpus/mesh_loader/crash_obj_texture_index_without_vt). Every face vertex must be
/// v, v/vt, v/vt/vn or v//vn with each index (1-based, or negative from the end) naming an
/// existing v, vt or vn line.
std::string objFileProblem(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
    return "cannot open it";
  std::vector<std::string> lines;
  long counts[3] = { 0, 0, 0 };  // v, vt, vn
  for (std::string line; std::getline(file, line);)
  {
    // Text only: VTK's reader sees "vn\0..." as a normal where a word-by-word count does not
    // (a heap overflow in vtk2mesh while fuzzing, corpus/mesh_loader/crash_obj_nul_in_keyword).
    for (const char c : line)
      if ((static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\r') || c == 0x7f)
        return "holds a control byte (an OBJ file is text)";
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    counts[0] += keyword == "v";
    counts[1] += keyword == "vt";
    counts[2] += keyword == "vn";
    if (keyword == "v" || keyword == "vn")
    {
      // x y z (a vertex may carry w or a colour after them)
      std::size_t numbers = 0;
      for (double value = 0.0; words >> value;)
        ++numbers;
      if (numbers < 3)
        return "'" + keyword + "' line with " + std::to_string(numbers) + " number(s): " + line.substr(0, 40);
    }
    if (keyword == "f")
      lines.push_back(line);
  }
  static const char* const kNames[3] = { "vertex", "texture coordinate", "normal" };
  bool face_names_a_normal = false;
  for (const std::string& line : lines)
  {
    std::istringstream words(line);
    std::string vertex;
    words >> vertex;  // "f"
    while (words >> vertex)
    {
      std::vector<std::string> parts(1);
      for (const char c : vertex)
        if (c == '/')
          parts.emplace_back();
        else
          parts.back().push_back(c);
      if (parts.size() > 3 || (parts.size() == 2 && parts[1].empty()) || (parts.size() == 3 && parts[2].empty()))
        return "face vertex '" + vertex + "' is not v, v/vt, v/vt/vn or v//vn";
      for (std::size_t k = 0; k < parts.size(); ++k)
      {
        if (k == 1 && parts[k].empty())
          continue;  // v//vn
        char* end = nullptr;
        const long index = std::strtol(parts[k].c_str(), &end, 10);
        if (parts[k].empty() || *end != '\0' || index == 0 || std::labs(index) > counts[k])
          return "face vertex '" + vertex + "' names " + kNames[k] + " " + parts[k] + " of " +
                 std::to_string(counts[k]);
      }
      face_names_a_normal = face_names_a_normal || parts.size() == 3;
    }
  }
  // VTK keeps normals no face names as one per vertex, and PCL's vtk2mesh copies one per vertex:
  // fewer of them is a heap overflow inside libpcl_io (found by fuzzing, test/fuzz/corpus/mesh_loader/).
  if (counts[2] > 0 && counts[2] < counts[0] && !face_names_a_normal)
    return std::to_string(counts[2]) + " normal(s) for " + std::to_string(counts[0]) +
           " vertices and no face names one (one normal per vertex expected)";
  return "";
}
/// Why PCL's PLY reader must not be given `path`, or "". Its header is read as PCL reads it: a
/// list property of any element but "face" (vertex_indices on the vertex element, after a
/// fuzzed "element face" line) hits an assert(false) in PLYReader's vertex list callback, an
/// abort of the whole process (corpus/mesh_loader/crash_ply_list_on_vertex).
std::string plyFileProblem(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
    return "cannot open it";
  std::error_code size_error;
  const auto file_bytes = static_cast<unsigned long long>(std::filesystem::file_size(path, size_error));
  if (size_error)
    return "cannot read its size";
  std::string element;
  for (std::string line; std::getline(file, line);)
  {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header")
      return "";
    if (keyword == "element")
    {
      // A count PCL reserves for inside a noexcept callback: "-5" wraps to 2^64 - 5 and the
      // length_error terminates the process (corpus/mesh_loader/crash_ply_negative_count).
      std::string count;
      words >> element >> count;
      char* end = nullptr;
      const long long n = std::strtoll(count.c_str(), &end, 10);
      if (count.empty() || *end != '\0' || n < 0 || static_cast<unsigned long long>(n) > file_bytes)
        return "element '" + element + "' has count '" + count + "' (a whole number, at most the file's size)";
    }
    else if (keyword == "property")
    {
      std::string type;
      words >> type;
      if (type == "list" && element != "face")
        return "a list property in element '" + element + "' (lists belong to 'face')";
    }
  }
  return "no end_header";
}
}  // namespace

bool loadMeshFile(const std::string& path, TriangleMesh& mesh, std::string& error)
{
  pcl::PolygonMesh polygon_mesh;
  // PLY through PCL's own reader, not VTK's: VTK 9.1's vtkPLY::add_property dereferences a bad
  // pointer on a malformed PLY header (a SEGV while fuzzing, test/fuzz/corpus/mesh_loader/),
  // and PCL's PLY reader is the one OSS-Fuzz covers. STL and OBJ stay with loadPolygonFile.
  const bool ply = path.size() >= 4 && path.compare(path.size() - 4, 4, ".ply") == 0;
  const bool stl = path.size() >= 4 && path.compare(path.size() - 4, 4, ".stl") == 0;
  const bool obj = path.size() >= 4 && path.compare(path.size() - 4, 4, ".obj") == 0;
  if (stl || obj || ply)
  {
    const std::string problem = stl ? stlFileProblem(path) : obj ? objFileProblem(path) : plyFileProblem(path);
    if (!problem.empty())
    {
      error = "mesh '" + path + "': " + problem;
      return false;
    }
  }
  if ((ply ? pcl::io::loadPLYFile(path, polygon_mesh) : pcl::io::loadPolygonFile(path, polygon_mesh)) < 0 ||
      polygon_mesh.cloud.width * polygon_mesh.cloud.height == 0)
  {
    error = "cannot read a mesh from '" + path + "' (STL, OBJ or PLY expected)";
    return false;
  }
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(polygon_mesh.cloud, cloud);
  mesh = TriangleMesh();
  mesh.vertices.reserve(cloud.size());
  for (const auto& p : cloud.points)
    mesh.vertices.emplace_back(p.x, p.y, p.z);
  const int vertex_count = static_cast<int>(mesh.vertices.size());
  for (const auto& polygon : polygon_mesh.polygons)
  {
    const auto& ids = polygon.vertices;
    for (size_t k = 2; k < ids.size(); ++k)  // fan-triangulate polygons
    {
      const Eigen::Vector3i t(static_cast<int>(ids[0]), static_cast<int>(ids[k - 1]), static_cast<int>(ids[k]));
      if (t.minCoeff() < 0 || t.maxCoeff() >= vertex_count)
      {
        error = "mesh '" + path + "' has a polygon with an out-of-range vertex index";
        return false;
      }
      mesh.triangles.push_back(t);
    }
  }
  if (mesh.triangles.empty())
  {
    error = "mesh '" + path + "' has no triangles";
    return false;
  }
  return true;
}

Eigen::Vector3f centreOnBase(TriangleMesh& mesh)
{
  const Eigen::Vector3f lo = mesh.minCorner(), hi = mesh.maxCorner();
  const Eigen::Vector3f shift(-(lo.x() + hi.x()) / 2, -(lo.y() + hi.y()) / 2, -lo.z());
  for (auto& v : mesh.vertices)
    v += shift;
  return shift;
}

// ------------------------------------------------------------------------------------------
// Noise

double axialNoiseSigma(double depth_m, double incidence_rad)
{
  const double theta = std::min(std::max(incidence_rad, 0.0), kPi / 2 - 1e-3);
  const double grazing = theta * theta / ((kPi / 2 - theta) * (kPi / 2 - theta));
  return 0.0012 + 0.0019 * (depth_m - 0.4) * (depth_m - 0.4) + 0.0001 / std::sqrt(depth_m) * grazing;
}

size_t RenderedFrame::validCount() const
{
  return static_cast<size_t>(
      std::count_if(points.begin(), points.end(), [](const Eigen::Vector3f& p) { return std::isfinite(p.z()); }));
}

// ------------------------------------------------------------------------------------------
// Bounding-volume hierarchy over all scene triangles (median split on the longest axis).
// Measured (one thread, -O2, shared 2-core machine): a 640x480 frame of a 102k-triangle sphere on a
// table takes ~0.7 s CPU including shadow rays; a 16k-triangle YCB scene renders 2 frames + truth in ~2 s.

struct XtionRenderer::Bvh
{
  struct Triangle
  {
    Eigen::Vector3f v0, e1, e2, normal;  // unit normal
    int part = 0;
  };
  struct Node
  {
    Eigen::Vector3f lo, hi;
    int left = -1, right = -1;  // children; -1 for a leaf
    int first = 0, count = 0;   // leaf range in triangles
  };
  std::vector<Triangle> triangles;
  std::vector<Node> nodes;

  struct Hit
  {
    float t = std::numeric_limits<float>::infinity();
    int triangle = -1;
  };

  void build(const std::vector<ScenePart>& parts)
  {
    for (size_t p = 0; p < parts.size(); ++p)
    {
      const auto& mesh = parts[p].mesh;
      for (const auto& t : mesh.triangles)
      {
        if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(mesh.vertices.size()))
          continue;  // malformed index: skip rather than read out of bounds
        Triangle tri;
        tri.v0 = mesh.vertices[t[0]];
        tri.e1 = mesh.vertices[t[1]] - tri.v0;
        tri.e2 = mesh.vertices[t[2]] - tri.v0;
        const Eigen::Vector3f n = tri.e1.cross(tri.e2);
        if (n.norm() < 1e-12f)
          continue;  // degenerate (e.g. the pole of a solid of revolution)
        tri.normal = n.normalized();
        tri.part = static_cast<int>(p);
        triangles.push_back(tri);
      }
    }
    nodes.clear();
    if (!triangles.empty())
      buildNode(0, static_cast<int>(triangles.size()));
  }

  int buildNode(int first, int count)
  {
    Node node;
    node.lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    node.hi = -node.lo;
    Eigen::Vector3f clo = node.lo, chi = node.hi;
    for (int i = first; i < first + count; ++i)
    {
      const auto& t = triangles[i];
      for (const Eigen::Vector3f& v : { t.v0, Eigen::Vector3f(t.v0 + t.e1), Eigen::Vector3f(t.v0 + t.e2) })
      {
        node.lo = node.lo.cwiseMin(v);
        node.hi = node.hi.cwiseMax(v);
      }
      const Eigen::Vector3f c = centroid(t);
      clo = clo.cwiseMin(c);
      chi = chi.cwiseMax(c);
    }
    const int index = static_cast<int>(nodes.size());
    nodes.push_back(node);
    if (count <= 4)
    {
      nodes[index].first = first;
      nodes[index].count = count;
      return index;
    }
    int axis = 0;
    (chi - clo).maxCoeff(&axis);
    const int mid = first + count / 2;
    std::nth_element(triangles.begin() + first, triangles.begin() + mid, triangles.begin() + first + count,
                     [&](const Triangle& a, const Triangle& b) { return centroid(a)[axis] < centroid(b)[axis]; });
    const int left = buildNode(first, mid - first);
    const int right = buildNode(mid, first + count - mid);
    nodes[index].left = left;
    nodes[index].right = right;
    return index;
  }

  static Eigen::Vector3f centroid(const Triangle& t) { return t.v0 + (t.e1 + t.e2) / 3.0f; }

  // Entry distance of the ray into the node's box, or +inf when it misses within t_max.
  static float boxEntry(const Node& n, const Eigen::Vector3f& o, const Eigen::Vector3f& inv_d, float t_max)
  {
    float t0 = 0.0f, t1 = t_max;
    for (int a = 0; a < 3; ++a)
    {
      float near = (n.lo[a] - o[a]) * inv_d[a], far = (n.hi[a] - o[a]) * inv_d[a];
      if (near > far)
        std::swap(near, far);
      t0 = near > t0 ? near : t0;
      t1 = far < t1 ? far : t1;
      if (t0 > t1)
        return std::numeric_limits<float>::infinity();
    }
    return t0;
  }

  // Moller-Trumbore; returns the ray parameter or +inf.
  static float triangleHit(const Triangle& t, const Eigen::Vector3f& o, const Eigen::Vector3f& d)
  {
    const Eigen::Vector3f p = d.cross(t.e2);
    const float det = t.e1.dot(p);
    if (std::abs(det) < 1e-12f)
      return std::numeric_limits<float>::infinity();
    const float inv_det = 1.0f / det;
    const Eigen::Vector3f s = o - t.v0;
    const float u = s.dot(p) * inv_det;
    if (u < 0.0f || u > 1.0f)
      return std::numeric_limits<float>::infinity();
    const Eigen::Vector3f q = s.cross(t.e1);
    const float v = d.dot(q) * inv_det;
    if (v < 0.0f || u + v > 1.0f)
      return std::numeric_limits<float>::infinity();
    const float dist = t.e2.dot(q) * inv_det;
    return dist > 0.0f ? dist : std::numeric_limits<float>::infinity();
  }

  // Closest hit (any_hit = false) or any hit closer than t_max that passes the filter.
  template <typename Filter>
  Hit trace(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_max, bool any_hit, Filter&& accept) const
  {
    Hit hit;
    hit.t = t_max;
    if (nodes.empty())
      return Hit();
    const Eigen::Vector3f inv_d(1.0f / d.x(), 1.0f / d.y(), 1.0f / d.z());
    // Nodes are pushed with their entry distance; the nearer child is visited first so the
    // closest hit shrinks hit.t early and farther subtrees are skipped.
    struct Entry
    {
      int node;
      float t;
    };
    Entry stack[128];
    int top = 0;
    const float root_t = boxEntry(nodes[0], o, inv_d, hit.t);
    if (std::isfinite(root_t))
      stack[top++] = { 0, root_t };
    while (top > 0)
    {
      const Entry entry = stack[--top];
      if (entry.t > hit.t)
        continue;  // a closer hit was found since this node was pushed
      const Node& n = nodes[entry.node];
      if (n.left < 0)
      {
        for (int i = n.first; i < n.first + n.count; ++i)
        {
          const float t = triangleHit(triangles[i], o, d);
          if (t < hit.t && accept(triangles[i]))
          {
            hit.t = t;
            hit.triangle = i;
            if (any_hit)
              return hit;
          }
        }
      }
      else if (top + 2 <= 128)
      {
        const float tl = boxEntry(nodes[n.left], o, inv_d, hit.t);
        const float tr = boxEntry(nodes[n.right], o, inv_d, hit.t);
        const Entry left{ n.left, tl }, right{ n.right, tr };
        const Entry& near = tl <= tr ? left : right;
        const Entry& far = tl <= tr ? right : left;
        if (std::isfinite(far.t))
          stack[top++] = far;
        if (std::isfinite(near.t))
          stack[top++] = near;
      }
    }
    if (hit.triangle < 0)
      hit.t = std::numeric_limits<float>::infinity();
    return hit;
  }
};

// ------------------------------------------------------------------------------------------
// Renderer

XtionRenderer::XtionRenderer(std::vector<ScenePart> parts, XtionIntrinsics intrinsics, XtionNoiseParams noise)
  : parts_(std::move(parts)), intrinsics_(intrinsics), noise_(noise), bvh_(std::make_unique<Bvh>())
{
  bvh_->build(parts_);
}

XtionRenderer::~XtionRenderer() = default;
XtionRenderer::XtionRenderer(XtionRenderer&&) noexcept = default;
XtionRenderer& XtionRenderer::operator=(XtionRenderer&&) noexcept = default;

size_t XtionRenderer::triangleCount() const
{
  return bvh_->triangles.size();
}

RenderedFrame XtionRenderer::render(const Eigen::Isometry3d& camera_pose, uint64_t seed) const
{
  return renderImpl(camera_pose, seed, noise_.enable_noise);
}

RenderedFrame XtionRenderer::renderNoiseFree(const Eigen::Isometry3d& camera_pose) const
{
  return renderImpl(camera_pose, 0, false);
}

RenderedFrame XtionRenderer::renderImpl(const Eigen::Isometry3d& camera_pose, uint64_t seed, bool noisy) const
{
  const XtionIntrinsics& k = intrinsics_;
  RenderedFrame frame;
  frame.width = std::max(k.width, 0);
  frame.height = std::max(k.height, 0);
  const size_t n = static_cast<size_t>(frame.width) * frame.height;
  frame.points.assign(n, Eigen::Vector3f::Constant(kNaN));
  frame.rgb.assign(n, 0u);
  frame.part_label.assign(n, -1);

  const Eigen::Matrix3f rot = camera_pose.linear().cast<float>();
  const Eigen::Vector3f origin = camera_pose.translation().cast<float>();
  const Eigen::Vector3f projector = origin + rot.col(0) * static_cast<float>(noise_.projector_baseline_m);
  const double slope = std::abs(noise_.disparity_per_inverse_m);  // d(1/Z)/dd

  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const auto opaque = [this](const Bvh::Triangle& t) { return !parts_[t.part].transparent; };
  const auto any = [](const Bvh::Triangle&) { return true; };

  for (int v = 0; v < frame.height; ++v)
    for (int u = 0; u < frame.width; ++u)
    {
      const size_t idx = static_cast<size_t>(v) * frame.width + u;
      double su = u, sv = v;
      if (noisy)
      {
        su += noise_.lateral_sigma_px * gauss(rng);
        sv += noise_.lateral_sigma_px * gauss(rng);
      }
      // Ray with unit optical z: the ray parameter is the depth.
      const Eigen::Vector3f dir_cam(static_cast<float>((su - k.cx) / k.fx), static_cast<float>((sv - k.cy) / k.fy), 1.0f);
      const Eigen::Vector3f dir = rot * dir_cam;
      const Bvh::Hit hit = bvh_->trace(origin, dir, std::numeric_limits<float>::infinity(), false, any);
      if (hit.triangle < 0)
        continue;
      const Bvh::Triangle& tri = bvh_->triangles[hit.triangle];
      const ScenePart& part = parts_[tri.part];
      frame.rgb[idx] = (uint32_t(part.red) << 16) | (uint32_t(part.green) << 8) | uint32_t(part.blue);
      frame.part_label[idx] = part.label;
      if (part.transparent)
        continue;
      double depth = hit.t;
      if (depth < noise_.min_range_m || depth > noise_.max_range_m)
        continue;
      const double cos_incidence = std::abs(tri.normal.dot(dir)) / dir.norm();
      const double incidence = std::acos(std::min(1.0, cos_incidence));
      if (incidence > noise_.max_incidence_rad)
        continue;
      if (noise_.projector_shadows)
      {
        const Eigen::Vector3f surface = origin + dir * hit.t;
        const Eigen::Vector3f to_projector = projector - surface;
        const float distance = to_projector.norm();
        const Eigen::Vector3f towards = to_projector / distance;
        const float eps = 1e-4f;  // 0.1 mm: avoids re-hitting the surface itself
        if (bvh_->trace(surface + towards * eps, towards, distance - 2 * eps, true, opaque).triangle >= 0)
          continue;
      }
      if (noisy)
      {
        if (uniform(rng) < noise_.dropout_probability)
          continue;
        // Nguyen's sigma_z expressed in disparity units (dZ/dd = slope * Z^2).
        const double sigma_z = axialNoiseSigma(depth, incidence);
        const double sigma_d = std::max(noise_.disparity_sigma_min_px, sigma_z / (slope * depth * depth));
        const double quantisation_var = noise_.quantise_disparity ? 1.0 / 12.0 : 0.0;
        const double gauss_sigma_d = std::sqrt(std::max(sigma_d * sigma_d - quantisation_var, 0.0));
        double disparity = (noise_.disparity_offset_inv_m - 1.0 / depth) / slope;
        disparity += gauss_sigma_d * gauss(rng);
        if (noise_.quantise_disparity)
          disparity = std::round(disparity);
        const double inverse_depth = noise_.disparity_offset_inv_m - slope * disparity;
        if (inverse_depth <= 0.0)
          continue;
        depth = 1.0 / inverse_depth;
        if (noise_.round_depth_to_mm)
          depth = std::round(depth * 1000.0) / 1000.0;
        if (depth < noise_.min_range_m || depth > noise_.max_range_m)
          continue;
      }
      frame.points[idx] = Eigen::Vector3f(static_cast<float>((u - k.cx) / k.fx * depth),
                                          static_cast<float>((v - k.cy) / k.fy * depth), static_cast<float>(depth));
    }
  return frame;
}

// ------------------------------------------------------------------------------------------
// Camera poses

Eigen::Quaterniond opticalFromLinkRotation()
{
  Eigen::Matrix3d r;
  // Columns: the optical x (right), y (down), z (forward) axes in camera_link coordinates.
  r.col(0) = Eigen::Vector3d(0, -1, 0);
  r.col(1) = Eigen::Vector3d(0, 0, -1);
  r.col(2) = Eigen::Vector3d(1, 0, 0);
  return Eigen::Quaterniond(r);
}

Eigen::Isometry3d lookAtOpticalPose(const Eigen::Vector3d& eye_m, const Eigen::Vector3d& target_m)
{
  Eigen::Vector3d forward = target_m - eye_m;
  if (forward.norm() < 1e-9)
    forward = Eigen::Vector3d::UnitX();
  forward.normalize();
  Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(forward);
  if (left.norm() < 1e-6)  // looking straight up or down: pick the world y as "left"
    left = Eigen::Vector3d::UnitY();
  left.normalize();
  const Eigen::Vector3d up = forward.cross(left);
  Eigen::Matrix3d link;
  link.col(0) = forward;
  link.col(1) = left;
  link.col(2) = up;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = link * opticalFromLinkRotation().toRotationMatrix();
  pose.translation() = eye_m;
  return pose;
}

}  // namespace fast_grasp
