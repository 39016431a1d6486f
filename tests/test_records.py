"""Result records (:mod:`pcmm_geo._records`): every dataclass of the package that holds arrays compares by
identity and has a repr whose length does not grow with the arrays.

The scan imports every module of the package and finds each dataclass with a field annotated as an array
(``FloatArray``, ``NDArray[...]``, ``np.ndarray``, ... also inside ``Optional`` / containers).  Each is built
without its ``__init__`` (fields set directly, arrays of N rows), so a class's own validation does not stop
the check; its repr is taken at N = 30 and N = 300 rows.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import pkgutil
import re
from typing import Any

import numpy as np
import pytest

import pcmm_geo
from pcmm_geo._records import is_record, record, record_repr

ARRAY = re.compile(r"\b(FloatArray|IntArray|BoolArray|IndexArray|NDArray|ndarray|ArrayLike)\b")
#: a repr of a record with arrays of 300 rows stays under this many characters
REPR_BOUND = 1500
#: classes keeping value equality by design, with the reason
VALUE_EQUALITY = {
    "pcmm_geo.machine.kinematics.limits.MachineLimits": "a machine's stated limits, compared by value "
                                                        "(MachineLimits.from_dict(d) == limits round-trips files)",
}


def _array_fields(cls: type) -> list[dataclasses.Field[Any]]:
    return [f for f in dataclasses.fields(cls) if ARRAY.search(str(f.type)) and "Callable" not in str(f.type)]


def _array_dataclasses() -> dict[str, type]:
    found = {}
    for info in pkgutil.walk_packages(pcmm_geo.__path__, "pcmm_geo."):
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if isinstance(obj, type) and dataclasses.is_dataclass(obj) and obj.__module__ == info.name \
                    and _array_fields(obj):
                found[f"{info.name}.{obj.__qualname__}"] = obj
    return found


ARRAY_CLASSES = _array_dataclasses()


def _fake(annotation: str, rows: int) -> Any:
    """A value of the annotated type; arrays of ``rows`` x 3."""
    if ARRAY.search(annotation) and "Callable" not in annotation:
        dtype = bool if re.search(r"Bool|bool_", annotation) else int if re.search(r"Int|Index|intp|int64",
                                                                                   annotation) else float
        value = np.ones((rows, 3), dtype=dtype)
        return {"x": value} if annotation.startswith(("Mapping", "dict")) else \
            [value] if annotation.startswith("list") else value
    for prefix, value in (("float", 1.5), ("int", 2), ("bool", True), ("str", "text"), ("tuple[str", ("a", "b", "c"))):
        if annotation.startswith(prefix):
            return value
    return None


#: fit results: their repr reads the fit's summary (vectors of 2 or 3 values), so real fits of N points
_FITS = {"CircleFit": ("circle3d", "fit_circle"), "ConeFit": ("cone", "fit_cone"),
         "CylinderFit": ("cylinder", "fit_cylinder"), "LineFit": ("line3d", "fit_line"),
         "PlaneFit": ("plane", "fit_plane"), "SphereFit": ("sphere", "fit_sphere"), "TorusFit": ("torus", "fit_torus")}


def _instance(cls: type, rows: int) -> Any:
    if cls.__name__ in _FITS and cls.__module__.startswith("pcmm_geo.fit."):
        from pcmm_geo import fit
        from pcmm_geo.fit.reference import make_reference_data

        element, fitter = _FITS[cls.__name__]
        return getattr(fit, fitter)(make_reference_data(element, n_points=rows, form=0.01, rng=3).points)
    obj = object.__new__(cls)
    for item in dataclasses.fields(cls):
        object.__setattr__(obj, item.name, _fake(str(item.type), rows))
    return obj


def problems(cls: type, name: str = "") -> list[str]:
    """What is wrong with one array-holding dataclass (empty: identity equality and a bounded repr)."""
    found = []
    if name not in VALUE_EQUALITY:
        if cls.__eq__ is not object.__eq__:
            found.append("== is not identity")
        if cls.__hash__ is not object.__hash__:
            found.append("hash is not identity")
    small, large = repr(_instance(cls, 30)), repr(_instance(cls, 300))  # (300, 3): numpy would print it whole
    if len(large) > REPR_BOUND or len(large) - len(small) > len(_array_fields(cls)) + 4:  # a digit more per shape
        found.append(f"repr grows with the arrays ({len(small)} -> {len(large)} characters)")
    return found


def test_the_scan_finds_the_records() -> None:
    # the fit results, the refit, the calibration covariance and the machine are among them
    names = set(ARRAY_CLASSES)
    for expected in ("pcmm_geo.fit.sphere.SphereFit", "pcmm_geo.cmm.refit.Refit",
                     "pcmm_geo.uncertainty.calibration.CalibrationCovariance",
                     "pcmm_geo.machine.kinematics.model.RigidBodyMachine"):
        assert expected in names
    assert len(names) >= 130


@pytest.mark.parametrize("name", sorted(ARRAY_CLASSES))
def test_array_record_compares_by_identity_and_has_a_bounded_repr(name: str) -> None:
    assert problems(ARRAY_CLASSES[name], name) == []


def test_the_check_fails_a_default_dataclass() -> None:
    @dataclasses.dataclass(frozen=True)
    class Plain:
        points: np.ndarray
        label: str = ""

    found = problems(Plain)
    assert "== is not identity" in found and "hash is not identity" in found
    assert any("repr grows" in p for p in found)


@record
class _Example:
    points: np.ndarray
    center: np.ndarray
    radius: float
    label: str = ""
    note: str | None = None
    bound: float = float("nan")


def test_record_repr_shows_what_applies() -> None:
    example = _Example(np.zeros((50, 3)), np.array([1.0, 2.0, 3.5]), 2.0, label="ball")
    assert repr(example) == "_Example(points=<(50, 3) float64>, center=[1.0, 2.0, 3.5], radius=2.0, label='ball')"
    assert repr(_Example(np.zeros((2, 2), dtype=np.intp), np.zeros(0), 1.0)) == \
        f"_Example(points=<(2, 2) {np.dtype(np.intp)}>, center=[], radius=1.0)"
    assert is_record(example) and is_record(_Example) and not is_record(object())
    assert record_repr(example) == repr(example)


def test_record_equality_is_identity() -> None:
    a = _Example(np.zeros((2, 3)), np.zeros(3), 1.0)
    twin = copy.copy(a)
    assert a == a and a != twin and len({a, twin, a}) == 2
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.radius = 2.0  # type: ignore[misc]


def test_calibration_covariance_equality_no_longer_raises() -> None:
    from pcmm_geo.uncertainty.calibration import CalibrationCovariance

    def make() -> CalibrationCovariance:
        return CalibrationCovariance(names=("a", "b"), values=np.array([1.0, 2.0]), covariance=np.eye(2),
                                     method="GUM linear", probing_sigma=1e-3, laser_sigma=1e-3)

    first, second = make(), make()
    assert first == first and first != second  # before: ValueError (truth value of an array is ambiguous)
    assert "covariance=<(2, 2) float64>" in repr(first)


def test_refit_repr_does_not_list_its_points() -> None:
    from pcmm_geo.cmm.compensation import Compensation
    from pcmm_geo.cmm.refit import Refit

    rng = np.random.default_rng(7)
    compensation = Compensation(probe_radius_mm=1.0, side="external", inferred=False, source="file",
                                method="element offset")
    shown = {n: repr(Refit(type="plane", n_points=n, method="gaussian", method_source="default",
                           compensation=compensation, points=rng.normal(size=(n, 3)),
                           location=np.zeros(3), direction=np.array([0.0, 0.0, 1.0])))
             for n in (50, 5000)}
    assert "points=<(50, 3) float64>" in shown[50] and "direction=[0.0, 0.0, 1.0]" in shown[50]
    assert len(shown[5000]) - len(shown[50]) == 4  # n_points and the shape: 2 digits more each (2,883 before)
    assert "fit=" not in shown[50] and "diameter=" not in shown[50]  # None: not applicable to a plane
