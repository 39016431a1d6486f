"""``pcmm qif show|verify|validate FILE``: what a QIF file holds, a second opinion on its results, its schema check."""

from __future__ import annotations

import argparse
from typing import Any

from pcmm_geo.cli._cmm_input import add_max_mb_option, cli_setting, max_bytes
from pcmm_geo.cli._output import (
    EXIT_FAILURE,
    Report,
    Table,
    add_json_flag,
    add_overwrite_flag,
    add_plot_flag,
    add_report_flag,
    refuse_renamed_options,
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "qif",
        help="QIF 3.0 results files: show what one holds, verify its results by refitting, validate it",
        description="Read a QIF 3.0 results file (ISO 23952) from an external CMM. The file is untrusted: DTDs, "
                    "entities and external references are refused, depth and size are bounded.",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    show = actions.add_parser("show", help="list the features, point sets and characteristics of a QIF file "
                              "(or a DMIS output, a CALYPSO table)")
    show.add_argument("file", help="QIF results file (or DMIS output .dmo, CALYPSO *_chr.txt)")
    _add_limits(show)
    add_report_flag(show)
    add_overwrite_flag(show)
    add_json_flag(show)
    show.set_defaults(handler=_handle_show)

    verify = actions.add_parser(
        "verify",
        help="refit every measured feature from its points and compare with the CMM's results",
        description="Refit every feature measurement that has points (the file's fitting algorithm, else "
                    "least squares; a 3-D circle in the least-squares plane of its points), compensate the probe "
                    "radius, bring points and actuals into the file's common frame and compare diameter, location "
                    "and direction with what the CMM reported. Then recompute every characteristic the file holds "
                    "the inputs for (sizes, position in the datum reference frame of the datum features' actuals, with "
                    "the datum shift of datums at MMB, point profiles, linear coordinates, distances, angles, form, "
                    "orientation, runout, coaxiality and profile from points) and compare it with "
                    "the reported value (agrees within --characteristic-fraction of its tolerance, at least 1 µm). "
                    "Exit status 0 when at least one feature or characteristic was compared and none disagrees; 1 "
                    "when a feature or a characteristic disagrees or when nothing could be compared (no feature "
                    "with points, compensation unknown, no characteristic computable: the file is not verified); 2 "
                    "on bad input.",
    )
    verify.add_argument("file", help="QIF results file")
    verify.add_argument("--tolerance-mm", type=float, metavar="MM", default=None,
                        help="largest difference that agrees, mm (default 0.0001); angles by MM / feature size")
    verify.add_argument("--criterion", choices=("gaussian", "chebyshev", "mcc", "mic"),
                        help="refit with this criterion instead of the file's (least squares, minimum zone, "
                             "minimum circumscribed, maximum inscribed)")
    verify.add_argument("--circle-plane", choices=("least-squares", "reported"), default="least-squares",
                        help="plane of a 3-D circle: the least-squares plane of its points (default) or the plane "
                             "the CMM reported (its working plane)")
    verify.add_argument("--compensated", choices=("yes", "no"),
                        help="for point sets without a Compensated flag: are the points surface points?")
    verify.add_argument("--probe-radius-mm", dest="probe_radius", type=float, metavar="MM",
                        help="probe radius in mm, overriding the file's")
    verify.add_argument("--material-side", choices=("internal", "external"),
                        help="material side of the circles, cylinders, spheres and cones whose file states none (a "
                             "side the file contradicts is refused); without it their centres and axes are still "
                             "compared, their diameters not")
    verify.add_argument("--characteristic-fraction", type=float, metavar="F", default=None,
                        help="a characteristic agrees when it differs by at most F x its tolerance width "
                             "(default 0.01), at least 1 µm (1 µrad)")
    refuse_renamed_options(verify, {"--probe-radius": "--probe-radius-mm"})
    _add_limits(verify)
    _add_qif_output(verify)
    add_plot_flag(verify, "each compared difference against its agreement tolerance, per feature, and each "
                          "recomputed characteristic against its agreement bound")
    add_report_flag(verify)
    add_overwrite_flag(verify)
    add_json_flag(verify)
    verify.set_defaults(handler=_handle_verify)

    validate = actions.add_parser(
        "validate",
        help="check a QIF file against the QIF 3.0 XML schema (shipped with pcmm_geo)",
        description="Validate a QIF file against the QIF 3.0 XML schema (ISO 23952; the schema ships with pcmm_geo) "
                    "with lxml. Exit status 0 when the file is valid, 1 when it is not (the first errors are listed "
                    "with their line numbers), 2 when it cannot be read, is not well-formed XML or is refused as "
                    "hostile (a DTD, entities, nesting deeper than 2048, larger than --max-mb, more elements than "
                    "--max-elements).",
    )
    validate.add_argument("file", help="QIF file")
    add_max_mb_option(validate, "QIF file checked")
    _add_max_elements(validate)
    validate.add_argument("--errors", type=int, metavar="N", default=10,
                          help="how many schema errors to list (default 10; --json lists all)")
    add_json_flag(validate)
    validate.set_defaults(handler=_handle_validate)


def _add_limits(parser: argparse.ArgumentParser) -> None:
    add_max_mb_option(parser, "file read (QIF; DMIS output and CALYPSO tables: default 32 MiB)")
    _add_max_elements(parser)
    parser.add_argument("--format", choices=("qif", "dmis", "calypso"),
                        help="the file's format (default: told by its content, e.g. a GEOPAK report saved as .txt)")
    text = parser.add_argument_group("files that may not state their units (DMIS output, CALYPSO tables, QIF "
                                     "without FileUnits)")
    text.add_argument("--units", choices=("mm", "cm", "m", "inch", "feet"),
                      help="length unit of the file (a CALYPSO table: mm or inch)")
    text.add_argument("--angle-unit", choices=("degree", "radian"), help="angle unit of the file")
    text.add_argument("--size-values", choices=("actual", "deviation"),
                      help="DMIS: the number of a size tolerance result is the actual size or its deviation")
    text.add_argument("--encoding", default="utf-8", help="text encoding (Windows software: often cp1252)")


def _add_max_elements(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--max-elements", metavar="N", default=None,
                        help="QIF: most XML elements read (default 1000000, some 250 MB of tree; a file with more "
                             "is refused before it fills the memory)")


def _max_elements(args: argparse.Namespace) -> int | None:
    """``--max-elements`` checked (None: the reader's default)."""
    from pcmm_geo.errors import InvalidInputError

    text = getattr(args, "max_elements", None)
    if text is None:
        return None
    try:
        value = int(str(text).strip())
    except ValueError:
        value = 0
    if not 0 < value <= 10**9:
        raise InvalidInputError("--max-elements", "a positive whole number of XML elements (at most 10^9)", repr(text))
    return value


def _read(args: argparse.Namespace, definitions: bool = False) -> Any:
    """The file's document and, with ``definitions`` and a QIF file, its characteristic definitions: one parse."""
    from pcmm_geo.cmm.files import read_cmm_document_and_definitions

    document, read = read_cmm_document_and_definitions(
        args.file, units=args.units, angle_unit=args.angle_unit, size_values=args.size_values,
        encoding=args.encoding, max_bytes=max_bytes(args), spell_setting=cli_setting, format=args.format,
        max_elements=_max_elements(args), definitions=definitions)
    return (document, read) if definitions else document


def _vector(value: Any) -> list[float]:
    return [] if value is None else [float(v) for v in value]


def _handle_show(args: argparse.Namespace) -> Report:
    from pcmm_geo.errors import PcmmGeoError

    document = _read(args)
    point_sets = document.point_sets
    sample_of = _samples(document)
    feature_rows = []
    features = []
    for feature in document.measured_features:
        try:
            points = document.points_of(feature, frame="stored")
        except PcmmGeoError:  # listed as unusable; the reason is in the file's problems
            points = None
        actual = feature.actual
        location = _vector(actual.location)
        feature_rows.append([feature.id, _named(feature.name, sample_of.get(feature.results_id)), feature.type,
                             0 if points is None else len(points),
                             "-" if points is None or points.compensated is None else points.compensated,
                             "-" if points is None or points.probe_radius is None else points.probe_radius,
                             (feature.internal_external or "-").lower(),
                             "-" if actual.diameter is None else actual.diameter,
                             *(location or ["-", "-", "-"])])
        features.append({"id": feature.id, "type": feature.type, "name": feature.name,
                         "sample": sample_of.get(feature.results_id),
                         "n_points": 0 if points is None else len(points),
                         "internal_external": feature.internal_external,
                         "substitute_algorithm": feature.substitute_algorithm,
                         "actual": {key: value for key, value in (("diameter_mm", actual.diameter),
                                                                   ("location_mm", _vector(actual.location) or None),
                                                                   ("normal", _vector(actual.normal) or None),
                                                                   ("direction", _vector(actual.direction) or None),
                                                                   ("half_angle_rad", actual.half_angle),
                                                                   ("form_mm", actual.form)) if value is not None},
                         "problems": list(feature.problems)})
    set_rows = []
    sets = []
    for set_id, point_set in point_sets.items():
        frame = "common" if point_set.transform_id is None and point_set.coordinate_system_id is None else \
            f"transform {point_set.transform_id}" if point_set.transform_id is not None else \
            f"coordinate system {point_set.coordinate_system_id}"
        compensated = point_set.compensated if point_set.compensated_per_point is None else "per point"
        radius = point_set.probe_radius if point_set.probe_radii is None else "per point"
        set_rows.append([set_id, len(point_set), "-" if compensated is None else compensated,
                         "-" if radius is None else radius, point_set.normals is not None, frame])
        sets.append({"id": set_id, "count": len(point_set), "compensated": compensated, "probe_radius_mm": radius,
                     "normals": point_set.normals is not None, "frame": frame})
    char_rows = []
    characteristics = []
    for characteristic in document.characteristics:
        lower, upper = (None, None) if characteristic.tolerance is None else \
            characteristic.tolerance.limits(characteristic.nominal)
        names = _feature_names(document, characteristic)
        # the feature measurements by QIF id; a table without measurements (CALYPSO) by the features it names
        features_cell = " ".join(str(i) for i in characteristic.feature_measurement_ids) or \
            ", ".join(name for name in names if name) or "-"
        char_rows.append([characteristic.id, _named(characteristic.name, sample_of.get(characteristic.results_id)),
                          characteristic.type,
                          _cell(characteristic.value), _cell(characteristic.nominal), _cell(lower), _cell(upper),
                          characteristic.quantity, characteristic.status or "-", features_cell])
        characteristics.append({"id": characteristic.id, "type": characteristic.type, "name": characteristic.name,
                                "sample": sample_of.get(characteristic.results_id),
                                "value": characteristic.value, "nominal": characteristic.nominal,
                                "lower_limit": lower, "upper_limit": upper, "quantity": characteristic.quantity,
                                "status": characteristic.status,
                                "feature_measurement_ids": list(characteristic.feature_measurement_ids),
                                "feature_item_ids": list(characteristic.feature_item_ids), "feature_names": names})
    units = document.units
    data = {"file": document.source, "format": document.format, "version": document.version,
            "application": document.application,
            "units": {"linear_unit": units.linear_unit, "mm_per_linear_unit": units.mm_per_linear_unit,
                      "angular_unit": units.angular_unit, "stated": units.stated},
            "results": [{"id": results.id, "sample": sample_of.get(results.id),
                         "serial_numbers": list(results.serial_numbers),
                         "inspection_status": results.inspection_status} for results in document.results],
            "features": features, "point_sets": sets, "characteristics": characteristics,
            "problems": list(document.problems)}
    result_rows = [[results.id, sample_of.get(results.id) or "-", ", ".join(results.serial_numbers) or "-",
                    results.inspection_status or "-"] for results in document.results
                   if len(document.results) > 1 or results.inspection_status or results.serial_numbers]
    tables = [
        Table("Measurement results (samples)", ["id", "sample", "serial numbers", "inspection status"], result_rows),
        Table(f"Measured features of {document.source}",
              ["id", "name", "type", "points", "compensated", "probe radius / mm", "side", "diameter / mm",
               "x / mm", "y / mm", "z / mm"], feature_rows),
        Table("Measured point sets", ["id", "points", "compensated", "probe radius / mm", "normals", "frame"],
              set_rows),
        Table("Characteristics (lengths in mm, angles in rad)",
              ["id", "name", "type", "value", "nominal", "lower limit", "upper limit", "quantity", "status",
               "features"], char_rows),
    ]
    origin = f"QIF {document.version or '(version not stated)'}" if document.format == "qif" else \
        document.format.upper()
    unit_text = f"file units {units.linear_unit}" if units.stated else \
        f"units not stated in the file, read as {units.linear_unit}"
    lines = [f"{origin} written by {document.application or 'unknown'}; {unit_text}"
             + ("" if units.mm_per_linear_unit == 1.0 else " (converted to mm)")]
    lines += [f"left out: {problem}" for problem in document.problems]
    return Report(data=data, tables=[t for t in tables if t.rows], lines=lines)


def _samples(document: Any) -> dict[Any, str]:
    """Results id -> how a multi-sample file's rows name their sample: its serial numbers, else its number."""
    if len(document.results) < 2:
        return {}
    return {results.id: ", ".join(results.serial_numbers) or f"sample {number}"
            for number, results in enumerate(document.results, start=1)}


def _named(name: str | None, sample: str | None) -> str:
    return (name or "-") if sample is None else f"{name or '-'} [{sample}]"


def _feature_names(document: Any, characteristic: Any) -> list[str | None]:
    """Names of the features a characteristic is about: its feature items', else its measurements'."""
    if characteristic.feature_item_ids:
        items = [document.feature_items.get(i) for i in characteristic.feature_item_ids]
        return [None if item is None else item.name for item in items]
    measured = {feature.id: feature for feature in document.measured_features}
    return [None if measured.get(i) is None else measured[i].name for i in characteristic.feature_measurement_ids]


def _cell(value: Any) -> Any:
    return "-" if value is None else value


def _micro(value: Any, factor: float = 1000.0) -> Any:
    return "-" if value is None else factor * float(value)


def _shown(check: Any, name: str, factor: float) -> Any:
    """A difference in µm / µrad; in parentheses when it did not decide the feature's agreement."""
    value = check.difference.get(name)
    if value is None:
        return "-"
    scaled = factor * float(value)
    return scaled if name in check.compared else f"({scaled:.6g})"


def _add_qif_output(verify: argparse.ArgumentParser) -> None:
    """``qif verify --qif OUT.qif``: every refitted feature in one QIF results document."""
    from pcmm_geo.cli._output import declare_output

    verify.add_argument("--qif", metavar="OUT.qif",
                        help="also write every refitted feature as a QIF 3.0 results document: the refits with the "
                             "file's names, nominals, InternalExternal and size tolerances, and its points")
    declare_output(verify, "qif")


def _write_refits(args: argparse.Namespace, document: Any, result: Any) -> tuple[str, str]:
    """Write the refits of ``result`` to ``args.qif``; the path and one line saying what was written."""
    from pcmm_geo.cmm.export import verification_document
    from pcmm_geo.io.cmm import write_qif

    written = verification_document(document, result)
    path = str(write_qif(written, args.qif, overwrite=bool(args.overwrite)))
    n, left = len(written.measured_features), len(result.features) - len(written.measured_features)
    return path, (f"QIF: {n} refitted feature(s) written to {path} ({len(written.feature_items)} with the file's "
                  f"nominal){f'; {left} not refitted, left out' if left else ''}")


def _handle_verify(args: argparse.Namespace) -> Report:
    import math

    from pcmm_geo.cli._record import Verdict
    from pcmm_geo.cmm.verify import DEFAULT_TOLERANCE_MM, verify_document
    from pcmm_geo.errors import InvalidInputError

    tolerance = DEFAULT_TOLERANCE_MM if args.tolerance_mm is None else args.tolerance_mm
    if args.probe_radius is not None and not (math.isfinite(args.probe_radius) and args.probe_radius > 0):
        raise InvalidInputError("--probe-radius-mm", "a positive probe radius (mm)", repr(args.probe_radius))
    document, definitions = _read(args, definitions=True)
    compensated = None if args.compensated is None else args.compensated == "yes"
    result = verify_document(document, tolerance_mm=tolerance, criterion=args.criterion,
                             circle_plane=args.circle_plane, compensated=compensated, probe_radius=args.probe_radius,
                             material_side=args.material_side, spell_setting=cli_setting)
    characteristics = _verify_characteristics(args, document, definitions, compensated)
    rows = []
    for check in result.features:
        compensation = check.compensation
        if compensation is None or compensation.side == "none":
            side = "-" if compensation is None else "none (surface points)"
        elif compensation.outward is not None:
            side = "along its normal"
        else:
            side = compensation.side + (" (inferred)" if compensation.inferred else "")
        cells = [_shown(check, name, factor) for name, factor in (("diameter_mm", 1000.0),
                                                                  ("location_distance_mm", 1000.0),
                                                                  ("direction_angle_rad", 1e6))]
        rows.append([check.id, check.name or "-", check.type, check.n_points, check.method or "-", side, *cells,
                     {True: "yes", False: "NO", None: "not checked"}[check.agrees]])
    table = Table(f"Second opinion on {document.source} (tolerance {1000 * tolerance:g} µm; angles tolerance / size)",
                  ["id", "name", "type", "points", "method", "compensation", "Δ diameter / µm", "Δ location / µm",
                   "Δ direction / µrad", "agrees"], rows)
    lines = ["(values in parentheses: reported, not compared)"] if any(
        "(" in str(cell) for row in rows for cell in row[6:9]) else []
    lines += [f"{check.id} {check.name or ''}: {check.reason}" for check in result.features]
    summary = result.summary()
    statement = (f"{summary['agree']} features agree, {summary['disagree']} disagree, "
                 f"{summary['not_checked']} not checked")
    lines += [f"left out by the reader: {problem}" for problem in result.problems]
    counts = characteristics.summary()
    statement += (f"; {counts['agrees']} characteristics agree, {counts['disagrees']} disagree, "
                  f"{counts['not_computable']} not computable")
    agrees = False if result.agrees is False or characteristics.agrees is False else (
        True if result.agrees or characteristics.agrees else None)
    if agrees is None:
        statement = (f"nothing verified: {statement} (no feature could be compared with its refit, no characteristic "
                     "recomputed)")
    lines += [f"characteristic {check.id} {check.name or ''}: {check.status}: {check.reason}"
              for check in characteristics.checks if check.status != "agrees"]
    verdict = Verdict(agrees, statement,
                      f"a feature agrees when every compared quantity of its refit (diameter, location, direction) "
                      f"differs from the CMM's by at most {tolerance:g} mm (angles: {tolerance:g} mm / feature size); "
                      f"{characteristics.rule}",
                      basis="the differences between pcmm_geo's refit of each feature's points and the values the "
                            "CMM reported, and between each characteristic recomputed from the feature actuals (or "
                            "points) and its reported value; the measurement uncertainty of the points is not taken "
                            "into account")
    data = result.to_dict()
    data.update(characteristics=[check.to_dict() for check in characteristics.checks],
                characteristics_summary=counts, characteristics_rule=characteristics.rule,
                characteristics_agree=characteristics.agrees, overall_agrees=agrees)
    if args.qif:
        data["qif"], line = _write_refits(args, document, result)
        lines.append(line)
    from pcmm_geo.cli.documents import qif_verify as second_opinion  # reported vs refitted, what was checked

    verdict = Verdict(verdict.passed, verdict.statement, verdict.decision_rule, basis=verdict.basis,
                      conformity_text=second_opinion.AGREEMENT)
    scope = second_opinion.scope_statement(document, result, counts)
    plots = [second_opinion.plot(result, args.plot, args.overwrite, characteristics)] if args.plot else []
    tables = [t for t in (table, _characteristic_table(characteristics)) if t.rows]
    return Report(data=data, tables=tables, lines=[*lines, scope] if agrees is None else lines,
                  exit_code=0 if agrees is True else EXIT_FAILURE, verdict=verdict, plots=plots,
                  console=[f"plot written to {p}" for p in plots],
                  report_tables=[second_opinion.values_table(result)], statements=[("What was checked", scope)],
                  environment=[second_opinion.NO_TEMPERATURE])


def _verify_characteristics(args: argparse.Namespace, document: Any, definitions: Any,
                            compensated: bool | None) -> Any:
    """Second opinion on the characteristics (:func:`pcmm_geo.gdt.qif.characteristics.verify_characteristics`).

    ``definitions`` come from the same parse as ``document`` (None: not a QIF file).
    """
    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.gdt.qif.characteristics import DEFAULT_FRACTION, verify_characteristics

    fraction = DEFAULT_FRACTION if args.characteristic_fraction is None else args.characteristic_fraction
    if not 0.0 < fraction <= 1.0:  # also refuses nan
        raise InvalidInputError("--characteristic-fraction", "a fraction of the tolerance in (0, 1]", repr(fraction))
    return verify_characteristics(document, definitions, fraction=fraction, compensated=compensated,
                                  probe_radius=args.probe_radius)


def _characteristic_table(verification: Any) -> Table:
    rows = [[check.id, check.name or "-", check.type, check.unit, _cell(check.reported), _cell(check.recomputed),
             check.status] for check in verification.checks]
    return Table("Characteristics: reported and recomputed (mm or rad)",
                 ["id", "name", "type", "unit", "reported", "recomputed", "status"], rows)


def _handle_validate(args: argparse.Namespace) -> Report:
    import re

    from pcmm_geo.errors import InvalidInputError
    from pcmm_geo.io.cmm import DEFAULT_MAX_BYTES, validate_qif
    from pcmm_geo.io.cmm.qif.reader import QIF3_NAMESPACE

    if args.errors < 1:
        raise InvalidInputError("--errors", "a positive number of errors to list", repr(args.errors))
    limit = max_bytes(args)
    namespace = "{" + QIF3_NAMESPACE + "}"  # element names are all in it: shown without it
    elements = _max_elements(args)
    bounds = {} if elements is None else {"max_elements": elements}
    errors = tuple(error.replace(namespace, "") for error in
                   validate_qif(args.file, max_bytes=DEFAULT_MAX_BYTES if limit is None else limit,
                                spell_setting=cli_setting, **bounds))
    listed = []
    for error in errors:
        match = re.match(r"line (\d+): (.*)", error, re.DOTALL)
        listed.append({"line": int(match.group(1)), "message": match.group(2)} if match else
                      {"line": None, "message": error})
    data = {"file": args.file, "schema": "QIF 3.0", "valid": not errors, "n_errors": len(errors), "errors": listed}
    if not errors:
        return Report(data=data, lines=[f"{args.file}: valid QIF 3.0"])
    shown = errors[:args.errors]
    lines = [f"{args.file}: not valid QIF 3.0, {len(errors)} schema error{'s' if len(errors) > 1 else ''}"
             + (f" (the first {len(shown)} listed)" if len(shown) < len(errors) else "")]
    lines += [f"  {error}" for error in shown]
    return Report(data=data, lines=lines, exit_code=EXIT_FAILURE)
