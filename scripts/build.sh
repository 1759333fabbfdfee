#!/usr/bin/env bash
# Builds fast_grasp (and its tests) in the catkin workspace $FAST_GRASP_WS. Idempotent.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
mkdir -p "${FAST_GRASP_WS}/src"
ln -sfn "${FAST_GRASP_SRC}" "${FAST_GRASP_WS}/src/fast_grasp"
cd "${FAST_GRASP_WS}"
JOBS="${FAST_GRASP_JOBS:-$(nproc)}"
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release -j"${JOBS}" "$@"
