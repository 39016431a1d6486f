"""What makes a ``--report`` a lab record: provenance, verdict and uncertainty slots.

:class:`Provenance` is taken when a command starts (UTC time, command line, working
folder, every input file with its SHA-256) and completed with the software versions when
the report is written (so that only the optional libraries actually used are listed).
:class:`Verdict` and :class:`UncertaintyEntry` / :class:`CovarianceBlock` are the generic
slots a handler fills in its :class:`~pcmm_geo.cli._output.Report`; the report writer
renders whatever is there.  This module imports nothing from the rest of the CLI.
"""

from __future__ import annotations

import argparse
import hashlib
import platform
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

#: argparse destinations that name files a command writes, never inputs
OUTPUT_DESTINATIONS = frozenset({"plot", "report", "out", "output", "output_dir"})
#: distributions always listed, then optional ones listed when their module was imported
CORE_DISTRIBUTIONS = ("pcmm_geo", "numpy", "scipy")
OPTIONAL_DISTRIBUTIONS = {  # import name -> distribution name
    "matplotlib": "matplotlib",
    "open3d": "open3d",
    "trimesh": "trimesh",
    "serial": "pyserial",
    "dask": "dask",
    "distributed": "distributed",
    "rich": "rich",
    "GTC": "GTC",
    "uncertainties": "uncertainties",
    "mpmath": "mpmath",
}
_CHUNK = 1 << 20


@dataclass(frozen=True)
class InputFile:
    """One input of a run: absolute path, SHA-256 (hex) and size in bytes.

    For a folder, ``sha256`` is the digest of the lines ``"<relative path>\\0<sha256 of file>\\n"``
    of all its files in sorted order, and ``files`` their number.
    """

    path: str
    sha256: str
    size: int
    files: int = 1


@dataclass(frozen=True)
class Verdict:
    """A conformity decision: the statement, the one decision rule, and U or what the verdict rests on.

    A report states its decision once: ``statement`` (e.g. ``"ISO 10360-2: PASS (105 values ...)"``),
    ``decision_rule`` (one sentence in ISO 14253-1 terms) and either ``uncertainty`` (the expanded
    uncertainty U the rule used, with its unit and coverage factor) or, for a verdict that has no
    U, ``basis`` (what it rests on instead, e.g. a certified minimum-zone width).  Handlers do
    not repeat the verdict in their free lines: the terminal and the report print it from here.

    Parameters
    ----------
    passed : bool or None
        True: conformity (PASS), False: nonconformity (FAIL), None: neither decided (NOT PROVEN,
        no specification stated, incomplete test).
    statement : str
    decision_rule : str
    uncertainty : str
        ``"U = 0.6 µm (k = 2)"``; empty when the decision used no U.
    basis : str
        For a verdict without U: the evidence it rests on.
    conformity_text : str
        The ISO 14253-1 state when the rule does not follow from ``passed`` and ``uncertainty``.

    Examples
    --------
    >>> Verdict(True, "PASS", "ISO 14253-1 default rule", uncertainty="U = 0.5 µm (k = 2)").conformity
    'conformity proven (ISO 14253-1: the value lies inside the specification zone reduced by U)'
    >>> Verdict(True, "pass", "simple acceptance", basis="certified zone width").conformity
    'conformity not proven in ISO 14253-1 terms: no U was stated, the verdict rests on the value alone'
    """

    passed: bool | None
    statement: str
    decision_rule: str
    uncertainty: str = ""
    basis: str = ""
    conformity_text: str = ""

    @property
    def conformity(self) -> str:
        """The ISO 14253-1 state the verdict reaches: conformity / nonconformity proven, or not proven.

        ``conformity_text``, when given, states it instead (a rule whose FAIL proves nothing, ...).
        """
        if self.conformity_text:
            return self.conformity_text
        if self.uncertainty:
            return {
                True: "conformity proven (ISO 14253-1: the value lies inside the specification zone reduced by U)",
                False: "nonconformity proven (ISO 14253-1: the value lies outside the specification zone "
                       "enlarged by U)",
                None: "neither conformity nor nonconformity proven (ISO 14253-1: within U of a limit, or no "
                      "complete decision)",
            }[self.passed]
        if self.passed is None:  # NOT PROVEN, INCOMPLETE: a decision was attempted and not reached
            return "neither conformity nor nonconformity proven"
        return ("conformity not proven in ISO 14253-1 terms: no U was stated, the verdict rests on the value alone"
                if self.passed else
                "nonconformity not proven in ISO 14253-1 terms: no U was stated, the verdict rests on the value alone")

    def lines(self) -> list[str]:
        """The verdict as the terminal prints it: statement, rule, then U or the basis (once each)."""
        out = [f"verdict: {self.statement}", f"decision rule: {self.decision_rule}"]
        if self.uncertainty:
            out.append(f"expanded uncertainty: {self.uncertainty}")
        elif self.basis:
            out.append(f"rests on: {self.basis}")
        return out


