#!/usr/bin/env bash
# usage: bash scripts/soak.sh MINUTES [--rate HZ] [--port PORT]
# Soaks the full pipeline (launch/soak.launch: perception, five grasp planners, arm planner) with
# the bundled bag frames at HZ (default 30) for MINUTES and prints per stage frames in, out,
# superseded and dropped by their ~status reason, the managers' memory over time and the targets
# (scripts/soak.py explains the columns). Starts its own master on a free port (or PORT), never
# 11311; expects a built workspace ($FAST_GRASP_WS, scripts/build.sh). The roslaunch log goes to
# $ROS_LOG_DIR/soak.log, the report also to $ROS_LOG_DIR/soak_report.txt.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
usage() { sed -n '2,9p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
minutes="" rate=30 port=""
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --rate) rate="$2"; shift 2 ;;
    --port) port="$2"; shift 2 ;;
    -*) usage >&2; exit 2 ;;
    *) [ -z "${minutes}" ] || { usage >&2; exit 2; }; minutes="$1"; shift ;;
  esac
done
[ -n "${minutes}" ] || { usage >&2; exit 2; }
source "${here}/env.sh"
set +u  # catkin's setup scripts read unset variables
source "${FAST_GRASP_WS}/devel/setup.bash"
set -u
if [ -z "${port}" ]; then
  port="$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')"
fi
export ROS_MASTER_URI="http://localhost:${port}"
mkdir -p "${ROS_LOG_DIR}"
report="${ROS_LOG_DIR}/soak_report.txt"
rm -f "${report}"
echo "soak: ${minutes} min at ${rate} Hz, master on port ${port}; log ${ROS_LOG_DIR}/soak.log; uptime:$(uptime)"
roslaunch -p "${port}" fast_grasp soak.launch minutes:="${minutes}" rate_hz:="${rate}" report:="${report}" \
  > "${ROS_LOG_DIR}/soak.log" 2>&1 || true
echo "uptime at the end:$(uptime)"
if [ ! -s "${report}" ]; then
  tail -n 30 "${ROS_LOG_DIR}/soak.log"
  echo "soak: no report (see ${ROS_LOG_DIR}/soak.log)" >&2
  exit 1
fi
cat "${report}"
! grep -q -- "-> FAIL" "${report}"
