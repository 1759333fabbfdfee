#!/usr/bin/env bash
# usage: bash scripts/planner_study.sh [--robots ur5,lwr4,jaco] [--planners A,B,...] [--groups 10s,20s]
#          [--runs 30] [--bin BENCH_PLANNERS] [--study-dir DIR] [--cpu N] [--nice LEVEL]
#          [--chunk-timeout-s S] [--status]
# The thesis appendix's planner study (issue 13, docs/benchmarks/arms.md "The study: what ran")
# in resumable chunks: one chunk is one (robot, planner, group), group 10s = shelf_pick and
# shelf_place at a 10 s limit, 20s = shelf_place_horizontal at 20 s, each --runs runs (default
# 30) with --end-to-end none, written to DIR/<robot>/<planner>_<group>/ (runs.csv, OMPL logs,
# bench.log). A chunk is done when its DONE marker exists: written only after bench_planners
# exited 0 with every row of runs.csv there. Rerunning skips done chunks and starts an unfinished
# one again from scratch, so stopping (kill, end of session) loses only the chunk that ran.
# Order: robots as given (default ur5, lwr4, jaco), per robot the planners as given (default
# the 8 limit-bound ones: PRM,LazyPRM,RRTstar,PRMstar,LazyPRMstar,LBTRRT,SPARS,SPARStwo), per
# planner 10s then 20s. --bin: the bench_planners to run (default DIR/bin/bench_planners, the
# frozen copy; see its COMMIT); --cpu N pins it to core N (taskset), --nice LEVEL (default 5);
# --chunk-timeout-s: a chunk still running after S s is stopped and counts as failed (default
# 3 x its runs' time limits + 600 s: a planner that never returns must not stall the study).
# DIR (default /work/study30) also gets chunks.tsv (one line per finished chunk: times, load
# averages, CPU seconds) and load.log (/proc/loadavg once a minute while this runs).
# --status lists every chunk as done / partial / todo and exits. Fold done chunks into
# docs/benchmarks/ with scripts/merge_planner_study.py.
set -euo pipefail
usage() { sed -n '2,23p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
robots="ur5,lwr4,jaco"
planners="PRM,LazyPRM,RRTstar,PRMstar,LazyPRMstar,LBTRRT,SPARS,SPARStwo"
groups="10s,20s"
runs=30
study_dir="/work/study30"
bin=""
cpu=""
nice_level=5
status_only=0
chunk_timeout_s=""
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --robots) robots="$2"; shift 2 ;;
    --planners) planners="$2"; shift 2 ;;
    --groups) groups="$2"; shift 2 ;;
    --runs) runs="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --study-dir) study_dir="$2"; shift 2 ;;
    --cpu) cpu="$2"; shift 2 ;;
    --nice) nice_level="$2"; shift 2 ;;
    --chunk-timeout-s) chunk_timeout_s="$2"; shift 2 ;;
    --status) status_only=1; shift ;;
    *) usage >&2; exit 2 ;;
  esac
done
[ -n "${bin}" ] || bin="${study_dir}/bin/bench_planners"
IFS=, read -r -a robot_list <<< "${robots}"
IFS=, read -r -a planner_list <<< "${planners}"
IFS=, read -r -a group_list <<< "${groups}"

# group -> bench_planners flags and the rows a complete runs.csv holds (scenes x runs)
group_flags() {
  case "$1" in
    10s) echo "--scenes shelf_pick,shelf_place --limits 10" ;;
    20s) echo "--scenes shelf_place_horizontal --limits 20" ;;
    *) echo "unknown group $1 (10s or 20s)" >&2; exit 2 ;;
  esac
}
group_rows() {
  case "$1" in
    10s) echo $((2 * runs)) ;;
    20s) echo "${runs}" ;;
  esac
}
group_limit_s() {  # seconds of time limits in one chunk: scenes x runs x limit
  case "$1" in
    10s) echo $((2 * runs * 10)) ;;
    20s) echo $((runs * 20)) ;;
  esac
}
for g in "${group_list[@]}"; do group_flags "${g}" > /dev/null; done

if [ "${status_only}" = 1 ]; then
  for robot in "${robot_list[@]}"; do
    for planner in "${planner_list[@]}"; do
      for g in "${group_list[@]}"; do
        d="${study_dir}/${robot}/${planner}_${g}"
        if [ -f "${d}/DONE" ]; then echo "done     ${robot} ${planner} ${g}: $(head -n 1 "${d}/DONE")"
        elif [ -d "${d}" ]; then echo "partial  ${robot} ${planner} ${g}"
        else echo "todo     ${robot} ${planner} ${g}"; fi
      done
    done
  done
  exit 0
fi

