"""The documentation: the user guide's examples run and print what the guide shows; the Sphinx
build (API reference from the numpydoc docstrings + guide) passes with warnings as errors and
nitpicky references, and a broken reference does fail it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLES = sorted((DOCS / "guide" / "examples").glob("*.py"))
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?|nan")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def _same_text_and_numbers(got: str, expected: str, rel: float = 1e-6, abs_: float = 2e-6) -> list[str]:
    """Lines differing in text, or in a number by more than the tolerance (floats differ across BLAS)."""
    problems = []
    got_lines, expected_lines = got.strip().splitlines(), expected.strip().splitlines()
    if len(got_lines) != len(expected_lines):
        return [f"{len(got_lines)} lines printed, the guide shows {len(expected_lines)}"]
    for line, shown in zip(got_lines, expected_lines, strict=True):
        if NUMBER.sub("#", line) != NUMBER.sub("#", shown):
            problems.append(f"{line!r} != {shown!r}")
            continue
        for a, b in zip(NUMBER.findall(line), NUMBER.findall(shown), strict=True):
            if a == b == "nan":
                continue
            if a == "nan" or b == "nan" or abs(float(a) - float(b)) > abs_ + rel * abs(float(b)):
                problems.append(f"{line!r} != {shown!r}")
    return problems


def test_the_guide_has_three_worked_examples() -> None:
    assert [p.stem for p in EXAMPLES] == ["calibrate_from_cmm_files", "gauge_block_to_20C", "verify_fitting_software"]
    for script in EXAMPLES:
        page = (DOCS / "guide" / f"{script.stem}.rst").read_text(encoding="utf-8")
        assert f"examples/{script.name}" in page and f"examples/{script.stem}.out" in page


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_guide_example_prints_what_the_guide_shows(script: Path, tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=_env(), cwd=tmp_path,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    shown = script.with_suffix(".out").read_text(encoding="utf-8")
    assert _same_text_and_numbers(done.stdout, shown) == []


def test_text_comparison_catches_changed_numbers_and_words() -> None:
    assert _same_text_and_numbers("d = 314.476 mm", "d = 314.476 mm") == []
    assert _same_text_and_numbers("d = 314.4760000001 mm", "d = 314.476 mm") == []
    assert _same_text_and_numbers("d = 314.477 mm", "d = 314.476 mm") != []
    assert _same_text_and_numbers("d = 314.476 um", "d = 314.476 mm") != []
    assert _same_text_and_numbers("a\nb", "a") != []


def _sphinx(source: Path, out: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n", "-q", "-d", str(out / ".doctrees"),
         str(source), str(out / "html")],
        capture_output=True, text=True, env=_env(), timeout=900,
    )


def test_docs_build_with_warnings_as_errors_and_nitpicky_references(tmp_path: Path) -> None:
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("_build", "generated"))
    done = _sphinx(source, tmp_path / "build")
    assert done.returncode == 0, done.stderr[-6000:]
    html = tmp_path / "build" / "html"
    calibration = (html / "api" / "generated" / "pcmm_geo.machine.calibration.result.html").read_text(encoding="utf-8")
    assert "beta_deg" in calibration and "TetrahedronCalibration" in calibration
    guide = (html / "guide" / "calibrate_from_cmm_files.html").read_text(encoding="utf-8")
    assert "calibrate_tetrahedron" in guide and "314.476" in guide


def test_a_broken_reference_fails_the_build(tmp_path: Path) -> None:
    source = tmp_path / "docs"
    source.mkdir()
    shutil.copy(DOCS / "conf.py", source / "conf.py")
    page = "Broken\n======\n\nSee :func:`pcmm_geo.fit.no_such_function`.\n"
    (source / "index.rst").write_text(page, encoding="utf-8")
    done = _sphinx(source, tmp_path / "build")
    assert done.returncode != 0
    assert "py:func reference target not found: pcmm_geo.fit.no_such_function" in done.stderr
