"""The stages one by one against the run: world -> scan -> map_scan gives the run's range images and
view maps bit for bit, map_range_image of the run's range image its map, merge at the true poses the
merge stage's composite (merge.poses: true), evaluate_footfalls on the run's composite the run's
choices and score rasters; Run.registrations against the pair JSONs and the views' true poses; the
arrays views (np.shares_memory, not writeable), footfall inputs read in place where the layout
allows (the address the C++ side read), and bad input as ValueError with the project's line."""
import json
import os
import subprocess
import tempfile

import numpy as np
import pytest

import ambler

SOURCE = os.environ["AMBLER_SOURCE_DIR"]
DEMO = os.path.join(SOURCE, "scenarios", "demo.yaml")
# The demo with two matching methods (fewer to wait for) and its composite at the true poses.
OVERRIDES = {"matching.methods": ["features+iconic_lm", "iconic_lm"], "merge.poses": "true"}
LAYERS = ("elevation", "sigma", "state", "ceiling")


def address(a):
    return a.__array_interface__["data"][0]


def assert_maps_equal(a, b):
    for layer in LAYERS:
        np.testing.assert_array_equal(getattr(a, layer), getattr(b, layer), err_msg=layer)
    assert (a.cell_m, a.x_min_m, a.y_max_m) == (b.cell_m, b.x_min_m, b.y_max_m)
    np.testing.assert_array_equal(a.transform, b.transform)


def read_tiff(path, shape):
    """A float32 GeoTIFF through GDAL's command line (gdal-bin), as raw float32 (ENVI): exact."""
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "band.raw")
        subprocess.run(["gdal_translate", "-q", "-of", "ENVI", "-ot", "Float32", path, raw], check=True)
        return np.fromfile(raw, dtype=np.float32).reshape(shape)


@pytest.fixture(scope="module")
def demo():
    s = ambler.load_scenario(DEMO, **OVERRIDES)
    run = ambler.run(s)
    world = ambler.world(s)
    scans = [world.scan(world.view_pose(k), seed=world.view_seed(k)) for k in range(world.views)]
    views = [ambler.map_scan(scan, world.view_pose(k), s) for k, scan in enumerate(scans)]
    return s, run, world, scans, views


def test_world_scans_are_the_runs(demo):
    s, run, world, scans, _ = demo
    assert world.views == 2
    for k, scan in enumerate(scans):
        np.testing.assert_array_equal(scan.range, run.scans[k])  # NaN where the run has NaN
        assert not scan.unwrapped and scan.edges is None
        assert scan.range.dtype == np.float32 and not scan.range.flags.writeable
        assert np.shares_memory(scan.range, scan.range)
        # Every return as a point (eq. 1): as many as the run's finite ranges, each at its range.
        points = scan.points
        assert points.shape == (np.isfinite(run.scans[k]).sum(), 3)
        np.testing.assert_allclose(np.linalg.norm(points, axis=1), run.scans[k][np.isfinite(run.scans[k])], rtol=1e-6)
    # seed None is view 0's seed; another seed draws other noise.
    np.testing.assert_array_equal(world.scan(world.view_pose(0)).range, run.scans[0])
    other = world.scan(world.view_pose(0), seed=world.view_seed(0) + 1).range
    assert not np.array_equal(other, run.scans[0])
    # The sensor pose of view 1: 1 m along +y from view 0, at z = 3 (scenarios/demo.yaml).
    np.testing.assert_allclose(world.view_pose(1)[:3, 3], [0, -5, 3], atol=0)


def test_world_heights_are_the_truth_maps(demo):
    s, _, world, _, _ = demo
    truth = world.truth_map()
    r, c = np.array([0, 17, 40, 109]), np.array([0, 55, 3, 99])
    x = truth.x_min_m + (c + 0.5) * truth.cell_m
    y = truth.y_max_m - (r + 0.5) * truth.cell_m
    np.testing.assert_array_equal(world.height(x, y).astype(np.float32), truth.elevation[r, c])
    assert np.isnan(world.height(1000.0, 0.0))
    assert (truth.state == 1).all() and (truth.sigma == 0).all()


