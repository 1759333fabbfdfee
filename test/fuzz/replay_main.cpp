// Native (uninstrumented) replay of a fuzz target: calls its LLVMFuzzerTestOneInput on every
// file named (every regular file in a folder named), one process, and prints each input's time
// when it exceeds --slow-s, then the slowest. Under ASan, UBSan and coverage a planner runs
// 10-300x slower than it does for a user (docs/tests.md), so libFuzzer's "slow unit" reports are
// judged here: the bar is no input slower than 1 s. Also runs under valgrind, which the
// sanitized build cannot.
//
//   test_replay_<target> [--slow-s S] FILE_OR_FOLDER...
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv)
{
  double slow_s = 1.0;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h")
    {
      std::printf("usage: %s [--slow-s S] FILE_OR_FOLDER...\n  replays fuzz inputs natively; prints those slower than S "
                  "(default 1) seconds and the slowest\n",
                  argv[0]);
      return 0;
    }
    if (arg == "--slow-s" && i + 1 < argc)
    {
      slow_s = std::atof(argv[++i]);
      continue;
    }
    std::error_code error;
    if (std::filesystem::is_directory(arg, error))
    {
      for (const auto& entry : std::filesystem::directory_iterator(arg, error))
        if (entry.is_regular_file())
          files.push_back(entry.path().string());
    }
    else
      files.push_back(arg);
  }
  std::sort(files.begin(), files.end());
  double slowest_s = 0.0;
  std::string slowest;
  int over = 0;
  for (const std::string& file : files)
  {
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto start = std::chrono::steady_clock::now();
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (s > slow_s)
    {
      ++over;
      std::printf("slow: %.3f s %s\n", s, file.c_str());
    }
    if (s >= slowest_s)
    {
      slowest_s = s;
      slowest = file;
    }
  }
  std::printf("%zu inputs replayed natively, %d slower than %.2f s, slowest %.3f s (%s)\n", files.size(), over, slow_s,
              slowest_s, slowest.c_str());
  return over > 0 ? 1 : 0;
}
