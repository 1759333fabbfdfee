// libFuzzer target: the renderer's mesh loader (loadMeshFile: PCL's STL, OBJ and PLY readers
// through loadPolygonFile) on arbitrary files, then what render_bag does with a loaded mesh:
// centre it on its base and render it noise-free into a small depth image.
//
// Layout: u8 format (0: .stl, 1: .obj, 2: .ply, by value mod 3), then the file.
#include "fuzz_input.h"

#include "fast_grasp/render/xtion_renderer.h"

#include <cmath>

// PCL 1.13's vtk2mesh (libpcl_io, not ours) frees with operator delete what it allocated with
// malloc on every OBJ file, the bundled box included: ASan's alloc-dealloc-mismatch stops at the
// first input. glibc serves both from one heap, so this check alone is off for this target.
extern "C" const char* __asan_default_options() { return "alloc_dealloc_mismatch=0"; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  using namespace fast_grasp;
  if (size < 1)
    return 0;
  static const char* const kExtensions[] = { ".stl", ".obj", ".ply" };
  const std::string path =
      fuzz::writeTempFile(std::string(reinterpret_cast<const char*>(data + 1), size - 1), kExtensions[data[0] % 3]);
  TriangleMesh mesh;
  std::string error;
  if (!loadMeshFile(path, mesh, error))
  {
    if (error.empty())
      __builtin_trap();  // rejected without a reason
    return 0;
  }
  for (const Eigen::Vector3i& t : mesh.triangles)
    if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(mesh.vertices.size()))
      __builtin_trap();  // the loader promises valid indices
  centreOnBase(mesh);
  ScenePart part;
  part.mesh = mesh;
  XtionIntrinsics small;
  small.width = 32;
  small.height = 24;
  small.fx = small.fy = 30.0;
  small.cx = 15.5;
  small.cy = 11.5;
  const XtionRenderer renderer({ part }, small);
  renderer.renderNoiseFree(lookAtOpticalPose(Eigen::Vector3d(0.6, 0.0, 0.5), Eigen::Vector3d(0.0, 0.0, 0.05)));
  return 0;
}
