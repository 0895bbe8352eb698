#!/usr/bin/env bash
# BPM single-grain plateau against plate speed, time step and F0, over many seeds
# (README, "BPM": the rate effect). The small CI grain, R = 1.5 mm, particles
# 0.16-0.26 mm (about 150): one run takes 8-30 s. Writes bench/bpm_rate_study.csv.
#   bench/bpm_rate_study.sh [SEEDS]      (default: 1 2 3 4; CASES=3 runs the first 3 cases,
#                                         FIRST=9 starts at the tenth)
# SPANS=1 runs the particle-size spans of Fig. 7 instead (F0 = 100 N/m, 0.2 m/s) and
# writes bench/bpm_span_study.csv, with particle count, <a0> and the plateau stress:
#   SPANS=1 RAYON_NUM_THREADS=1 bench/bpm_rate_study.sh "$(seq 1 24)"
# SG=/path/to/softgrain runs another binary (e.g. a copy, safe from rebuilds).
# Run from the repository root after `cargo build --release`.
set -euo pipefail
sg=${SG:-${CARGO_TARGET_DIR:-target}/release/softgrain}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# 0.1 t0 of seed 1's smallest particle at F0 = 100 N/m; at F0 the step is scaled by
# sqrt(100/F0) (t0 ∝ F0^-1/2), so F0 = 200 with the plate √2 faster is the same
# dimensionless problem as F0 = 100. Only for the 0.16-0.26 mm span: a case that sets
# its span (4th and 5th fields, dmin dmax in m) keeps the pipeline's step, 0.1 t0 of
# its own smallest particle, and has "-" as its time-step factor.
dt0=5.64802303087408e-7
run() {
  local seed=$1 f0=$2 v=$3 fac=$4 dmin=${5:-1.6e-4} dmax=${6:-2.6e-4} key=$4 step=()
  if [ $# -gt 4 ]; then
    key="$dmin,$dmax"
  else
    step=(--set compact.time_step="$(python3 -c "print($dt0 / $fac * (100.0 / $f0) ** 0.5)")")
  fi
  "$sg" pipeline run pipelines/single-grain-bpm.yaml --quiet --out "$work/o" \
    --set prepare.radius=1.5e-3 --set "discretise.bpm.particle_diameter=[$dmin, $dmax]" \
    --set seed="$seed" --set output.vtk=false --set discretise.bpm.f0="$f0" \
    --set compact.wall_velocity="$v" "${step[@]}" > /dev/null
  python3 - "$work/o/single-grain-bpm" "$f0,$v,$key,$seed" "$#" >> "$csv" <<'PY'
import json, sys
out, head, nargs = sys.argv[1:]
f = json.load(open(f"{out}/compact/bpm-mu0/stage.json"))["figures"]
row = [head, f"{f['plateau']:.5f}"]
if int(nargs) > 4:  # a span case: particles, <a0> (m), plateau, plateau stress (Pa)
    s = json.load(open(f"{out}/analyse/stage.json"))["figures"]["summary"]["bpm-mu0"]
    row[1:1] = [str(s["particles"]), f"{s['mean_a0']:.6e}"]
    row.append(f"{s['plateau_stress']:.1f}")
print(",".join(row + [str(f["steps"]), f"{f['area_change']:.4f}",
                      f"{f['nlgs_iterations'] / f['steps']:.1f}"]))
PY
  rm -rf "$work/o"
}
if [ "${SPANS:-0}" = 1 ]; then
  csv=bench/bpm_span_study.csv
  [ -f "$csv" ] || echo "f0,v,dmin,dmax,seed,particles,a0_mean,plateau,plateau_stress,steps,area_change,sweeps_per_step" > "$csv"
  # (F0 in N/m, plate speed in m/s, -, smallest and largest particle diameter in m)
  cases=("100 0.2 - 1.0e-4 2.4e-4" "100 0.2 - 1.6e-4 2.6e-4" "100 0.2 - 2.2e-4 2.8e-4")
else
  csv=bench/bpm_rate_study.csv
  [ -f "$csv" ] || echo "f0,v,dt_factor,seed,plateau,steps,area_change,sweeps_per_step" > "$csv"
  # (F0 in N/m, plate speed in m/s, time step divided by)
  cases=("100 0.2 1" "200 0.2 1" "100 0.1 1" "100 0.05 1" "100 0.4 2" "100 0.8 4"
         "100 0.2 2" "100 0.2 4" "200 0.2828427 1" "100 0.025 1" "100 0.0125 1" "200 0.05 1")
fi
for seed in ${1:-1 2 3 4}; do
  for c in "${cases[@]:${FIRST:-0}:${CASES:-${#cases[@]}}}"; do
    # shellcheck disable=SC2086
    run "$seed" $c
  done
done