@dataclass(frozen=True)
class Method:
    """The method a result was obtained by: the standard with its clause, or the laboratory's own.

    Examples
    --------
    >>> Method("ISO 10360-2:2009", "clauses 6 and 7", "length measurement error E0").text()
    'ISO 10360-2:2009, clauses 6 and 7: length measurement error E0'
    >>> Method("", "", "least-squares sphere").text()
    'least-squares sphere (laboratory method, no standard method)'
    """

    standard: str
    clause: str
    description: str

    def text(self) -> str:
        """One line: ``standard, clause: description`` or ``description (laboratory method ...)``."""
        if not self.standard:
            return f"{self.description} (laboratory method, no standard method)"
        where = f"{self.standard}, {self.clause}" if self.clause else self.standard
        return f"{where}: {self.description}"


@dataclass(frozen=True)
class Condition:
    """One environmental condition a result depends on (a temperature the command used, ...)."""

    quantity: str
    value: float | str
    unit: str


@dataclass(frozen=True)
class UncertaintyEntry:
    """One quantity with its standard uncertainty (and, optionally, expanded uncertainty).

    Parameters
    ----------
    quantity : str
        What was measured, e.g. ``"radius"``.
    value : float
    standard_uncertainty : float
        ``u`` in the same unit as ``value``.
    unit : str
        ``"mm"``, ``"rad"``, ``"1"``, ...
    coverage_factor : float or None
        ``k`` of the expanded uncertainty ``U = k u`` when one is stated.
    method : str
        How ``u`` was obtained, e.g. ``"least-squares covariance"`` or ``"GUM"``.
    """

    quantity: str
    value: float
    standard_uncertainty: float
    unit: str
    coverage_factor: float | None = None
    method: str = ""

    @property
    def expanded_uncertainty(self) -> float | None:
        """``k u`` or None when no coverage factor is stated."""
        return None if self.coverage_factor is None else self.coverage_factor * self.standard_uncertainty


@dataclass(frozen=True)
class CovarianceBlock:
    """A covariance matrix with its parameter names (rendered as a correlation matrix plus u)."""

    title: str
    names: tuple[str, ...]
    matrix: Any  # (P, P) array-like

    def correlation(self) -> list[list[float]]:
        """Correlation coefficients (P, P); NaN where a standard uncertainty is zero."""
        import numpy as np

        cov = np.asarray(self.matrix, dtype=float)
        scale = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(scale, scale)
        return np.where(np.outer(scale, scale) > 0, corr, np.nan).tolist()


@dataclass
class Provenance:
    """Where a result came from: time, command line, inputs with SHA-256, software versions."""

    created_utc: str
    command_line: list[str]
    working_directory: str
    inputs: list[InputFile] = field(default_factory=list)
    versions: dict[str, str] = field(default_factory=dict)
    platform: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "created_utc": self.created_utc,
            "command_line": list(self.command_line),
            "working_directory": self.working_directory,
            "inputs": [{"path": f.path, "sha256": f.sha256, "size": f.size, "files": f.files} for f in self.inputs],
            "versions": dict(self.versions),
            "platform": self.platform,
        }


