#!/usr/bin/env python3
"""Rock shadows at 4x the ERIM's rows and columns (docs/experiments/metamorphic.md): each hidden cell
of a scenario's view 0, the jump beyond the trend that its occluder makes in the noise-free image
(the largest among the links within six rows of the cell's row, in its column), in the units the
edge detector decides in, σ = √((kρ²)² + q²/12 + σ_s²); what the ERIM's map at 4x calls the cell;
and, for a per-link test at threshold t, the expected false links in the image and the recall it
can reach at most, the mean of Φ(J − t) over the cells.

    PYTHONPATH=build/python /usr/bin/python3 scripts/shadow_jumps.py [scenarios/demo.yaml]
"""
import sys
from math import erf, sqrt

import numpy as np

import ambler
base = sys.argv[1] if len(sys.argv) > 1 else "scenarios/demo.yaml"
x4 = {"sensor.rows": 256, "sensor.cols": 1024}
ideal = {**x4, "sensor.noise_k": 0, "sensor.quantization_m": 0, "sensor.mixed_pixels": False}
s_erim = ambler.load_scenario(base, **x4); s_ideal = ambler.load_scenario(base, **ideal)
w = ambler.world(s_erim); T = np.array(w.view_pose(0)); vis = w.visibility(T); truth = np.array(w.truth_map().elevation, float)
erim_map = ambler.map_scan(w.scan(T, seed=w.view_seed(0)), T, s_erim).map
wi = ambler.world(s_ideal); ideal_scan = wi.scan(T, seed=wi.view_seed(0))
R = np.array(ideal_scan.range, float); phi = np.array(ideal_scan.phi); th = np.array(ideal_scan.theta)
k, q, ss = 0.0003, 0.0762, 0.02  # the ERIM's noise and counts (the demo's sensor), the detector's σ_s
sigma = lambda rho: np.sqrt((k * rho * rho) ** 2 + q * q / 12 + ss * ss)
Tinv = np.linalg.inv(T); m = erim_map; st = np.array(m.state)
rows = []
for r, c in np.argwhere(vis == 2):
    x = m.x_min_m + (c + 0.5) * m.cell_m; y = m.y_max_m - (r + 0.5) * m.cell_m
    p = Tinv @ np.array([x, y, truth[r, c], 1.0]); rho = np.linalg.norm(p[:3])
    fr = np.interp(np.arctan2(p[2], p[1]), phi[::-1], np.arange(len(phi))[::-1]); fc = np.interp(np.arcsin(p[0] / rho), th, np.arange(len(th)))
    col = int(round(fc)); r0 = int(np.floor(fr))
    if col < 0 or col >= R.shape[1] or r0 < 8 or r0 > R.shape[0] - 8: continue
    best = 0.0
    # the occlusion: the largest jump beyond the trend (far side farther) among the links near the
    # cell's row, rows r0-6 .. r0+6 of its column (row i to i+1: far minus near)
    d = R[:-1, col] - R[1:, col]
    for i in range(r0 - 6, r0 + 7):
        nb = [d[j] for j in (i - 3, i - 2, i - 1, i + 1, i + 2, i + 3) if 0 <= j < len(d) and np.isfinite(d[j])]
        if not np.isfinite(d[i]) or len(nb) < 2: continue
        ex = d[i] - np.median(nb)
        if ex > best: best = ex; rho_l = R[i + 1, col]
    J = best / sigma(rho_l) if best > 0 else 0.0
    rows.append((J, st[r, c]))
a = np.array(rows)
print(f"hidden cells traced: {len(a)}; ERIM 4x map: shadow {(a[:,1]==2).sum()}, known {(a[:,1]==1).sum()}, unseen {(a[:,1]==0).sum()}")
for lo, hi in ((0, 2), (2, 4), (4, 6), (6, 12), (12, np.inf)):
    sel = (a[:, 0] >= lo) & (a[:, 0] < hi)
    n = sel.sum()
    print(f"J in [{lo}, {hi}): {n} cells ({n/len(a):.0%}); shadow {(a[sel,1]==2).sum()}, known {(a[sel,1]==1).sum()}, unseen {(a[sel,1]==0).sum()}")
Phi = lambda x: 0.5 * (1 + erf(x / sqrt(2)))
links = 2 * R.size
print("per-link threshold t (noise units): expected false links in the image, recall bound over the traced cells")
for t in (3.0, 3.5, 4.0, 4.24, 4.5):
    print(f"  t {t}: false links {links * (1 - Phi(t)):.0f}, recall at most {np.mean([Phi(J - t) for J in a[:, 0]]):.2f}")