[ -x "${bin}" ] || { echo "planner_study: no bench_planners at ${bin} (--bin)" >&2; exit 1; }
mkdir -p "${study_dir}"
# One study process per study dir: a second one would run the same chunk twice.
exec 9> "${study_dir}/.lock"
flock -n 9 || { echo "planner_study: another planner_study.sh runs on ${study_dir}" >&2; exit 1; }

runner=()
[ -z "${cpu}" ] || runner+=(taskset -c "${cpu}")
runner+=(nice -n "${nice_level}")

# The sampler must not hold the lock (fd 9): a rerun right after this one ends would be refused.
( while kill -0 $$ 2> /dev/null; do echo "$(date -u +%FT%TZ) $(cat /proc/loadavg)"; sleep 60; done ) \
  >> "${study_dir}/load.log" 9>&- &
sampler=$!
trap 'kill ${sampler} 2> /dev/null || true' EXIT

[ -f "${study_dir}/chunks.tsv" ] || printf 'robot\tplanner\tgroup\tstart_utc\tend_utc\twall_s\tcpu_s\tloadavg_start\tloadavg_end\tbin_commit\n' \
  > "${study_dir}/chunks.tsv"
commit="$(cat "$(dirname "${bin}")/COMMIT" 2> /dev/null || echo unknown)"
echo "planner_study: robots ${robots}, planners ${planners}, groups ${groups}, ${runs} runs; bin ${bin} (commit ${commit});" \
  "runner: ${runner[*]}; study dir ${study_dir}"
for robot in "${robot_list[@]}"; do
  for planner in "${planner_list[@]}"; do
    for g in "${group_list[@]}"; do
      d="${study_dir}/${robot}/${planner}_${g}"
      if [ -f "${d}/DONE" ]; then
        echo "skip ${robot} ${planner} ${g}: done"
        continue
      fi
      rm -rf "${d}"
      mkdir -p "${d}"
      start="$(date -u +%FT%TZ)"; start_s="$(date +%s)"; load_start="$(cut -d' ' -f1-3 /proc/loadavg)"
      echo "${start} start ${robot} ${planner} ${g} (load ${load_start})"
      # shellcheck disable=SC2046  # group_flags is several words on purpose
      budget_s="${chunk_timeout_s:-$(( 3 * $(group_limit_s "${g}") + 600 ))}"
      # timeout signals its whole process group: bench_planners and its per-planner children
      cmd=("${runner[@]}" timeout --kill-after=60 "${budget_s}" "${bin}" --robot "${robot}" --planners "${planner}" $(group_flags "${g}")
           --runs "${runs}" --end-to-end none --out "${d}")
      echo "${cmd[*]}" > "${d}/command.txt"
      # CPU seconds of the chunk without /usr/bin/time (not always installed): the subshell's
      # cutime + cstime in /proc/self/stat after it waited for the run.
      set +e
      ( "${cmd[@]}" > "${d}/bench.log" 2>&1; rc=$?
        read -r -a st < /proc/self/stat  # fields 16, 17: cutime, cstime of this subshell (ticks)
        echo "${rc} $(awk -v t=$(( st[15] + st[16] )) -v hz="$(getconf CLK_TCK)" 'BEGIN { printf "%.1f", t / hz }')" \
          > "${d}/exit_status" )
      set -e
      read -r rc cpu_s < "${d}/exit_status"
      end="$(date -u +%FT%TZ)"; wall_s=$(( $(date +%s) - start_s )); load_end="$(cut -d' ' -f1-3 /proc/loadavg)"
      rows=0
      [ -s "${d}/runs.csv" ] && rows=$(( $(wc -l < "${d}/runs.csv") - 1 ))
      want="$(group_rows "${g}")"
      if [ "${rc}" != 0 ] || [ "${rows}" != "${want}" ]; then
        echo "${end} FAILED ${robot} ${planner} ${g}: exit ${rc}, ${rows} of ${want} rows (see ${d}/bench.log)"
        continue
      fi
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "${robot}" "${planner}" "${g}" "${start}" "${end}" "${wall_s}" \
        "${cpu_s}" "${load_start}" "${load_end}" "${commit}" >> "${study_dir}/chunks.tsv"
      printf '%s .. %s, %s s wall, %s s cpu, load %s .. %s, commit %s\n' "${start}" "${end}" "${wall_s}" "${cpu_s}" \
        "${load_start}" "${load_end}" "${commit}" > "${d}/DONE"
      echo "${end} done ${robot} ${planner} ${g}: ${wall_s} s wall, ${cpu_s} s cpu, load ${load_end}"
    done
  done
done
echo "planner_study: finished $(date -u +%FT%TZ)"