def test_visibility_scores_the_views_as_the_runs_metrics(demo):
    """World.visibility is what the map metrics score against: from it, each view map's coverage,
    shadow precision and recall and its counts of visible and hidden cells are metrics.json's."""
    _, run, world, _, _ = demo
    for k in range(world.views):
        vis = world.visibility(world.view_pose(k))
        m, metrics = run.maps[f"view_{k}"], run.metrics["map"][k]
        assert vis.dtype == np.uint8 and vis.shape == m.state.shape and set(np.unique(vis)) <= {0, 1, 2}
        visible, hidden = vis == 1, vis == 2
        known, shadow = m.state == 1, m.state == 2
        assert (visible.sum(), hidden.sum(), shadow.sum()) == (metrics["visible"], metrics["hidden"], metrics["shadow"])
        assert (known & visible).sum() / visible.sum() == pytest.approx(metrics["coverage"], rel=1e-12)
        assert (shadow & hidden).sum() / shadow.sum() == pytest.approx(metrics["shadow_precision"], rel=1e-12)
        assert (shadow & hidden).sum() / hidden.sum() == pytest.approx(metrics["shadow_recall"], rel=1e-12)


def test_map_scan_gives_the_runs_view_maps(demo):
    _, run, world, _, views = demo
    for k, v in enumerate(views):
        assert_maps_equal(v.map, run.maps[f"view_{k}"])
        np.testing.assert_array_equal(v.sensor_pose, world.view_pose(k))
        assert v.scan.unwrapped and v.scan.edges is not None
        for layer in LAYERS:
            a = getattr(v.map, layer)
            assert not a.flags.writeable and np.shares_memory(a, getattr(v.map, layer))
        assert not v.scan.range.flags.writeable and np.shares_memory(v.scan.range, v.scan.range)
    # The ambiguity interval folds nothing within the demo's 40 m: unwrapping moved no range.
    np.testing.assert_array_equal(views[0].scan.range, run.scans[0])


def test_a_views_scan_mapped_again_at_its_pose_gives_its_map(demo):
    s, _, world, _, views = demo
    again = ambler.map_scan(views[1].scan, world.view_pose(1), s)
    assert_maps_equal(again.map, views[1].map)
    # At another pose the map moves: 0.5 m up, the same surface 0.5 m higher where it is known.
    up = world.view_pose(1)
    up[2, 3] += 0.5
    moved = ambler.map_scan(views[1].scan, up, s).map
    assert not np.array_equal(moved.elevation, views[1].map.elevation)


def test_map_range_image_of_the_runs_range_image_is_its_map(demo):
    s, run, world, _, _ = demo
    rng = np.array(run.scans[0])  # float32, writeable: the user's own
    before = rng.copy()
    v = ambler.map_range_image(rng, world.view_pose(0), s)
    assert_maps_equal(v.map, run.maps["view_0"])
    np.testing.assert_array_equal(rng, before)  # mapping unwraps its own copy
    assert not np.shares_memory(v.scan.range, rng)
    # float64 in: the same map (the ranges are float32 values).
    assert_maps_equal(ambler.map_range_image(rng.astype(np.float64), world.view_pose(0), s).map, v.map)
    with pytest.raises(ValueError, match=r"^map_range_image: range: expected a 64 x 256 array of ranges"):
        ambler.map_range_image(rng[:10], world.view_pose(0), s)
    rng[3, 4] = -1
    with pytest.raises(ValueError, match=r"^map_range_image: range\[3, 4\] = -1.000000: expected a range >= 0"):
        ambler.map_range_image(rng, world.view_pose(0), s)


def test_merge_at_the_true_poses_is_the_merge_stages_composite(demo):
    s, run, world, _, views = demo
    composite = ambler.merge(views, s)
    assert_maps_equal(composite, run.maps["composite"])
    for layer in LAYERS:
        a = getattr(composite, layer)
        assert not a.flags.writeable and np.shares_memory(a, getattr(composite, layer))
    # The poses given: the same; view 1 placed 0.3 m east: another composite.
    poses = [world.view_pose(0), world.view_pose(1)]
    assert_maps_equal(ambler.merge(views, s, poses=poses), composite)
    poses[1][0, 3] += 0.3
    assert not np.array_equal(ambler.merge(views, s, poses=poses).elevation, composite.elevation)
    with pytest.raises(ValueError, match=r"^merge: 1 poses for 2 views$"):
        ambler.merge(views, s, poses=poses[:1])


