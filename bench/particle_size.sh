#!/bin/bash
# Particle-size study (README "BPM packings"): quick.yaml's 30 grains (seed 42), frictionless,
# from Φ0 = 0.63 at 0.5 m/s to ε = 0.45, Anderson-accelerated compaction, discretised at
# three particle sizes, each run in OUT_DIR/<size>. Then, per case folder,
#   python3 bench/z_neighbours.py OUT_DIR/<size>/quick/compact/bpm-mu0 --stride 10 --tiling
# Usage: bench/particle_size.sh OUT_DIR [--set KEY=VALUE ...]   (about 50 CPU-minutes, most
# of it the finest size; a --set given here, e.g. seed=1, overrides the settings above)
set -euo pipefail
out=${1:?output directory}
shift
softgrain=${SOFTGRAIN:-target/release/softgrain}
run() { # name, smallest and largest particle diameter (m), steps between frames
  "$softgrain" pipeline run pipelines/quick.yaml --out "$out/$1" --quiet --jobs 1 \
    --set compact.friction=0.0 --set compact.initial_phi=0.63 --set compact.wall_velocity=0.5 \
    --set compact.solver.anderson=8 --set "discretise.bpm.particle_diameter=[$2,$3]" \
    --set output.every=$4 "${extra[@]}"
}
extra=("$@")
run coarse 2.0e-4 3.4e-4 200
run medium 1.2e-4 2.0e-4 400
run paper 7.0e-5 1.3e-4 1000
