#!/usr/bin/env bash
# Builds the ASan + UBSan workspace (clang, -Dfast_grasp_SANITIZE=ON): the ROS-free gtests and
# the libFuzzer targets of test/fuzz/ (docs/tests.md). It lives inside the git-ignored workspace,
# beside the normal build: ${FAST_GRASP_WS}/asan, or FAST_GRASP_SANITIZE_WS. Idempotent.
# Usage: build_sanitized.sh [TARGET ...]   (default: fast_grasp_sanitizer_checks, i.e. all)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then
  echo "usage: build_sanitized.sh [TARGET ...]"
  echo "Builds the ASan + UBSan (clang) workspace \${FAST_GRASP_SANITIZE_WS:-\${FAST_GRASP_WS}/asan}:"
  echo "the ROS-free gtests and the libFuzzer targets (default target: fast_grasp_sanitizer_checks)."
  exit 0
fi
for arg in "$@"; do
  case "${arg}" in
    -*) echo "build_sanitized.sh: unknown option ${arg}" >&2; echo "usage: build_sanitized.sh [TARGET ...]" >&2; exit 2 ;;
  esac
done
ws="${FAST_GRASP_SANITIZE_WS:-${FAST_GRASP_WS}/asan}"
mkdir -p "${ws}/src"
ln -sfn "${FAST_GRASP_SRC}" "${ws}/src/fast_grasp"
cd "${ws}"
targets=("$@")
[ "${#targets[@]}" -gt 0 ] || targets=(fast_grasp_sanitizer_checks)
# Release (optimised like the real build) plus line tables (-gline-tables-only in CMakeLists.txt)
# for the reports: full -g would make the build a third slower.
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -Dfast_grasp_SANITIZE=ON \
  -j"${FAST_GRASP_JOBS:-$(nproc)}" "${targets[@]}"
