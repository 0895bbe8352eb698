"""Window means of the quasi-static check's runs (bench/quasi_static.sh): sigma, inertial
number and kinetic ratio over strain windows, one row per run, case and window, to standard
output as CSV. Windows default to the MPM check's.
Usage: python3 bench/quasi_static.py OUT_DIR [FROM-TO ...] > bench/quasi_static_<method>.csv"""
import csv
import pathlib
import sys

WINDOWS = [tuple(map(float, w.split("-"))) for w in sys.argv[2:]] or [
    (0.2, 0.25), (0.25, 0.3), (0.3, 0.35)]
out = csv.writer(sys.stdout)
out.writerow(["friction", "seed", "wall_velocity", "strain_from", "strain_to", "rows",
              "sigma_pa", "inertial", "kinetic_ratio"])
for f in sorted(pathlib.Path(sys.argv[1]).glob("s*_v*/*/compact/*/timeseries.csv")):
    run, case = f.parts[-5], f.parts[-2]
    seed, v = run[1:].split("_v")
    rows = list(csv.DictReader(open(f)))
    for lo, hi in WINDOWS:
        sel = [r for r in rows if lo < float(r["strain"]) <= hi]

        def mean(key):
            vals = [float(r[key]) for r in sel if r[key] != "NaN"]
            return sum(vals) / max(1, len(vals))

        out.writerow([case.split("-mu")[1], seed, v, lo, hi, len(sel), "%.4g" % mean("sigma"),
                      "%.3g" % mean("inertial"), "%.3g" % mean("kinetic_ratio")])
