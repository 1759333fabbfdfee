// The command-line convention every fast_grasp executable follows: `--help` or `-h` prints the
// usage on stdout and exits 0; a bad command line (unknown flag, missing value) prints the
// problem and the usage on stderr and exits 2. Header-only, standard library only.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace fast_grasp
{
/// Exits 0 with `usage` on stdout when any argument is --help or -h.
inline void exitOnHelpFlag(int argc, char** argv, const char* usage)
{
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0)
    {
      std::fputs(usage, stdout);
      std::exit(0);
    }
}

/// Exits 2 with `problem` and `usage` on stderr.
[[noreturn]] inline void exitWithUsage(const std::string& problem, const char* usage)
{
  std::fprintf(stderr, "%s\n%s", problem.c_str(), usage);
  std::exit(2);
}

/// The non-empty items of a comma-separated flag value ("a,,b" -> {a, b}).
inline std::vector<std::string> splitCommaList(const std::string& text)
{
  std::vector<std::string> items;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');)
    if (!item.empty())
      items.push_back(item);
  return items;
}

}  // namespace fast_grasp
