#include "fuzz_input.h"

#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace fast_grasp
{
namespace fuzz
{
std::string writeTempFile(const std::string& bytes, const std::string& extension)
{
  // Per process (parallel fuzz jobs share /tmp); the extension selects the reader (mesh loader).
  const char* tmp = std::getenv("TMPDIR");
  const std::string path = std::string(tmp && *tmp ? tmp : "/tmp") + "/fast_grasp_fuzz_" +
                           std::to_string(static_cast<long>(getpid())) + extension;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out)
    throw std::runtime_error("cannot write " + path);
  return path;
}

}  // namespace fuzz
}  // namespace fast_grasp
