#!/bin/bash
# The 300-disk deposit against the Froude-scaled rapier over many seeds (README
# "Performance", "Forty seeds"). Steps to rest are chaotic (one creeping disk decides them,
# in both engines), so one seed's time says little: this runs a range of seeds, R runs each,
# the engines interleaved run by run, one child process per run, and writes one CSV row per
# run (a run that fails gets a row with `failed` and its stderr goes to deposit_seeds.err).
# Then
#   python3 bench/deposit_seeds.py bench/deposit_seeds.csv
# prints per-seed medians, the medians over seeds, the totals and the per-seed ratios.
# Usage: bench/deposit_seeds.sh [SEEDS=1-20] [R=3] [softgrain flags] > bench/deposit_seeds.csv
#   softgrain flags default to --tolerance 7e-4 --anderson 4; `defaults` alone runs the
#   prepare stage's own solver settings. NO_HEADER=1 leaves out the header line, to append
#   a second range to the same file:
#   bench/deposit_seeds.sh 1-20 3 > bench/deposit_seeds.csv
#   NO_HEADER=1 bench/deposit_seeds.sh 21-40 3 >> bench/deposit_seeds.csv
set -euo pipefail
seeds=${1:-1-20}
runs=${2:-3}
shift $(( $# < 2 ? $# : 2 ))
flags=("$@")
if [ ${#flags[@]} -eq 0 ]; then
  flags=(--tolerance 7e-4 --anderson 4)
elif [ "${flags[*]}" = defaults ]; then
  flags=()
fi
if ! [[ $seeds =~ ^([0-9]+)-([0-9]+)$ ]] || (( BASH_REMATCH[1] > BASH_REMATCH[2] )); then
  echo "deposit_seeds.sh: SEEDS must be FIRST-LAST with FIRST <= LAST, got '$seeds'" >&2
  exit 2
fi
first=${BASH_REMATCH[1]}
last=${BASH_REMATCH[2]}
build=$(cargo bench --bench deposit --no-run 2>&1) || { echo "$build" >&2; exit 1; }
bin=$(echo "$build" | sed -n 's/.*Executable benches\/deposit.rs (\(.*\))/\1/p')
[ -n "$bin" ] || { echo "deposit_seeds.sh: no bench binary in cargo's output" >&2; exit 1; }
[ "${NO_HEADER:-0}" = 1 ] ||
  echo "engine,seed,run,at_rest,steps,wall_s,contact_updates,sim_time_s,iterations_per_step,peak_rss_kib,mean_overlap_r,max_overlap_r,floor_over_weight,contacts"
for run in $(seq 1 "$runs"); do
  for seed in $(seq "$first" "$last"); do
    for engine in softgrain rapier-froude; do
      extra=()
      [ "$engine" = softgrain ] && extra=("${flags[@]}")
      if line=$("$bin" --child "$engine" 300 --seed "$seed" ${extra[@]+"${extra[@]}"} \
          2>>deposit_seeds.err | grep '^RESULT'); then
        echo "$engine,$seed,$run,$(echo "${line#RESULT }" | tr ' ' ',')"
      else
        echo "deposit_seeds.sh: $engine seed $seed run $run failed (deposit_seeds.err)" >&2
        echo "$engine,$seed,$run,failed"
      fi
    done
  done
done
