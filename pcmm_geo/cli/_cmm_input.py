"""Options shared by ``pcmm fit`` and ``pcmm form`` for files from CMMs: which feature, probe compensation, QIF out.

``--feature`` picks the feature of a QIF file; ``--probe-radius-mm``, ``--material-side`` and
``--compensated`` say how the probe radius is applied (:mod:`pcmm_geo.cmm.points`); ``--qif OUT``
writes the result as a QIF 3.0 results document through the command's output plan.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from pcmm_geo.cli._output import declare_output, refuse_renamed_options


def add_cmm_input_flags(parser: argparse.ArgumentParser) -> None:
    """Add ``--feature``, ``--probe-radius-mm``, ``--material-side``, ``--compensated`` and ``--qif``."""
    parser.add_argument("--feature", metavar="ID|NAME",
                        help="QIF file: the feature measurement (QIF id or name) whose points are used, when the file "
                             "holds several")
    parser.add_argument("--probe-radius-mm", dest="probe_radius", type=float, metavar="MM",
                        help="the points are probe-ball centres of this radius (mm): the fitted element is offset "
                             "onto the touched surface (a fixed --radius-mm is the surface radius)")
    refuse_renamed_options(parser, {"--probe-radius": "--probe-radius-mm"})
    parser.add_argument("--material-side", choices=("internal", "external"),
                        help="circle, sphere, cylinder, cone: internal (hole) or external (boss, shaft); default "
                             "from the file (InternalExternal, point normals, nominal size)")
    parser.add_argument("--compensated", choices=("yes", "no"),
                        help="are the points surface points (yes) or probe centres (no)? Required for formats that "
                             "do not say (a PC-DMIS XYZIJK export, recognised by its first line); checked against "
                             "QIF's Compensated flag")
    parser.add_argument("--qif", metavar="OUT.qif", help="also write the result as a QIF 3.0 results document")
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


def read_fit_input(args: argparse.Namespace, element: str) -> FitInput:
    """Read FILE for ``element`` (QIF feature, XYZIJK or point file) and decide the probe radius to apply."""
    from pcmm_geo.cmm.points import load_feature_points, probe_radius_to_apply
    from pcmm_geo.errors import InvalidInputError

    data = load_feature_points(args.file, element=element, feature=args.feature, decimal=args.decimal)
    radius, source = probe_radius_to_apply(data, compensated=args.compensated, probe_radius=args.probe_radius)
    if args.material_side is not None and radius == 0:
        raise InvalidInputError("--material-side", "a probe radius to apply (--probe-radius-mm or probe centres in the "
                                "file)", "surface points")
    if getattr(args, "two_d", False):
        if element not in ("line", "circle"):
            raise InvalidInputError("--two-d", "element line or circle", element)
        data = dataclasses.replace(data, points=data.points[:, :2],
                                   normals=None if data.normals is None else data.normals[:, :2],
                                   reported_normal=None if data.reported_normal is None else data.reported_normal[:2])
    return FitInput(data, data.points, radius, source)


def compensation_summary(compensation: Any, side_source: str, radius_source: str) -> tuple[dict[str, Any], str]:
    """JSON object and one text line describing an applied probe compensation."""
    side = compensation.side
    data = {"probe_radius_mm": compensation.probe_radius, "side": side, "side_source": side_source,
            "inferred": compensation.inferred, "method": compensation.method, "radius_source": radius_source}
    if compensation.outward is not None:
        data["outward_normal"] = compensation.outward.tolist()
        where = f"outward normal from {side_source}"
    else:
        where = f"material side {side}" + (" (inferred)" if compensation.inferred else "") + f" from {side_source}"
    line = (f"probe compensation: radius {compensation.probe_radius:.6g} mm ({radius_source}), {where}; "
            "the element fitted to the probe centres is offset onto the surface")
    return data, line


def write_qif_result(args: argparse.Namespace, fit: Any, element: str, source: Any, *, radius: float,
                     compensation: Any = None, evaluation: Any = None) -> str:
    """Write the fit (and form evaluation) as a QIF document to ``args.qif``; returns the path written."""
    from pcmm_geo.cmm.export import fit_results_document
    from pcmm_geo.io.cmm import write_qif

    name = source.feature.name if source.feature is not None and source.feature.name else None
    document = fit_results_document(fit, element, points=source.points, normals=source.normals, probe_radius=radius,
                                    compensation=compensation, evaluation=evaluation, name=name,
                                    source=str(args.file))
    return str(write_qif(document, args.qif, overwrite=bool(getattr(args, "overwrite", False))))
