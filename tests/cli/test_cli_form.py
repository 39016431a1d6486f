"""``pcmm form`` and ``pcmm fit --criterion`` in a subprocess, on data with known minimum zones."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
from pcmm_runner import run_pcmm

from pcmm_geo.fit.zone.reference import make_minimax_reference


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def _write(path: Path, points: np.ndarray) -> Path:
    if points.shape[1] == 2:
        points = np.c_[points, np.zeros(len(points))]
    np.savetxt(path, points, delimiter=",", header="x,y,z", comments="", fmt="%.15g")
    return path


def test_form_roundness_pass_and_fail_with_plot(tmp_path: Path) -> None:
    data = make_minimax_reference("circle", "chebyshev", n_points=60, size=12.5, form=0.008, offset=100.0, rng=4)
    file = _write(tmp_path / "ring.csv", data.points)
    plot = tmp_path / "zone.png"
    done = _run(
        "form", str(file), "--element", "circle", "--two-d", "--tolerance-mm", "0.010", "--json", "--plot", str(plot)
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["characteristic"] == "roundness" and result["verdict"] == "PASS" and result["certified"]
    assert abs(result["deviation_mm"] - 0.008) < 1e-9
    assert set(data.contacts.tolist()) <= set(result["contacts"])
    import matplotlib.image

    image = matplotlib.image.imread(plot)
    assert image.shape[0] > 100 and float(np.std(image[..., :3])) > 0.01
    failed = _run("form", str(file), "--element", "circle", "--two-d", "--tolerance-mm", "0.005")
    assert failed.returncode == 1
    assert "roundness: FAIL" in failed.stdout and "scope" in failed.stdout


def test_form_flatness_json(tmp_path: Path) -> None:
    data = make_minimax_reference("plane", "chebyshev", n_points=200, size=50.0, form=0.02, offset=300.0, rng=2)
    done = _run("form", str(_write(tmp_path / "plane.csv", data.points)), "--element", "plane", "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["characteristic"] == "flatness" and result["verdict"] == "no tolerance"
    assert abs(result["deviation_mm"] - 0.02) < 1e-9


def test_fit_criterion_mcc(tmp_path: Path) -> None:
    data = make_minimax_reference("sphere", "mcc", n_points=300, size=10.0, form=0.01, offset=500.0, rng=1)
    done = _run("fit", "sphere", str(_write(tmp_path / "sphere.csv", data.points)), "--criterion", "mcc", "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["criterion"] == "mcc" and result["certificate"]["certified"] is True
    np.testing.assert_allclose(result["center"], data.parameters["center"], atol=1e-9)
    assert abs(result["radius"] - 10.0) < 1e-9


def test_form_bad_input_is_exit_2(tmp_path: Path) -> None:
    line = _write(tmp_path / "line.csv", np.c_[np.arange(10.0), 2 * np.arange(10.0)])
    done = _run("form", str(line), "--element", "circle", "--two-d")
    assert done.returncode == 2 and "collinear" in done.stderr
    done = _run("fit", "cone", str(line), "--criterion", "mcc")
    assert done.returncode == 2 and "criterion" in done.stderr


def test_form_verdicts_and_exit_codes_from_value_bound_and_tolerance(tmp_path: Path, monkeypatch, capsys) -> None:
    """PASS (exit 0) within tolerance; FAIL (exit 1) when the proven bound exceeds it; NOT PROVEN (exit 1) between."""
    import dataclasses

    import pcmm_geo.fit
    from pcmm_geo.cli import main

    data = make_minimax_reference("circle", "chebyshev", n_points=40, size=10.0, form=0.010, offset=50.0, rng=6)
    file = _write(tmp_path / "ring.csv", data.points)
    args = ["form", str(file), "--element", "circle", "--two-d", "--json", "--tolerance-mm"]
    assert main([*args, "0.0105"]) == 0
    passed = json.loads(capsys.readouterr().out)
    assert passed["verdict"] == "PASS" and passed["scope"] == "global" and passed["domain"] == "all circles"
    assert abs(passed["bound_mm"] - 0.010) <= 1e-9 and passed["gap_mm"] <= 1e-9
    assert main([*args, "0.0095"]) == 1
    assert json.loads(capsys.readouterr().out)["verdict"] == "FAIL"
    # a local answer whose proven bound (0.009 mm) is below the tolerance: neither verdict is proven
    real_fit = pcmm_geo.fit.fit_circle

    def local_fit(points, **kwargs):
        fit = real_fit(points, **kwargs)
        certificate = dataclasses.replace(fit.certificate, scope="local", bound_mm=0.009, gap_mm=0.001, domain="")
        return dataclasses.replace(fit, certificate=certificate)

    monkeypatch.setattr(pcmm_geo.fit, "fit_circle", local_fit)
    assert main([*args, "0.0095"]) == 1
    unproven = json.loads(capsys.readouterr().out)
    assert unproven["verdict"] == "NOT PROVEN" and unproven["passed"] is None and unproven["bound_mm"] == 0.009
    assert main([*args[:-2], "--tolerance-mm", "0.0095"]) == 1
    text = capsys.readouterr().out
    assert "roundness: NOT PROVEN" in text and "proven lower bound" in text and "9.000000" in text
    assert main([*args, "0.0085"]) == 1  # the bound exceeds the tolerance: FAIL even for a local answer
    assert json.loads(capsys.readouterr().out)["verdict"] == "FAIL"
