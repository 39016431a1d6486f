"""``pcmm fit|form --qif`` keep the feature of the file they refit (nominal, side, size tolerance) and name it.

Truth: what the public sample ``QIF_PTS_SAMPLE.QIF`` states for CIRCLE1 (nominal diameter 12 mm,
INTERNAL, DIA_CIRCLE1 12 +- 0.05 mm) and CYL_1 (nominal diameter 30 mm), and the command's own
JSON (the QIF holds the same numbers to 1e-12 relative).
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
from pcmm_runner import run_pcmm

from pcmm_geo.io.cmm import read_qif, validate_qif

SAMPLE = Path(__file__).parents[1] / "data" / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return run_pcmm(*args)


def test_fit_qif_keeps_circle1s_nominal_side_and_size_tolerance_under_a_new_name(tmp_path: Path) -> None:
    out = tmp_path / "hole.qif"
    done = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--qif", out, "--feature-name", "HOLE_A", "--json")
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert validate_qif(out) == ()
    back = read_qif(out)
    feature = back.feature("HOLE_A")
    assert back.item_of(feature).name == "HOLE_A"
    definition = back.definition_of(feature)
    assert (definition.internal_external, definition.diameter) == ("INTERNAL", 12.0)
    np.testing.assert_allclose(back.nominal_of(feature).geometry.location, [-33.05, -4.35, -1.309995069701],
                               rtol=1e-12)
    (size,) = back.characteristics_of(feature)
    assert (size.name, size.nominal, size.tolerance.max_value, size.tolerance.min_value) == (
        "DIA_CIRCLE1", 12.0, 0.05, -0.05)
    np.testing.assert_allclose(size.value, 2.0 * data["radius"], rtol=1e-12)
    text = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--qif", tmp_path / "default.qif").stdout
    assert ("QIF feature CIRCLE1: kept from the file: nominal (diameter 12 mm, InternalExternal INTERNAL); size "
            "characteristic DIA_CIRCLE1 (nominal 12 mm, limits 11.95 to 12.05 mm; status NOT_ANALYZED)") in text
    assert read_qif(tmp_path / "default.qif").measured_features[0].name == "CIRCLE1"  # the file's name by default


def test_form_qif_keeps_the_cylinders_nominal_and_a_two_d_fit_drops_the_placement(tmp_path: Path) -> None:
    out = tmp_path / "bore.qif"
    done = _run("form", SAMPLE, "--element", "cylinder", "--feature", "CYL_1", "--tolerance-mm", "0.5", "--qif", out,
                "--feature-name", "BORE")
    assert done.returncode == 0, done.stderr
    back = read_qif(out)
    bore = back.feature("BORE")
    assert validate_qif(out) == () and back.definition_of(bore).diameter == 30.0
    assert [c.type for c in back.characteristics_of(bore)] == ["diameter", "cylindricity"]
    flat = tmp_path / "flat.qif"
    done = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", "--two-d", "--qif", flat)
    assert done.returncode == 0, done.stderr
    assert "the file's nominal placement is not written with a 2-D fit" in done.stdout
    back = read_qif(flat)
    assert back.feature_items == {} and back.nominal_of(back.feature("CIRCLE1")) is None
    assert back.characteristics[0].nominal == 12.0  # the size tolerance still applies to the 2-D diameter


def test_feature_name_needs_qif_and_a_name() -> None:
    for extra, text in ((("--feature-name", "X"), "--feature-name: expected --qif OUT.qif as well"),
                        (("--feature-name", " ", "--qif", "never.qif"),
                         "--feature-name: expected a non-empty feature name"),
                        (("--feature-name", "A  B", "--qif", "never.qif"),
                         "--feature-name: expected a name that reads back the same"),
                        (("--feature-name", "A\x07", "--qif", "never.qif"),
                         "--feature-name: expected text XML 1.0 can hold")):
        done = _run("fit", "circle", SAMPLE, "--feature", "CIRCLE1", *extra)
        assert done.returncode == 2 and done.stdout == "" and done.stderr.count("\n") == 1, done.stderr
        assert text in done.stderr
    assert not Path("never.qif").exists()


def test_verify_qif_writes_every_refit_in_one_file_which_verifies_itself(tmp_path: Path) -> None:
    out = tmp_path / "refits.qif"
    done = _run("qif", "verify", SAMPLE, "--qif", out)
    assert done.returncode == 1, done.stderr  # the sample's own actuals disagree in 5 features
    assert f"QIF: 9 refitted feature(s) written to {out} (9 with the file's nominal); 5 not refitted, left out" \
        in done.stdout
    assert validate_qif(out) == ()
    back = read_qif(out)
    assert back.definition_of(back.feature("CYL_1")).diameter == 30.0
    again = _run("qif", "verify", out, "--json")
    assert again.returncode == 0, again.stdout + again.stderr
    assert json.loads(again.stdout)["summary"] == {"agree": 9, "disagree": 0, "not_checked": 0}
    refused = _run("qif", "verify", SAMPLE, "--qif", out)  # never overwritten without --overwrite
    assert refused.returncode == 2 and refused.stdout == "" and "--overwrite" in refused.stderr, refused.stderr
