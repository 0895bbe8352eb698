#!/bin/bash
# Quasi-static check (bench/README-packings.md, "Quasi-static check (30 grains)" and "(16 grains)"): one pipeline at several wall speeds over
# seeds 1-3, each run in OUT_DIR/s<seed>_v<speed>. Then
#   python3 bench/quasi_static.py OUT_DIR [FROM-TO ...] > bench/quasi_static_<method>.csv
# gives window means of sigma, inertial and kinetic_ratio.
# Usage: bench/quasi_static.sh OUT_DIR PIPELINE SPEED[,SPEED...] [--set KEY=VALUE ...]
#   MPM (25 CPU-minutes, the node contact; the surface contact, the default since session 33,
#   costs more): bench/quasi_static.sh OUT pipelines/mpm-packing-small.yaml 0.2,0.1 \
#       --set prepare.grains=32 --set output.every=10 --set discretise.mpm.contact=node
#   BPM (20 CPU-minutes): bench/quasi_static.sh OUT pipelines/quick.yaml 1.0,0.5,0.25 \
#       --set output.every=100
#   then: python3 bench/quasi_static.py OUT 0.3-0.35 0.35-0.4 0.4-0.45
set -euo pipefail
out=${1:?output directory}
pipeline=${2:?pipeline}
IFS=, read -ra speeds <<< "${3:?speeds}"
shift 3
softgrain=${SOFTGRAIN:-target/release/softgrain}
for seed in 1 2 3; do
  for v in "${speeds[@]}"; do
    "$softgrain" pipeline run "$pipeline" --out "$out/s${seed}_v$v" --quiet --jobs 1 \
      --set seed=$seed --set compact.wall_velocity=$v --set output.vtk=false "$@"
  done
done
