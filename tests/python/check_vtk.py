#!/usr/bin/env python3
"""Check softgrain VTK output with two independent readers (meshio and pyvista).

Usage:
    python3 tests/python/check_vtk.py DIR

Finds every ``series.pvd`` under DIR, and opens each ``.vtu`` it references
with BOTH meshio and pyvista. Each file must have:

* point count > 0 and finite point coordinates;
* ``grain_id``: integer, 1 component;
* ``velocity``: 3 components;
* ``radius`` (disk/BPM frames, must be > 0) or ``volume`` (MPM frames);
* if a ``stress`` array is present: 9 components, and a ``von_mises``
  array with all values >= 0;
* all point and cell data finite; meshio and pyvista agree on points and
  arrays.

Prints one line per file and a final line ``N passed, M failed``. Exits
non-zero if any file fails, a .pvd is malformed or references a missing file,
or no files are found.

Sample data: ``cargo test --release --test vtk_io`` writes sample series to
``<target dir>/tmp/vtk-sample`` (``target/tmp/vtk-sample`` by default, or
``$CARGO_TARGET_DIR/tmp/vtk-sample``; override with env ``VTK_SAMPLE_DIR``),
and a deliberately broken series to ``.../tmp/vtk-sample-bad`` (this script
must fail on it):

    CARGO_TARGET_DIR=/work/target-vtk cargo test --release --test vtk_io
    python3 tests/python/check_vtk.py /work/target-vtk/tmp/vtk-sample      # passes
    python3 tests/python/check_vtk.py /work/target-vtk/tmp/vtk-sample-bad  # fails

Requires: numpy, meshio, pyvista (``pip install meshio pyvista``).
"""

import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
import meshio  # noqa: E402
import pyvista as pv  # noqa: E402


def pvd_files(pvd_path):
    """Return the .vtu paths referenced by a .pvd collection, in order."""
    root = ET.parse(pvd_path).getroot()
    if root.tag != "VTKFile" or root.get("type") != "Collection":
        raise ValueError("root is not <VTKFile type=\"Collection\">")
    coll = root.find("Collection")
    if coll is None:
        raise ValueError("no <Collection> element")
    base = os.path.dirname(pvd_path)
    out = []
    for ds in coll.findall("DataSet"):
        f = ds.get("file")
        t = ds.get("timestep")
        if f is None or t is None:
            raise ValueError("<DataSet> without file or timestep")
        if not np.isfinite(float(t)):
            raise ValueError(f"non-finite timestep {t!r}")
        out.append(os.path.join(base, f))
    return out


def as_2d(a):
    a = np.asarray(a)
    return a.reshape(len(a), -1)


def check_arrays(reader, points, point_data, cell_data, errors):
    """Checks common to both readers; returns {name: 2D array} of point data."""
    n = len(points)
    if n == 0:
        errors.append(f"{reader}: no points")
    if not np.all(np.isfinite(points)):
        errors.append(f"{reader}: non-finite point coordinates")
    arrays = {}
    for name, a in point_data.items():
        a = np.asarray(a)
        arrays[name] = as_2d(a)
        if len(a) != n:
            errors.append(f"{reader}: point array {name} has {len(a)} entries, expected {n}")
        if a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
            errors.append(f"{reader}: {name} has non-finite values")
    for name, a in cell_data.items():
        a = np.asarray(a)
        if a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
            errors.append(f"{reader}: cell array {name} has non-finite values")

    def need(name, ncomp):
        if name not in arrays:
            errors.append(f"{reader}: missing array {name}")
            return None
        a = arrays[name]
        if a.shape[1] != ncomp:
            errors.append(f"{reader}: {name} has {a.shape[1]} components, expected {ncomp}")
            return None
        return a

    gid = need("grain_id", 1)
    if gid is not None and gid.dtype.kind not in "iu":
        errors.append(f"{reader}: grain_id is {gid.dtype}, not integer")
    need("velocity", 3)
    if "radius" in arrays:
        r = need("radius", 1)
        if r is not None and not np.all(r > 0):
            errors.append(f"{reader}: radius has values <= 0 (min {np.nanmin(r)})")
    elif "volume" not in arrays:
        errors.append(f"{reader}: neither radius nor volume present")
    else:
        need("volume", 1)
    if "stress" in arrays:
        need("stress", 9)
        vm = need("von_mises", 1)
        if vm is not None and not np.all(vm >= 0):
            errors.append(f"{reader}: von_mises has negative values")
    return arrays


def check_file(path):
    """Return a list of error strings (empty if the file passes)."""
    errors = []
    if not os.path.isfile(path):
        return [f"missing file {path}"]

    try:
        m = meshio.read(path)
        cell_data = {}
        for name, blocks in m.cell_data.items():
            cell_data[name] = np.concatenate([np.asarray(b) for b in blocks])
        ma = check_arrays("meshio", np.asarray(m.points), m.point_data, cell_data, errors)
        mpts = np.asarray(m.points)
    except Exception as e:  # noqa: BLE001
        errors.append(f"meshio: cannot read: {type(e).__name__}: {e}")
        ma, mpts = None, None

    try:
        g = pv.read(path)
        pd = {k: np.asarray(g.point_data[k]) for k in g.point_data.keys()}
        cd = {k: np.asarray(g.cell_data[k]) for k in g.cell_data.keys()}
        pa = check_arrays("pyvista", np.asarray(g.points), pd, cd, errors)
        ppts = np.asarray(g.points)
    except Exception as e:  # noqa: BLE001
        errors.append(f"pyvista: cannot read: {type(e).__name__}: {e}")
        pa, ppts = None, None

    if ma is not None and pa is not None:
        if mpts.shape != ppts.shape or not np.array_equal(mpts, ppts):
            errors.append("meshio and pyvista disagree on points")
        if set(ma) != set(pa):
            errors.append(f"array names differ: meshio {sorted(ma)} vs pyvista {sorted(pa)}")
        for name in set(ma) & set(pa):
            a, b = ma[name], pa[name]
            if a.shape != b.shape or not np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"):
                errors.append(f"meshio and pyvista disagree on {name}")
    return errors


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[0])
        print(f"usage: {argv[0]} DIR", file=sys.stderr)
        return 2
    root = argv[1]
    pvds = []
    for dirpath, _dirs, files in os.walk(root):
        if "series.pvd" in files:
            pvds.append(os.path.join(dirpath, "series.pvd"))
    pvds.sort()

    passed = failed = 0
    for pvd in pvds:
        try:
            vtus = pvd_files(pvd)
        except Exception as e:  # noqa: BLE001
            print(f"FAIL {pvd}: malformed pvd: {type(e).__name__}: {e}")
            failed += 1
            continue
        if not vtus:
            print(f"FAIL {pvd}: no DataSet entries")
            failed += 1
            continue
        for vtu in vtus:
            errors = check_file(vtu)
            if errors:
                failed += 1
                print(f"FAIL {vtu}: " + "; ".join(errors))
            else:
                passed += 1
                print(f"ok   {vtu}")
    print(f"{passed} passed, {failed} failed")
    if passed + failed == 0:
        print(f"no series.pvd / .vtu files found under {root}", file=sys.stderr)
        return 1
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