def sha256_file(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks.

    Examples
    --------
    >>> import os, tempfile
    >>> name = os.path.join(tempfile.mkdtemp(), "a.txt")
    >>> _ = open(name, "wb").write(b"abc")
    >>> sha256_file(name)[:16]
    'ba7816bf8f01cfea'
    """
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def describe_input(path: str | Path) -> InputFile:
    """:class:`InputFile` of a file or folder (absolute, symlinks resolved).

    Raises
    ------
    OSError
        The path cannot be read.
    """
    target = Path(path).resolve()
    if target.is_dir():
        files = sorted(p for p in target.rglob("*") if p.is_file())
        digest = hashlib.sha256()
        for file in files:
            digest.update(f"{file.relative_to(target).as_posix()}\0{sha256_file(file)}\n".encode())
        return InputFile(str(target), digest.hexdigest(), sum(f.stat().st_size for f in files), len(files))
    return InputFile(str(target), sha256_file(target), target.stat().st_size)


def input_paths(args: argparse.Namespace) -> list[str]:
    """Values of ``args`` that name existing files or folders, outputs excluded.

    Every argument is considered (positional files, ``--calibration``, ...) except the
    destinations in :data:`OUTPUT_DESTINATIONS` and the declared outputs; call it before the handler runs so that the
    files a command writes do not exist yet.
    """
    found: list[str] = []
    declared = {output.dest for output in getattr(args, "output_options", None) or ()}  # declare_output's
    for dest, value in sorted(vars(args).items()):
        # command_line repeats every argument, the outputs too: an output that exists (--overwrite) is no input
        if dest in OUTPUT_DESTINATIONS or dest in declared or dest == "command_line" or callable(value):
            continue
        values: Iterable[Any] = value if isinstance(value, (list, tuple)) else (value,)
        for item in values:
            if isinstance(item, (str, Path)) and str(item) and Path(item).exists() and str(item) not in found:
                found.append(str(item))
    return found


def start_provenance(command_line: Sequence[str], inputs: Iterable[str | Path] = ()) -> Provenance:
    """Record the start of a run: UTC time (ISO 8601, seconds), command line, cwd, hashed inputs.

    Examples
    --------
    >>> record = start_provenance(["pcmm", "fit", "sphere", "x.csv"])
    >>> record.created_utc.endswith("+00:00"), record.command_line[1]
    (True, 'fit')
    """
    import os

    return Provenance(
        created_utc=datetime.now(UTC).isoformat(timespec="seconds"),
        command_line=list(command_line),
        working_directory=os.getcwd(),
        inputs=[describe_input(path) for path in inputs],
        platform=platform.platform(),
    )


def software_versions() -> dict[str, str]:
    """Versions of python, pcmm_geo, numpy, scipy and of the optional libraries imported so far.

    Examples
    --------
    >>> versions = software_versions()
    >>> sorted(set(versions) & {"python", "pcmm_geo", "numpy", "scipy"})
    ['numpy', 'pcmm_geo', 'python', 'scipy']
    """
    from importlib import metadata

    from pcmm_geo import __version__

    def version_of(distribution: str) -> str:
        try:
            return metadata.version(distribution)
        except metadata.PackageNotFoundError:
            module = sys.modules.get(distribution)
            return str(getattr(module, "__version__", "unknown"))

    versions = {"python": platform.python_version(), "pcmm_geo": __version__}
    versions.update({name: version_of(name) for name in CORE_DISTRIBUTIONS[1:]})
    for module_name, distribution in OPTIONAL_DISTRIBUTIONS.items():
        if module_name in sys.modules:
            versions[distribution] = version_of(distribution)
    return versions


def package_digest(folder: str | Path | None = None) -> tuple[str, int]:
    """SHA-256 over the files of the installed package (``__pycache__`` left out) and their number.

    The digest covers the lines ``"<relative path>\\0<sha256 of file>\\n"`` in sorted order, as
    :func:`describe_input` does for a folder, so a changed, added or removed file changes it.

    Examples
    --------
    >>> digest, files = package_digest()
    >>> len(digest), files > 100
    (64, True)
    """
    import pcmm_geo

    root = Path(folder) if folder is not None else Path(pcmm_geo.__file__).resolve().parent
    files = sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    digest = hashlib.sha256()
    for file in files:
        digest.update(f"{file.relative_to(root).as_posix()}\0{sha256_file(file)}\n".encode())
    return digest.hexdigest(), len(files)


def source_revision() -> str:
    """The git commit the running pcmm_geo was loaded from, ``"... (dirty: ...)"`` if the tree has changes.

    Empty when pcmm_geo does not run from a git checkout (an installed package: then the
    package digest identifies it) or git cannot tell.  git runs without network and without
    taking locks (``GIT_OPTIONAL_LOCKS=0``), with a timeout.
    """
    import os
    import shutil
    import subprocess

    import pcmm_geo

    root = Path(pcmm_geo.__file__).resolve().parent.parent
    git = shutil.which("git")
    if git is None or not (root / ".git").exists():
        return ""
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0", "GIT_TERMINAL_PROMPT": "0", "LC_ALL": "C"}

    def git_output(*arguments: str) -> str | None:
        try:
            done = subprocess.run([git, "-C", str(root), *arguments], capture_output=True, text=True, env=env,
                                  timeout=20, check=False)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git_output("rev-parse", "HEAD")
    if not commit:
        return ""
    changes = git_output("status", "--porcelain")
    if changes is None:
        return f"{commit} (git could not tell whether the tree has uncommitted changes)"
    if changes:
        return f"{commit} (dirty: {len(changes.splitlines())} uncommitted changes in the tree)"
    return commit


def software_identity() -> list[tuple[str, str]]:
    """Rows identifying the software exactly: version, source revision (checkout) and package digest.

    Examples
    --------
    >>> rows = dict(software_identity())
    >>> sorted(rows)[:2], len(rows["package files SHA-256"].split()[0])
    (['package files SHA-256', 'pcmm_geo version'], 64)
    """
    from pcmm_geo import __version__

    digest, files = package_digest()
    rows = [("pcmm_geo version", __version__)]
    revision = source_revision()
    rows.append(("source revision (git)", revision) if revision else
                ("source revision (git)", "not a git checkout: identified by the package digest below"))
    rows.append(("package files SHA-256", f"{digest} ({files} files)"))
    return rows
