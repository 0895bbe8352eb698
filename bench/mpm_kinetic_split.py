"""Where an MPM packing's kinetic energy is (README, MPM packings, quasi-static check).

For each of the last frames of a compaction case, each grain's kinetic energy
(sum of volume * |v|^2 / 2 over its points, density dropped: it is the same in every grain)
is split into the translation of its centre, its rigid rotation about the centre
(L^2 / 2I from the points' angular momentum and polar moment) and the rest (deformation).
Prints the three shares of the packing's total.

    python3 bench/mpm_kinetic_split.py OUT/<pipeline>/compact/<case> [more cases] [--last N]
"""

import argparse
import glob

import meshio
import numpy as np


def split(frame):
    m = meshio.read(frame)
    grain = m.point_data["grain_id"].astype(int).ravel()
    vol = m.point_data["volume"].ravel()
    v = m.point_data["velocity"][:, :2]
    x = m.points[:, :2]
    total = 0.5 * (vol * (v**2).sum(1)).sum()
    translation = rotation = 0.0
    for g in np.unique(grain):
        s = grain == g
        w, xs, vs = vol[s], x[s], v[s]
        mass = w.sum()
        vc = (w[:, None] * vs).sum(0) / mass
        r = xs - (w[:, None] * xs).sum(0) / mass
        vr = vs - vc
        inertia = (w * (r**2).sum(1)).sum()
        spin = (w * (r[:, 0] * vr[:, 1] - r[:, 1] * vr[:, 0])).sum()
        translation += 0.5 * mass * (vc**2).sum()
        rotation += 0.5 * spin**2 / inertia
    return translation / total, rotation / total, 1.0 - (translation + rotation) / total


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="+", help="compact/<case> folders holding frame_*.vtu")
    ap.add_argument("--last", type=int, default=6, help="how many of the last frames")
    a = ap.parse_args()
    for case in a.cases:
        for frame in sorted(glob.glob(f"{case}/frame_*.vtu"))[-a.last :]:
            t, r, d = split(frame)
            print(f"{frame}: translation {t:.3f} rotation {r:.3f} deformation {d:.3f}")


if __name__ == "__main__":
    main()
