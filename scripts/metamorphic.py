#!/usr/bin/env python3
"""The metamorphic table of the map (docs/experiments/metamorphic.md): view 0's locus map, scored
against ground truth as the map stage scores it, for the ERIM and each step towards a better sensor
(noise off, quantisation off, mixed pixels off, all off, 2x and 4x the rows and columns), with the
relations of tests/integration/test_metamorphic.cpp checked against the ERIM. With --seeds N, the
spread of the ERIM's figures over N noise draws of the same terrain instead.

    PYTHONPATH=build/python /usr/bin/python3 scripts/metamorphic.py [--shadows gnc|gnc_bridge]
        [--seeds N] SCENARIO.yaml ...

Needs the Python module (build/python, docs/python.md)."""
import argparse
import math
import sys

import numpy as np

import ambler

STEPS = [
    ("ERIM", {}),
    ("noise off", {"sensor.noise_k": 0}),
    ("quantisation off", {"sensor.quantization_m": 0}),
    ("mixed pixels off", {"sensor.mixed_pixels": False}),
    ("all off", {"sensor.noise_k": 0, "sensor.quantization_m": 0, "sensor.mixed_pixels": False}),
    ("2x", {"sensor.rows": 128, "sensor.cols": 512}),
    ("4x", {"sensor.rows": 256, "sensor.cols": 1024}),
]


def figures(view, vis, truth):
    """Coverage, RMS error, visible cells called shadow, hidden cells known beyond 3 sigma_z."""
    m = view.map
    z, sigma, state = m.elevation.astype(float), m.sigma.astype(float), m.state
    known = state == 1
    e = z - truth
    return {
        "coverage": (known & (vis == 1)).sum() / (vis == 1).sum(),
        "rms": math.sqrt(np.nanmean(e[known & np.isfinite(truth)] ** 2)),
        "visible_shadow": int(((state == 2) & (vis == 1)).sum()),
        "hidden_beyond": int((known & (vis == 2) & (np.abs(e) > 3 * sigma)).sum()),
        "precision": ((state == 2) & (vis == 2)).sum() / max(1, (state == 2).sum()),
        "recall": ((state == 2) & (vis == 2)).sum() / max(1, (vis == 2).sum()),
    }


def view0(path, shadows, overrides, seed=None):
    """View 0 mapped as the map stage maps it (the world, its scan and map_scan), and scored."""
    s = ambler.load_scenario(path, **{"map.shadows": shadows, **overrides})
    world = ambler.world(s)
    pose = world.view_pose(0)
    scan = world.scan(pose, seed=world.view_seed(0) if seed is None else seed)
    return figures(ambler.map_scan(scan, pose, s), world.visibility(pose), world.truth_map().elevation.astype(float))


def table(path, shadows):
    print(f"\n{path}, shadows: {shadows}\n")
    print("| sensor | coverage | RMS | shadow P / R | visible called shadow | hidden known > 3σ_z | fails |")
    print("|---|---|---|---|---|---|---|")
    erim = None
    for name, overrides in STEPS:
        f = view0(path, shadows, overrides)
        fails = []
        if erim is None:
            erim = f
        else:
            if f["coverage"] < erim["coverage"] - 0.01:
                fails.append("coverage")
            if f["rms"] > 1.1 * erim["rms"]:
                fails.append("RMS")
            if f["visible_shadow"] > erim["visible_shadow"] + 2 * math.sqrt(2 * erim["visible_shadow"]):
                fails.append("visible called shadow")
            if f["hidden_beyond"] > erim["hidden_beyond"] + 2 * math.sqrt(2 * erim["hidden_beyond"]):
                fails.append("hidden beyond 3σ")
        print(f"| {name} | {f['coverage']:.3f} | {100 * f['rms']:.2f} cm | {f['precision']:.2f} / {f['recall']:.2f} "
              f"| {f['visible_shadow']} | {f['hidden_beyond']} | {', '.join(fails)} |", flush=True)


def spread(path, shadows, seeds):
    rows = [view0(path, shadows, {}, seed=1000 + k) for k in range(seeds)]
    print(f"{path}, shadows: {shadows}, {seeds} noise draws (mean ± standard deviation):")
    for key in ("coverage", "rms", "visible_shadow", "hidden_beyond"):
        v = np.array([r[key] for r in rows], float)
        print(f"  {key}: {v.mean():.4g} ± {v.std(ddof=1):.2g}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenarios", nargs="+")
    p.add_argument("--shadows", default="gnc", choices=["gnc", "gnc_bridge"])
    p.add_argument("--seeds", type=int, default=0, help="the spread over N noise draws instead of the table")
    a = p.parse_args()
    for path in a.scenarios:
        if a.seeds:
            spread(path, a.shadows, a.seeds)
        else:
            table(path, a.shadows)


if __name__ == "__main__":
    sys.exit(main())
