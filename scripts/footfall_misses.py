#!/usr/bin/env python3
"""Trial by trial, why a footfall method's steps missed (docs/experiments/footfall.md).

    PYTHONPATH=build/python /usr/bin/python3 scripts/footfall_misses.py runs/footfall/footfall_trials \
        [--method equilibrium_soil]

For every trial of the sweep whose step on METHOD's choice missed (tilt > 5 deg, slip > 1 cm or not
settled), it rebuilds the trial's world and view-0 map (ambler's Python module, the run's own
stages) and prints one markdown row: the step, the same method's choice on the true surface
stepped on (what a perfect map would have given), and the rocks under the foot and its rim at the
chosen spot (the cells within one cell beyond the rim, the method's own disk): the tallest rock
above the ground in truth (the world minus the same world without its rocks) and what the map
showed there, its white top-hat (height above the grey opening by a 0.6 m disk, the method's rule
for a rock: above 3 cm). A miss whose rock the map shows below 3 cm, while the truth's choice
held, is the map's when no threshold on the top-hat could have told it from the map's noise: the
share p of the map's rock-free Known cells whose top-hat is at least the rock's, and the chance
that a disk of the method's 37 rock-free cells holds one (1 − (1 − p)^37): a threshold low
enough to call this rock a rock calls that share of clean disks rocky too. Where that is at least
half, the cause says the map's. Also the map's: a cell of that disk the sensor could not see (a
range shadow in truth, World.visibility) that the map calls Known more than 2 cm off the truth,
the shadow bridged as ground. Otherwise the method's (the map shows the rock).
"""
import argparse
import csv
import math
import os
import re
import sys

import numpy as np

import ambler

TILT_DEG, SLIP_M = 5.0, 0.01
RIGID_HEIGHT_M, RIGID_WIDTH_M = 0.03, 0.6  # perception::FootfallConfig's defaults


def held(row, k, pre=""):
    try:
        return (float(row[f"footfall.{k}.{pre}leg.tilt_deg"]) <= TILT_DEG
                and float(row[f"footfall.{k}.{pre}leg.slip_m"]) <= SLIP_M
                and row[f"footfall.{k}.{pre}leg.settled"] in ("true", "1", "True"))
    except ValueError:
        return False


def disk_offsets(radius_cells):
    r = int(math.floor(radius_cells * (1 + 1e-9)))
    return [(i, j) for i in range(-r, r + 1) for j in range(-r, r + 1) if i * i + j * j <= radius_cells ** 2 * (1 + 1e-9)]


