#!/usr/bin/env bash
# One command: install every dependency, build, run every gtest and rostest, and exit
# non-zero when any test fails. The last line is "N passed, N failed".
set -uo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
bash "${here}/install_deps.sh" || { echo "dependency installation failed"; echo "0 passed, 1 failed"; exit 1; }
source "${here}/env.sh"
mkdir -p "${FAST_GRASP_WS}"
if ! bash "${here}/build.sh" > "${FAST_GRASP_WS}/build.log" 2>&1; then
  tail -n 60 "${FAST_GRASP_WS}/build.log"; echo "build failed"; echo "0 passed, 1 failed"; exit 1
fi
set +u  # catkin's setup scripts read unset variables
source "${FAST_GRASP_WS}/devel/setup.bash"
set -u
cd "${FAST_GRASP_WS}"
rm -rf build/test_results
# Build every test first so a compile error is reported as such, not as "no tests ran".
if ! catkin_make tests -DPYTHON_EXECUTABLE=/usr/bin/python3 -j"${FAST_GRASP_JOBS:-$(nproc)}" > build/tests_build.log 2>&1; then
  grep -E 'error|Error' build/tests_build.log | head -n 40; echo "test build failed"; echo "0 passed, 1 failed"; exit 1
fi
# catkin_make run_tests exits 0 even when tests fail: the verdict comes from catkin_test_results.
catkin_make run_tests -DPYTHON_EXECUTABLE=/usr/bin/python3 -j1 "$@" 2>&1 | tee build/run_tests.log \
  | grep -E '^\[( +OK|  FAILED|  PASSED| RUN)|^\[ROSTEST\]|^SUMMARY|^ \* RESULT|^FAILURE|Failure|FAILED|^-- run_tests' || true
# ASan + UBSan: the ROS-free gtests and every fuzz corpus in a clang build of their own
# (scripts/sanitizer_tests.sh, ${FAST_GRASP_WS}/asan); their results count like the others.
sanitizer_start="$(date +%s)"
bash "${FAST_GRASP_SRC}/scripts/sanitizer_tests.sh" build/test_results/fast_grasp > build/sanitizer_tests.log 2>&1
grep -E '^\[asan\]|ERROR: |runtime error' build/sanitizer_tests.log || true
echo "sanitizer stage: $(( $(date +%s) - sanitizer_start )) s"
# catkin_lint -W2 must stay clean: its verdict is one more test case in the results.
mkdir -p build/test_results/fast_grasp
lint_output="$(cd "${FAST_GRASP_WS}/src/fast_grasp" && catkin_lint -W2 --strict . 2>&1)"
lint_rc=$?
/usr/bin/python3 - "${lint_rc}" "${lint_output}" > build/test_results/fast_grasp/lint-catkin_lint.xml <<'PY'
import sys
from xml.sax.saxutils import escape
ok = sys.argv[1] == "0"
body = "" if ok else '<failure message="catkin_lint -W2 found problems">%s</failure>' % escape(sys.argv[2])
print('<testsuite name="catkin_lint" tests="1" failures="%d"><testcase classname="lint" name="catkin_lint_W2">%s</testcase></testsuite>' % (0 if ok else 1, body))
PY
echo
# catkin_test_results flags missing result files; the counts come from the test cases.
catkin_test_results build/test_results > build/catkin_test_results.log 2>&1
catkin_rc=$?
grep -vE '^(Summary|$)' build/catkin_test_results.log | grep -vE 'xml: [0-9]+ tests, 0 errors, 0 failures' | head -n 20
/usr/bin/python3 "${FAST_GRASP_SRC}/scripts/count_test_results.py" build/test_results
count_rc=$?
if [ "${count_rc}" -ne 0 ] || [ "${catkin_rc}" -ne 0 ]; then exit 1; fi
exit 0
