"""Who, what, when and against what a ``--report`` was made: the identity of a lab record (ISO/IEC 17025 7.8).

Every command with ``--report`` takes the options of :func:`add_identity_flags`:
``--report-id`` (the laboratory's own numbering; otherwise a unique id is generated),
``--laboratory``, ``--operator``, ``--approved-by``, ``--customer``, ``--item``,
``--instrument``, ``--reference`` (a reference standard with its certificate and calibration
uncertainty, repeatable), ``--measurement-date``, ``--supersedes`` (an amended report names the
one it replaces) and ``--config``.  The same keys, spelled as the options (``laboratory``,
``operator``, ``approved-by`` -- ``approved_by`` works too --, ``customer``, ``item``,
``instrument``, ``[[reference]]`` tables and an ``[environment]`` table of the conditions
the laboratory recorded) can be kept in a ``pcmm.toml`` in the working folder or in the file ``--config`` names;
an option given on the command line wins over the file.  ``pcmm.toml`` is untrusted input:
bounded in size, every key checked, an unknown key or a wrong type refused naming the file
once and then the key (docs/guide/pcmm_toml.rst).

Example ``pcmm.toml``::

    laboratory = "Dimensional Metrology Laboratory, 1 Example Road, Stellenbosch"
    operator = "A. Operator"
    approved-by = "B. Approver"
    instrument = "micro-CMM serial 001"

    [[reference]]
    name = "gauge block 100 mm, steel, grade K"
    certificate = "CAL-2025-0417"
    U_um = 0.05
    k = 2
    calibrated = "2025-04-17"

    [environment]
    "air temperature" = "20.1 °C ± 0.2 K"
"""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import dataclass
from datetime import UTC, date, datetime
from pathlib import Path
from typing import Any

from pcmm_geo.cli._record import Condition, Method

#: the name looked for in the working folder when ``--config`` is not given
CONFIG_NAME = "pcmm.toml"
#: a configuration file larger than this is refused (it holds a few lines of text)
MAX_CONFIG_BYTES = 64 * 1024
#: free-text identity fields: (option, key in pcmm.toml and in :class:`ReportIdentity`, label)
TEXT_FIELDS = (
    ("--laboratory", "laboratory", "laboratory"),
    ("--customer", "customer", "customer"),
    ("--item", "item", "item measured"),
    ("--instrument", "instrument", "measuring instrument"),
    ("--operator", "operator", "operator"),
    ("--approved-by", "approved_by", "approved by"),
)
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._/-]{0,63}")
_MAX_TEXT = 500
_REFERENCE_KEYS = {"name", "certificate", "U_um", "U_mm", "k", "calibrated"}
STATEMENT = "The results relate only to the item measured, as received, under the conditions stated."


@dataclass(frozen=True)
class ReferenceStandard:
    """A reference standard a result is traced to: what it is, its certificate and its calibration U.

    Attributes
    ----------
    name : str
    certificate : str
        Certificate number (and issuer).
    expanded_uncertainty : float
        Its calibration uncertainty U in ``unit``.
    unit : str
        ``"µm"`` or ``"mm"``.
    coverage_factor : float
    calibrated : str
        Calibration date (ISO 8601) or empty.
    """

    name: str
    certificate: str
    expanded_uncertainty: float
    unit: str
    coverage_factor: float = 2.0
    calibrated: str = ""

    def uncertainty_text(self) -> str:
        """``"U = 0.05 µm (k = 2)"``."""
        return f"U = {self.expanded_uncertainty:g} {self.unit} (k = {self.coverage_factor:g})"


