"""File formats: point files and point clouds, labelled point files, triangle meshes, NIST reference pairs.

:func:`read_points` is the one reader of plain point files (``(N, 3)`` from CSV/TXT/XYZ,
NIST ``.ds``, PLY, PCD, E57), streamed into one array; :func:`read_points_lazy` reads the same
text formats larger than memory as a dask array; :func:`read_labelled_points` reads
``name,x,y,z`` files keeping the labels (:class:`LabelledPoints`).

Names are loaded on first access so that ``import pcmm_geo.io`` stays light (open3d is
imported only when a point cloud is read or written, trimesh only for meshes).
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "read_points": "points",
    "write_points": "points",
    "read_points_lazy": "lazy",
    "read_labelled_points": "labelled",
    "LabelledPoints": "labelled",
    "read_nist_pair": "nist",
    "iter_nist_pairs": "nist",
    "NistPair": "nist",
    "read_mesh": "meshes",
    "write_mesh": "meshes",
    "box_mesh": "meshes",
    "cylinder_mesh": "meshes",
    "sphere_mesh": "meshes",
    "nominal_mesh": "meshes",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'pcmm_geo.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"pcmm_geo.io.{module_name}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
