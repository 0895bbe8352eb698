"""Points of an MPM packing frame whose centre lies inside another grain (README, MPM packings).

A frame has no deformation gradient, so each point's domain is drawn as the axis-aligned
square of its area (side sqrt(volume)), as in `mpm_overlap_area.py`; the compact stage's
own count (`points_inside`, `src/mpm/overlap.rs`) carries each domain by F. A square's
corner reaches 0.41 of its half-size past a slanted face, so this count starts at overlaps of
about 0.6 of a half-size there instead of one: an upper estimate of the stage's count, for
frames of runs made before it (bench/README-packings.md, "Points inside another grain").

    python3 bench/mpm_points_inside.py RUN/compact/mpm-mu0/frame_000004.vtu   (needs meshio)
"""
import sys

import meshio
import numpy as np

mesh = meshio.read(sys.argv[1])
x = mesh.points[:, :2]
grain = mesh.point_data["grain_id"].astype(int).ravel()
half = 0.5 * np.sqrt(mesh.point_data["volume"].ravel())
size = 2 * half.max()
cell = np.floor((x - x.min(0)) / size).astype(int)
ncol = cell[:, 0].max() + 2
key = cell[:, 1] * ncol + cell[:, 0]
order = np.argsort(key, kind="stable")
starts = np.searchsorted(key[order], np.arange(key.max() + ncol + 2))
inside = np.zeros(len(x), bool)
# a centre can lie only in squares whose centre is within one bin of its own
for dj in (-1, 0, 1):
    for di in (-1, 0, 1):
        nb = key + dj * ncol + di
        ok = (nb >= 0) & (nb < len(starts) - 1)
        for p in np.flatnonzero(ok & ~inside):
            q = order[starts[nb[p]]:starts[nb[p] + 1]]
            q = q[grain[q] != grain[p]]
            if q.size and (np.abs(x[q] - x[p]).max(1) < half[q]).any():
                inside[p] = True
n = inside.sum()
print(f"{sys.argv[1]}: {n} of {len(x)} points ({100 * n / len(x):.2f}%) inside another grain's square")
