#!/usr/bin/env bash
# Builds the ThreadSanitizer workspace (g++, -Dfast_grasp_TSAN=ON) that scripts/tsan_rostests.sh
# runs the nodelet rostests against (docs/tests.md, "ThreadSanitizer"). It lives inside the
# git-ignored workspace, beside the normal build: ${FAST_GRASP_WS}/tsan, or FAST_GRASP_TSAN_WS.
# Idempotent.
# Usage: build_tsan.sh [TARGET ...]   (default: the nodelets library, scene_camera, the messages,
# and the thread gtests test_nodelet_unload, test_pcl_ros_mapping, test_callback_gate)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then
  echo "usage: build_tsan.sh [TARGET ...]"
  echo "Builds the ThreadSanitizer (g++) workspace \${FAST_GRASP_TSAN_WS:-\${FAST_GRASP_WS}/tsan}:"
  echo "by default what the nodelet rostests run (fast_grasp_nodelets, scene_camera, the messages)."
  exit 0
fi
for arg in "$@"; do
  case "${arg}" in
    -*) echo "build_tsan.sh: unknown option ${arg}" >&2; echo "usage: build_tsan.sh [TARGET ...]" >&2; exit 2 ;;
  esac
done
ws="${FAST_GRASP_TSAN_WS:-${FAST_GRASP_WS}/tsan}"
mkdir -p "${ws}/src"
ln -sfn "${FAST_GRASP_SRC}" "${ws}/src/fast_grasp"
cd "${ws}"
targets=("$@")
# The rostests need the nodelets, the simulated camera, the generated messages (Python side of
# the test nodes) and the thread gtests; the other tools and gtests are not run under TSan.
[ "${#targets[@]}" -gt 0 ] || targets=(fast_grasp_nodelets scene_camera fast_grasp_generate_messages test_nodelet_unload
  test_pcl_ros_mapping test_callback_gate)
# Release keeps NDEBUG like the real build; the TSan flags add -O1 -g after it (CMakeLists.txt).
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER=gcc -DCMAKE_CXX_COMPILER=g++ -Dfast_grasp_TSAN=ON \
  -j"${FAST_GRASP_JOBS:-$(nproc)}" "${targets[@]}"
