#!/usr/bin/env bash
# Builds the ASan + UBSan libFuzzer targets of test/fuzz/ (if needed) and fuzzes them one after
# the other, each for SECONDS, then prints per target: executions, seconds, exec/s, coverage
# (libFuzzer's cov: edges and ft: features) and the crashes, leaks, timeouts and slow inputs it
# found. Exits 1 when any target found one. docs/tests.md explains the targets and the corpora.
#
# New inputs go to ${FAST_GRASP_SANITIZE_WS}/fuzz/corpus/<target>/ (git-ignored), next to the
# committed seeds test/fuzz/corpus/<corpus>/ (read only); findings to .../fuzz/artifacts/<target>/.
# Keep a finding as a regression input: copy it to test/fuzz/corpus/<corpus>/crash_<what>.
set -uo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
usage="usage: fuzz.sh [TARGET] [SECONDS]   (TARGET: a name below or 'all' (default); SECONDS: per target, default 60)"
targets_all=(principal_axis_plan boundary_plan concavity_plan cshape_plan fused_plan cloud_preprocess
  grasp_planner_params gripper_model robot_config pcd_input arm_ik trajectory_timing mesh_loader)
case "${1:-}" in
  --help|-h) echo "${usage}"; echo "targets: ${targets_all[*]}"; exit 0 ;;
  -*) echo "fuzz.sh: unknown option $1" >&2; echo "${usage}" >&2; exit 2 ;;
esac
target="${1:-all}"
seconds="${2:-60}"
if ! [[ "${seconds}" =~ ^[0-9]+$ ]]; then echo "fuzz.sh: SECONDS must be a whole number" >&2; echo "${usage}" >&2; exit 2; fi
if [ "${target}" = "all" ]; then
  targets=("${targets_all[@]}")
else
  target="${target#test_}"
  target="${target#fuzz_}"
  if ! printf '%s\n' "${targets_all[@]}" | grep -qx "${target}"; then
    echo "fuzz.sh: unknown target ${target}" >&2; echo "targets: ${targets_all[*]}" >&2; exit 2
  fi
  targets=("${target}")
fi

ws="${FAST_GRASP_SANITIZE_WS:-${FAST_GRASP_WS}/asan}"
export FAST_GRASP_SANITIZE_WS="${ws}"
build_targets=()
for t in "${targets[@]}"; do build_targets+=("test_fuzz_${t}"); done
mkdir -p "${ws}"
if ! bash "${here}/build_sanitized.sh" "${build_targets[@]}" > "${ws}/fuzz_build.log" 2>&1; then
  tail -n 40 "${ws}/fuzz_build.log"; echo "fuzz.sh: build failed (${ws}/fuzz_build.log)"; exit 1
fi

# The seed corpus of a target (the five planners share the object views).
seed_dir() {
  case "$1" in
    *_plan) echo "${FAST_GRASP_SRC}/test/fuzz/corpus/object_view" ;;
    *) echo "${FAST_GRASP_SRC}/test/fuzz/corpus/$1" ;;
  esac
}

# halt_on_error: the first sanitizer report stops the run and becomes a crash artifact.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
found=0
summary=()
for t in "${targets[@]}"; do
  work="${ws}/fuzz/corpus/${t}"
  artifacts="${ws}/fuzz/artifacts/${t}"
  log="${ws}/fuzz/logs/${t}.log"
  mkdir -p "${work}" "${artifacts}" "$(dirname "${log}")"
  before="$(ls "${artifacts}" | wc -l)"
  echo "== test_fuzz_${t}: ${seconds} s (log ${log})"
  start="$(date +%s)"
  # -timeout: a hang; -report_slow_units: any input slower than 1 s is a finding too (issue 12).
  TMPDIR="${ws}/fuzz" nice "${ws}/devel/lib/fast_grasp/test_fuzz_${t}" -max_total_time="${seconds}" -timeout=20 \
    -report_slow_units=1 -rss_limit_mb=3072 -print_final_stats=1 -artifact_prefix="${artifacts}/" \
    "${work}" "$(seed_dir "${t}")" > "${log}" 2>&1
  rc=$?
  took=$(( $(date +%s) - start ))
  # "Slowest unit: N s" only counts from 1 s on: it is a slow input, and libFuzzer saves it.
  slow="$(grep -c '^Slowest unit' "${log}")"
  new=$(( $(ls "${artifacts}" | wc -l) - before ))
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "${log}" | tail -n 1)"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "${log}" | tail -n 1)"
  cov="$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "${log}" | tail -n 1)"
  findings=$(( new > slow ? new : slow ))
  status="ok"
  if [ "${rc}" -ne 0 ] || [ "${findings}" -gt 0 ]; then
    status="FOUND ${findings} (exit ${rc}; see ${artifacts})"
    grep -E '^(==[0-9]+==ERROR|SUMMARY|.*runtime error|Slowest unit|ALARM)' "${log}" | head -n 5
    found=1
  fi
  summary+=("$(printf '%-22s %10s execs %6s s %7s exec/s  %-22s %s' "${t}" "${execs:-?}" "${took}" "${rate:-?}" "${cov:-cov: ?}" "${status}")")
done
echo
printf '%-22s %16s %8s %14s  %-22s %s\n' target executions time rate coverage result
printf '%s\n' "${summary[@]}"
exit "${found}"
