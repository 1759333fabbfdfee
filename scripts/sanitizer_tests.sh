#!/usr/bin/env bash
# The sanitizer stage of scripts/run_tests.sh: builds the ASan + UBSan workspace
# (build_sanitized.sh), runs every ROS-free gtest in it (and test_grasp_offline: the sanitized
# grasp_offline on every bundled bag) and replays every fuzz corpus
# (test/fuzz/corpus/, seeds and regression inputs) through its fuzz target once. Writes one JUnit
# file per gtest and per fuzz target to RESULTS_DIR (asan-*.xml), so that a sanitizer report, a
# failing test or a crashing corpus input counts as a failed test in the summary line.
# Usage: sanitizer_tests.sh RESULTS_DIR
set -uo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
usage="usage: sanitizer_tests.sh RESULTS_DIR"
case "${1:-}" in
  --help|-h) echo "${usage}"; echo "ASan + UBSan gtests and fuzz-corpus replay; JUnit results go to RESULTS_DIR."; exit 0 ;;
  -*|"") echo "sanitizer_tests.sh: ${1:-missing RESULTS_DIR}" >&2; echo "${usage}" >&2; exit 2 ;;
esac
results="$(mkdir -p "$1" && cd "$1" && pwd)"
ws="${FAST_GRASP_SANITIZE_WS:-${FAST_GRASP_WS}/asan}"
export FAST_GRASP_SANITIZE_WS="${ws}"
mkdir -p "${ws}/logs"
bin="${ws}/devel/lib/fast_grasp"

# One JUnit file with one test case: junit NAME FAILURE_MESSAGE LOG_FILE (empty message: passed).
junit() {
  /usr/bin/python3 - "$1" "$2" "$3" > "${results}/asan-$1.xml" <<'PY'
import sys
from xml.sax.saxutils import escape, quoteattr
name, message, log = sys.argv[1:4]
body = ""
if message:
    try:
        with open(log, errors="replace") as f:
            tail = "".join(f.readlines()[-60:])
    except OSError:
        tail = ""
    body = "<failure message=%s>%s</failure>" % (quoteattr(message), escape(tail))
print('<testsuite name="asan" tests="1" failures="%d"><testcase classname="asan" name=%s>%s</testcase></testsuite>'
      % (1 if message else 0, quoteattr(name), body))
PY
}

# Prints the run's line; on a non-zero exit marks the stage failed and shows the first report
# lines. Usage: finished RC LOG START_SECONDS LABEL
failed=0
finished() {
  echo "[asan] $4: exit $1 ($(( $(date +%s) - $3 )) s)"
  [ "$1" -eq 0 ] && return 0
  failed=1
  grep -E 'ERROR: |runtime error|SUMMARY|FAILED' "$2" | head -n 5
  return 1
}

start="$(date +%s)"
if ! bash "${here}/build_sanitized.sh" > "${ws}/logs/build.log" 2>&1; then
  grep -E 'error' "${ws}/logs/build.log" | head -n 20
  junit build "the ASan + UBSan build failed" "${ws}/logs/build.log"
  exit 1
fi
built="$(date +%s)"

# halt_on_error: the first report ends the process with a non-zero status (UBSan included:
# the build has -fno-sanitize-recover=undefined). detect_leaks: LeakSanitizer at exit.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:allocator_may_return_null=1"
# The test binaries find the package's libraries by RUNPATH, which LD_LIBRARY_PATH overrides: with
# the normal workspace's setup.bash sourced (run_tests.sh does) they loaded the UNINSTRUMENTED
# libraries and only the tests' own code ran under the sanitizers. The sanitized ones come first.
export LD_LIBRARY_PATH="${ws}/devel/lib${LD_LIBRARY_PATH:+:${LD_LIBRARY_PATH}}"
# Checked, as one more test case: a sanitized test must load the sanitized package libraries.
loaded="$(ldd "${bin}/test_perception" 2>&1 | grep 'libfast_grasp_perception' || true)"
if [[ "${loaded}" == *"${ws}/devel/lib/libfast_grasp_perception.so"* ]]; then
  junit sanitized_libraries_loaded "" /dev/null
else
  failed=1
  echo "${loaded}" > "${ws}/logs/ldd.log"
  junit sanitized_libraries_loaded "test_perception does not load ${ws}/devel/lib/libfast_grasp_perception.so: ${loaded}" \
    "${ws}/logs/ldd.log"
fi
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Tests that assert a time budget check speed, which an ASan + UBSan build (10-20x slower) does
# not measure: they run in the normal build only. The JACO IK round trip counts solutions found
# within ik_timeout_s (5 ms): 76-77 of 100 under the sanitizers, 100 natively.
timed_tests="BoundaryGrasp.ReportsComputeTimeAtTenThousandPoints:Lwr4.ShelfPickIsSolved:Jaco.IkRoundTripsThroughTheOffsetWrist"
for test in test_core test_gripper_volume test_perception test_renderer test_arm_kinematics test_arm_collision \
    test_arm_planning test_arm_robots test_grasp_execution test_principal_axis_grasp test_cshape_grasp \
    test_boundary_grasp test_fused_grasp test_lying_cylinder test_resting_ball test_standing_cylinder test_one_seen_face test_wide_flat_top test_unseen_part test_near_range test_steep_closing_line test_table_grasps test_concavity_grasp test_grasp_offline test_callback_gate; do
  log="${ws}/logs/${test}.log"
  t0="$(date +%s)"
  timeout 1800 nice "${bin}/${test}" --gtest_filter="-${timed_tests}" --gtest_output="xml:${results}/asan-${test}.xml" \
    > "${log}" 2>&1
  rc=$?
  # A sanitizer report at exit (a leak) or a crash mid-test leaves the gtest XML without the
  # failure: one more case carries it.
  finished "${rc}" "${log}" "${t0}" "${test}" || junit "${test}_exit" "${test} exited ${rc} under ASan + UBSan" "${log}"

done

# Every corpus input once (libFuzzer runs the files given and exits): seeds and regressions.
for fuzzer in "${bin}"/test_fuzz_*; do
  name="$(basename "${fuzzer}")"
  target="${name#test_fuzz_}"
  case "${target}" in *_plan) corpus=object_view ;; *) corpus="${target}" ;; esac
  inputs=("${FAST_GRASP_SRC}/test/fuzz/corpus/${corpus}"/*)
  log="${ws}/logs/${name}.log"
  t0="$(date +%s)"
  TMPDIR="${ws}" timeout 600 nice "${fuzzer}" -timeout=30 "${inputs[@]}" > "${log}" 2>&1
  rc=$?
  if finished "${rc}" "${log}" "${t0}" "${name} on ${#inputs[@]} corpus inputs"; then
    junit "corpus_${target}" "" "${log}"
  else
    junit "corpus_${target}" "${name} failed on its corpus (exit ${rc})" "${log}"
  fi
done
echo "[asan] build $(( built - start )) s, tests and corpora $(( $(date +%s) - built )) s"
exit "${failed}"
