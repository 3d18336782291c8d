"""examples/python/basin_open3d.py runs as the README says, and its user's method, Open3D-Python's
point-to-plane ICP with the project's peer settings, is scored beside the project's own C++ peer."""
import csv
import os
import subprocess
import sys

import pytest

SOURCE = os.environ["AMBLER_SOURCE_DIR"]
pytest.importorskip("open3d", reason="Debian's python3-open3d (scripts/setup.sh installs it)")


def test_the_open3d_basin_example(tmp_path):
    out = tmp_path / "basin"
    subprocess.run([sys.executable, os.path.join(SOURCE, "examples", "python", "basin_open3d.py"), str(out)],
                   check=True, cwd=SOURCE, env=os.environ.copy(), stdout=subprocess.DEVNULL)
    with open(out / "basin.csv") as f:
        rows = list(csv.reader(f))[1:]
    success = {}
    for r in rows:
        success.setdefault(r[0], []).append(r[6] == "true")
    assert sorted(success) == ["features+iconic_lm", "iconic_lm", "icp_point_to_plane", "o3d_icp"]
    # The same algorithm, settings and returns as the C++ peer (only the voxel grid's frame differs):
    # they succeed and fail on the same draws but for at most a tenth of them.
    py, cpp = success["o3d_icp"], success["icp_point_to_plane"]
    assert len(py) == len(cpp) == 48
    assert sum(a != b for a, b in zip(py, cpp)) <= len(py) // 10
    # Every draw from the exact pose comes home (the first rotation, the first translation).
    assert all(py[:4])
    # Its heatmap is in the report, beside the built-in methods'.
    html = (out / "report.html").read_text()
    for method in ("o3d_icp", "icp_point_to_plane", "iconic_lm"):
        assert f"basin_{method}.png" in html
