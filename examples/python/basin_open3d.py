#!/usr/bin/env python3
"""A basin of your own registration method beside the built-in ones (docs/python.md, "Your own
method"): Open3D-Python's point-to-plane ICP (Debian's python3-open3d) as `o3d_icp`, beside the
project's own Open3D peer (the same ICP in C++) and two of the paper's methods, on the demo's pair, every method from the same seeded initial errors, scored and drawn as `ambler basin` does.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/basin_open3d.py [OUT]

Writes OUT (default runs/basin_open3d)/basin.csv, basin.md, basin_METHOD.png, basin_boundary.png
and report.html, and prints basin.md.
"""
import os
import sys

import numpy as np
import open3d as o3d

import ambler

HERE = os.path.dirname(os.path.abspath(__file__))
SCENARIO = os.path.join(HERE, "..", "..", "scenarios", "demo.yaml")


def o3d_icp(view_i, scan_j, T_initial):
    """Scan J's returns (its own frame) onto scan I's (sensor I's frame) from the believed pose, with
    the settings of the project's own Open3D peer (eval/peers/open3d_peers.hpp: 0.10 m voxels,
    normals within 0.40 m, a 0.15 m pair gate, 60 iterations)."""
    reg = o3d.pipelines.registration
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(view_i.scan.points)).voxel_down_sample(0.10)
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(scan_j.points)).voxel_down_sample(0.10)
    target.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.40, max_nn=30))
    result = reg.registration_icp(source, target, 0.15, np.asarray(T_initial), reg.TransformationEstimationPointToPlane(),
                                  reg.ICPConvergenceCriteria(relative_fitness=1e-9, relative_rmse=1e-9, max_iteration=60))
    return {"T": np.asarray(result.transformation)}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join("runs", "basin_open3d")
    scenario = ambler.load_scenario(SCENARIO)
    csv = ambler.basin(scenario, out, methods=["iconic_lm", "features+iconic_lm", "icp_point_to_plane"], custom={"o3d_icp": o3d_icp},
                       translation_m="0,0.5,1,1.5", rotation_deg="0,10,20", trials=4, jobs=2, progress=True)
    print(f"wrote {csv} and {ambler.report(out)}")
    with open(os.path.join(out, "basin.md")) as f:
        print(f.read())


if __name__ == "__main__":
    main()
