"""Units convention for the tetrahedron angles: ``beta`` radians inside, ``beta_deg`` degrees at the edges."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from pcmm_geo.machine.calibration import calibrate_tetrahedron, load_calibration, save_calibration
from pcmm_geo.machine.calibration.seed import appendix_cd_files

TABLE_7_1_BETA_DEG = {"ab": 68.25, "bc": 69.03, "ca": 68.70}  # printed to 0.01 degree


@pytest.fixture(scope="module")
def cal():  # type: ignore[no-untyped-def]
    return calibrate_tetrahedron(*appendix_cd_files())


def test_beta_is_radians_and_beta_deg_degrees(cal) -> None:  # type: ignore[no-untyped-def]
    for pair, printed in TABLE_7_1_BETA_DEG.items():
        assert cal.beta[pair] == pytest.approx(math.radians(printed), abs=math.radians(0.006))
        assert cal.beta_deg[pair] == pytest.approx(printed, abs=0.006)
        assert math.degrees(cal.beta[pair]) == pytest.approx(cal.beta_deg[pair], rel=1e-14)
        assert all(1.0 < value < 1.3 for value in cal.beta_per_position[pair])  # ~68 deg in rad


def test_file_stores_degrees_and_reads_back_radians(cal, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = save_calibration(cal, tmp_path / "cal.json")
    document = json.loads(path.read_text(encoding="utf-8"))
    for pair, printed in TABLE_7_1_BETA_DEG.items():
        assert document["results"]["beta_deg"][pair] == pytest.approx(printed, abs=0.006)  # unchanged format
    assert "beta" not in document["results"]
    back = load_calibration(path)
    assert back.beta == pytest.approx(cal.beta, abs=1e-15)


def test_a_file_whose_beta_deg_was_edited_is_still_caught(cal, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from pcmm_geo import FileFormatError

    path = save_calibration(cal, tmp_path / "cal.json")
    document = json.loads(path.read_text(encoding="utf-8"))
    document["results"]["beta_deg"]["ab"] = cal.beta["ab"]  # radians written where degrees belong
    path.write_text(json.dumps(document), encoding="utf-8")
    with pytest.raises(FileFormatError, match=r"results\.beta_deg\.ab"):
        load_calibration(path)


def test_deprecated_beta_rad_is_beta(cal) -> None:  # type: ignore[no-untyped-def]
    with pytest.warns(DeprecationWarning, match="beta_rad is deprecated"):
        assert cal.beta_rad == dict(cal.beta)


def test_cli_prints_degrees_labelled_deg(capsys: pytest.CaptureFixture[str]) -> None:
    from pcmm_geo.cli import main
    probings, lasers = appendix_cd_files()
    assert main(["calibrate", str(probings), str(lasers)]) == 0
    text = capsys.readouterr().out
    assert re.search(r"beta \(deg\)|beta / deg|beta / °", text)  # the unit is named where degrees are printed
    row = next(line for line in text.splitlines() if line.startswith("a ") and " ab " in line)
    assert float(row.split()[3]) == pytest.approx(68.246, abs=0.001)
