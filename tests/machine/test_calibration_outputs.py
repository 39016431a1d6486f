"""Every writer of the calibration and log modules refuses to overwrite unless asked."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from pcmm_geo.errors import OutputExistsError, PcmmGeoError
from pcmm_geo.machine import calibration
from pcmm_geo.machine.analysis.logproc import MeasurementLog, write_log
from pcmm_geo.machine.calibration import calfile
from pcmm_geo.machine.calibration.probings import write_element_export, write_lasers_csv, write_probings_csv
from pcmm_geo.machine.calibration.seed import appendix_cd_files, build_appendix_cd

LASERS = np.array([[50.0, 130.0, 135.0], [12.0, 3.0, 2.0]])


@pytest.fixture(scope="module")
def seed_cal():
    return calibration.calibrate_tetrahedron(*appendix_cd_files())


def _writers(seed_cal) -> dict[str, Callable[..., object]]:
    points = {("tip", None): np.eye(4, 3), ("joint_a", 1): np.eye(4, 3) + 1.0}
    log = MeasurementLog([1, 0], [0, 1], [2, 2], [1, 1], LASERS)
    return {
        "write_probings_csv": lambda path, **kw: write_probings_csv(path, points, **kw),
        "write_element_export": lambda path, **kw: write_element_export(path, np.zeros((1, 3, 3)), np.ones(3), **kw),
        "write_lasers_csv": lambda path, **kw: write_lasers_csv(path, (1, 2), LASERS, **kw),
        "calibration.save_calibration": lambda path, **kw: calibration.save_calibration(seed_cal, path, **kw),
        "calfile.save_calibration": lambda path, **kw: calfile.save_calibration(seed_cal, path, **kw),
        "write_log": lambda path, **kw: write_log(path, log, **kw),
        "build_appendix_cd": lambda path, **kw: build_appendix_cd(path.parent, **kw),
    }


@pytest.mark.parametrize(
    "name",
    ["write_probings_csv", "write_element_export", "write_lasers_csv", "calibration.save_calibration",
     "calfile.save_calibration", "write_log", "build_appendix_cd"],
)
def test_writer_refuses_to_overwrite_unless_asked(tmp_path: Path, seed_cal, name: str) -> None:
    write = _writers(seed_cal)[name]
    target = tmp_path / ("cmm_export.csv" if name == "build_appendix_cd" else "out.file")
    recorded = "recorded earlier: must survive\n"
    target.write_text(recorded)
    with pytest.raises(OutputExistsError) as caught:
        write(target)
    assert isinstance(caught.value, FileExistsError) and isinstance(caught.value, PcmmGeoError)
    assert caught.value.path == str(target) and "overwrite=True" in str(caught.value)
    assert target.read_text() == recorded  # untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cmm_export.csv" if name == "build_appendix_cd"
                                                          else "out.file"]  # no temporary left behind
    write(target, overwrite=True)
    assert target.read_text() != recorded


def test_calibration_json_written_then_refused_keeps_the_first_calibration(tmp_path: Path, seed_cal) -> None:
    path = calibration.save_calibration(seed_cal, tmp_path / "cal.json")
    first = path.read_bytes()
    other = calibration.calibrate_tetrahedron(*appendix_cd_files(), laser_scale=1.0)  # a different calibration
    with pytest.raises(OutputExistsError):
        calibration.save_calibration(other, path)
    assert path.read_bytes() == first
    assert calibration.load_calibration(path).slider_lines["a"].laser_scale == seed_cal.slider_lines["a"].laser_scale
    calibration.save_calibration(other, path, overwrite=True)
    assert calibration.load_calibration(path).slider_lines["a"].laser_scale == 1.0