@dataclass(frozen=True)
class ReportIdentity:
    """Everything that identifies one report: id, parties, item, dates, references, conditions."""

    report_id: str
    generated_id: bool
    measurement_date: str
    laboratory: str = ""
    customer: str = ""
    item: str = ""
    instrument: str = ""
    operator: str = ""
    approved_by: str = ""
    supersedes: str = ""
    references: tuple[ReferenceStandard, ...] = ()
    environment: tuple[Condition, ...] = ()
    config: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``report_id``, parties, dates, references)."""
        out: dict[str, Any] = {"report_id": self.report_id, "measurement_date": self.measurement_date}
        out.update({key: getattr(self, key) for _, key, _ in TEXT_FIELDS if getattr(self, key)})
        if self.supersedes:
            out["supersedes"] = self.supersedes
        out["references"] = [
            {"name": r.name, "certificate": r.certificate, "expanded_uncertainty": r.expanded_uncertainty,
             "unit": r.unit, "coverage_factor": r.coverage_factor, "calibrated": r.calibrated}
            for r in self.references]
        return out


def add_identity_flags(parser: argparse.ArgumentParser) -> None:
    """Add the report identity options (used only with ``--report``) in their own help group."""
    group = parser.add_argument_group(
        "report identity (ISO/IEC 17025 7.8; with --report only; defaults from ./pcmm.toml or --config)")
    group.add_argument("--report-id", metavar="ID",
                       help="the laboratory's report number (default: a generated unique id)")
    for option, key, label in TEXT_FIELDS:
        group.add_argument(option, dest=f"identity_{key}", metavar="TEXT", help=f"{label}, as printed in the report")
    group.add_argument("--reference", dest="reference_standards", action="append", metavar="SPEC",
                       help="reference standard, 'name=...;certificate=...;U_um=...[;k=2][;calibrated=DATE]' "
                            "(U_mm for millimetres); repeatable")
    group.add_argument("--measurement-date", metavar="DATE",
                       help="date(s) the data were measured, ISO 8601: 2026-11-20 or 2026-11-20/2026-11-21")
    group.add_argument("--supersedes", metavar="ID", help="id of the report this one amends and replaces")
    group.add_argument("--config", metavar="PCMM.toml",
                       help=f"identity defaults (default: ./{CONFIG_NAME} when it exists)")


def _invalid(what: str, needed: str, got: object) -> Exception:
    from pcmm_geo.errors import InvalidInputError

    return InvalidInputError(what, needed, repr(got))


def _text(what: str, value: object) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > _MAX_TEXT or "\x00" in value:
        raise _invalid(what, f"text of 1 to {_MAX_TEXT} characters", value)
    return " ".join(value.split())


def _date(what: str, value: str) -> str:
    parts = value.split("/")
    if len(parts) > 2:
        raise _invalid(what, "an ISO 8601 date or a range DATE/DATE", value)
    try:
        days = [date.fromisoformat(part) for part in parts]
    except ValueError:
        raise _invalid(what, "an ISO 8601 date (YYYY-MM-DD) or a range DATE/DATE", value) from None
    if len(days) == 2 and days[1] < days[0]:
        raise _invalid(what, "a range that ends after it starts", value)
    return "/".join(day.isoformat() for day in days)


def _report_id(what: str, value: str) -> str:
    if not _ID.fullmatch(value):
        raise _invalid(what, "1 to 64 letters, digits, '.', '_', '/' or '-', starting with a letter or digit",
                       value)
    return value


def _reference(what: str, entries: dict[str, Any]) -> ReferenceStandard:
    unknown = set(entries) - _REFERENCE_KEYS
    if unknown:
        raise _invalid(what, f"keys among {sorted(_REFERENCE_KEYS)}", sorted(unknown)[0])
    missing = [key for key in ("name", "certificate") if key not in entries]
    if missing or ("U_um" in entries) == ("U_mm" in entries):
        raise _invalid(what, "name, certificate and one of U_um or U_mm (the calibration uncertainty)",
                       ", ".join(sorted(entries)) or "nothing")
    unit_key = "U_um" if "U_um" in entries else "U_mm"

    def number(key: str, value: Any) -> float:
        try:
            result = float(value)
        except (TypeError, ValueError):
            raise _invalid(f"{what} {key}", "a number", value) from None
        if not math.isfinite(result) or result <= 0 or isinstance(value, bool):
            raise _invalid(f"{what} {key}", "a positive number", value)
        return result

    calibrated = entries.get("calibrated", "")
    if isinstance(calibrated, (date, datetime)):
        calibrated = calibrated.isoformat()
    return ReferenceStandard(
        name=_text(f"{what} name", entries["name"]),
        certificate=_text(f"{what} certificate", entries["certificate"]),
        expanded_uncertainty=number(unit_key, entries[unit_key]),
        unit="µm" if unit_key == "U_um" else "mm",
        coverage_factor=number("k", entries.get("k", 2.0)),
        calibrated=_date(f"{what} calibrated", str(calibrated)) if calibrated else "",
    )


def parse_reference(spec: str) -> ReferenceStandard:
    """A ``--reference`` value, ``name=...;certificate=...;U_um=...[;k=2][;calibrated=DATE]``.

    Raises
    ------
    InvalidInputError
        A part without ``=``, an unknown or missing key, a U that is not a positive number.

    Examples
    --------
    >>> parse_reference("name=sphere 25 mm;certificate=CAL-7;U_um=0.08;calibrated=2025-01-10").uncertainty_text()
    'U = 0.08 µm (k = 2)'
    """
    entries: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in spec.split(";"))):
        key, sep, value = part.partition("=")
        if not sep or key.strip() in entries:
            raise _invalid("--reference", "parts KEY=VALUE separated by ';', each key once", part)
        entries[key.strip()] = value.strip()
    return _reference("--reference", entries)


def load_config(path: str | Path) -> dict[str, Any]:
    """The identity defaults of a ``pcmm.toml``, checked key by key.

    Raises
    ------
    FileFormatError
        Not TOML, too large, an unknown key or a value of the wrong type (the message names the key).
    OSError
        The file cannot be read.
    """
    import tomllib

    from pcmm_geo.errors import FileFormatError, PcmmGeoError

    source = Path(path)
    raw = source.read_bytes()[: MAX_CONFIG_BYTES + 1]
    if len(raw) > MAX_CONFIG_BYTES:
        raise FileFormatError(str(source), f"expected at most {MAX_CONFIG_BYTES} bytes of identity settings")
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise FileFormatError(str(source), f"expected UTF-8 TOML, got {exc}") from None
    data = _flag_spelling(source, data, "")
    allowed = [option.removeprefix("--") for option, _, _ in TEXT_FIELDS] + ["reference", "environment"]
    unknown = sorted(set(data) - {key.replace("-", "_") for key in allowed})
    if unknown:
        raise FileFormatError(str(source), f"unknown key {unknown[0].replace('_', '-')!r}: expected keys among "
                              f"{', '.join(allowed)} (spelled as the options; underscores work too)")
    out: dict[str, Any] = {}
    try:
        for _, key, _ in TEXT_FIELDS:
            if key in data:
                out[key] = _text(key.replace("_", "-"), data[key])
        references = data.get("reference", [])
        if isinstance(references, dict):
            references = [references]
        if not isinstance(references, list) or not all(isinstance(r, dict) for r in references):
            raise _invalid("reference", "a [[reference]] table per standard", references)
        out["reference"] = [_reference(f"[[reference]] {i + 1}", _reference_keys(source, r, i + 1))
                            for i, r in enumerate(references)]
        environment = data.get("environment", {})
        if not isinstance(environment, dict):
            raise _invalid("environment", "an [environment] table of 'quantity = value'", environment)
        conditions = []
        for quantity, value in environment.items():
            if isinstance(value, bool) or not isinstance(value, (str, int, float)):
                raise _invalid(f"[environment] {quantity!r}", "text or a number", value)
            conditions.append(Condition(_text("[environment] key", quantity),
                                        value if isinstance(value, (int, float)) else
                                        _text(f"[environment] {quantity!r}", value), ""))
        out["environment"] = conditions
    except PcmmGeoError as exc:  # the file's path once, then what is wrong with which key
        raise FileFormatError(str(source), " ".join(str(exc).split())) from None
    return out


def _flag_spelling(source: Path, table: dict[str, Any], where: str) -> dict[str, Any]:
    """``table`` with its keys spelled with underscores (``approved-by`` -> ``approved_by``); both spellings refused."""
    from pcmm_geo.errors import FileFormatError

    out: dict[str, Any] = {}
    for key, value in table.items():
        name = key.replace("-", "_")
        if name in out:
            raise FileFormatError(str(source), f"{where}{key!r} is given twice (as {name.replace('_', '-')!r} and "
                                  f"{name!r}); keep one")
        out[name] = value
    return out


def _reference_keys(source: Path, table: dict[str, Any], number: int) -> dict[str, Any]:
    """A ``[[reference]]`` table with hyphenated keys accepted (``U-um`` for ``U_um``)."""
    return _flag_spelling(source, table, f"[[reference]] {number}: ")


def config_path(args: argparse.Namespace) -> Path | None:
    """The ``pcmm.toml`` this run reads: ``--config``, else ``./pcmm.toml`` when it exists, else None."""
    given = getattr(args, "config", None)
    if given:
        return Path(given)
    default = Path.cwd() / CONFIG_NAME
    return default if default.is_file() else None


def check_identity_flags(args: argparse.Namespace) -> None:
    """Refuse identity options given without ``--report`` (they would be silently lost).

    Raises
    ------
    InvalidInputError
    """
    if getattr(args, "report", None):
        return
    given = [option for option, key, _ in TEXT_FIELDS if getattr(args, f"identity_{key}", None)]
    given += [option for option, dest in (("--report-id", "report_id"), ("--reference", "reference_standards"),
                                          ("--measurement-date", "measurement_date"), ("--supersedes", "supersedes"),
                                          ("--config", "config"))
              if getattr(args, dest, None)]
    if given:
        raise _invalid(given[0], "--report FILE.md|FILE.html as well (identity is printed only in a report)",
                       "no --report")


def resolve_identity(args: argparse.Namespace, inputs: list[str] | None = None) -> ReportIdentity:
    """The identity of this run's report: options first, then ``pcmm.toml``, then generated values.

    ``inputs`` (the input paths) give the measurement date's hint when ``--measurement-date`` is
    not stated: the newest modification time among them, labelled as such.

    Raises
    ------
    InvalidInputError
        A malformed option value.
    FileFormatError
        A malformed ``pcmm.toml``.
    """
    path = config_path(args)
    config = load_config(path) if path is not None else {}
    values = {}
    for option, key, _ in TEXT_FIELDS:
        given = getattr(args, f"identity_{key}", None)
        values[key] = _text(option, given) if given else config.get(key, "")
    given_id = getattr(args, "report_id", None)
    if given_id:
        report_id = _report_id("--report-id", given_id)
    else:
        import uuid

        now = datetime.now(UTC)
        report_id = f"PCMM-{now:%Y%m%d-%H%M%S}-{uuid.uuid4().hex[:8].upper()}"
    stated = getattr(args, "measurement_date", None)
    if stated:
        measurement_date = _date("--measurement-date", stated)
    else:
        stamps = [Path(p).stat().st_mtime for p in inputs or () if Path(p).exists()]
        measurement_date = "not stated" + (
            f" (newest input file last modified {datetime.fromtimestamp(max(stamps), UTC):%Y-%m-%d} UTC)"
            if stamps else "")
    references = tuple(parse_reference(spec) for spec in getattr(args, "reference_standards", None) or ())
    supersedes = getattr(args, "supersedes", None)
    return ReportIdentity(
        report_id=report_id, generated_id=not given_id, measurement_date=measurement_date,
        supersedes=_report_id("--supersedes", supersedes) if supersedes else "",
        references=references or tuple(config.get("reference", ())),
        environment=tuple(config.get("environment", ())),
        config=str(path.resolve()) if path is not None else "",
        **values,
    )


def method_for(args: argparse.Namespace) -> Method:
    """The method of a command's result (standard and clause where one applies).

    A handler that knows better sets :attr:`pcmm_geo.cli._output.Report.method` itself.
    """
    command = getattr(args, "command", "")
    action = getattr(args, "action", None)
    if command == "iso10360-2":
        return Method("ISO 10360-2:2009", "clause 6 (acceptance test), clause 7 (compliance with specifications)",
                      "length measurement error E0 and repeatability range R0 of a CMM")
    if command == "iso10360-5":
        return Method("ISO 10360-5:2010", "clause 6 (acceptance test), clause 7 (compliance with specifications)",
                      "single-stylus probing form error P_FTU and size error P_STU on a calibrated sphere, "
                      "Gaussian sphere of the 25 points")
    if command == "iso10360-6":
        return Method("ISO 10360-6:2001", "test data sets and reference results (whole part)",
                      "errors of computed Gaussian associated features against reference results and MPEs")
    if command == "gauge-block":
        return Method("ISO 3650:1998", "clause 3 (central length of a gauge block)",
                      "central length from least-squares planes of the probed measuring faces, evaluated on a CMM")
    if command == "form":
        standards = {"line": "ISO 12780-1:2011 (straightness)", "plane": "ISO 12781-1:2011 (flatness)",
                     "circle": "ISO 12181-1:2011 (roundness)", "cylinder": "ISO 12180-1:2011 (cylindricity)"}
        element = getattr(args, "element", "")
        if element in standards:
            return Method(standards[element], "clause 3 (minimum zone reference)",
                          f"{element} form deviation as the width of the minimum (Chebyshev) zone")
        return Method("", "", f"{element} form deviation as the width of the minimum (Chebyshev) zone")
    if command == "fit":
        criterion = getattr(args, "criterion", "gaussian")
        how = {"gaussian": "least-squares (Gaussian)", "chebyshev": "minimum zone (Chebyshev)",
               "mcc": "minimum circumscribed", "mic": "maximum inscribed"}.get(criterion, criterion)
        return Method("", "", f"{how} {getattr(args, 'element', 'element')} associated to the points, orthogonal "
                      "distances (the fits are verified with ISO 10360-6 reference data: pcmm iso10360-6)")
    if command == "uncertainty":
        return Method("ISO 15530-4:2008; JCGM 101:2008", "JCGM 101 clause 7 (adaptive Monte Carlo, 7.9)",
                      "task-specific uncertainty by simulation of the calibrated micro-CMM (virtual CMM), with "
                      "the GUM (JCGM 100:2008) linear result for comparison")
    if command == "thermal" and action == "correct-length":
        return Method("ISO 1:2022; JCGM 100:2008", "clause 5 of JCGM 100 (law of propagation of uncertainty)",
                      "length corrected to the reference temperature 20 °C with its uncertainty budget")
    if command == "calibrate":
        return Method("", "", "tetrahedron calibration from external-CMM probings (the thesis, chapter 7)")
    if command in ("qif", "results") and action == "verify":
        return Method("", "", "second opinion on a CMM's QIF results: every feature refitted from its measured "
                      "points (probe compensated) and compared with the reported values")
    if command == "compare":
        return Method("", "", "registration to the nominal CAD model (ICP, then least squares) and signed "
                      "distances of the points from the nominal surface")
    title = f"pcmm {command}" + (f" {action}" if isinstance(action, str) else "")
    return Method("", "", f"the evaluation of {title}")
