"""Exception and warning classes of pcmm_geo.

Every error the library raises on purpose derives from :class:`PcmmGeoError`
and *also* from the builtin that describes its nature, so callers can catch
either ``pcmm_geo.PcmmGeoError`` or, say, ``ValueError``.  Each class carries
structured fields (``what``, ``expected``, ``got``, ...) next to its message so
that tools can react without parsing text.

Examples
--------
>>> import numpy as np
>>> from pcmm_geo import fit
>>> try:
...     fit.fit_sphere(np.zeros((2, 3)))
... except PcmmGeoError as exc:
...     print(type(exc).__name__, exc.needed, exc.got)
TooFewPointsError 4 2
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "PcmmGeoError",
    "InvalidInputError",
    "TooFewPointsError",
    "DegenerateGeometryError",
    "AmbiguousFitError",
    "ConvergenceError",
    "NoRealSolutionError",
    "FileFormatError",
    "QifError",
    "UnsafeXmlError",
    "CalibrationError",
    "DeviceError",
    "DeviceTimeoutError",
    "DeviceProtocolError",
    "LogIntegrityError",
    "OutputExistsError",
    "MissingDependencyError",
    "IncompleteTestError",
    "OutOfRangeError",
    "InconsistentMeasurementError",
    "NotRefittedError",
    "CalibrationNotConvergedWarning",
    "IllConditionedWarning",
    "AmbiguousFitWarning",
    "UnassuredMinimumWarning",
    "PcmmGeoWarning",
]


#: longest text from a file or an argument an error message repeats (see :func:`_bounded`)
_MAX_QUOTED_CHARS = 480


def _bounded(text: str) -> str:
    """``text`` cut in the middle when longer than :data:`_MAX_QUOTED_CHARS`.

    A last line of defence: readers quote short excerpts of bad input, but a message must never
    grow with the input (a 100 MB damaged line must not become 100 MB of stderr).
    """
    if len(text) <= _MAX_QUOTED_CHARS:
        return text
    head, tail = text[:400], text[-60:]
    return f"{head} ... [{len(text) - len(head) - len(tail)} characters left out] ... {tail}"


class PcmmGeoError(Exception):
    """Base class of every error raised by pcmm_geo."""

    def __init__(self, message: str, **fields: Any) -> None:
        super().__init__(message)
        self.message = message
        self.fields = dict(fields)
        for name, value in fields.items():
            setattr(self, name, value)

    def __reduce__(self) -> tuple[Any, ...]:
        # each class has its own __init__ arguments: rebuild from the message and fields instead, so
        # that an error raised in a worker process (dask, multiprocessing) arrives whole, line included
        return _rebuild, (type(self), self.message, self.fields)


def _rebuild(cls: type[PcmmGeoError], message: str, fields: dict[str, Any]) -> PcmmGeoError:
    """A :class:`PcmmGeoError` of class ``cls`` with ``message`` and ``fields``, without calling its ``__init__``."""
    error = cls.__new__(cls)
    PcmmGeoError.__init__(error, message, **fields)
    return error


class InvalidInputError(PcmmGeoError, ValueError):
    """Input of the wrong shape, type or containing NaN/inf.

    Fields: ``what`` (argument name), ``expected``, ``got``.
    """

    def __init__(self, what: str, expected: str, got: str) -> None:
        got = _bounded(str(got))
        super().__init__(f"{what}: expected {expected}, got {got}", what=what, expected=expected, got=got)


class TooFewPointsError(PcmmGeoError, ValueError):
    """Fewer points than the element needs. Fields: ``element``, ``needed``, ``got``."""

    def __init__(self, element: str, needed: int, got: int) -> None:
        super().__init__(
            f"{element} fit needs at least {needed} points, got {got}",
            element=element,
            needed=needed,
            got=got,
        )


class DegenerateGeometryError(PcmmGeoError, ValueError):
    """The data cannot determine the element (collinear points for a plane, coplanar for a sphere...).

    Fields: ``element``, ``reason`` and any extra given (batch fits add ``set_index``).
    """

    def __init__(self, element: str, reason: str, **fields: Any) -> None:
        super().__init__(f"{element}: degenerate data: {reason}", element=element, reason=reason, **fields)


class AmbiguousFitError(DegenerateGeometryError):
    """The data admit several equally good solutions and nothing tells them apart.

    Example: a sphere of fixed radius through coplanar points (its centre and the mirror
    image of the centre in the points' plane fit equally well).

    Fields: ``element``, ``reason``, ``candidates`` (the competing solutions, e.g. centres).
    """

    def __init__(self, element: str, reason: str, candidates: Any) -> None:
        super().__init__(element, reason, candidates=candidates)


class ConvergenceError(PcmmGeoError, RuntimeError):
    """An iterative solver did not converge. Fields: ``element``, ``iterations``, ``reason``."""

    def __init__(self, element: str, iterations: int, reason: str) -> None:
        super().__init__(
            f"{element}: no convergence after {iterations} iterations: {reason}",
            element=element,
            iterations=iterations,
            reason=reason,
        )


class NoRealSolutionError(PcmmGeoError, ValueError):
    """A kinematic or geometric equation has no real solution (negative discriminant).

    Fields: ``what`` and ``discriminant`` (the offending value, in its units; may be an array).
    """

    def __init__(self, what: str, discriminant: Any = None, detail: str = "") -> None:
        text = f"{what}: no real solution"
        if discriminant is not None:
            text += f" (discriminant {discriminant})"
        if detail:
            text += f": {detail}"
        super().__init__(text, what=what, discriminant=discriminant, detail=detail)


class FileFormatError(PcmmGeoError, ValueError):
    """A file does not follow its documented format. Fields: ``path``, ``line`` (1-based or None), ``reason``."""

    def __init__(self, path: str, reason: str, line: int | None = None) -> None:
        where = f"{path}:{line}" if line is not None else f"{path}"
        reason = _bounded(reason)
        super().__init__(f"{where}: {reason}", path=path, line=line, reason=reason)


class QifError(FileFormatError):
    """A QIF document the reader cannot use: a dangling id, a ``count`` that disagrees with the
    points, a non-numeric coordinate, an unknown unit...

    Fields: ``path``, ``reason``, ``line`` (or None), ``qif_id`` (the QIF id of the element
    concerned, or None) and ``element`` (its path, e.g. ``QIFDocument/Results/.../MeasuredPointSet``).
    """

    def __init__(self, path: str, reason: str, *, qif_id: int | str | None = None, element: str | None = None,
                 line: int | None = None) -> None:
        where = f"{path}:{line}" if line is not None else f"{path}"
        subject = " ".join(part for part in (element, None if qif_id is None else f"id={qif_id}") if part)
        reason = _bounded(reason)
        PcmmGeoError.__init__(self, f"{where}: {subject + ': ' if subject else ''}{reason}", path=path,
                              line=line, reason=reason, qif_id=qif_id, element=element)


class UnsafeXmlError(FileFormatError):
    """An XML file refused before its content is used: a DTD, an entity declaration or reference,
    an external reference, nesting deeper or a file larger than the limit, or XML that is not
    well formed.  Nothing external is fetched.

    Fields: ``path``, ``reason``, ``line`` (or None), ``limit`` (the limit exceeded, or None).
    """

    def __init__(self, path: str, reason: str, line: int | None = None, limit: int | None = None) -> None:
        FileFormatError.__init__(self, path, reason, line)
        self.limit = limit
        self.fields["limit"] = limit


class CalibrationError(PcmmGeoError, ValueError):
    """Calibration data are inconsistent or insufficient. Fields: ``reason``."""

    def __init__(self, reason: str, **fields: Any) -> None:
        super().__init__(reason, reason=reason, **fields)


class DeviceError(PcmmGeoError, OSError):
    """A serial device reported an error or the link failed. Fields: ``device``, ``reason``, ``code``."""

    def __init__(self, device: str, reason: str, code: int | None = None) -> None:
        text = f"{device}: {reason}" + (f" (code {code})" if code is not None else "")
        PcmmGeoError.__init__(self, text, device=device, reason=reason, code=code)


class DeviceTimeoutError(DeviceError, TimeoutError):
    """A device did not answer in time. Fields: ``device``, ``reason``, ``timeout``."""

    def __init__(self, device: str, timeout: float, reason: str = "no reply") -> None:
        PcmmGeoError.__init__(
            self, f"{device}: {reason} within {timeout} s", device=device, reason=reason, code=None, timeout=timeout
        )


class DeviceProtocolError(DeviceError):
    """Bytes from a device that do not follow its protocol (after resynchronisation failed)."""


class LogIntegrityError(PcmmGeoError, ValueError):
    """An acquisition log is damaged (partial row, header mismatch) or would be overwritten.

    Fields: ``path``, ``reason``, ``line``.
    """

    def __init__(self, path: str, reason: str, line: int | None = None) -> None:
        where = f"{path}:{line}" if line is not None else f"{path}"
        reason = _bounded(reason)
        super().__init__(f"{where}: {reason}", path=path, reason=reason, line=line)


class OutputExistsError(PcmmGeoError, FileExistsError):
    """Writing would overwrite an existing file; pass ``overwrite=True`` to allow it. Fields: ``path``."""

    def __init__(self, path: str) -> None:
        PcmmGeoError.__init__(
            self, f"{path}: already exists; refusing to overwrite (pass overwrite=True to replace it)", path=path
        )


class MissingDependencyError(PcmmGeoError, ImportError):
    """An optional dependency is not installed; the message names the extra that provides it.

    Fields: ``package`` (distribution name, e.g. ``"open3d"``), ``extra`` (e.g. ``"cad"``),
    ``purpose`` (what needed it).  Raised by :func:`pcmm_geo.require`.
    """

    def __init__(self, package: str, extra: str, purpose: str) -> None:
        PcmmGeoError.__init__(
            self,
            f"{purpose} needs {package}, which is not installed; "
            f"install the extra with: pip install 'pcmm_geo[{extra}]'",
            package=package,
            extra=extra,
            purpose=purpose,
        )
class IncompleteTestError(PcmmGeoError, ValueError):
    """A standard test's data set is not the standard's (too few values); no verdict without an explicit opt-in.

    Fields: ``test`` (e.g. "ISO 10360-5"), ``needed`` (the standard's count), ``got``, ``detail``.
    """

    def __init__(self, test: str, needed: int, got: int, detail: str = "", unit: str = "values") -> None:
        text = f"{test}: the standard uses {needed} {unit}, got {got}"
        if detail:
            text += f" ({detail})"
        text += "; evaluate a partial data set only with allow_incomplete=True (--allow-incomplete)"
        super().__init__(text, test=test, needed=needed, got=got, detail=detail)


class OutOfRangeError(PcmmGeoError, ValueError):
    """A value lies outside the physical range of the machine or instrument.

    Fields: ``quantity`` (what, e.g. "column a height"), ``value``, ``low``, ``high`` (the
    allowed closed interval, either may be None for a one-sided limit) and ``unit``.
    """

    def __init__(self, quantity: str, value: Any, low: Any = None, high: Any = None, unit: str = "mm") -> None:
        if low is not None and high is not None:
            allowed = f"[{low}, {high}] {unit}"
        elif low is not None:
            allowed = f">= {low} {unit}"
        else:
            allowed = f"<= {high} {unit}"
        super().__init__(
            f"{quantity}: expected a value in {allowed}, got {value} {unit}",
            quantity=quantity,
            value=value,
            low=low,
            high=high,
            unit=unit,
        )


class InconsistentMeasurementError(PcmmGeoError, ValueError):
    """Redundant readings disagree beyond their tolerance (e.g. a kinematic closure residual).

    Fields: ``what``, ``residual`` and ``tolerance`` (same unit, ``unit``), ``detail``.
    """

    def __init__(self, what: str, residual: Any, tolerance: Any, unit: str = "mm", detail: str = "") -> None:
        text = f"{what}: residual {residual} {unit} exceeds the tolerance {tolerance} {unit}"
        if detail:
            text += f" ({detail})"
        super().__init__(text, what=what, residual=residual, tolerance=tolerance, unit=unit, detail=detail)


class NotRefittedError(PcmmGeoError, ValueError):
    """A feature of a CMM results file that cannot be refitted from its points (no points, compensation
    or material side unknown, a type or fitting algorithm not offered, a fit that fails).

    Fields: ``reason``.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(_bounded(reason), reason=reason)


class PcmmGeoWarning(UserWarning):
    """Base class of pcmm_geo warnings."""


class IllConditionedWarning(PcmmGeoWarning):
    """A fit or calibration is poorly determined by its data (large condition number, tiny arc...)."""


class AmbiguousFitWarning(IllConditionedWarning):
    """A fit found two or more distinct local minima of practically equal sum of squares.

    The data cannot tell the competing solutions apart (sparse points on a cylinder, cone
    or torus); the least is returned, but another is about as good.

    Fields: ``element``; ``minima``, a tuple of dicts (``sum_of_squares``, ``axis``, ``point``
    and the element's size parameters), the returned one first; ``margin``, the relative
    difference of sums of squares below which minima count as indistinguishable.
    """

    def __init__(self, element: str, minima: tuple[dict[str, Any], ...], margin: float) -> None:
        costs = ", ".join(f"{m['sum_of_squares']:.6g}" for m in minima)
        super().__init__(
            f"{element}: {len(minima)} distinct least-squares minima with sums of squares within "
            f"{margin:.0%} of each other ({costs} mm^2); the data cannot tell them apart "
            "(add points or pass axis_hint)"
        )
        self.element = element
        self.minima = minima
        self.margin = margin


class UnassuredMinimumWarning(IllConditionedWarning):
    """A fit converged, but for data this sparse the library cannot assure it is the global minimum.

    Raised where scans against an independent multi-start reference still show silent wrong
    minima (sparse tori without an axis hint: ``docs/fit-robustness.md``). The returned fit is the
    best minimum found; a nominal ``axis_hint`` or more points remove the doubt.

    Fields: ``element``; ``n_points``; ``assured_from``, the number of points from which the
    search is assured without a hint.
    """

    def __init__(self, element: str, n_points: int, assured_from: int) -> None:
        super().__init__(
            f"{element}: {n_points} points and no axis_hint: the least-squares minimum found is not assured "
            f"to be the global one (sparse data can hold a narrow true basin beside spurious minima); pass the "
            f"nominal axis as axis_hint (pcmm fit: --axis-hint X Y Z) or measure at least {assured_from} points"
        )
        self.element = element
        self.n_points = n_points
        self.assured_from = assured_from


class CalibrationNotConvergedWarning(PcmmGeoWarning):
    """A calibration solver stopped without meeting its convergence test or is ill-determined.

    The result is returned (``converged=False`` and a ``message`` saying why) so that nothing
    computed is lost, but it must not be used as a calibration without inspection.
    """
