"""The MIC cylinder's domain (axes the points surround) and the search's effort on sparse rings.

The depth bounds of :class:`~pcmm_geo.fit.zone.axial.surround.Surround` are checked against
an independent depth: the signed distance of the trace of an axis from the edges of the
projected hull (scipy's ConvexHull), positive inside.  The sparse sets below are those of
``test_zone_axial.py``'s slow scan (MIC, seeds 0, 4 and 7) where the search used to exhaust
its budget or, once, to claim that the points surround no axis: their cell counts
(machine-independent) guard the speed of the proof.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError
from test_zone_axial import BUDGET, _unambiguous

from pcmm_geo.errors import DegenerateGeometryError
from pcmm_geo.fit import fit_cylinder
from pcmm_geo.fit.zone.axial.bounds import directions, plane_basis
from pcmm_geo.fit.zone.axial.solve import _hull_vertices
from pcmm_geo.fit.zone.axial.surround import Surround


def _independent_depth(points: np.ndarray, x: np.ndarray) -> float:
    """Signed distance of the trace of axis ``x`` from the projected hull's edges (scipy's ConvexHull): positive
    inside, negative outside; -1 for a flat projection (no hull)."""
    axis = directions(x[None, 2:4])
    first, second = plane_basis(axis)
    rel = points - np.array([x[0], x[1], 0.0])
    planar = np.column_stack([rel @ first[0], rel @ second[0]])
    try:
        hull = ConvexHull(planar)
    except QhullError:
        return -1.0
    return float(np.min(-hull.equations[:, 2]))  # each edge's outward normal n and offset d: n . 0 + d


def test_cell_depth_bounds_hold_every_sampled_axis() -> None:
    """Upper bounds above every surrounded axis of a cell, lower bounds below; a negative upper bound: none."""
    rng = np.random.default_rng(31)
    decided = 0
    for _ in range(30):
        points = rng.normal(size=(int(rng.integers(4, 14)), 3)) * [3.0, 3.0, 5.0]
        surround = Surround(points, _hull_vertices(points))
        center = np.c_[rng.normal(size=(12, 2)), 0.5 * rng.normal(size=(12, 2))]
        half = rng.uniform(0.0, 0.2, (12, 4)) * rng.uniform(0.0, 1.0, (12, 1)) ** 3
        upper, lower = surround.cell_depth(center, half)
        for k in range(len(center)):
            samples = np.vstack([rng.uniform(-1.0, 1.0, (6, 4)), rng.choice([-1.0, 1.0], (6, 4))])
            axes = np.vstack([center[k], center[k] + half[k] * samples])
            depth = np.array([_independent_depth(points, x) for x in axes])
            inside = depth > 0
            assert np.all(depth[inside] <= upper[k] + 1e-9), (depth.max(), upper[k])
            assert np.all(depth[inside] >= lower[k] - 1e-9), (depth.min(), lower[k])
            if upper[k] < 0:
                assert not inside.any()
                decided += 1
            if lower[k] > 0:
                assert inside.all()
    assert decided > 30  # the check above is not vacuous


def test_centre_depth_is_the_depth_for_small_hulls() -> None:
    """At a single axis (zero-size cell) the chord-normal bound is the depth itself, inside and outside."""
    rng = np.random.default_rng(32)
    for _ in range(40):
        points = rng.normal(size=(int(rng.integers(4, 14)), 3)) * [3.0, 3.0, 5.0]
        surround = Surround(points, _hull_vertices(points))
        assert surround.exact
        x = np.c_[rng.normal(size=(25, 2)), 0.3 * rng.normal(size=(25, 2))]
        axis = directions(x[:, 2:4])
        first, second = plane_basis(axis)
        foot = np.c_[x[:, :2], np.zeros(len(x))]
        bound = surround.center_depth_upper(first, second, foot)
        for k, row in enumerate(x):
            depth = _independent_depth(points, row)
            if depth > 0:
                assert bound[k] == pytest.approx(depth, abs=1e-9)
            else:
                assert bound[k] < 0


def _mic_set(seed: int, index: int) -> np.ndarray:
    """Set ``index`` of seed ``seed`` of the slow scan's MIC sets."""
    rng = np.random.default_rng(9000 + seed + 200)
    for _ in range(index + 1):
        points, _ = _unambiguous(rng, 6, 13, 2 * np.pi)
    return points


def _cells(message: str) -> int:
    return int(re.search(r"branch and bound: (\d+) cells", message).group(1))


@pytest.mark.parametrize(("seed", "index"), [(0, 2), (4, 2), (7, 1)])
def test_sparse_mic_proofs_close(seed: int, index: int) -> None:
    """Sets whose proof used to exhaust the budget (0.47-1.1 million cells, scope local) now close it."""
    fit = fit_cylinder(_mic_set(seed, index), criterion="mic", search_budget=BUDGET)
    assert fit.certificate.scope == "global", fit.message
    assert _cells(fit.message) <= 150_000, fit.message


def test_mic_running_onto_the_edge_of_the_points_is_refused_early() -> None:
    """Seven points in a half ring: the largest empty cylinders run onto the edge of their projection.

    The search used to end after 0.7 million cells saying that no surrounded axis exists
    (there are many); it now finds them and stops when its best axes run onto the edge.
    """
    with pytest.raises(DegenerateGeometryError, match="run onto the edge of the points' projection") as info:
        fit_cylinder(_mic_set(4, 1), criterion="mic", search_budget=BUDGET)
    assert _cells(str(info.value)) <= 150_000, str(info.value)
