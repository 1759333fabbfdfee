#!/usr/bin/env bash
# The physics evaluation the README quotes: every planner, the fused one and the baseline on the
# held-out objects, Robotiq 2F-85 at friction 0.8 and 0.5, the Lacquey Fetch and PR2 at 0.8, and
# the principal-axis planner following its next view (success within two views).
# Writes bench_out/physics/<gripper>_mu<friction>/ (trials.csv, summary.txt, PNG charts) and
# prints every summary's last lines. About 20 minutes on two cores.
#   bash scripts/physics_report.sh [--split train|heldout] [extra evaluate_grasps_physics.py flags]
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
PY="$(bash "${here}/setup_venv.sh")"
set +u
source "${FAST_GRASP_WS}/devel/setup.bash"
set -u
export FAST_GRASP_YCB_DIR="${FAST_GRASP_YCB_DIR:-$(bash "${here}/fetch_ycb.sh")}"
split="heldout"
if [ "${1:-}" = "--split" ]; then split="$2"; shift 2; fi
out="${FAST_GRASP_SRC}/bench_out/physics"
mkdir -p "${out}"
planners="principal_axis,cshape,boundary,concavity,fused,baseline"
for run in robotiq_2f85:0.8 robotiq_2f85:0.5 lacquey_fetch:0.8 pr2:0.8; do
  gripper="${run%%:*}"; mu="${run##*:}"
  dir="${out}/${split}_${gripper}_mu${mu}"
  "$PY" "${FAST_GRASP_SRC}/scripts/evaluate_grasps_physics.py" --gripper "${gripper}" --friction "${mu}" \
      --split "${split}" --planners "${planners}" --out-dir "${dir}" "$@" > "${dir}.log" 2>&1 || {
    echo "evaluation ${gripper} mu ${mu} failed: ${dir}.log" >&2; exit 1; }
  echo "## ${gripper}, friction ${mu} (${dir}/summary.txt)"
  grep -E "^[a-z_]+ [a-z0-9_]+ (single|within)" "${dir}/summary.txt"
done
# The principal-axis planner following its own next view (Ch. 3.2.3): success within two views.
dir="${out}/${split}_robotiq_2f85_mu0.8_next_view"
"$PY" "${FAST_GRASP_SRC}/scripts/evaluate_grasps_physics.py" --gripper robotiq_2f85 --split "${split}" \
    --planners principal_axis,fused --follow-next-view 1 --out-dir "${dir}" "$@" > "${dir}.log" 2>&1 || {
  echo "next-view evaluation failed: ${dir}.log" >&2; exit 1; }
echo "## robotiq_2f85, friction 0.8, following the principal-axis next view (${dir}/summary.txt)"
grep -E "^[a-z_]+ [a-z0-9_]+ (single|within)" "${dir}/summary.txt"
