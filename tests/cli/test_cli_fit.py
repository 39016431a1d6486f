"""``pcmm fit`` in a subprocess, against NIST reference values."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pcmm_runner import run_pcmm

NIST = Path(__file__).parents[1] / "data" / "nist"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def _reference(path: Path) -> np.ndarray:
    return np.array([float(v) for v in path.with_suffix(".fit").read_text().split()])


def test_fit_sphere_json_matches_nist() -> None:
    done = _run("fit", "sphere", str(NIST / "Sphere" / "sph20.ds"), "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    reference = _reference(NIST / "Sphere" / "sph20.ds")
    np.testing.assert_allclose(data["center"], reference[:3], atol=1e-9)
    assert abs(2 * data["radius"] - reference[3]) < 1e-9
    assert data["converged"] is True and "residuals" not in data


def test_fit_circle_projected_matches_nist_and_human_table(tmp_path: Path) -> None:
    data_file = NIST / "Circle3d" / "cir7.ds"
    done = _run("fit", "circle", str(data_file), "--method", "projected", "--json", "--residuals")
    data = json.loads(done.stdout)
    reference = _reference(data_file)
    np.testing.assert_allclose(data["center"], reference[:3], atol=1e-9)
    assert abs(2 * data["radius"] - reference[6]) < 1e-9
    assert len(data["residuals"]) == data["n"] == 5
    plot = tmp_path / "residuals.png"
    human = _run("fit", "circle", str(data_file), "--method", "projected", "--plot", str(plot))
    assert human.returncode == 0 and "radius" in human.stdout and "form / mm" in human.stdout
    import matplotlib.image

    image = matplotlib.image.imread(plot)
    assert image.shape[0] > 100 and float(np.std(image[..., :3])) > 0.01


def test_fit_errors_are_one_line_with_exit_code_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2,3\n4,five,6\n")
    done = _run("fit", "plane", str(bad))
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "bad.csv:2: expected numbers" in done.stderr
    collinear = tmp_path / "line.csv"
    collinear.write_text("0,0,0\n1,1,1\n2,2,2\n3,3,3\n")
    done = _run("fit", "sphere", str(collinear))
    assert done.returncode == 2 and "degenerate" in done.stderr
    done = _run("fit", "cone", str(collinear), "--radius-mm", "2")
    assert done.returncode == 2 and "--radius-mm" in done.stderr


def test_help_is_fast_and_lists_commands() -> None:
    code = "import time, sys; t = time.perf_counter(); import pcmm_geo.cli; sys.exit(0)"
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", code], capture_output=True, text=True)
    assert done.returncode == 0
    heavy = [m for m in ("open3d", "trimesh", "matplotlib", "serial", "scipy") if f" {m}\n" in done.stderr]
    assert heavy == []  # nothing heavy is imported to build the command line
    listing = _run("--help")
    assert listing.returncode == 0
    for command in ("fit", "demo", "calibrate", "acquire", "gauge-block", "thermal"):
        assert command in listing.stdout


def test_sparse_torus_warns_in_one_line_and_axis_hint_silences_it(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    around, tube = rng.uniform(0, 2 * np.pi, 9), rng.uniform(0, 2 * np.pi, 9)
    points = np.c_[(20 + 4 * np.cos(tube)) * np.cos(around), (20 + 4 * np.cos(tube)) * np.sin(around), 4 * np.sin(tube)]
    data_file = tmp_path / "torus9.csv"
    np.savetxt(data_file, points + np.array([0.0, 0.0, 500.0]), delimiter=",", header="x,y,z", comments="")
    unhinted = _run("fit", "torus", str(data_file), "--json")
    assert unhinted.returncode == 0, unhinted.stderr
    warning_lines = unhinted.stderr.strip().splitlines()
    assert len(warning_lines) == 1
    assert warning_lines[0].startswith("pcmm fit: warning: UnassuredMinimumWarning: torus: 9 points")
    hinted = _run("fit", "torus", str(data_file), "--axis-hint", "0", "0", "1", "--json")
    assert hinted.returncode == 0 and hinted.stderr == ""
    data = json.loads(hinted.stdout)
    assert abs(data["major_radius"] - 20.0) < 1e-9 and abs(data["minor_radius"] - 4.0) < 1e-9
    np.testing.assert_allclose(data["center"], [0.0, 0.0, 500.0], atol=1e-9)
    refused = _run("fit", "plane", str(data_file), "--axis-hint", "0", "0", "1")
    assert refused.returncode == 2 and "--axis-hint" in refused.stderr


def test_minimum_zone_fit_prints_its_scope(tmp_path: Path) -> None:
    """A Chebyshev circle (exact method) states its scope: global over the circles of its plane."""
    angles = np.linspace(0.0, 2.0 * np.pi, 40, endpoint=False)
    radii = 7.0 + 0.004 * np.cos(5.0 * angles)
    circle = tmp_path / "circle.csv"
    np.savetxt(circle, np.c_[radii * np.cos(angles), radii * np.sin(angles), np.zeros(40)], delimiter=",",
               header="x,y,z", comments="")
    done = _run("fit", "circle", str(circle), "--criterion", "chebyshev")
    assert done.returncode == 0, done.stderr
    scope_line = next(line for line in done.stdout.splitlines() if line.startswith("scope "))
    assert scope_line.startswith("scope global;"), scope_line
    # the zone of a 5-lobed profile is 2 x 0.004 mm wide (the lobes' peaks and valleys alternate)
    assert "0.008" in done.stdout


def test_fit_prints_the_diameter_with_its_type_a_standard_uncertainty(tmp_path: Path) -> None:
    """12 points on a circle of radius 10 mm, radial residuals alternating ±1 µm, all in one plane.

    The least-squares circle keeps centre and radius (the alternation is orthogonal to the centre's
    cos/sin directions); s² = n δ² / (2n − 6) over 2 residual components per point and 6 parameters,
    and the radius' column of the Jacobian is all ones radially, so u(r) = s / √n = δ / √(2n − 6) and
    u(d) = 2 u(r) = 2 δ / √18.
    """
    n, radius, delta = 12, 10.0, 0.001
    angles = 2 * np.pi * np.arange(n) / n
    r = radius + delta * np.where(np.arange(n) % 2, 1.0, -1.0)
    path = tmp_path / "ring.csv"
    np.savetxt(path, np.c_[5 + r * np.cos(angles), -3 + r * np.sin(angles), np.full(n, 2.0)], delimiter=",",
               header="x,y,z", comments="", fmt="%.12f")
    done = run_pcmm("fit", "circle", str(path), "--json")
    data = json.loads(done.stdout)
    expected = 2 * delta / np.sqrt(2 * n - 6)
    assert data["diameter_mm"] == pytest.approx(2 * radius, abs=1e-9)
    assert data["u_diameter_mm"] == pytest.approx(expected, rel=1e-3)
    text = run_pcmm("fit", "circle", str(path)).stdout
    assert f"diameter d = 20.000000 mm, standard uncertainty u(d) = {1000 * expected:.3f} µm" in text
    assert "type A" in text and "k = 1" in text
    row = next(line for line in text.splitlines() if line.startswith("diameter "))
    assert row.split()[1:] == ["20.000000", f"{expected:.6f}", "mm"]
    # a minimum-zone fit has no type A uncertainty: said so, no number invented
    zone = run_pcmm("fit", "circle", str(path), "--criterion", "chebyshev").stdout
    assert "diameter d = 20.000000 mm (no standard uncertainty from this fit)" in zone
