"""Naming convention of the public API: ``center`` (US spelling) everywhere; ``centre`` only as deprecated aliases."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re
import types
from collections.abc import Iterator

import numpy as np
import pytest

import pcmm_geo
from pcmm_geo._deprecation import DEPRECATED_ALIASES

BRITISH = re.compile("centre", re.IGNORECASE)


def _public_modules() -> Iterator[str]:
    yield "pcmm_geo"
    for info in pkgutil.walk_packages(pcmm_geo.__path__, "pcmm_geo."):
        if any(part.startswith("_") for part in info.name.split(".")) or ".data." in info.name:
            continue
        yield info.name


def _parameters(function: object) -> list[str]:
    try:
        return list(inspect.signature(function).parameters)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return []


def public_names() -> Iterator[tuple[str, str]]:
    """``(owner, name)`` of every public module attribute, class attribute, field and parameter."""
    for module_name in _public_modules():
        module = importlib.import_module(module_name)
        for name, value in vars(module).items():
            if name.startswith("_") or getattr(value, "__module__", module_name) != module_name:
                continue
            yield module_name, name
            if inspect.isfunction(value):
                for parameter in _parameters(value):
                    yield f"{module_name}.{name}", parameter
            if inspect.isclass(value):
                owner = f"{module_name}.{value.__qualname__}"
                members = set(vars(value))
                if dataclasses.is_dataclass(value):
                    members |= {f.name for f in dataclasses.fields(value)}
                for member in sorted(members):
                    if member.startswith("_"):
                        continue
                    yield owner, member
                    attribute = inspect.getattr_static(value, member, None)
                    if isinstance(attribute, staticmethod | classmethod):
                        attribute = attribute.__func__
                    if inspect.isfunction(attribute):
                        for parameter in _parameters(attribute):
                            yield f"{owner}.{member}", parameter
                for parameter in _parameters(value):
                    yield owner, parameter


def test_public_api_spells_center() -> None:
    offenders = sorted(
        f"{owner}.{name}"
        for owner, name in set(public_names())
        if BRITISH.search(name) and (owner, name) not in DEPRECATED_ALIASES
    )
    assert offenders == []


def test_the_walk_sees_the_renamed_names() -> None:
    """The walker must reach the names it polices (a walk that finds nothing cannot fail)."""
    names = {(owner.rsplit(".", 1)[-1], name) for owner, name in public_names()}
    for expected in [("Tetrahedron", "tip_center"), ("GaugeBlockMeasurement", "face_centers"),
                     ("TetrahedronCalibration", "joint_centers"), ("FittedSphere", "center"),
                     ("sphere_probing_pattern", "center"), ("CircleFit", "center")]:
        assert expected in names
    assert len(names) > 1000


def _import_everything() -> dict[tuple[str, str], str]:
    for module_name in _public_modules():
        importlib.import_module(module_name)
    return dict(DEPRECATED_ALIASES)


ALIASES = _import_everything()


def _resolve(owner: str) -> object:
    parts = owner.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            target: object = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attribute in parts[cut:]:
            target = getattr(target, attribute)
        return target
    raise LookupError(owner)


def test_aliases_cover_the_renames() -> None:
    olds = {old for _, old in ALIASES}
    assert {"tip_centre", "face_centres", "joint_centres", "centre", "centres", "working_volume_centre",
            "fit_centre_line"} <= olds
    assert all(BRITISH.search(old) and not BRITISH.search(new) for (_, old), new in ALIASES.items() if old != "beta")


@pytest.mark.parametrize(("owner", "old"), sorted(ALIASES), ids=[f"{o}.{n}" for o, n in sorted(ALIASES)])
def test_deprecated_alias_warns(owner: str, old: str) -> None:
    """Every 0.1 spelling still works for one release and warns, naming its replacement."""
    new = ALIASES[(owner, old)]
    target = _resolve(owner)
    message = f"{old}.* is deprecated since pcmm_geo 0.2.0 and will be removed in 0.3.0; use .*{new}"
    if inspect.ismodule(target):
        with pytest.warns(DeprecationWarning, match=message):
            assert getattr(target, old) is getattr(target, new)
    elif inspect.isclass(target):
        alias = vars(target)[old]
        instance = types.SimpleNamespace(**{new: object()})
        with pytest.warns(DeprecationWarning, match=message):
            assert alias.__get__(instance, target) is getattr(instance, new)
        assert new in inspect.signature(target).parameters or hasattr(target, new)
    else:
        assert new in inspect.signature(target).parameters
        with pytest.warns(DeprecationWarning, match=message), pytest.raises(Exception):  # noqa: B017
            target(**{old: "not-a-value"})  # the keyword is translated (warning), then the call fails on the value


def _calibration():  # type: ignore[no-untyped-def]
    from pcmm_geo.machine.calibration.seed import appendix_cd_files
    from pcmm_geo.machine.calibration.tetrahedron import calibrate_tetrahedron

    return calibrate_tetrahedron(*appendix_cd_files())


def test_old_names_give_the_new_values_on_real_objects() -> None:
    cal = _calibration()
    with pytest.warns(DeprecationWarning, match="tip_centre"):
        np.testing.assert_array_equal(cal.tip_centre, cal.tip_center)
    with pytest.warns(DeprecationWarning, match="joint_centres"):
        np.testing.assert_array_equal(cal.joint_centres, cal.joint_centers)
    with pytest.warns(DeprecationWarning, match="tip_centre"):
        np.testing.assert_array_equal(cal.tetrahedron.tip_centre, cal.tetrahedron.tip_center)
    from pcmm_geo.machine.kinematics.model_parts import Tetrahedron

    with pytest.warns(DeprecationWarning, match=r"Tetrahedron\(tip_centre=...\)"):
        rebuilt = Tetrahedron(sliders=cal.tetrahedron.sliders, tip_centre=[1.0, 2.0, 3.0])
    np.testing.assert_array_equal(rebuilt.tip_center, [1.0, 2.0, 3.0])
    with pytest.raises(TypeError, match="got both"):
        Tetrahedron(sliders=cal.tetrahedron.sliders, tip_centre=[1.0, 2.0, 3.0], tip_center=[1.0, 2.0, 3.0])
