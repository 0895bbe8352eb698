#!/bin/bash
# Quasi-static check of the MPM packing (README "Quasi-static check"): 32 grains of
# pipelines/mpm-packing-small.yaml, seeds 1-3, top wall at 0.2 and 0.1 m/s, both frictions.
# Then `python3 bench/mpm_quasi_static.py OUT_DIR > bench/mpm_quasi_static.csv` gives the
# window means. Usage: bench/mpm_quasi_static.sh OUT_DIR (about 25 CPU-minutes).
set -euo pipefail
out=${1:?output directory}
softgrain=${SOFTGRAIN:-target/release/softgrain}
for seed in 1 2 3; do
  for v in 0.2 0.1; do
    "$softgrain" pipeline run pipelines/mpm-packing-small.yaml --out "$out/s${seed}_v$v" --quiet \
      --set prepare.grains=32 --set seed=$seed --set compact.wall_velocity=$v \
      --set output.vtk=false --set output.every=10 --jobs 1
  done
done
