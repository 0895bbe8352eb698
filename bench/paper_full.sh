#!/bin/bash
# The full `pipelines/paper.yaml` run, one compaction case per process, resumable across
# machine sessions (README "Cost of the paper's scene"). A BPM case at the paper's particle
# size takes longer than a session, so each case runs in its own output folder (one run per
# folder holds the folder's lock) with snapshots every few minutes (`output.snapshot_every`
# names no node), and the same command resumes it from its last snapshot. Resume with the
# binary that started the case: a build with other bits has another FORMAT_VERSION, hence
# other node names, and would start the case over.
#
# Usage:
#   bench/paper_full.sh run BIN ROOT CASE    CASE: bpm-mu0, bpm-mu0.5, mpm-mu0 or mpm-mu0.5;
#                                            runs (or resumes) it in ROOT/CASE, one thread,
#                                            log in ROOT/CASE.log
#   bench/paper_full.sh merge BIN ROOT       copies the four cases' checkpoints and outputs
#                                            into ROOT/all and runs the rest of paper.yaml
#                                            there (single grains, analyse)
# e.g. (session 21): BIN=/work/runs/bin/softgrain-bb7af19 ROOT=/work/runs
#   nohup setsid nice -n 5 bench/paper_full.sh run $BIN $ROOT bpm-mu0 &
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
pipeline=$here/pipelines/paper.yaml
what=${1:?run or merge}
bin=${2:?softgrain binary}
root=${3:?output root}
case $what in
  run)
    case_name=${4:?case}
    case $case_name in
      # a snapshot every few minutes: a BPM step takes 0.05-0.5 s, an MPM step 0.1-18 s
      bpm-mu0) sets=(discretise.method=bpm compact.friction=0.0 output.snapshot_every=2000) ;;
      bpm-mu0.5) sets=(discretise.method=bpm compact.friction=0.5 output.snapshot_every=2000) ;;
      # the BPM solver settings are refused without a BPM case; they name no MPM node
      mpm-mu0) sets=(discretise.method=mpm compact.friction=0.0 compact.solver=null
        output.snapshot_every=25) ;;
      mpm-mu0.5) sets=(discretise.method=mpm compact.friction=0.5 compact.solver=null
        output.snapshot_every=25) ;;
      *) echo "paper_full.sh: unknown case '$case_name'" >&2; exit 2 ;;
    esac
    args=(--set include=[])
    for s in "${sets[@]}"; do args+=(--set "$s"); done
    mkdir -p "$root/$case_name"
    # wall time and peak memory of each stretch of the run, appended to ROOT/CASE.time
    /usr/bin/time -a -o "$root/$case_name.time" -f "%e s wall, %M KiB peak RSS" \
      "$bin" pipeline run "$pipeline" --out "$root/$case_name" "${args[@]}" --until compact \
      --jobs 1 >> "$root/$case_name.log" 2>&1
    ;;
  merge)
    mkdir -p "$root/all/paper"
    for c in bpm-mu0 bpm-mu0.5 mpm-mu0 mpm-mu0.5; do
      src=$root/$c/paper
      [ -d "$src/compact/$c" ] || { echo "paper_full.sh: $c has not run" >&2; exit 1; }
      for d in checkpoints prepare discretise compact; do
        mkdir -p "$root/all/paper/$d"
        cp -rn "$src/$d/." "$root/all/paper/$d/"
      done
    done
    "$bin" pipeline run "$pipeline" --out "$root/all"
    ;;
  *) echo "paper_full.sh: run or merge, not '$what'" >&2; exit 2 ;;
esac
