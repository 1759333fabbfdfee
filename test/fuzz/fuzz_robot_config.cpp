// libFuzzer target: the robot YAML loader (loadRobotConfig) on arbitrary bytes, placed where
// config/robots/*.yaml live (so the bundled relative URDF and home-pose paths resolve), then what
// the arm planner does with an accepted config: the chain from its URDF, its limits, its home pose.
// Seeds: config/robots/*.yaml.
#include "fuzz_input.h"

#include "fast_grasp/arm/arm_kinematics.h"
#include "fast_grasp/arm/robot_config.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace fs = std::filesystem;

namespace
{
// <tmp>/fast_grasp_fuzz_<pid>/config/robots/ holding the bundled home poses, <tmp>/.../urdf ->
// the repository's urdf/.
fs::path robotsFolder()
{
  const char* tmp = std::getenv("TMPDIR");
  const fs::path root = fs::path(tmp && *tmp ? tmp : "/tmp") / ("fast_grasp_fuzz_" + std::to_string(getpid()));
  const fs::path robots = root / "config" / "robots";
  fs::create_directories(robots);
  const fs::path source = FAST_GRASP_SOURCE_DIR;
  for (const auto& entry : fs::directory_iterator(source / "config" / "robots"))
    if (entry.path().filename().string().find("home_pose") != std::string::npos)
      fs::copy_file(entry.path(), robots / entry.path().filename(), fs::copy_options::overwrite_existing);
  if (!fs::exists(root / "urdf"))
    fs::create_directory_symlink(source / "urdf", root / "urdf");
  return robots;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  using namespace fast_grasp;
  static const fs::path robots = robotsFolder();
  const std::string path = (robots / "fuzz.yaml").string();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  RobotConfig robot;
  try
  {
    robot = loadRobotConfig(path);
  }
  catch (const std::runtime_error&)
  {
    return 0;
  }
  // Only real files of URDF size: a config naming /dev/zero is the user's own hang.
  std::error_code error;
  if (!fs::is_regular_file(robot.urdf_path, error) || fs::file_size(robot.urdf_path, error) > (1u << 20))
    return 0;
  try
  {
    ArmKinematics kinematics = ArmKinematics::fromUrdfFile(robot.urdf_path, robot.base_link, robot.tip_link);
    if (robot.joint_lower_rad.size() > 0 || robot.joint_upper_rad.size() > 0)
      kinematics.setJointLimits(robot.joint_lower_rad, robot.joint_upper_rad);
    if (robot.velocity_limit_rad_s.size() > 0)
      kinematics.setVelocityLimits(robot.velocity_limit_rad_s);
    const Eigen::VectorXd home = robot.homePose(kinematics.jointNames());
    kinematics.fk(home);
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
