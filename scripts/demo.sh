#!/usr/bin/env bash
# One command: install every dependency, build, and replay a bundled bag through the pipeline.
# Extra arguments go to demo.launch, e.g. scripts/demo.sh bag:=$(pwd)/bags/mug.bag algorithm:=cshape
# The terminal shows the report and any warning or error; everything else goes to
# $ROS_LOG_DIR/demo.log. verbose:=true shows roslaunch's own output instead (every INFO line).
# Exit status: 0 when every frame was reported, 1 otherwise.
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
verbose=false
launch_args=()
for arg in "$@"; do
  case "${arg}" in
    verbose:=true) verbose=true ;;
    verbose:=*) ;;
    -h|--help) sed -n '2,6p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) launch_args+=("${arg}") ;;
  esac
done
if [ "${verbose}" = true ]; then
  bash "${here}/install_deps.sh"
  bash "${here}/build.sh"
else
  echo "installing dependencies and building (log: ${FAST_GRASP_WS:-.ws}/demo_setup.log) ..."
  source "${here}/env.sh"; mkdir -p "${FAST_GRASP_WS}"
  { bash "${here}/install_deps.sh" && bash "${here}/build.sh"; } > "${FAST_GRASP_WS}/demo_setup.log" 2>&1 \
    || { tail -n 40 "${FAST_GRASP_WS}/demo_setup.log"; echo "set-up failed" >&2; exit 1; }
fi
source "${here}/env.sh"
set +u  # catkin's setup scripts read unset variables
source "${FAST_GRASP_WS}/devel/setup.bash"
set -u
if [ "${verbose}" = true ]; then
  exec roslaunch fast_grasp demo.launch rviz:=false "${launch_args[@]}"
fi
mkdir -p "${ROS_LOG_DIR}"
report="$(mktemp "${TMPDIR:-/tmp}/fast_grasp_report.XXXXXX")"
log="${ROS_LOG_DIR}/demo.log"
: > "${report}"
# roslaunch's own lines (process starts, the report node ending) stay in the log; rosconsole's
# WARN, ERROR and FATAL lines reach the terminal.
roslaunch fast_grasp demo.launch rviz:=false report_file:="${report}" "${launch_args[@]+"${launch_args[@]}"}" 2>&1 \
  | tee "${log}" | grep --line-buffered -E '^\[ ?(WARN|ERROR|FATAL) ?\]' >&2 &
launch_pid=$!
tail -n +1 -f --pid="${launch_pid}" "${report}" 2>/dev/null &
tail_pid=$!
wait "${launch_pid}" || true
wait "${tail_pid}" 2>/dev/null || true
last="$(tail -n 1 "${report}")"
rm -f "${report}"
case "${last}" in
  "pipeline_report: all "*|"pipeline_report: a grasp after "*) exit 0 ;;
  *) echo "demo: the report did not complete (full log: ${log})" >&2; exit 1 ;;
esac
