"""Summary of bench/deposit_seeds.sh's CSV: per seed the median wall time of each engine
over its runs, then over the seeds the median of those times, their totals (sums: the mean
time), the median of the per-seed ratios, the seeds each engine wins and the mean-overlap
ratios. Seeds where an engine has no successful run are listed and left out. Standard
library only. Usage: python3 bench/deposit_seeds.py bench/deposit_seeds.csv"""

import csv
import statistics
import sys
from collections import defaultdict

ENGINES = ("softgrain", "rapier-froude")


def main(path):
    wall = defaultdict(list)
    first = {}
    at_rest = True
    failed = []
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["engine"], int(row["seed"]))
            if row["at_rest"] == "failed":
                failed.append(key)
                continue
            at_rest &= row["at_rest"] == "1"
            wall[key].append(float(row["wall_s"]))
            first.setdefault(key, row)
    all_seeds = sorted({s for _, s in wall} | {s for _, s in failed})
    seeds = [s for s in all_seeds if all((e, s) in wall for e in ENGINES)]
    if not seeds:
        sys.exit(f"{path}: no seed with a successful run of both engines")
    med = {k: statistics.median(v) for k, v in wall.items()}
    print("seed,softgrain_s,rapier_froude_s,ratio,softgrain_steps,rapier_steps,"
          "softgrain_overlap,rapier_overlap")
    for s in seeds:
        a, b = med[("softgrain", s)], med[("rapier-froude", s)]
        fa, fb = first[("softgrain", s)], first[("rapier-froude", s)]
        print(f"{s},{a:.4f},{b:.4f},{a / b:.3f},{fa['steps']},{fb['steps']},"
              f"{fa['mean_overlap_r']},{fb['mean_overlap_r']}")
    ours = [med[("softgrain", s)] for s in seeds]
    theirs = [med[("rapier-froude", s)] for s in seeds]
    ratios = [a / b for a, b in zip(ours, theirs)]
    overlap = [float(first[("softgrain", s)]["mean_overlap_r"])
               / float(first[("rapier-froude", s)]["mean_overlap_r"]) for s in seeds]
    runs = sorted({len(wall[(e, s)]) for e in ENGINES for s in seeds})
    m_a, m_b = statistics.median(ours), statistics.median(theirs)
    print(f"# {len(seeds)} seeds, {'-'.join(map(str, runs))} runs each; "
          f"every run at rest: {at_rest}")
    if failed or len(seeds) < len(all_seeds):
        print(f"# failed runs (engine, seed): {failed}; seeds left out: "
              f"{sorted(set(all_seeds) - set(seeds))}")
    print(f"# median over seeds: softgrain {m_a:.4f} s, rapier-froude {m_b:.4f} s, "
          f"ratio of the medians {m_a / m_b:.3f}, median of the per-seed ratios "
          f"{statistics.median(ratios):.3f}")
    print(f"# total: softgrain {sum(ours):.3f} s, rapier-froude {sum(theirs):.3f} s, "
          f"ratio {sum(ours) / sum(theirs):.3f}")
    print(f"# seeds where softgrain is faster: {sum(r < 1 for r in ratios)} of {len(seeds)}")
    print(f"# mean-overlap ratio per seed: median {statistics.median(overlap):.2e}, "
          f"largest {max(overlap):.2e}")


if __name__ == "__main__":
    main(sys.argv[1])
