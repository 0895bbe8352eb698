#!/usr/bin/env python3
"""Check the analyse outputs of a single-grain MPM run as pandas/pyarrow users see them.

Usage: python3 tests/python/check_analyse.py RUN_DIR   (RUN_DIR = <--out>/single-grain-mpm)

The time-series table must hold the rows of compact/mpm-mu0/timeseries.csv, the summary
table must agree with summary.json, and the figures and report must be there.
"""
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

run = Path(sys.argv[1])
an = run / "analyse"
failures = []
checks = []


def check(name, ok):
    checks.append(name)
    print(("ok   " if ok else "FAIL ") + name)
    if not ok:
        failures.append(name)


series = pd.read_parquet(an / "single_grains.parquet", engine="pyarrow")
csv = pd.read_csv(run / "compact" / "mpm-mu0" / "timeseries.csv")
check("time series columns", {"case", "method", "friction", "strain", "force", "width", "sigma"} <= set(series.columns))
check("one parquet row per CSV row", len(series) == len(csv))
check("strain as in the CSV", np.allclose(series["strain"].to_numpy(), csv["strain"].to_numpy(), rtol=1e-12))
check("sigma as in the CSV", np.allclose(series["sigma"].to_numpy(), csv["sigma"].to_numpy(), rtol=1e-12))
check("case name", set(series["case"]) == {"mpm-mu0"})

summary = json.loads((an / "summary.json").read_text())
table = pd.read_parquet(an / "summary.parquet", engine="pyarrow").set_index("case")
s = summary["mpm-mu0"]
check("summary.json: method and friction", s["method"] == "mpm" and s["friction"] == 0.0)
check("summary tables agree", abs(table.loc["mpm-mu0", "eq13_ratio"] - s["eq13_ratio"]) < 1e-12)
check("slope below Eq. 13", 0.3 < s["eq13_ratio"] < 1.0)
for f in ["report.md", "fig6_single_grain.png", "fig6_single_grain.svg"]:
    check(f"{f} exists", (an / f).stat().st_size > 0)

print(f"{len(checks) - len(failures)} passed, {len(failures)} failed")
sys.exit(1 if failures else 0)
