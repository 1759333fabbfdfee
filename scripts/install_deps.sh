#!/usr/bin/env bash
# Installs every system dependency of fast_grasp from Debian bookworm's own ROS 1 packages.
# Idempotent: apt-get skips what is already there. Needs root (or sudo).
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
PACKAGES=(
  # build
  build-essential cmake catkin catkin-lint ros-message-generation ros-message-runtime
  libgtest-dev googletest python3-catkin-pkg python3-empy python3-numpy
  # the ASan + UBSan build and the libFuzzer targets (scripts/sanitizer_tests.sh, scripts/fuzz.sh)
  clang libfuzzer-14-dev libclang-rt-14-dev
  # core libraries
  libeigen3-dev libpcl-dev libompl-dev libfcl-dev liboctomap-dev liborocos-kdl-dev
  libkdl-parser-dev liburdfdom-dev liburdf-dev libyaml-cpp-dev
  # ROS C++
  libroscpp-dev libnodeletlib-dev pluginlib-dev libpcl-ros-dev libpcl-conversions-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-sensor-msgs-dev libtf2-geometry-msgs-dev libtf2-msgs-dev
  libmessage-filters-dev libdiagnostic-updater-dev librosbag-dev
  libstd-msgs-dev libstd-srvs-dev libsensor-msgs-dev libgeometry-msgs-dev libtrajectory-msgs-dev
  libvisualization-msgs-dev libdiagnostic-msgs-dev libshape-msgs-dev
  # ROS runtime and tools
  python3-rospy python3-rostest python3-roslaunch python3-rosmaster python3-rosbag python3-roslz4
  python3-rostopic python3-rosnode python3-rosservice python3-tf2-ros python3-lz4
  rosbash rospack-tools ros-robot-state-publisher joint-state-publisher libnodeletlib-tools libnodelet-dev
  libnodelet-topic-tools-dev python3-nodelet
  # message definitions (generation) and their Python side (rostest scripts)
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-trajectory-msgs ros-visualization-msgs
  ros-diagnostic-msgs ros-shape-msgs ros-tf2-msgs ros-pcl-msgs ros-std-srvs ros-roscpp-msg
  python3-std-msgs python3-sensor-msgs python3-geometry-msgs python3-trajectory-msgs
  python3-visualization-msgs python3-diagnostic-msgs python3-tf2-msgs python3-std-srvs
  python3-pcl-msgs python3-genpy python3-gencpp python3-genmsg
  # renderer's mesh source (pip) and bag compression
  python3-pip python3-venv
  # bench_planners' bar and box plots
  python3-matplotlib
)
# rviz_view.test runs rviz under Xvfb and screenshots it with ImageMagick's import.
if [ "${FAST_GRASP_NO_RVIZ:-0}" != "1" ]; then PACKAGES+=(rviz xvfb imagemagick); fi
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update
  $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
fi
# The physics grasp evaluator's venv (MuJoCo, trimesh, CoACD from PyPI) in the workspace.
bash "$(dirname "${BASH_SOURCE[0]}")/setup_venv.sh" > /dev/null
# YCB meshes (PyPI) for the tests that render scenes from the principal-axis planner's next view.
bash "$(dirname "${BASH_SOURCE[0]}")/fetch_ycb.sh" > /dev/null
