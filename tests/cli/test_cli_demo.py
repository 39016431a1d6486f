"""``pcmm demo`` end to end against the simulated truth: the installed console script in a subprocess once, then
in process (:mod:`pcmm_runner`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

PCMM = str(Path(sys.executable).with_name("pcmm"))


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("demo")
    done = subprocess.run(
        [PCMM, "demo", "--json", "--out", str(out)], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout), out


def test_demo_recovers_the_simulated_machine(demo_run: tuple[dict, Path]) -> None:
    data, _ = demo_run
    settings = data["settings"]
    # laser scales of the simulated machine are recovered to a few ppm (probing noise 0.5 um)
    recovered = [data["calibration"]["laser_scale"][arm] for arm in "abc"]
    np.testing.assert_allclose(recovered, settings["laser_scales"], atol=2e-5)
    # slider lines that miss the tip by ~3 mm are located to a few micrometres
    assert max(data["true_slider_miss_mm"].values()) > 2.0
    assert max(data["calibration"]["slider_line_error_mm"].values()) < 0.005


def test_demo_gauge_block_length_error(demo_run: tuple[dict, Path]) -> None:
    data, _ = demo_run
    assert data["gauge_length_mm"] == 100.0
    # calibrated rigid-body model: error at the level of the simulated reading noise
    assert abs(data["length_error_calibrated_mm"]) < 0.005
    assert data["tip_error_rms_calibrated_mm"] < 0.005
    # the nominal design (lines meeting at the tip) is off by the simulated manufacturing errors
    assert abs(data["length_error_nominal_mm"]) > 0.05
    assert data["tip_error_rms_nominal_mm"] > 1.0


def test_demo_plots_are_real_images_and_runs_never_overwrite(demo_run: tuple[dict, Path]) -> None:
    import matplotlib.image

    data, out = demo_run
    assert len(data["plots"]) == 2
    for path in data["plots"]:
        image = matplotlib.image.imread(path)
        assert image.shape[0] > 200 and image.shape[1] > 200
        assert float(np.std(image[..., :3])) > 0.02  # not blank
    again = run_pcmm("demo", "--json", "--out", out)
    assert again.returncode == 0, again.stderr
    second = json.loads(again.stdout)["plots"]
    assert set(second).isdisjoint(data["plots"])
    assert all(Path(p).exists() for p in data["plots"] + second)


def test_demo_human_output_is_a_table() -> None:
    done = run_pcmm("demo", "--no-plots")
    assert done.returncode == 0, done.stderr
    assert "gauge block" in done.stdout and "calibrated (rigid body)" in done.stdout
    assert "error / µm" in done.stdout
