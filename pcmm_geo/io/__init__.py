"""File formats: point files and point clouds, labelled point files, triangle meshes, NIST reference pairs.

:func:`read_points` is the one reader of plain point files (``(N, 3)`` from CSV/TXT/XYZ,
NIST ``.ds``, PLY, PCD, E57), streamed into one array; :func:`read_points_lazy` reads the same
text formats larger than memory as a dask array; :func:`read_labelled_points` reads
``name,x,y,z`` files keeping the labels (:class:`LabelledPoints`).

Names are loaded on first access so that ``import pcmm_geo.io`` stays light (open3d is
imported only when a point cloud is read or written, trimesh only for meshes).
"""

from __future__ import annotations

from pcmm_geo._lazy import attach

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

__getattr__, __dir__, __all__ = attach(__name__, _LAZY)
