"""Triangle meshes: STL, OBJ and PLY files, and nominal CAD primitives in millimetres.

Files are parsed by trimesh (imported on first use) and returned as ``trimesh.Trimesh``
with duplicate vertices merged, so that a triangle soup from STL gets its connectivity.

Precision of the written files:

- ``.stl`` -- binary STL; the format stores single-precision floats, so coordinates keep a
  relative error up to 2^-24 (6e-6 mm at 100 mm).  Prefer OBJ or PLY for nominal data
  that must survive to the nanometre.
- ``.obj`` -- text with 15 decimal places (round trip within 1e-12 mm below 1000 mm).
- ``.ply`` -- binary little-endian with ``double`` vertex coordinates (exact round trip).

Writers never replace an existing file unless ``overwrite=True``
(:class:`~pcmm_geo.errors.OutputExistsError`).

Nominal primitives (:func:`box_mesh`, :func:`cylinder_mesh`, :func:`sphere_mesh`) are
centred at the origin: a box has its length along x, width along y and height along z;
a cylinder has its axis along z.  Curved surfaces are tessellated finely enough that the
chord (the gap between the true surface and the flat triangles) stays within a given
``chord_tolerance``; their vertices lie on the true surface and the facets inside it.
:func:`nominal_mesh` builds one from a short text such as ``"box:100x35x9"``.

Examples
--------
>>> import os, tempfile
>>> block = box_mesh(100.0, 35.0, 9.0)
>>> path = write_mesh(os.path.join(tempfile.mkdtemp(), "block.ply"), block)
>>> back = read_mesh(path)
>>> len(back.faces), back.bounds.tolist()
(12, [[-50.0, -17.5, -4.5], [50.0, 17.5, 4.5]])
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pcmm_geo.errors import FileFormatError, InvalidInputError

if TYPE_CHECKING:
    import trimesh

__all__ = [
    "MESH_SUFFIXES",
    "PRIMITIVE_SPECS",
    "box_mesh",
    "cylinder_mesh",
    "cylinder_sections",
    "nominal_mesh",
    "read_mesh",
    "sphere_mesh",
    "write_mesh",
]

#: file suffixes :func:`read_mesh` and :func:`write_mesh` understand
MESH_SUFFIXES = (".stl", ".obj", ".ply")
#: the texts :func:`nominal_mesh` accepts (sizes in mm)
PRIMITIVE_SPECS = ("box:LENGTHxWIDTHxHEIGHT", "cylinder:RADIUSxHEIGHT", "sphere:RADIUS")
#: decimal places of OBJ coordinates
_OBJ_DECIMALS = 15
#: the finest icosphere level :func:`sphere_mesh` builds (327 680 triangles)
_MAX_SPHERE_LEVEL = 7


def _suffix(path: Path, what: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise FileFormatError(str(path), f"{what}: expected a name ending in {', '.join(MESH_SUFFIXES)}, "
                                         f"got {path.suffix or 'no suffix'!r}")
    return suffix


def read_mesh(path: str | Path) -> trimesh.Trimesh:
    """Read a triangle mesh (mm) from an STL, OBJ or PLY file.

    Parameters
    ----------
    path : str or Path
        ``.stl`` (binary or ASCII), ``.obj`` or ``.ply``.  Several objects in one file are
        joined into one mesh.

    Returns
    -------
    trimesh.Trimesh
        ``vertices`` (V, 3) float64 mm and ``faces`` (F, 3) int, duplicate vertices merged.

    Raises
    ------
    FileFormatError
        Unknown suffix, a file the parser rejects, a binary STL whose size does not match
        its triangle count, a file without any triangle (empty, a point cloud, garbage) or
        with non-finite vertex coordinates.
    OSError
        The file cannot be read (``FileNotFoundError`` when it does not exist).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "triangle.obj")
    >>> _ = open(path, "w").write("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n")
    >>> mesh = read_mesh(path)
    >>> mesh.vertices.shape, mesh.faces.tolist()
    ((3, 3), [[0, 1, 2]])
    """
    import trimesh

    file = Path(path)
    suffix = _suffix(file, "mesh file")
    content = file.read_bytes()  # OSError (missing, unreadable) passes through as it is
    if not content.strip():
        raise FileFormatError(str(file), "expected a triangle mesh, got an empty file")
    if suffix == ".stl":
        _check_binary_stl_size(file, content)
    try:
        loaded = trimesh.load_mesh(io.BytesIO(content), file_type=suffix[1:], process=False)
    except Exception as exc:  # the parsers raise anything from ValueError to IndexError on bad input
        reason = f"not a valid {suffix[1:].upper()} mesh ({type(exc).__name__}: {exc})"
        raise FileFormatError(str(file), reason) from None
    if isinstance(loaded, trimesh.Scene):  # several objects: one mesh in the file's frame
        loaded = loaded.to_mesh() if loaded.geometry else trimesh.Trimesh()
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        raise FileFormatError(str(file), "expected triangles, got none (unreadable data, or a point cloud: "
                                          "read those with pcmm_geo.io.read_points)")
    if not np.all(np.isfinite(loaded.vertices)):
        raise FileFormatError(str(file), "non-finite vertex coordinate (NaN or inf)")
    loaded.process()  # merge duplicate vertices: an STL triangle soup gets its connectivity
    return loaded


def _check_binary_stl_size(file: Path, content: bytes) -> None:
    """A binary STL holds 84 + 50 n bytes for the n triangles its header announces; ASCII starts with 'solid'."""
    if len(content) >= 84:
        announced = int(np.frombuffer(content[80:84], dtype="<u4")[0])
        if len(content) == 84 + 50 * announced or content.lstrip()[:5].lower() == b"solid":
            return
        raise FileFormatError(str(file), f"binary STL announces {announced} triangles ({84 + 50 * announced} "
                                         f"bytes), got {len(content)} bytes (truncated or not an STL)")
    if content.lstrip()[:5].lower() != b"solid":
        raise FileFormatError(str(file), f"expected a binary STL (at least 84 bytes) or ASCII 'solid ...', "
                                         f"got {len(content)} bytes")


def write_mesh(path: str | Path, mesh: trimesh.Trimesh, *, overwrite: bool = False) -> Path:
    """Write a triangle mesh as STL, OBJ or PLY (chosen by the suffix).

    Parameters
    ----------
    path : str or Path
        Destination, ``.stl`` (binary, single precision), ``.obj`` (15 decimals) or ``.ply``
        (binary, double precision).
    mesh : trimesh.Trimesh
        Vertices (V, 3) in mm and faces (F, 3), F >= 1.
    overwrite : bool
        Replace an existing file (default False: refuse).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is False (also when it appears while writing).
    FileFormatError
        Unknown suffix.
    InvalidInputError
        A mesh without triangles or with non-finite vertices.
    OSError
        The folder does not exist or is not writable.

    Examples
    --------
    >>> import os, tempfile
    >>> from pcmm_geo.errors import OutputExistsError
    >>> folder = tempfile.mkdtemp()
    >>> write_mesh(os.path.join(folder, "pin.stl"), cylinder_mesh(5.0, 20.0)).name
    'pin.stl'
    >>> try:
    ...     write_mesh(os.path.join(folder, "pin.stl"), cylinder_mesh(5.0, 20.0))
    ... except OutputExistsError:
    ...     print("kept")
    kept
    """
    file = Path(path)
    suffix = _suffix(file, "mesh file")
    vertices = np.asarray(mesh.vertices, dtype=float)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise InvalidInputError("mesh", "at least one triangle (faces of shape (F, 3))",
                                f"faces of shape {faces.shape}")
    if not np.all(np.isfinite(vertices)):
        raise InvalidInputError("mesh", "finite vertex coordinates", "NaN or inf")
    if suffix == ".ply":
        content = _ply_bytes(vertices, faces)
    elif suffix == ".obj":
        import trimesh

        text = trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_color=False,
                                               include_texture=False, digits=_OBJ_DECIMALS, header=None)
        content = text.encode("utf-8")
    else:
        import trimesh

        content = trimesh.exchange.stl.export_stl(mesh)
    from pcmm_geo._atomic import write_atomic

    return write_atomic(file, content, overwrite=overwrite)


def _ply_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """Binary little-endian PLY with double-precision vertices and int32 triangle lists."""
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment pcmm_geo mesh, millimetres\n"
        f"element vertex {len(vertices)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    vertex_block = np.ascontiguousarray(vertices, dtype="<f8").tobytes()
    face_records = np.empty(len(faces), dtype=[("count", "u1"), ("index", "<i4", (3,))])
    face_records["count"] = 3
    face_records["index"] = faces
    return header.encode("ascii") + vertex_block + face_records.tobytes()


def _positive(name: str, value: float) -> float:
    number = float(value)
    if not math.isfinite(number) or number <= 0.0:
        raise InvalidInputError(name, "a positive finite size in mm", repr(value))
    return number


def box_mesh(length: float, width: float, height: float) -> trimesh.Trimesh:
    """Nominal rectangular block (e.g. a gauge block), centred at the origin.

    Parameters
    ----------
    length, width, height : float
        Extents along x, y and z (mm), all positive.

    Returns
    -------
    trimesh.Trimesh
        8 vertices, 12 outward-facing triangles, watertight.

    Raises
    ------
    InvalidInputError
        A non-positive or non-finite size.

    Examples
    --------
    >>> block = box_mesh(100.0, 35.0, 9.0)
    >>> float(block.volume), block.is_watertight
    (31500.0, True)
    """
    import trimesh

    extents = [_positive("length", length), _positive("width", width), _positive("height", height)]
    return trimesh.creation.box(extents=extents)


def cylinder_sections(radius: float, chord_tolerance: float) -> int:
    """Number of polygon sides for which the chord of a circle of ``radius`` stays within ``chord_tolerance``.

    A regular n-gon inscribed in a circle of radius ``r`` is at most ``r (1 - cos(pi / n))``
    inside it; the smallest ``n >= 16`` that keeps this below the tolerance is returned.

    Raises
    ------
    InvalidInputError
        A non-positive radius or tolerance.

    Examples
    --------
    >>> cylinder_sections(10.0, 0.001)
    223
    """
    r = _positive("radius", radius)
    tolerance = _positive("chord_tolerance", chord_tolerance)
    if tolerance >= r:
        return 16
    return max(16, math.ceil(math.pi / math.acos(1.0 - tolerance / r)))


def cylinder_mesh(radius: float, height: float, *, chord_tolerance: float = 0.001) -> trimesh.Trimesh:
    """Nominal closed cylinder with its axis along z, centred at the origin (z from -height/2 to height/2).

    Parameters
    ----------
    radius, height : float
        Radius and length along the axis (mm).
    chord_tolerance : float
        Largest gap between the true cylinder and the flat side facets (mm); sets the number
        of sides with :func:`cylinder_sections`.

    Returns
    -------
    trimesh.Trimesh
        Watertight mesh, side vertices on the true cylinder.

    Raises
    ------
    InvalidInputError
        A non-positive or non-finite size or tolerance.

    Examples
    --------
    >>> pin = cylinder_mesh(10.0, 40.0)
    >>> len(pin.faces), pin.is_watertight
    (892, True)
    """
    import trimesh

    sections = cylinder_sections(radius, chord_tolerance)
    return trimesh.creation.cylinder(radius=float(radius), height=_positive("height", height), sections=sections)


def sphere_mesh(radius: float, *, chord_tolerance: float = 0.001) -> trimesh.Trimesh:
    """Nominal sphere centred at the origin: the coarsest icosphere whose facets stay within ``chord_tolerance``.

    Parameters
    ----------
    radius : float
        Radius (mm).
    chord_tolerance : float
        Largest gap between the true sphere and the flat facets (mm).  Icosphere levels 1 to
        7 reach a relative gap of 0.066 down to 1.8e-5 of the radius.

    Returns
    -------
    trimesh.Trimesh
        Watertight mesh, vertices on the true sphere.

    Raises
    ------
    InvalidInputError
        A non-positive size, or a tolerance finer than the finest level (7) reaches.

    Examples
    --------
    >>> ball = sphere_mesh(12.5, chord_tolerance=0.01)
    >>> len(ball.faces)
    20480
    """
    import trimesh

    r = _positive("radius", radius)
    tolerance = _positive("chord_tolerance", chord_tolerance)
    for level in range(1, _MAX_SPHERE_LEVEL + 1):
        ball = trimesh.creation.icosphere(subdivisions=level, radius=r)
        facet_distance = np.abs(np.einsum("ij,ij->i", ball.triangles_center, ball.face_normals))
        if r - float(facet_distance.min()) <= tolerance:
            return ball
    raise InvalidInputError(
        "chord_tolerance", f"at least {r * 1.8e-5:.3g} mm for a sphere of radius {r} mm", repr(chord_tolerance)
    )


_NUMBER = r"([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)"
_SPEC_PATTERNS = {
    "box": re.compile(rf"^{_NUMBER}x{_NUMBER}x{_NUMBER}$"),
    "cylinder": re.compile(rf"^{_NUMBER}x{_NUMBER}$"),
    "sphere": re.compile(rf"^{_NUMBER}$"),
}


def nominal_mesh(spec: str, *, chord_tolerance: float = 0.001) -> trimesh.Trimesh:
    """Build a nominal primitive from a short text: ``box:LxWxH``, ``cylinder:RxH`` or ``sphere:R`` (mm).

    Parameters
    ----------
    spec : str
        Kind and sizes, e.g. ``"box:100x35x9"`` (a 100 mm gauge block), ``"cylinder:10x40"``
        (radius 10 mm, height 40 mm) or ``"sphere:12.5"`` (radius 12.5 mm).
    chord_tolerance : float
        Tessellation tolerance of curved surfaces (mm), see :func:`cylinder_mesh`.

    Returns
    -------
    trimesh.Trimesh
        Centred at the origin, as :func:`box_mesh`, :func:`cylinder_mesh`, :func:`sphere_mesh`.

    Raises
    ------
    InvalidInputError
        Unknown kind, wrong number of sizes, or a non-positive size.

    Examples
    --------
    >>> nominal_mesh("box:100x35x9").extents.tolist()
    [100.0, 35.0, 9.0]
    >>> nominal_mesh("cylinder:10x40").bounds[:, 2].tolist()
    [-20.0, 20.0]
    """
    kind, _, sizes = spec.strip().lower().partition(":")
    pattern = _SPEC_PATTERNS.get(kind)
    match = pattern.match(sizes.replace(" ", "")) if pattern is not None else None
    if match is None:
        raise InvalidInputError("nominal", f"one of {', '.join(PRIMITIVE_SPECS)} (sizes in mm)", repr(spec))
    values = [float(v) for v in match.groups()]
    if kind == "box":
        return box_mesh(*values)
    if kind == "cylinder":
        return cylinder_mesh(values[0], values[1], chord_tolerance=chord_tolerance)
    return sphere_mesh(values[0], chord_tolerance=chord_tolerance)