def top_hat(z, known, cell):
    """z minus its grey opening by a disk RIGID_WIDTH_M across, over the Known cells (as
    perception/footfall.cpp's rigidCells: placements anywhere that hold a Known cell)."""
    offs = disk_offsets(0.5 * RIGID_WIDTH_M / cell)
    k = max(max(abs(i), abs(j)) for i, j in offs)
    rows, cols = z.shape
    big = np.full((rows + 4 * k, cols + 4 * k), np.inf)
    big[2 * k:2 * k + rows, 2 * k:2 * k + cols] = np.where(known, z, np.inf)
    ero = np.full((rows + 2 * k, cols + 2 * k), np.inf)
    for i, j in offs:
        ero = np.minimum(ero, big[k + i:k + i + rows + 2 * k, k + j:k + j + cols + 2 * k])
    ero_m = np.where(np.isfinite(ero), ero, -np.inf)
    opened = np.full((rows, cols), -np.inf)
    for i, j in offs:
        opened = np.maximum(opened, ero_m[k + i:k + i + rows, k + j:k + j + cols])
    return np.where(known, z - opened, np.nan)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir", help="the sweep's output directory (holds results.csv and sweep.resolved.yaml)")
    ap.add_argument("--method", default="equilibrium_soil")
    args = ap.parse_args()
    path = os.path.join(args.sweep_dir, "results.csv")
    try:
        rows = list(csv.DictReader(open(path)))
    except OSError as e:
        sys.exit(f"footfall_misses: {path}: {e.strerror}")
    names = {rows[0][f"footfall.{k}.method"]: k for k in range(16) if f"footfall.{k}.method" in rows[0]}
    if args.method not in names:
        sys.exit(f"footfall_misses: {path}: no method '{args.method}' (it has {', '.join(names)})")
    m = names[args.method]
    base = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenarios", "experiments", "sandbox.yaml")
    print(f"| seed | region x, y (m) | k | soil | chosen (m) | tilt / slip | truth's choice: tilt | tallest rock within the rim + 1 cell: true / on the map (top-hat) | "
          f"rock-free cells / disks at least as high | cause |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        if held(row, m):
            continue
        seed = int(row["seed"])
        x0, x1, y0, y1 = map(float, re.findall(r"-?\d+(?:\.\d+)?", row["footfall.region"]))
        over = {"footfall.region": {"x_m": [x0, x1], "y_m": [y0, y1]}, "leg.soil": row["leg.soil"]}
        if row.get("terrain.rocks.abundance_k"):
            over["terrain.rocks.abundance_k"] = float(row["terrain.rocks.abundance_k"])
        region = ambler.load_scenario(base, seed=seed, **over)
        world = ambler.world(region)
        bare = ambler.world(ambler.load_scenario(base, seed=seed, **{**over, "terrain.rocks.abundance_k": 1e-9}))
        truth, ground = world.truth_map(), bare.truth_map()
        pose = world.view_pose(0)
        view = ambler.map_scan(world.scan(pose, seed=world.view_seed(0)), pose, region).map
        cell = view.cell_m
        x, y = float(row[f"footfall.{m}.x_m"]), float(row[f"footfall.{m}.y_m"])
        r0, c0 = int((view.y_max_m - y) / cell), int((x - view.x_min_m) / cell)
        rock = truth.elevation - ground.elevation
        hidden = world.visibility(pose) == 2
        hat = top_hat(view.elevation.astype(float), view.state == 1, cell)
        best = (0.0, math.nan)
        ring = disk_offsets(0.5 * 0.30 / cell + 1)
        bridged = max((abs(float(view.elevation[r0 + i, c0 + j]) - float(truth.elevation[r0 + i, c0 + j]))
                       for i, j in ring if hidden[r0 + i, c0 + j] and view.state[r0 + i, c0 + j] == 1), default=0.0)
        for i, j in ring:
            h = rock[r0 + i, c0 + j]
            if h > best[0]:
                best = (h, hat[r0 + i, c0 + j])
        tb = held(row, m, "truth_best.")
        clean = hat[(np.abs(rock) < 0.001) & np.isfinite(hat)]
        p = float(np.mean(clean >= best[1])) if np.isfinite(best[1]) else math.nan
        false_disks = 1 - (1 - p) ** len(ring)
        tilt, slip = float(row[f"footfall.{m}.leg.tilt_deg"]), float(row[f"footfall.{m}.leg.slip_m"])
        if best[0] < 0.005:
            cause = "the leg: no rock within reach"
        elif not tb:
            cause = "the truth's choice missed too"
        elif false_disks >= 0.5:
            cause = ("the map: below the 3 cm, " if not (best[1] > RIGID_HEIGHT_M) else "the map: ") + \
                "as high as the noise in most clean disks"
        elif bridged > 0.02:
            cause = f"the map: a range shadow in the disk mapped as ground, {100 * bridged:.1f} cm off"
        else:
            cause = "the method: the map shows the rock"
        print(f"| {seed} | [{x0:g}, {x1:g}], [{y0:g}, {y1:g}] | {row.get('terrain.rocks.abundance_k', '')} | {row['leg.soil']} | "
              f"({x:.3f}, {y:.3f}) | {tilt:.1f}° / {1000 * slip:.1f} mm | "
              f"{float(row[f'footfall.{m}.truth_best.leg.tilt_deg']):.1f}° ({'held' if tb else 'missed'}) | "
              f"{100 * best[0]:.1f} / {100 * best[1]:.1f} cm | {100 * p:.1f} % / {100 * false_disks:.0f} % | {cause} |")


if __name__ == "__main__":
    main()
