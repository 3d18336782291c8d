"""A user's own registration method (docs/python.md, "Your own method"): scored exactly as a built-in
method in the basin (same draws, same columns, sharded and resumed alike) and in a run's match
stage, and refused with one clear line when it is wrong."""
import csv
import json
import math
import os

import numpy as np
import pytest

import ambler

SOURCE = os.environ["AMBLER_SOURCE_DIR"]
DEMO = os.path.join(SOURCE, "scenarios", "demo.yaml")
GRID = dict(translation_m="0,1.5", rotation_deg="0,20", trials=3)


def rows_of(path):
    with open(path) as f:
        return list(csv.reader(f))


def by_method(rows):
    out = {}
    for r in rows[1:]:
        out.setdefault(r[0], []).append(r[1:])
    return out


def builtin_lm(map_i, scan_j, T_initial):
    return ambler.register(map_i, scan_j, T_initial, "iconic_lm")


@pytest.fixture(scope="module")
def demo():
    return ambler.load_scenario(DEMO)


@pytest.fixture(scope="module")
def lm_basin(demo, tmp_path_factory):
    out = tmp_path_factory.mktemp("basin")
    return ambler.basin(demo, str(out), methods=["iconic_lm"], custom={"mine": builtin_lm}, jobs=2, **GRID)


def test_a_function_that_calls_iconic_lm_gives_the_builtin_rows(lm_basin):
    rows = rows_of(lm_basin)
    assert rows[0][:4] == ["method", "translation_m", "rotation_deg", "trial"]
    m = by_method(rows)
    assert sorted(m) == ["iconic_lm", "mine"]
    assert len(m["mine"]) == 2 * 2 * 3
    assert m["mine"] == m["iconic_lm"]  # every cell but the name: errors, success, iterations, verdict
    # The heatmap of the user's method is drawn beside the built-in's.
    assert os.path.getsize(os.path.join(os.path.dirname(lm_basin), "basin_mine.png")) > 0


def test_the_believed_pose_comes_in_and_the_estimate_goes_out_as_scored(demo, tmp_path):
    # A method that does nothing returns the believed pose: its error is the draw's initial error,
    # |E|'s translation (horizontal, the cell's magnitude) and rotation (the cell's angle).
    seen = []

    def stay(map_i, scan_j, T_initial):
        seen.append(np.array(T_initial))
        return T_initial

    path = ambler.basin(demo, str(tmp_path), methods=["iconic_lm"], custom={"stay": stay}, **GRID)
    rows = by_method(rows_of(path))["stay"]
    assert len(seen) == len(rows) == 12
    for t, r, _trial, e_t, e_r, *_ in rows:
        assert math.isclose(float(e_t), float(t), abs_tol=1e-9)
        assert math.isclose(float(e_r), float(r), abs_tol=1e-9)
    for T in seen:
        assert T.shape == (4, 4)
        np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)


def test_shards_merge_and_resume_into_the_same_bytes(demo, lm_basin, tmp_path):
    custom = {"mine": builtin_lm}
    for k in (1, 2):
        ambler.basin(demo, str(tmp_path), methods=["iconic_lm"], custom=custom, shard=f"{k}/2", **GRID)
    merged = ambler.basin(demo, str(tmp_path), methods=["iconic_lm"], custom=custom, merge=True, **GRID)
    with open(merged, "rb") as a, open(lm_basin, "rb") as b:
        assert a.read() == b.read()
    # Resuming a finished basin registers nothing again: the function is not called.
    calls = []

    def counted(map_i, scan_j, T_initial):
        calls.append(1)
        return builtin_lm(map_i, scan_j, T_initial)

    again = ambler.basin(demo, os.path.dirname(lm_basin), methods=["iconic_lm"], custom={"mine": counted},
                         resume=True, **GRID)
    assert calls == []
    with open(again, "rb") as a, open(lm_basin, "rb") as b:
        assert a.read() == b.read()


def test_what_the_method_sees(demo, tmp_path):
    seen = {}

    def look(map_i, scan_j, T_initial):
        seen["map"] = map_i.map.elevation
        seen["pose"] = map_i.sensor_pose
        seen["points"] = scan_j.points
        seen["range"] = scan_j.range
        return T_initial

    ambler.basin(demo, str(tmp_path), methods=["iconic_lm"], custom={"look": look}, translation_m="0",
                 rotation_deg="0", trials=1)
    # Scan J's returns in its own frame: their ranges are the image's valid ranges.
    r = seen["range"]
    valid = r[np.isfinite(r)]
    assert seen["points"].shape == (valid.size, 3)
    np.testing.assert_allclose(np.linalg.norm(seen["points"], axis=1), valid, rtol=1e-6)
    # Kept after the basin: the method owns what it was given.
    assert np.isfinite(seen["map"]).any()
    assert not seen["range"].flags.writeable
    assert not hasattr(ambler.Scan, "sensor_pose") and hasattr(ambler.View, "sensor_pose")