def test_footfalls_on_the_runs_composite_are_the_runs_choices(demo):
    s, run, _, _, _ = demo
    m = run.maps["composite"]
    fs = ambler.evaluate_footfalls(m.elevation, m.sigma, m.state, m.cell_m, m.x_min_m, m.y_max_m,
                                   ceiling=m.ceiling, scenario=s)
    choices = run.footfalls
    assert [f.method for f in fs] == [c["method"] for c in choices] and len(fs) == 6
    assert all(c["map"] == "composite" for c in choices)
    assert choices == [dict(c, map="composite") for c in run.metrics["footfall"]]
    for f, c in zip(fs, choices):
        assert (f.x_m, f.y_m, f.best_score) == (c["x_m"], c["y_m"], c["score"])
        tif = read_tiff(os.path.join(run.out, "footfall", f"{f.method}_score.tiff"), f.score.shape)
        np.testing.assert_array_equal(f.score, tif)
        assert not f.score.flags.writeable and np.shares_memory(f.score, f.score)
        # The run's float32 / uint8 rasters were read where they are, not copied.
        assert f.read_from == {"elevation": address(m.elevation), "sigma": address(m.sigma),
                               "state": address(m.state), "ceiling": address(m.ceiling)}
    assert fs[1].method == "planar_fit" and fs[1].tilt_deg.shape == m.elevation.shape
    assert fs[0].tilt_deg is None


def test_footfall_inputs_are_read_in_place_where_the_layout_allows(demo):
    s, run, _, _, _ = demo
    m = run.maps["composite"]
    z, sig, st, ceil = (np.array(getattr(m, a)) for a in LAYERS)
    # A block of the map (rows strided by the full width) is read in place and gives the scores
    # of the same block copied to its own memory.
    b = (slice(10, 90), slice(20, 80))
    x_min, y_max = m.x_min_m + 20 * m.cell_m, m.y_max_m - 10 * m.cell_m
    args = (m.cell_m, x_min, y_max)
    block = ambler.evaluate_footfalls(z[b], sig[b], st[b], *args, ceiling=ceil[b], scenario=s)
    assert block[0].read_from["elevation"] == address(z[b]) and block[0].read_from["state"] == address(st[b])
    own = [np.ascontiguousarray(a[b]) for a in (z, sig, st, ceil)]
    copied = ambler.evaluate_footfalls(*own[:3], *args, ceiling=own[3], scenario=s)
    assert copied[0].read_from["elevation"] == address(own[0])
    for f, g in zip(block, copied):
        np.testing.assert_array_equal(f.score, g.score)
        assert (f.x_m, f.y_m, f.best_score) == (g.x_m, g.y_m, g.best_score)
    # float64 heights, or every other column: copied (another address), the same scores.
    for elevation in (z[b].astype(np.float64), np.repeat(z[b], 2, axis=1)[:, ::2]):
        other = ambler.evaluate_footfalls(elevation, sig[b], st[b], *args, ceiling=ceil[b], scenario=s)
        assert other[0].read_from["elevation"] != address(elevation)
        assert other[0].read_from["sigma"] == address(sig[b])
        for f, g in zip(other, block):
            np.testing.assert_array_equal(f.score, g.score)
    # The region and methods given, a wider foot: only those methods, and the foot's keyword counts.
    fs = ambler.evaluate_footfalls(z, sig, st, m.cell_m, m.x_min_m, m.y_max_m, region=(0, 2, 1, 3),
                                   methods=["max_min"], foot_diameter_m=0.5)
    assert len(fs) == 1 and fs[0].method == "max_min"
    default = ambler.evaluate_footfalls(z, sig, st, m.cell_m, m.x_min_m, m.y_max_m, region=(0, 2, 1, 3),
                                        methods=["max_min"])
    assert np.isfinite(fs[0].score).sum() < np.isfinite(default[0].score).sum()  # fewer centres hold a 0.5 m foot


def test_the_soils_sinkage_is_the_scenarios_leg(demo):
    # equilibrium_soil takes its sinkage from the scenario's leg (sand, 4 kN: Bekker's law,
    # docs/leg.md) as the footfall stage does; given as a keyword it overrides that, and 0 differs.
    s, run, _, _, _ = demo
    m = run.maps["composite"]
    args = (m.elevation, m.sigma, m.state, m.cell_m, m.x_min_m, m.y_max_m)
    n, k_c, k_phi, b = 1.1, 0.99e3, 1528.43e3, 0.15
    bekker = (4000 / (np.pi * b * b) / (k_c / b + k_phi)) ** (1 / n)
    assert abs(bekker - 0.0498) < 1e-4  # docs/leg.md: 4.98 cm at 4 kN
    scen = ambler.evaluate_footfalls(*args, ceiling=m.ceiling, scenario=s, methods=["equilibrium_soil"])[0]
    given = ambler.evaluate_footfalls(*args, ceiling=m.ceiling, scenario=s, methods=["equilibrium_soil"],
                                      sinkage_m=bekker)[0]
    rigid = ambler.evaluate_footfalls(*args, ceiling=m.ceiling, scenario=s, methods=["equilibrium_soil"],
                                      sinkage_m=0.0)[0]
    np.testing.assert_allclose(scen.score, given.score, rtol=1e-6, atol=1e-12)
    assert np.isfinite(scen.score).sum() > 100
    assert not np.allclose(scen.score[np.isfinite(scen.score)], rigid.score[np.isfinite(rigid.score)])


