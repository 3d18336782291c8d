"""The module against the CLI: `ambler.run` of the demo gives metrics.json's metrics (but the times),
maps that equal the GeoTIFFs and view the run's memory, and the project's errors as exceptions."""
import json
import os
import subprocess
import tempfile

import numpy as np
import pytest

import ambler

SOURCE = os.environ["AMBLER_SOURCE_DIR"]
DEMO = os.path.join(SOURCE, "scenarios", "demo.yaml")


def without_times(metrics):
    """metrics.json without its measured times (timing_s and each registration's time_s)."""
    if isinstance(metrics, dict):
        return {k: without_times(v) for k, v in metrics.items() if k not in ("timing_s", "time_s")}
    if isinstance(metrics, list):
        return [without_times(v) for v in metrics]
    return metrics


@pytest.fixture(scope="module")
def demo_runs():
    with tempfile.TemporaryDirectory() as tmp:
        cli = os.path.join(tmp, "cli")
        subprocess.run([os.environ["AMBLER_BINARY"], "run", DEMO, "--out", cli, "-q"], check=True)
        run = ambler.run(ambler.load_scenario(DEMO), out=os.path.join(tmp, "py"))
        with open(os.path.join(cli, "metrics.json")) as f:
            yield run, json.load(f), cli


def test_metrics_equal_the_clis(demo_runs):
    run, cli_metrics, _ = demo_runs
    assert without_times(run.metrics) == without_times(cli_metrics)
    # The run's own metrics.json is what run.metrics holds, times too.
    with open(os.path.join(run.out, "metrics.json")) as f:
        assert json.load(f) == run.metrics


def read_tiff(path, shape):
    """A float32 GeoTIFF through GDAL's command line (gdal-bin), as raw float32 (ENVI): exact."""
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "band.raw")
        subprocess.run(["gdal_translate", "-q", "-of", "ENVI", "-ot", "Float32", path, raw], check=True)
        return np.fromfile(raw, dtype=np.float32).reshape(shape)


def test_maps_equal_the_geotiffs_and_view_the_runs_memory(demo_runs):
    run, _, _ = demo_runs
    assert list(run.maps) == ["view_0", "view_1", "composite"]
    for name, m in run.maps.items():
        for field, stem in (("elevation", "elevation"), ("sigma", "sigma"), ("ceiling", "shadow_ceiling")):
            a = getattr(m, field)
            assert a.dtype == np.float32 and not a.flags.writeable
            # A view, not a copy: two reads share the run's memory.
            assert np.shares_memory(a, getattr(m, field))
            tif = read_tiff(os.path.join(run.out, "maps", f"{name}_{stem}.tiff"), a.shape)
            np.testing.assert_array_equal(a, tif)
        assert m.state.dtype == np.uint8 and m.state.shape == m.elevation.shape
        assert m.transform.shape == (4, 4)
    scans = run.scans
    assert len(scans) == 2 and scans[0].shape == (64, 256)
    assert np.shares_memory(scans[0], run.scans[0])


def test_overrides_and_errors():
    s = ambler.load_scenario(DEMO, seed=3, **{"map.cell_m": 0.2})
    assert s.seed == 3 and s.name == "demo"
    with pytest.raises(ValueError, match="matching.nonsense"):
        ambler.load_scenario(DEMO, **{"matching.nonsense": 1})
    with pytest.raises(ValueError, match="missing.yaml"):
        ambler.load_scenario(os.path.join(SOURCE, "missing.yaml"))
