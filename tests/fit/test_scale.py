"""Chunked passes and dask arrays: the same fits, to 1e-9 mm of the known least-squares solutions.

Truth: the null-space reference generator (:mod:`pcmm_geo.fit.reference`), moments from
numpy on the whole array, and the in-memory fits (themselves checked against the truth
in ``test_accuracy.py``).
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from pcmm_geo.errors import DegenerateGeometryError, InvalidInputError, TooFewPointsError
from pcmm_geo.fit import fit_cylinder, fit_line, fit_plane, fit_sphere
from pcmm_geo.fit._kernels import _tall
from pcmm_geo.fit.reference import make_reference_data
from pcmm_geo.fit.scale import chunked, is_dask_array
from pcmm_geo.testing import assert_fit_close

da = pytest.importorskip("dask.array")


def test_is_dask_array_does_not_import_dask() -> None:
    assert is_dask_array(da.zeros((4, 3)))
    assert not is_dask_array(np.zeros((4, 3)))
    assert not is_dask_array([[0.0, 0.0, 0.0]])


def test_importing_the_fits_does_not_import_dask() -> None:
    import subprocess

    code = ("import sys, numpy as np; from pcmm_geo.fit import fit_sphere, fit_plane; "
            "fit_sphere(np.random.default_rng(1).normal(size=(30000, 3))); fit_plane(np.eye(3)); "
            "print('dask' in sys.modules)")
    answer = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert answer.stdout.strip() == "False"


def test_moments_of_chunks_equal_numpy_on_the_whole_array(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(chunked, "CHUNK_ROWS", 7)
    rng = np.random.default_rng(2)
    points = rng.normal(size=(100, 3)) * [3.0, 2.0, 1.0] + 1000.0
    found = chunked.moments(chunked.in_memory(points), points[0])
    centred = points - points.mean(axis=0)
    squared = np.einsum("ij,ij->i", centred, centred)
    assert found.count == 100
    np.testing.assert_allclose(found.centroid, points.mean(axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(found.scatter, centred.T @ centred, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(found.third, squared @ centred, rtol=1e-10, atol=1e-8)
    assert found.second == pytest.approx(squared.sum(), rel=1e-12)
    np.testing.assert_array_equal(found.lower, points.min(axis=0))


# the accuracy grid of test_accuracy.py for the sphere, through the chunked solver at every size
SPHERE_GRID = [(offset, cap, form, count) for offset in (0.0, 1000.0) for cap in (180.0, 30.0)
               for form in (0.0, 0.1) for count in (25, 4000)]


@pytest.mark.parametrize(("offset", "cap_deg", "form", "count"), SPHERE_GRID)
def test_chunked_sphere_meets_the_accuracy_target(monkeypatch: pytest.MonkeyPatch, offset: float, cap_deg: float,
                                                  form: float, count: int) -> None:
    monkeypatch.setattr(_tall, "TALL_ROWS", 4)
    monkeypatch.setattr(chunked, "CHUNK_ROWS", 1000)  # several chunks
    data = make_reference_data("sphere", n_points=count, radius=12.7, form=form, offset=offset,
                               cap=math.radians(cap_deg), rng=count + int(cap_deg))
    result = fit_sphere(data.points)
    assert "Gauss-Newton" in result.message
    assert_fit_close(result, data)
    np.testing.assert_allclose(result.residuals, result.distance(data.points), rtol=0, atol=1e-12)
    assert result.rms == pytest.approx(float(np.sqrt(np.mean(result.residuals**2))), rel=1e-9)
    assert result.form == pytest.approx(float(np.ptp(result.residuals)), abs=1e-12)


def test_chunked_sphere_with_fixed_radius_and_its_covariance(monkeypatch: pytest.MonkeyPatch) -> None:
    data = make_reference_data("sphere", n_points=30_000, radius=12.5, form=0.02, offset=500.0, rng=9)
    chunked_fit = fit_sphere(data.points, radius=12.5)
    monkeypatch.setattr(_tall, "TALL_ROWS", 10**9)
    orthogonal = fit_sphere(data.points, radius=12.5)
    np.testing.assert_allclose(chunked_fit.center, orthogonal.center, rtol=0, atol=1e-9)
    np.testing.assert_allclose(chunked_fit.covariance, orthogonal.covariance, rtol=1e-6, atol=1e-30)
    np.testing.assert_allclose(chunked_fit.residuals, orthogonal.residuals, rtol=0, atol=1e-9)


@pytest.mark.parametrize("element", ["line3d", "plane", "cylinder"])
def test_chunked_line_plane_cylinder_equal_the_truth_and_the_orthogonal_path(
    monkeypatch: pytest.MonkeyPatch, element: str
) -> None:
    sizes = {"line3d": {"length": 120.0}, "plane": {"length": 60.0}, "cylinder": {"radius": 15.0, "length": 40.0}}
    function = {"line3d": fit_line, "plane": fit_plane, "cylinder": fit_cylinder}[element]
    data = make_reference_data(element, n_points=_tall.TALL_ROWS + 5000, form=0.02, offset=1000.0, rng=17,
                               **sizes[element])
    monkeypatch.setattr(chunked, "CHUNK_ROWS", 4096)
    fast = function(data.points)
    assert "chunks" in fast.message or "Gauss-Newton" in fast.message
    assert_fit_close(fast, data)
    monkeypatch.setattr(_tall, "TALL_ROWS", 10**9)
    orthogonal = function(data.points)
    assert "chunks" not in orthogonal.message
    np.testing.assert_allclose(fast.residuals, orthogonal.residuals, rtol=0, atol=1e-9)
    assert fast.rms == pytest.approx(orthogonal.rms, rel=1e-9) and fast.form == pytest.approx(orthogonal.form, abs=1e-9)
    np.testing.assert_allclose(fast.covariance, orthogonal.covariance, rtol=1e-6,
                               atol=1e-9 * np.abs(orthogonal.covariance).max())


@pytest.mark.parametrize("function", [fit_line, fit_plane, fit_sphere, fit_cylinder])
def test_chunked_fits_check_the_values_in_their_first_pass_with_the_same_errors(function) -> None:
    """Many points skip the separate value checks; the moment pass finds the same errors, rows named."""
    rows = _tall.TALL_ROWS + 3000
    points = make_reference_data("sphere", n_points=rows, radius=20.0, form=0.01, offset=400.0, rng=5).points
    for row, value in ((0, np.nan), (rows - 1, np.inf), (12_345, -np.inf)):
        bad = points.copy()
        bad[row, 1] = value
        with pytest.raises(InvalidInputError, match=f"finite coordinates.*in row {row}$"):
            function(bad)
    huge = points.copy()
    huge[777, 2] = 3e150
    with pytest.raises(InvalidInputError, match=r"magnitude at most.*3e\+150 at index \(777, 2\)"):
        function(huge)
    with pytest.raises(DegenerateGeometryError, match=f"all {rows} points are identical"):
        function(np.tile([[400.0, -3.0, 1e-3]], (rows, 1)))
    if function in (fit_sphere, fit_plane):  # far out but within the limit: its sums overflow, no false refusal
        assert function(points * 1e100).rms == pytest.approx(function(points).rms * 1e100, rel=1e-6)


def test_chunked_cylinder_subsample_is_fitted_in_memory() -> None:
    """A subsample of exactly ``TALL_ROWS`` points would re-enter the chunked path (it recursed before)."""
    data = make_reference_data("cylinder", n_points=2 * _tall.TALL_ROWS, radius=15.0, length=40.0, form=0.02,
                               offset=1000.0, rng=17)
    assert_fit_close(fit_cylinder(data.points), data)


# ---------------------------------------------------------------------- dask


def _lazy(points: np.ndarray, rows: int = 997) -> object:
    return da.from_array(points, chunks=(rows, 3))


@pytest.mark.parametrize("element", ["line3d", "plane", "sphere", "cylinder"])
def test_dask_fits_equal_the_truth_and_keep_residuals_lazy(element: str) -> None:
    sizes = {"line3d": {"length": 120.0}, "plane": {"length": 60.0}, "sphere": {"radius": 12.7},
             "cylinder": {"radius": 15.0, "length": 40.0}}[element]
    data = make_reference_data(element, n_points=5000, form=0.05, offset=800.0, rng=11, **sizes)
    function = {"line3d": fit_line, "plane": fit_plane, "sphere": fit_sphere, "cylinder": fit_cylinder}[element]
    lazy = function(_lazy(data.points))
    eager = function(data.points)
    assert type(lazy) is type(eager)
    assert_fit_close(lazy, data)
    assert is_dask_array(lazy.residuals)
    residuals = lazy.residuals.compute()
    np.testing.assert_allclose(residuals, eager.residuals, rtol=0, atol=1e-9)
    assert lazy.rms == pytest.approx(eager.rms, rel=1e-9)
    assert lazy.form == pytest.approx(eager.form, abs=1e-9)
    assert lazy.n == eager.n and lazy.dof == eager.dof
    np.testing.assert_allclose(lazy.covariance, eager.covariance, rtol=1e-6, atol=1e-9 * np.abs(eager.covariance).max())
    assert lazy.condition_number == pytest.approx(eager.condition_number, rel=1e-6)


def test_dask_fit_of_a_generated_array_never_materialised() -> None:
    """Blocks generated from a seed inside the graph: equal to the in-memory fit of the same points."""
    def block(seed_block: np.ndarray, block_info: dict | None = None) -> np.ndarray:
        index = block_info[None]["chunk-location"][0] if block_info else 0
        rng = np.random.default_rng(1000 + index)
        direction = rng.normal(size=(len(seed_block), 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        return np.array([300.0, -200.0, 50.0]) + direction * (20.0 + 0.01 * rng.uniform(-1, 1, (len(seed_block), 1)))

    lazy = da.zeros((40_000, 3), chunks=(6_000, 3)).map_blocks(block, dtype=float)
    fitted = fit_sphere(lazy)
    eager = fit_sphere(lazy.compute())
    np.testing.assert_allclose(fitted.center, eager.center, rtol=0, atol=1e-9)
    assert fitted.radius == pytest.approx(eager.radius, abs=1e-9)
    assert fitted.form == pytest.approx(eager.form, abs=1e-12)


def test_dask_fits_on_a_distributed_cluster() -> None:
    distributed = pytest.importorskip("distributed")
    data = make_reference_data("sphere", n_points=3000, radius=10.0, form=0.01, offset=100.0, rng=4)
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None)
    with cluster, distributed.Client(cluster):
        fitted = fit_sphere(_lazy(data.points, 500))
        upper = data.points[data.points[:, 2] > np.median(data.points[:, 2])]
        plane = fit_plane(_lazy(upper, 500))
    assert_fit_close(fitted, data)
    eager = fit_plane(upper)
    np.testing.assert_allclose(plane.normal, eager.normal, rtol=0, atol=1e-12)
    assert plane.n == len(upper)


def test_dask_input_errors() -> None:
    with pytest.raises(InvalidInputError, match="shape"):
        fit_sphere(da.zeros((10, 2)))
    with pytest.raises(TooFewPointsError):
        fit_sphere(da.zeros((3, 3)))
    with pytest.raises(InvalidInputError, match="weights"):
        fit_plane(_lazy(np.eye(3) * [1, 2, 3]), weights=np.ones(3))
    bad = np.random.default_rng(1).normal(size=(50, 3))
    bad[17, 1] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        fit_line(_lazy(bad, 10))
    with pytest.raises(DegenerateGeometryError, match="identical"):
        fit_sphere(_lazy(np.ones((20, 3)), 7))
    flat = np.c_[np.random.default_rng(2).normal(size=(100, 2)), np.zeros(100)]
    with pytest.raises(DegenerateGeometryError, match="coplanar"):
        fit_sphere(_lazy(flat, 30))
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        fit_plane(_lazy(np.outer(np.arange(20.0), [1.0, 2.0, 3.0]), 7))
