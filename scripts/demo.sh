#!/usr/bin/env bash
# One command: install every dependency, build, and replay a bundled bag through the pipeline.
# Extra arguments go to demo.launch, e.g. scripts/demo.sh bag:=$(pwd)/bags/mug.bag algorithm:=cshape
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
bash "${here}/install_deps.sh"
bash "${here}/build.sh"
source "${here}/env.sh"
set +u  # catkin's setup scripts read unset variables
source "${FAST_GRASP_WS}/devel/setup.bash"
exec roslaunch fast_grasp demo.launch rviz:=false "$@"
