#!/usr/bin/env bash
# Which grasp the arm planner executes: every single-object bag, both frames, every grasp
# planner, through arm_offline (bag -> grasps -> the ArmPlanner's scene -> planGraspMotion, the
# UR5 of config/arm.yaml). A grasp planner ranks its grasps best first (the fused one by the
# physics-fitted model), so how often its grasp 0 is planned as given (not a later grasp, not a
# flipped or tilted variant) says how much of that ranking reaches the robot.
# Prints one line per bag, planner and frame, then per planner and overall
#   <planner>: P of N frames with grasps planned, B with the planner's best grasp as given
# About 3 minutes on one core.
#   bash scripts/arm_grasp_report.sh [--planners fused,cshape,...] [--bags mug,cup,...]
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
set +u
source "${FAST_GRASP_WS}/devel/setup.bash"
set -u
planners="fused,cshape,concavity,boundary,principal_axis"
bags=""
while [ $# -gt 0 ]; do
  case "$1" in
    --planners) planners="$2"; shift 2 ;;
    --bags) bags="$2"; shift 2 ;;
    *) echo "usage: arm_grasp_report.sh [--planners a,b] [--bags a,b]" >&2; exit 2 ;;
  esac
done
if [ -z "${bags}" ]; then
  # single-object bags: the clutter and two-camera bags need other tools (bench_clutter, two_camera_pipeline.test)
  bags="$(cd "${FAST_GRASP_SRC}/bags" && ls ./*.bag | sed 's|^\./||; s|\.bag$||' | grep -v -E '^(clutter_|two_camera_)' | paste -sd, -)"
fi
arm_offline="${FAST_GRASP_WS}/devel/lib/fast_grasp/arm_offline"
results="$(mktemp)"
trap 'rm -f "${results}"' EXIT
for bag in ${bags//,/ }; do
  for planner in ${planners//,/ }; do
    for frame in 0 1; do
      # arm_offline exits non-zero when nothing plans; its last PLANNED/FAILED line is the verdict
      verdict="$("${arm_offline}" --bag "${FAST_GRASP_SRC}/bags/${bag}.bag" --algorithm "${planner}" --frame "${frame}" 2>&1 \
                 | grep -E '^(PLANNED|FAILED)' | head -n 1 || true)"
      echo "${bag} ${planner} ${frame} ${verdict:-no grasps}" | tee -a "${results}"
    done
  done
done
/usr/bin/python3 - "${results}" "${planners}" <<'PY'
import re
import sys
rows = [line.rstrip("\n").split(" ", 3) for line in open(sys.argv[1])]
def summary(name, sel):
    with_grasps = [r for r in sel if r[3] != "no grasps"]
    planned = [r for r in with_grasps if r[3].startswith("PLANNED")]
    best = [r for r in planned if re.match(r"PLANNED: grasp 0 planned", r[3])]
    print("%s: %d of %d frames with grasps planned, %d with the planner's best grasp as given"
          % (name, len(planned), len(with_grasps), len(best)))
print()
for planner in sys.argv[2].split(","):
    summary(planner, [r for r in rows if r[1] == planner])
summary("all", rows)
PY