def test_footfall_errors_are_the_projects_lines(demo):
    s, run, _, _, _ = demo
    m = run.maps["composite"]
    args = (m.elevation, m.sigma, m.state, m.cell_m, m.x_min_m, m.y_max_m)
    with pytest.raises(ValueError, match=r"^unknown footfall method 'best'"):
        ambler.evaluate_footfalls(*args, scenario=s, methods=["best"])
    with pytest.raises(ValueError, match=r"^evaluateFootfalls: the foot \(0.1 m across\) covers 1 cell\(s\) of 0.1 m; a plane needs 3$"):
        ambler.evaluate_footfalls(*args, scenario=s, foot_diameter_m=0.1)
    with pytest.raises(ValueError, match=r"^evaluate_footfalls: sigma: expected a 110 x 100 array"):
        ambler.evaluate_footfalls(m.elevation, m.sigma[1:], m.state, m.cell_m, m.x_min_m, m.y_max_m, scenario=s)
    with pytest.raises(ValueError, match=r"^evaluate_footfalls: region: expected \(x0, x1, y0, y1\)"):
        ambler.evaluate_footfalls(*args)
    with pytest.raises(ValueError, match=r"^evaluate_footfalls: unknown keyword 'foot_m'"):
        ambler.evaluate_footfalls(*args, scenario=s, foot_m=0.3)
    with pytest.raises(ValueError, match=r"^evaluate_footfalls: foot_diameter_m: expected a number$"):
        ambler.evaluate_footfalls(*args, scenario=s, foot_diameter_m="wide")


def test_registrations_are_the_pair_records(demo):
    s, run, world, _, _ = demo
    regs = run.registrations
    assert [(r["pair"], r["method"]) for r in regs] == [([0, 1], "features+iconic_lm"), ([0, 1], "iconic_lm")]
    T_true = np.linalg.inv(world.view_pose(0)) @ world.view_pose(1)  # sensor 1 in sensor 0's frame
    for r, m in zip(regs, run.metrics["registration"]):
        with open(os.path.join(run.out, "matching", f"pair_0_1_{r['method'].replace('+', '_')}.json")) as f:
            record = json.load(f)
        assert r["translation_error_m"] == m["translation_error_m"] == record["translation_error_m"]
        assert r["accepted"] == m["accepted"]
        for key in ("T_true", "T_initial", "T_estimated"):
            assert r[key].shape == (4, 4) and r[key].dtype == np.float64
            np.testing.assert_array_equal(r[key], np.array(record[key]))
        np.testing.assert_allclose(r["T_true"], T_true, atol=1e-12)
        # The error is the estimate's offset in the true sensor frame (perception::poseError).
        D = np.linalg.inv(r["T_true"]) @ r["T_estimated"]
        assert abs(np.linalg.norm(D[:3, 3]) - r["translation_error_m"]) < 1e-9
        assert r["covariance_pose"].shape == (6, 6)


def test_bad_input_raises_the_projects_lines(demo):
    s, _, world, scans, _ = demo
    with pytest.raises(ValueError, match=r"^World.scan: sensor_pose: expected a 4 x 4 array \(a pose\)$"):
        world.scan(np.eye(3))
    bent = np.eye(4)
    bent[0, 1] = 0.5
    with pytest.raises(ValueError, match=r"^map_scan: sensor_pose: not a rigid transform"):
        ambler.map_scan(scans[0], bent, s)
    with pytest.raises(ValueError, match=r"^World.view_pose: no view 2 \(the scenario has 2\)$"):
        world.view_pose(2)
    under = ambler.load_scenario(DEMO, views=[{"xyz_m": [0, -6, -10], "rpy_deg": [0, -30, 0]},
                                              {"xyz_m": [0, -5, 3], "rpy_deg": [0, -30, 5]}])
    with pytest.raises(ambler.ScenarioError, match=r"views\[0\].xyz_m: expected the sensor above the terrain"):
        ambler.world(under)
