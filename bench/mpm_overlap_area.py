"""Area of an MPM packing frame that lies under two grains (README, MPM packings).

Each material point is drawn as its square (side sqrt(volume), the deformation gradient's
stretch ignored), per grain, on a raster of 1/8 of the smallest side; the result is the
share of covered pixels covered by two or more grains.

    python3 bench/mpm_overlap_area.py RUN/compact/mpm-mu0/frame_000004.vtu   (needs meshio)
"""
import sys

import meshio
import numpy as np

mesh = meshio.read(sys.argv[1])
x = mesh.points[:, :2]
grain = mesh.point_data["grain_id"].astype(int).ravel()
side = np.sqrt(mesh.point_data["volume"].ravel())
px = side.min() / 8
lo = x.min(0) - side.max()
shape = np.ceil((x.max(0) + side.max() - lo) / px).astype(int) + 1
count = np.zeros((shape[1], shape[0]), np.int16)
for g in np.unique(grain):
    covered = np.zeros_like(count, bool)
    for p in np.flatnonzero(grain == g):
        a = ((x[p] - side[p] / 2 - lo) / px).astype(int)
        b = ((x[p] + side[p] / 2 - lo) / px).astype(int)
        covered[a[1]:b[1], a[0]:b[0]] = True
    count += covered
share = (count >= 2).sum() / (count >= 1).sum()
print(f"{sys.argv[1]}: {100 * share:.2f}% of the covered area lies under two grains")
