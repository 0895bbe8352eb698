"""Summary of bench/deposit_seeds.sh's CSV: per seed the median wall time of each engine
over its runs, then the median over seeds, the totals, the seeds each engine wins and the
ratio softgrain / rapier-froude of each figure. Standard library only.
Usage: python3 bench/deposit_seeds.py bench/deposit_seeds.csv"""

import csv
import statistics
import sys
from collections import defaultdict


def main(path):
    wall = defaultdict(list)
    first = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["engine"], int(row["seed"]))
            wall[key].append(float(row["wall_s"]))
            first.setdefault(key, row)
    seeds = sorted({s for _, s in wall})
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
    overlap = [float(first[("softgrain", s)]["mean_overlap_r"])
               / float(first[("rapier-froude", s)]["mean_overlap_r"]) for s in seeds]
    rest = all(first[(e, s)]["at_rest"] == "1" for e in ("softgrain", "rapier-froude")
               for s in seeds)
    m_a, m_b = statistics.median(ours), statistics.median(theirs)
    print(f"# {len(seeds)} seeds, {len(wall[('softgrain', seeds[0])])} runs each; "
          f"all at rest: {rest}")
    print(f"# median over seeds: softgrain {m_a:.4f} s, rapier-froude {m_b:.4f} s, "
          f"ratio {m_a / m_b:.3f}")
    print(f"# total: softgrain {sum(ours):.3f} s, rapier-froude {sum(theirs):.3f} s, "
          f"ratio {sum(ours) / sum(theirs):.3f}")
    print(f"# seeds where softgrain is faster: {sum(a < b for a, b in zip(ours, theirs))} "
          f"of {len(seeds)}")
    print(f"# mean-overlap ratio per seed: median {statistics.median(overlap):.2e}, "
          f"largest {max(overlap):.2e}")


if __name__ == "__main__":
    main(sys.argv[1])
