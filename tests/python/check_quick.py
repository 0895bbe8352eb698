#!/usr/bin/env python3
"""Check the values of a quick.yaml run as ParaView/pyvista users see them.

Usage: python3 tests/python/check_quick.py RUN_DIR   (RUN_DIR = <--out>/quick)

The last frame of the deposit must hold the 30 grains with distinct ids, radii inside the
pipeline's [0.7, 1.2] mm, centres above the floor, and (at rest) negligible velocities.
Each compaction case must have its particles coloured by 30 grain ids, and a time series
that starts at Φ0 and reaches the final strain.
"""
import csv
import json
import sys
from pathlib import Path

import meshio
import numpy as np
import pyvista as pv

run = Path(sys.argv[1])
dep = run / "prepare" / "deposit"
reader = pv.get_reader(str(dep / "series.pvd"))
reader.set_active_time_point(len(reader.time_values) - 1)
last = reader.read()[0]
m = meshio.read(sorted(dep.glob("frame_*.vtu"))[-1])
failures = []

def check(name, ok):
    print(("ok   " if ok else "FAIL ") + name)
    if not ok:
        failures.append(name)

ids = np.asarray(last.point_data["grain_id"])
r = np.asarray(last.point_data["radius"])
v = np.asarray(last.point_data["velocity"])
pts = np.asarray(last.points)
check("30 grains with distinct ids", len(ids) == 30 and len(set(ids.tolist())) == 30)
check("radii in [0.7, 1.2] mm", bool(np.all((r >= 0.7e-3) & (r <= 1.2e-3))))
check("centres above the floor", bool(np.all(pts[:, 1] - r > -1e-6)))
check("at rest: |v| < 1e-3 m/s", float(np.abs(v).max()) < 1e-3)
check("meshio sees the same radii", np.allclose(m.point_data["radius"], r))
stage = json.loads((dep / "stage.json").read_text())
f = stage["figures"]
check("stage.json: floor force = weight within 0.5%", abs(f["floor_force"] / f["weight"] - 1) < 5e-3)
checks = 6
for case in ("bpm-mu0", "bpm-mu0.5"):
    comp = run / "compact" / case
    reader = pv.get_reader(str(comp / "series.pvd"))
    reader.set_active_time_point(len(reader.time_values) - 1)
    frame = reader.read()[0]
    gid = np.asarray(frame.point_data["grain_id"])
    check(f"{case}: particles of 30 grains", len(set(gid.tolist())) == 30 and len(gid) > 30 * 15)
    rows = list(csv.DictReader(open(comp / "timeseries.csv")))
    check(f"{case}: contract columns", all(k in rows[0] for k in ("time", "strain", "phi", "z", "sigma")))
    check(f"{case}: starts at Φ0 = 0.63", abs(float(rows[0]["phi"]) - 0.63) < 1e-9)
    last = rows[-1]
    check(f"{case}: reaches ε = 0.45 loaded", float(last["strain"]) >= 0.45 and float(last["sigma"]) > 0)
    check(f"{case}: inertial number defined once loaded", 0 < float(last["inertial"]) < 1)
    # rigid particles overlapping by the solver's tolerance: almost no area under two grains
    check(f"{case}: area under two grains below 1e-4", max(float(r["overlap_area"]) for r in rows) < 1e-4)
    check(f"{case}: no particle centre inside another grain", all(float(r["points_inside"]) == 0 for r in rows))
    net = pv.read(str(sorted(comp.glob("contacts_*.vtu"))[-1]))
    check(f"{case}: force network with normal_force", net.n_cells > 0 and float(np.max(net.cell_data["normal_force"])) > 0)
    checks += 7
print(f"{checks - len(failures)} passed, {len(failures)} failed")
sys.exit(1 if failures else 0)
