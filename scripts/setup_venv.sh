#!/usr/bin/env bash
# Creates the physics evaluator's virtual environment in the git-ignored workspace
# (.ws/venv: MuJoCo, trimesh, CoACD, matplotlib from PyPI, pinned in requirements-physics.txt)
# and prints its python. Idempotent: reinstalls only when the requirements changed.
#   PY="$(bash scripts/setup_venv.sh)"; "$PY" scripts/evaluate_grasps_physics.py --help
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
source "${here}/env.sh"
venv="${FAST_GRASP_WS}/venv"
requirements="${here}/requirements-physics.txt"
stamp="${venv}/.requirements"
if [ ! -x "${venv}/bin/python" ]; then
  mkdir -p "${FAST_GRASP_WS}"
  /usr/bin/python3 -m venv "${venv}" >&2
fi
if ! cmp -s "${requirements}" "${stamp}"; then
  echo "installing the physics evaluator's packages into ${venv}" >&2
  "${venv}/bin/python" -m pip install --quiet --disable-pip-version-check -r "${requirements}" >&2
  cp "${requirements}" "${stamp}"
fi
echo "${venv}/bin/python"
