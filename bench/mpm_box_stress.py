"""Box-average vertical stress of an MPM compaction, read from its frames: -Σ v_p σ_yy,p / A_box.
With the contact forces internal to the box, this equals the walls' mean σ_yy in quasi-static
equilibrium, so it gives σ(ε) of a run that has not written its timeseries.csv yet (a running
or interrupted compaction). A_box = A0 e^-ε with A0 = Σ v_p(frame 0) / Φ0, and
ε = -ln(1 - V t / h0) from each frame's time in series.pvd.
Usage: python3 bench/mpm_box_stress.py CASE_DIR PHI0 WALL_VELOCITY H0 [EVERY]
(H0, the box height at ε = 0 in m, is in a finished run's frames of the same deposit:
h0 = V t / (1 - e^-ε) from any row of its timeseries.csv.)"""
import math
import re
import sys

import meshio

case, phi0, v, h0 = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
every = int(sys.argv[5]) if len(sys.argv) > 5 else 1
frames = re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', open(f"{case}/series.pvd").read())
v0 = meshio.read(f"{case}/{frames[0][1]}").point_data["volume"].sum()
print("frame,time,strain,box_sigma_yy_pa,area_ratio")
for t, name in frames[::every]:
    m = meshio.read(f"{case}/{name}")
    vol, s = m.point_data["volume"], m.point_data["stress"]
    eps = -math.log(1.0 - v * float(t) / h0)
    box = v0 / phi0 * math.exp(-eps)
    print(f"{name},{t},{eps:.4f},{-(vol * s[:, 4]).sum() / box:.4g},{vol.sum() / v0:.5f}")