def test_a_run_scores_the_users_method_beside_the_builtin(demo, tmp_path):
    cov = np.diag([1e-6, 1e-6, 1e-6, 1e-5, 1e-5, 1e-5])

    def with_covariance(map_i, scan_j, T_initial):
        r = ambler.register(map_i, scan_j, T_initial, "iconic_lm")
        return {"T": r.T, "covariance": cov, "iterations": r.iterations}

    s = ambler.load_scenario(DEMO, **{"matching.methods": ["iconic_lm"]})
    run = ambler.run(s, out=str(tmp_path), custom={"mine": builtin_lm, "cov": with_covariance})
    reg = {r["method"]: r for r in run.metrics["registration"]}
    assert sorted(reg) == ["cov", "iconic_lm", "mine"]
    for key in ("translation_error_m", "rotation_error_deg", "success", "accepted", "iterations"):
        assert reg["mine"][key] == reg["iconic_lm"][key]
        if key != "accepted":  # "cov" is judged by the rover's own tests, not by LM's
            assert reg["cov"][key] == reg["iconic_lm"][key]
    pair = os.path.join(run.out, "matching", "pair_0_1_cov.json")
    with open(pair) as f:
        record = json.load(f)
    np.testing.assert_array_equal(np.array(record["covariance_pose"]), cov)
    assert record["covariance_calibrated"] is False
    # The composite is placed by the built-in methods alone: the same as a run without the user's.
    plain = ambler.run(s)
    assert run.metrics["composite"] == plain.metrics["composite"]


@pytest.mark.parametrize("custom,message", [
    ({"iconic_lm": builtin_lm}, "built-in method's name"),
    ({"a b": builtin_lm}, "letters, digits"),
    ({"mine": 3}, "expected a function"),
])
def test_bad_methods_are_refused_before_anything_runs(demo, tmp_path, custom, message):
    with pytest.raises(ValueError, match=message):
        ambler.basin(demo, str(tmp_path / "b"), custom=custom, translation_m="0", rotation_deg="0", trials=1)
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("fn,message", [
    (lambda m, s, T: np.eye(3), "4 x 4"),
    (lambda m, s, T: (T, np.eye(5)), "6 x 6"),
    (lambda m, s, T: 1 / 0, "custom method bad: ZeroDivisionError"),
])
def test_a_method_that_fails_stops_the_basin_with_its_line(demo, tmp_path, fn, message):
    with pytest.raises(ValueError, match=message):
        ambler.basin(demo, str(tmp_path), methods=["iconic_lm"], custom={"bad": fn}, translation_m="0",
                     rotation_deg="0", trials=1)


def test_unknown_builtin_method_names_the_choices(demo, tmp_path):
    with pytest.raises(ValueError, match="unknown method \"lm\" .*iconic_lm"):
        ambler.basin(demo, str(tmp_path), methods=["lm"])


def test_the_matching_experiment_reports_the_users_method(tmp_path):
    md = ambler.experiment_matching(str(tmp_path), sweeps=os.path.join(SOURCE, "scenarios", "experiments"),
                                    custom={"mine": builtin_lm}, quick=True)
    rows = {line.split("|")[1].strip(): line.split("|")[2:] for line in md.splitlines()
            if line.startswith("| iconic_lm |") or line.startswith("| mine |")}
    assert sorted(rows) == ["iconic_lm", "mine"]
    assert rows["mine"] == rows["iconic_lm"]  # success, errors, iterations: every figure but the name
    assert (tmp_path / "table.md").read_text() == md


def test_register_stage_by_stage_gives_the_runs_registration(tmp_path):
    # world -> scan -> map_scan -> register reproduces the match stage's estimate bit for bit.
    s = ambler.load_scenario(DEMO, **{"matching.methods": ["iconic_lm"]})
    run = ambler.run(s, out=str(tmp_path))
    w = ambler.world(s)
    views = [ambler.map_scan(w.scan(w.view_pose(k), seed=w.view_seed(k)), w.view_pose(k), s) for k in (0, 1)]
    reg_run = run.registrations[0]
    reg = ambler.register(views[0], views[1].scan, reg_run["T_initial"], "iconic_lm")
    np.testing.assert_array_equal(reg.T, reg_run["T_estimated"])
    assert reg.iterations == reg_run["iterations"] and reg.accepted == reg_run["accepted"]
    # A raw scan (not unwrapped, no edges) is refused with what to do.
    with pytest.raises(ValueError, match="raw scan"):
        ambler.register(views[0], w.scan(w.view_pose(1)), reg_run["T_initial"])
