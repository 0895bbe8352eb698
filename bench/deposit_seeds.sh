#!/bin/bash
# The 300-disk deposit against the Froude-scaled rapier over many seeds (README
# "Performance", "300 disks over twenty seeds"). Steps to rest are chaotic (one creeping disk
# decides them, in both engines), so one seed's time says little: this runs a range of seeds,
# R runs each, the engines interleaved run by run, one child process per run, and writes
# one CSV row per run. Then
#   python3 bench/deposit_seeds.py bench/deposit_seeds.csv
# prints per-seed medians, the median over seeds, the totals and the per-seed ratios.
# Usage: bench/deposit_seeds.sh [SEEDS=1-20] [R=3] [softgrain flags, default
#   --tolerance 7e-4 --anderson 4] > bench/deposit_seeds.csv
set -euo pipefail
seeds=${1:-1-20}
runs=${2:-3}
shift $(( $# < 2 ? $# : 2 ))
flags=("$@")
[ ${#flags[@]} -eq 0 ] && flags=(--tolerance 7e-4 --anderson 4)
bin=$(cargo bench --bench deposit --no-run 2>&1 | sed -n 's/.*Executable benches\/deposit.rs (\(.*\))/\1/p')
echo "engine,seed,run,at_rest,steps,wall_s,contact_updates,sim_time_s,iterations_per_step,peak_rss_kib,mean_overlap_r,max_overlap_r,floor_over_weight,contacts"
for run in $(seq 1 "$runs"); do
  for seed in $(seq "${seeds%-*}" "${seeds#*-}"); do
    for engine in softgrain rapier-froude; do
      extra=()
      [ "$engine" = softgrain ] && extra=("${flags[@]}")
      line=$("$bin" --child "$engine" 300 --seed "$seed" "${extra[@]}" 2>/dev/null | grep '^RESULT')
      echo "$engine,$seed,$run,$(echo "${line#RESULT }" | tr ' ' ',')"
    done
  done
done
