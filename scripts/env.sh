# Sourced by the other scripts: where the workspace lives and a sane PATH for Debian's ROS.
# Debian's catkin, rostest and rosbag need the system python3 (the pyenv one lacks catkin_pkg).
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
FAST_GRASP_SRC="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# The catkin workspace lives beside the sources, inside the git-ignored .ws/ folder,
# so the source tree itself never holds build output.
FAST_GRASP_WS="${FAST_GRASP_WS:-${FAST_GRASP_SRC}/.ws}"
export FAST_GRASP_SRC FAST_GRASP_WS
export ROS_HOME="${ROS_HOME:-${FAST_GRASP_WS}/ros_home}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-${ROS_HOME}/log}"
