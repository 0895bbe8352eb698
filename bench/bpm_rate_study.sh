#!/usr/bin/env bash
# BPM single-grain plateau against plate speed, time step and F0, over many seeds
# (README, "BPM": the rate effect). The small CI grain, R = 1.5 mm, particles
# 0.16-0.26 mm (about 150): one run takes 8-30 s. Writes bench/bpm_rate_study.csv.
#   bench/bpm_rate_study.sh [SEEDS]      (default: 1 2 3 4; CASES=3 runs the first 3 cases,
#                                         FIRST=9 starts at the tenth)
# Run from the repository root after `cargo build --release`.
set -euo pipefail
sg=${CARGO_TARGET_DIR:-target}/release/softgrain
csv=bench/bpm_rate_study.csv
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# 0.1 t0 of seed 1's smallest particle at F0 = 100 N/m; at F0 the step is scaled by
# sqrt(100/F0) (t0 ∝ F0^-1/2), so F0 = 200 with the plate √2 faster is the same
# dimensionless problem as F0 = 100.
dt0=5.64802303087408e-7
[ -f "$csv" ] || echo "f0,v,dt_factor,seed,plateau,steps,area_change,sweeps_per_step" > "$csv"
run() {
  local f0=$1 v=$2 fac=$3 seed=$4
  local dt
  dt=$(python3 -c "print($dt0 / $fac * (100.0 / $f0) ** 0.5)")
  "$sg" pipeline run pipelines/single-grain-bpm.yaml --quiet --out "$work/o" \
    --set prepare.radius=1.5e-3 --set 'discretise.bpm.particle_diameter=[1.6e-4, 2.6e-4]' \
    --set seed="$seed" --set output.vtk=false --set discretise.bpm.f0="$f0" \
    --set compact.wall_velocity="$v" --set compact.time_step="$dt" > /dev/null
  python3 - "$work/o/single-grain-bpm/compact/bpm-mu0/stage.json" "$f0" "$v" "$fac" "$seed" >> "$csv" <<'PY'
import json, sys
path, f0, v, fac, seed = sys.argv[1:]
f = json.load(open(path))["figures"]
print(f"{f0},{v},{fac},{seed},{f['plateau']:.5f},{f['steps']},{f['area_change']:.4f},"
      f"{f['nlgs_iterations'] / f['steps']:.1f}")
PY
  rm -rf "$work/o"
}
# (F0 in N/m, plate speed in m/s, time step divided by)
cases=("100 0.2 1" "200 0.2 1" "100 0.1 1" "100 0.05 1" "100 0.4 2" "100 0.8 4"
       "100 0.2 2" "100 0.2 4" "200 0.2828427 1" "100 0.025 1" "100 0.0125 1" "200 0.05 1")
for seed in ${1:-1 2 3 4}; do
  for c in "${cases[@]:${FIRST:-0}:${CASES:-${#cases[@]}}}"; do
    # shellcheck disable=SC2086
    run $c "$seed"
  done
done
