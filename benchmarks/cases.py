"""The benchmark cases: pcmm_geo fits against peer libraries on the same reference data.

Every case draws its data from :func:`pcmm_geo.fit.reference.make_reference_data`, so the
exact least-squares element is known and each peer's accuracy is reported against it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from _timing import best_of

from pcmm_geo.fit.reference import make_reference_data
from pcmm_geo.testing import fit_deviations


@dataclass(frozen=True)
class Contender:
    """One library's result on a case: best and median time (s) and its deviations from the truth."""

    name: str
    seconds: float
    deviations: dict[str, float]
    note: str = ""
    median: float | None = None


@dataclass(frozen=True)
class CaseResult:
    """A benchmark case with its contenders and target.

    ``threads`` is the thread mode it ran in (``single`` or ``default``); ``before`` and
    ``after`` are :func:`_environment.snapshot` s taken around it (cores, load, thread settings).
    """

    name: str
    data: str
    contenders: list[Contender]
    target: str
    ratio: float | None
    target_met: bool | None
    extra: dict[str, float] = field(default_factory=dict)
    threads: str = ""
    before: dict[str, Any] = field(default_factory=dict)
    after: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> CaseResult:
        """The inverse of ``dataclasses.asdict`` (results travel as JSON from the child processes)."""
        return cls(**{**values, "contenders": [Contender(**item) for item in values["contenders"]]})


def sphere_case(n_points: int, repeat: int, threads: int | None = None) -> CaseResult:
    """Sphere, ``n_points`` points: pcmm_geo fit_sphere vs trimesh.nsphere.fit_nsphere (target <= 0.5x).

    Both use numpy/BLAS only: their threads follow the BLAS thread variables (``threads`` unused).
    """
    del threads
    import trimesh.nsphere

    from pcmm_geo.fit import fit_sphere

    data = make_reference_data("sphere", n_points=n_points, radius=25.0, form=0.01, offset=500.0, rng=101)
    ours = best_of(lambda: fit_sphere(data.points), repeat)
    theirs = best_of(lambda: trimesh.nsphere.fit_nsphere(data.points), repeat)
    center, radius, _ = theirs.value
    contenders = [
        Contender("pcmm_geo.fit_sphere", ours.best, fit_deviations(ours.value, data), median=ours.median),
        Contender("trimesh.nsphere.fit_nsphere", theirs.best,
                  fit_deviations({"center": center, "radius": radius}, data), "radius = mean distance",
                  median=theirs.median),
    ]
    ratio = ours.best / theirs.best
    return CaseResult(
        "sphere",
        f"{n_points:,} points, R 25 mm, form 0.01 mm, 500 mm offset",
        contenders,
        "pcmm <= 0.5 x trimesh time",
        ratio,
        ratio <= 0.5,
    )


def cylinder_case(n_points: int, repeat: int, peer_repeat: int, threads: int | None = None) -> CaseResult:
    """Cylinder, ``n_points`` points: fit_cylinder vs skspatial Cylinder.best_fit (target <= 0.01x)."""
    del threads  # numpy/BLAS (and scipy's MINPACK for skspatial): the thread variables decide
    from skspatial.objects import Cylinder

    from pcmm_geo.fit import fit_cylinder

    data = make_reference_data(
        "cylinder", n_points=n_points, radius=20.0, length=60.0, form=0.01, offset=500.0, rng=202
    )
    ours = best_of(lambda: fit_cylinder(data.points), repeat)
    theirs = best_of(lambda: Cylinder.best_fit(data.points), peer_repeat)
    peer = theirs.value
    peer_axis = np.asarray(peer.vector, dtype=float)
    peer_element = {
        "point": np.asarray(peer.point, dtype=float),
        "axis": peer_axis / np.linalg.norm(peer_axis),
        "radius": float(peer.radius),
    }
    contenders = [
        Contender("pcmm_geo.fit_cylinder", ours.best, fit_deviations(ours.value, data), median=ours.median),
        Contender("skspatial Cylinder.best_fit", theirs.best, fit_deviations(peer_element, data), median=theirs.median),
    ]
    ratio = ours.best / theirs.best
    return CaseResult(
        "cylinder",
        f"{n_points:,} points, R 20 mm, 60 mm long, form 0.01 mm, 500 mm offset",
        contenders,
        "pcmm <= 0.01 x skspatial time",
        ratio,
        ratio <= 0.01,
    )


def batch_sphere_case(n_fits: int, repeat: int, threads: int | None = None) -> CaseResult:
    """Batch of five-point sphere fits (fit_spheres, (K, 5, 3)); target >= 10,000 fits/s."""
    del threads
    from pcmm_geo.fit import fit_spheres

    rng = np.random.default_rng(303)
    base_count = 200
    bases = [
        make_reference_data("sphere", n_points=5, radius=1.5, form=0.002, cap=np.pi / 2, offset=0.0, rng=seed)
        for seed in range(base_count)
    ]
    # residuals are translation invariant: tile the base sets over random positions in a 1 m cube
    picks = rng.integers(0, base_count, n_fits)
    shifts = rng.uniform(-500.0, 500.0, (n_fits, 3))
    points = np.stack([bases[i].points for i in picks]) + shifts[:, None, :]
    true_centers = np.stack([bases[i].parameters["center"] for i in picks]) + shifts
    timing = best_of(lambda: fit_spheres(points), repeat)
    result = timing.value
    centers = np.asarray(result.centers, dtype=float)  # SphereBatchFit: centers (K, 3), radii (K,)
    radii = np.asarray(result.radii, dtype=float)
    deviations = {
        "center": float(np.max(np.linalg.norm(centers - true_centers, axis=1))),
        "radius": float(np.max(np.abs(radii - 1.5))),
    }
    rate = n_fits / timing.best
    return CaseResult(
        "batch spheres",
        f"{n_fits:,} sets of 5 points (hemisphere caps, R 1.5 mm, form 0.002 mm)",
        [Contender("pcmm_geo.fit_spheres", timing.best, deviations, f"{rate:,.0f} fits/s", median=timing.median)],
        ">= 10,000 fits/s",
        None,
        rate >= 10_000,
        {"fits_per_second": rate},
    )
