"""Options shared by the commands that read files from CMMs: which feature, probe compensation, limits, QIF out.

``--feature`` picks the feature of a QIF file; ``--probe-radius-mm``, ``--material-side`` and
``--compensated`` say how the probe radius is applied (:mod:`pcmm_geo.cmm.points`); ``--qif OUT``
writes the result as a QIF 3.0 results document through the command's output plan.
``--max-mb`` (``pcmm fit``, ``form``, ``calibrate``, ``qif``) raises the size limit of a QIF file;
:func:`cli_setting` makes the readers' messages name these options instead of their Python
parameters (``--units mm``, not ``units='mm'``).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from pcmm_geo.cli._output import declare_output, refuse_renamed_options
from pcmm_geo.elements import SPECS, Element

#: library parameter -> the option that sets it (:func:`cli_setting`), where the two are not spelled alike
READER_OPTIONS = {"units": "--units", "angle_unit": "--angle-unit", "size_values": "--size-values",
                  "max_bytes": "--max-mb", "probe_radius": "--probe-radius-mm"}
MIB = 1 << 20


def cli_setting(parameter: str, value: object = None) -> str:
    """How the command line sets a library parameter: ``--units mm`` (``--units`` without a value).

    The one place where the library's parameter names become the command's options: passed as
    ``spell_setting`` to the readers (:mod:`pcmm_geo.io.cmm.settings`) and to the refit, point and
    compensation functions of :mod:`pcmm_geo.cmm`, so that a file without units asks for
    ``--units``, not for the Python keyword, and an unknown compensation for ``--compensated``.
    A True / False value is the options' ``yes`` / ``no``.

    Examples
    --------
    >>> cli_setting("units", "inch"), cli_setting("max_bytes"), cli_setting("compensated", False)
    ('--units inch', '--max-mb', '--compensated no')
    """
    option = READER_OPTIONS.get(parameter, "--" + parameter.replace("_", "-"))
    if value is None:
        return option
    if isinstance(value, bool):
        value = "yes" if value else "no"
    return f"{option} {value}"


def add_max_mb_option(parser: argparse.ArgumentParser, what: str = "QIF file read") -> None:
    """Add ``--max-mb MIB``: the size limit of a QIF file, in MiB (read by :func:`max_bytes`)."""
    parser.add_argument("--max-mb", type=float, metavar="MIB", default=None,
                        help=f"largest {what}, in MiB (2^20 bytes; default 1024 MiB = 1 GiB; scanner point clouds "
                             "may need more)")


def max_bytes(args: argparse.Namespace) -> int | None:
    """``--max-mb`` in bytes (None: the reader's default, 1 GiB)."""
    from pcmm_geo.errors import InvalidInputError

    value = getattr(args, "max_mb", None)
    if value is None:
        return None
    if not (value > 0 and value < 1e9):
        raise InvalidInputError("--max-mb", "a positive size in MiB", repr(value))
    return int(value * MIB)


def add_cmm_input_flags(parser: argparse.ArgumentParser) -> None:
    """Add ``--feature``, ``--probe-radius-mm``, ``--material-side``, ``--compensated``, ``--max-mb`` and ``--qif``."""
    parser.add_argument("--feature", metavar="ID|NAME",
                        help="QIF file: the feature measurement (QIF id or name) whose points are used, when the file "
                             "holds several")
    parser.add_argument("--probe-radius-mm", dest="probe_radius", type=float, metavar="MM",
                        help="the points are probe-ball centres of this radius (mm): the fitted element is offset "
                             "onto the touched surface (a fixed --radius-mm is the surface radius)")
    refuse_renamed_options(parser, {"--probe-radius": "--probe-radius-mm"})
    parser.add_argument("--material-side", choices=("internal", "external"),
                        help="circle, sphere, cylinder, cone: internal (hole) or external (boss, shaft); default "
                             "from the file (InternalExternal, point normals, nominal size); a side the file's "
                             "InternalExternal or point normals contradict is refused")
    parser.add_argument("--compensated", choices=("yes", "no"),
                        help="are the points surface points (yes) or probe centres (no)? Required for formats that "
                             "do not say (a PC-DMIS XYZIJK export, recognised by its first line); checked against "
                             "QIF's Compensated flag")
    add_max_mb_option(parser, "QIF file read (FILE)")
    parser.add_argument("--qif", metavar="OUT.qif",
                        help="also write the result as a QIF 3.0 results document (a feature of a QIF file keeps its "
                             "name, nominal, InternalExternal and size tolerance)")
    parser.add_argument("--feature-name", metavar="NAME",
                        help="with --qif: the feature's name in the QIF written (default: its name in FILE, else the "
                             "element in capitals)")
    declare_output(parser, "qif")


@contextmanager
def naming_the_file(path: Any) -> Iterator[None]:
    """Library errors raised inside (a fit of too few points, degenerate data) name ``path`` first."""
    from pcmm_geo.errors import PcmmGeoError

    try:
        yield
    except PcmmGeoError as exc:
        text = str(exc)
        if str(path) not in text:
            exc.args = (f"{path}: {text}",)
            exc.message = exc.args[0]
        raise


@dataclasses.dataclass
class FitInput:
    """The points to fit and the probe radius still to apply."""

    data: Any  # pcmm_geo.cmm.points.FeaturePoints (2-D when --two-d)
    points: Any
    probe_radius: float
    radius_source: str


def read_fit_input(args: argparse.Namespace, element: Element) -> FitInput:
    """Read FILE for ``element`` (QIF feature, XYZIJK or point file) and decide the probe radius to apply."""
    from pcmm_geo.cmm.files import detect_format
    from pcmm_geo.cmm.points import load_feature_points, probe_radius_to_apply
    from pcmm_geo.errors import InvalidInputError

    if getattr(args, "feature_name", None) is not None:
        if not getattr(args, "qif", None):
            raise InvalidInputError("--feature-name", "--qif OUT.qif as well (the name is written into the QIF)",
                                    "no --qif")
        from pcmm_geo.io.cmm.qif.write.build import check_feature_name

        check_feature_name(args.feature_name, "--feature-name")
    limit = max_bytes(args)
    if limit is not None and detect_format(args.file) != "qif":
        raise InvalidInputError("--max-mb", "a QIF file (the limit applies to QIF files)", str(args.file))
    data = load_feature_points(args.file, element=element, feature=args.feature, decimal=args.decimal,
                               max_bytes=limit, spell_setting=cli_setting)
    compensated = None if args.compensated is None else args.compensated == "yes"  # the library's bool
    radius, source = probe_radius_to_apply(data, compensated=compensated, probe_radius=args.probe_radius,
                                           spell_setting=cli_setting)
    if args.material_side is not None and radius == 0:
        raise InvalidInputError("--material-side", "a probe radius to apply (--probe-radius-mm or probe centres in the "
                                "file)", "surface points")
    if getattr(args, "two_d", False):
        if 2 not in SPECS[element].dims:  # the planar elements: line, circle
            raise InvalidInputError("--two-d", "element line or circle", element)
        data = dataclasses.replace(data, points=data.points[:, :2],
                                   normals=None if data.normals is None else data.normals[:, :2],
                                   reported_normal=None if data.reported_normal is None else data.reported_normal[:2])
    return FitInput(data, data.points, radius, source)


def write_qif_result(args: argparse.Namespace, fit: Any, element: Element, source: Any, *, radius: float,
                     compensation: Any = None, evaluation: Any = None) -> tuple[str, list[str]]:
    """Write the fit (and form evaluation) as a QIF document to ``args.qif``.

    A feature of a QIF file keeps what the file states about it (:func:`pcmm_geo.cmm.export.file_feature`),
    except its nominal placement after ``--two-d`` (the 2-D fit lies in z = 0, the file's nominal does not).

    Returns
    -------
    path : str
        The file written.
    lines : list of str
        What was kept from the file and what not (empty for a point file).
    """
    import dataclasses as dc

    from pcmm_geo.cmm.export import fit_results_document
    from pcmm_geo.io.cmm import write_qif

    kept = source.file_feature
    notes: list[str] = []
    if kept is not None and getattr(args, "two_d", False) and kept.nominal is not None:
        kept = dc.replace(kept, nominal=None)
        notes.append("QIF: the file's nominal placement is not written with a 2-D fit (it lies in z = 0)")
    document = fit_results_document(fit, element, points=source.points, normals=source.normals, probe_radius=radius,
                                    compensation=compensation, evaluation=evaluation,
                                    name=getattr(args, "feature_name", None), from_file=kept, source=str(args.file))
    path = str(write_qif(document, args.qif, overwrite=bool(getattr(args, "overwrite", False))))
    if kept is not None:
        notes += _kept_lines(document, kept, element)
    return path, notes


def _kept_lines(document: Any, kept: Any, element: Element) -> list[str]:
    """One line on what of the file's feature the QIF written keeps."""
    if kept.type != element:
        return [f"QIF: only the name is kept from the file's {kept.type} feature (fitted as a {element})"]
    feature = document.measured_features[0]
    parts = []
    definition = document.definition_of(feature)
    if definition is not None:
        facts = ([] if definition.diameter is None else [f"diameter {definition.diameter:g} mm"]) + (
            [] if definition.internal_external is None else [f"InternalExternal {definition.internal_external}"])
        parts.append("nominal" + (f" ({', '.join(facts)})" if facts else ""))
    size_char = next((c for c in document.characteristics if c.tolerance is not None and c.nominal is not None), None)
    if size_char is not None:
        lower, upper = size_char.tolerance.limits(size_char.nominal)
        shown = " to ".join("-" if v is None else f"{v:g}" for v in (lower, upper))
        parts.append(f"size characteristic {size_char.name} (nominal {size_char.nominal:g} mm, limits {shown} mm; "
                     "status NOT_ANALYZED)")
    lines = [f"QIF feature {feature.name}: kept from the file: {'; '.join(parts) if parts else 'the name only'}"]
    return lines + [f"QIF: {note}" for note in kept.notes]
