"""Z of a BPM compaction against the neighbours its grains could touch (README "BPM packings").

For frames of one case folder (`compact/<case>/frame_*.vtu`, and `contacts_*.vtu` with
--threshold):
  z         the reported Z (timeseries.csv: grain pairs with a loaded particle contact),
  z_f<EPS>  the same counting only particle contacts with f_n > EPS <f_n> (METHODS §2.4's
            force threshold), one column per --threshold value,
  z_near    grain pairs with two particles closer than GAP d_min (neighbours, touching or not),
  z_tiling  grain pairs adjacent in the tiling of the box that gives every point to the
            grain of its nearest particle (power distance): the Z the arrangement would have
            if every pore were filled, i.e. the ceiling of Z without a change of neighbours.
A pair of grains sharing fewer than 3 pixel edges in the tiling is a corner, not a face.

Usage: python3 bench/z_neighbours.py CASE_FOLDER [--stride K] [--tiling] [--pixel P] [--gap G]
                                     [--threshold EPS ...]
Prints CSV: frame,strain,phi,z[,z_f<EPS>...],z_near[,z_tiling]. Needs numpy and meshio; the
tiling takes about 1.5 min per frame at 300 grains with --pixel 5e-5 (m).
"""

import argparse
import csv
import glob
import re
from collections import Counter

import meshio
import numpy as np


def particles(path):
    m = meshio.read(path)
    return m.points[:, :2], m.point_data["grain_id"].astype(int), m.point_data["radius"]


def pairs_z(pairs, n_grains):
    return 2 * len(pairs) / n_grains


def grain_contacts(path):
    """(grain i, grain j, f_n) of every contact line between two grains' particles."""
    try:
        c = meshio.read(path)
    except KeyError:  # a frame without contacts has no cells
        return None
    if not c.cells:
        return None
    lines = c.cells[0].data.astype(int)
    g = c.point_data["grain_id"].astype(int)
    return g[lines[:, 0]], g[lines[:, 1]], c.cell_data["normal_force"][0]


def force_pairs(contacts, eps):
    """Grain pairs joined by a contact line with f_n > eps <f_n> (the mean over loaded lines)."""
    if contacts is None:
        return set()
    gi, gj, f = contacts
    keep = (gi != gj) & (f > eps * f[f > 0].mean())
    return set(zip(np.minimum(gi, gj)[keep], np.maximum(gi, gj)[keep]))


def near_pairs(x, g, r, gap):
    """Grain pairs with two particles less than gap * d_min apart (surface to surface)."""
    d_min = 2 * r.min()
    out = set()
    for a in range(0, len(x), 512):
        d = np.linalg.norm(x[a : a + 512, None] - x[None], axis=2) - r[a : a + 512, None] - r
        i, j = np.nonzero(d < gap * d_min)
        i += a
        keep = g[i] < g[j]
        out.update(zip(g[i][keep], g[j][keep]))
    return out


def tiling_pairs(x, g, r, pixel):
    """Grain pairs sharing at least 3 pixel edges in the nearest-particle tiling of the box."""
    lo, hi = x.min(0) - r.max(), x.max(0) + r.max()
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], pixel), np.arange(lo[1], hi[1], pixel))
    p = np.stack([gx.ravel(), gy.ravel()], 1)
    label = np.empty(len(p), int)
    for a in range(0, len(p), 4000):
        power = ((p[a : a + 4000, None] - x[None]) ** 2).sum(2) - r**2
        label[a : a + 4000] = g[power.argmin(1)]
    grid = label.reshape(gx.shape)
    faces = Counter()
    for u, v in [(grid[:, :-1], grid[:, 1:]), (grid[:-1], grid[1:])]:
        s = u != v
        faces.update(zip(np.minimum(u[s], v[s]), np.maximum(u[s], v[s])))
    return {k for k, n in faces.items() if n >= 3}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("--stride", type=int, default=5)
    ap.add_argument("--tiling", action="store_true")
    ap.add_argument("--pixel", type=float, default=2e-5)
    ap.add_argument("--gap", type=float, default=0.25)
    ap.add_argument("--threshold", type=float, action="append", default=[])
    a = ap.parse_args()
    rows = list(csv.DictReader(open(a.case + "/timeseries.csv")))
    frames = sorted(glob.glob(a.case + "/frame_*.vtu"))
    picked = frames[:: a.stride]
    if picked[-1] != frames[-1]:
        picked.append(frames[-1])
    head = ",".join(
        ["frame,strain,phi,z"]
        + [f"z_f{eps:g}" for eps in a.threshold]
        + ["z_near"]
        + (["z_tiling"] if a.tiling else [])
    )
    print(head)
    for f in picked:
        k = int(re.findall(r"(\d+)\.vtu$", f)[0])
        x, g, r = particles(f)
        n = g.max() + 1
        row = rows[min(k, len(rows) - 1)]  # a frame and a row every output.every steps
        out = [str(k), row["strain"], row["phi"], f"{float(row['z']):.3f}"]
        if a.threshold:
            contacts = grain_contacts(f.replace("frame_", "contacts_"))
        for eps in a.threshold:
            out.append(f"{pairs_z(force_pairs(contacts, eps), n):.3f}")
        out.append(f"{pairs_z(near_pairs(x, g, r, a.gap), n):.3f}")
        if a.tiling:
            out.append(f"{pairs_z(tiling_pairs(x, g, r, a.pixel), n):.3f}")
        print(",".join(out), flush=True)


if __name__ == "__main__":
    main()
