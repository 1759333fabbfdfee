#!/usr/bin/env bash
# Runs the nodelet rostests under ThreadSanitizer (issue 12; docs/tests.md "ThreadSanitizer"):
# the package from the TSan workspace (scripts/build_tsan.sh), every nodelet manager with
# FAST_GRASP_TSAN_THREADS (default 4) worker threads and Debian's uninstrumented manager given
# the TSan runtime by LD_PRELOAD (the launch files' manager_launch_prefix / num_worker_threads
# args read FAST_GRASP_MANAGER_LAUNCH_PREFIX / FAST_GRASP_NUM_WORKER_THREADS). Prints per test
# whether it passed and its distinct TSan reports with their top fast_grasp frames
# (scripts/tsan_summary.py). Not part of run_tests.sh / CI: it takes far longer than the CI budget.
# Usage: tsan_rostests.sh [--list] [TEST ...]   (default: every test below)
# Output: ${FAST_GRASP_TSAN_OUT:-${FAST_GRASP_WS}/tsan_out}/<test>/ (rostest log, tsan.<pid> logs,
# ros_home with the test results); the exit status is 1 when a test failed or a report has a
# fast_grasp frame.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
declare -A TESTS=(
  [grasp_pipeline]="grasp_pipeline.test scene:=spray_bottle expect_no_grasp:=none known_failures:=none arm_grasps_from:=principal_axis_planner expect_next_view:=none"
  [perception_bags]="perception_bags.test scene:=mug"
  [perception_bad_input]="perception_bad_input.test"
  [cloud_fusion]="cloud_fusion.test"
  [two_camera_pipeline]="two_camera_pipeline.test"
  [all_objects_pipeline]="all_objects_pipeline.test"
  [clear_table]="clear_table.test"
  [next_view_pipeline]="next_view_pipeline.test scene:=hammer"
  [pipeline_faults]="pipeline_faults.test"
  [nodelet_unload]="nodelet_unload.test"
  [pcl_ros_mapping]="gtest:test_pcl_ros_mapping"
  [callback_gate]="gtest:test_callback_gate"
)
ORDER=(perception_bad_input perception_bags cloud_fusion two_camera_pipeline grasp_pipeline
  all_objects_pipeline next_view_pipeline clear_table pipeline_faults nodelet_unload
  pcl_ros_mapping callback_gate)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ] || [ "${1:-}" = "--list" ]; then
  echo "usage: tsan_rostests.sh [--list] [TEST ...]"
  for name in "${ORDER[@]}"; do echo "  ${name}: ${TESTS[${name}]}"; done
  exit 0
fi
selected=("$@")
[ "${#selected[@]}" -gt 0 ] || selected=("${ORDER[@]}")
for name in "${selected[@]}"; do
  [ -n "${TESTS[${name}]:-}" ] || { echo "tsan_rostests.sh: unknown test ${name} (--list)" >&2; exit 2; }
done

ws="${FAST_GRASP_TSAN_WS:-${FAST_GRASP_WS}/tsan}"
runtime=/usr/lib/x86_64-linux-gnu/libtsan.so.2
[ -f "${ws}/devel/setup.bash" ] || { echo "no TSan workspace at ${ws}: run scripts/build_tsan.sh" >&2; exit 2; }
[ -f "${runtime}" ] || { echo "no ${runtime} (GCC's TSan runtime, package libtsan2)" >&2; exit 2; }
set +u
source "${ws}/devel/setup.bash"
set -u
export PATH="/usr/bin:${PATH}"
# scene_camera scenes with ycb: parts (clear_table, next_view_pipeline)
if [ -z "${FAST_GRASP_YCB_DIR:-}" ]; then
  FAST_GRASP_YCB_DIR="$(bash "${FAST_GRASP_SRC}/scripts/fetch_ycb.sh" 2>/dev/null | tail -n 1 || true)"
  export FAST_GRASP_YCB_DIR
fi
out="${FAST_GRASP_TSAN_OUT:-${FAST_GRASP_WS}/tsan_out}"
export FAST_GRASP_NUM_WORKER_THREADS="${FAST_GRASP_TSAN_THREADS:-4}"
export FAST_GRASP_MANAGER_LAUNCH_PREFIX="env LD_PRELOAD=${runtime}"
# GCC's built-in symbolizer names no frame of our (dlopen'ed, DWARF 5) libraries: llvm-symbolizer
# (clang's, installed for the ASan build) does.
symbolizer=""
if command -v llvm-symbolizer > /dev/null; then
  symbolizer="external_symbolizer_path=$(command -v llvm-symbolizer) "
fi
status=0
summary=()
for name in "${selected[@]}"; do
  dir="${out}/${name}"
  rm -rf "${dir}"
  mkdir -p "${dir}"
  # history_size=4: deeper previous-access stacks (the races are between callbacks seconds
  # apart); halt_on_error=0: every report of a run, not the first one.
  export TSAN_OPTIONS="log_path=${dir}/tsan halt_on_error=0 history_size=4 second_deadlock_stack=1 ${symbolizer}suppressions=${FAST_GRASP_SRC}/test/tsan.supp"
  read -r -a spec <<< "${TESTS[${name}]}"
  start=$(date +%s)
  # Judged from the log: rostest exits 0 on some failures, and a gtest process exits with TSan's
  # code 66 after its tests passed whenever there was a report (counted below instead).
  if [[ "${spec[0]}" == gtest:* ]]; then  # a plain gtest binary (no ROS master)
    "${ws}/devel/lib/fast_grasp/${spec[0]#gtest:}" > "${dir}/rostest.log" 2>&1 || true
  else
    ROS_HOME="${dir}/ros_home" ROS_LOG_DIR="${dir}/ros_home/log" \
      rostest --text fast_grasp "${spec[@]}" > "${dir}/rostest.log" 2>&1 || true
  fi
  if grep -qE "RESULT: SUCCESS|\[  PASSED  \]" "${dir}/rostest.log" &&
     ! grep -qE "RESULT: FAIL|FAILURES: [1-9]|ERRORS: [1-9]|\[  FAILED  \]" "${dir}/rostest.log"; then
    result=passed
  else
    result=FAILED
    status=1
  fi
  seconds=$(( $(date +%s) - start ))
  report="$(/usr/bin/python3 "${FAST_GRASP_SRC}/scripts/tsan_summary.py" --lib-dir "${ws}/devel/lib" --lib-dir "${ws}/devel/lib/fast_grasp" "${dir}")"
  echo "== ${name}: ${result} in ${seconds} s; $(echo "${report}" | tail -n 1)"
  echo "${report}" | sed '$d'
  grep -q "^reports: 0 fast_grasp" <<< "$(echo "${report}" | tail -n 1)" || status=1
  summary+=("${name}: ${result}, ${seconds} s, $(echo "${report}" | tail -n 1)")
done
echo "== summary (logs in ${out})"
printf '  %s\n' "${summary[@]}"
exit "${status}"
