#!/usr/bin/env python3
"""The forward bias of a registration one metre long, view against view, at the true poses.

For each seed, the terrain of scenarios/traverse.yaml is walked along y = 0 in +x; at stop k the
ERIM looks along the path from 3 m above the ground (pitch -30 deg), and view k is mapped at its
true pose on the 10 cm grid 2-10 m ahead of it (x, the path) and 6 m either side. Scan k + 1 is
registered against it from the true relative pose. The bias is the mean of the estimated step's
error along the true step (positive: the step reads long). docs/traverse.md, "Where the drift
comes from".

    PYTHONPATH=build/python /usr/bin/python3 scripts/footprint_bias.py --seeds 1,2,3,4,5,6,7,8,9,10
    ... --set sensor.beam_divergence_deg=0.938    # twice the footprint
"""
import argparse, json, os, re, sys, tempfile
import numpy as np
import ambler

HERE = os.path.dirname(os.path.abspath(__file__))
BASE = os.path.join(HERE, "..", "scenarios", "traverse.yaml")


def views_scenario(seed, stops, path):
    """traverse.yaml with its traverse replaced by `stops` views along y = 0, 3 m above the ground."""
    world = ambler.world(ambler.load_scenario(BASE, seed=seed))
    text = open(BASE).read()
    text = re.sub(r"^traverse:\n(  .*\n)+", "", text, flags=re.M)
    text = re.sub(r"^seed: .*$", f"seed: {seed}", text, flags=re.M)
    text += "views:\n" + "".join(
        f"  - {{xyz_m: [{x:.1f}, 0, {float(world.height(x, 0.0)) + 3.0:.4f}], rpy_deg: [0, -30, -90]}}\n"
        for x in (-25.0 + k for k in range(stops)))
    with open(path, "w") as f:
        f.write(text)


def value(text):
    try:
        return json.loads(text)
    except ValueError:
        return text


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1,2,3,4,5,6,7,8,9,10")
    ap.add_argument("--pairs", type=int, default=25, help="pairs per seed, spread over the 50 m")
    ap.add_argument("--method", default="features+iconic_lm")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scenario override")
    a = ap.parse_args()
    over = {k: value(v) for k, v in (kv.split("=", 1) for kv in a.set)}
    errors = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in (int(x) for x in a.seeds.split(",")):
            path = os.path.join(tmp, f"views_{seed}.yaml")
            views_scenario(seed, 51, path)
            world = ambler.world(ambler.load_scenario(path, **over))
            step = max(1, (world.views - 1) // a.pairs)
            for k in list(range(0, world.views - 1, step))[: a.pairs]:
                Pi, Pj = np.array(world.view_pose(k)), np.array(world.view_pose(k + 1))
                x = Pi[0, 3]
                s = ambler.load_scenario(path, **over, **{"map.region": {"x_m": [x + 2, x + 10], "y_m": [-6, 6]}})
                vi = ambler.map_scan(world.scan(Pi, seed=world.view_seed(k)), Pi, s)
                sj = ambler.map_scan(world.scan(Pj, seed=world.view_seed(k + 1)), Pj, s).scan
                T = np.array(ambler.register(vi, sj, np.linalg.inv(Pi) @ Pj, a.method).T)
                e = (Pi @ T)[:3, 3] - Pj[:3, 3]
                u = (Pj[:3, 3] - Pi[:3, 3]) / np.linalg.norm(Pj[:3, 3] - Pi[:3, 3])
                errors.append((e @ u, e @ np.cross([0, 0, 1], u), e[2]))
            print(f"seed {seed}: {len(errors)} pairs so far", file=sys.stderr)
    e = 1000 * np.array(errors)
    n = len(e)
    print(f"{n} pairs: forward bias {e[:, 0].mean():+.2f} mm (standard error {e[:, 0].std() / np.sqrt(n):.2f}), "
          f"forward RMS {np.sqrt((e[:, 0] ** 2).mean()):.1f} mm, lateral RMS {np.sqrt((e[:, 1] ** 2).mean()):.1f} mm, "
          f"height mean {e[:, 2].mean():+.2f} mm")


if __name__ == "__main__":
    main()
