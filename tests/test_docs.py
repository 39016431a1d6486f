"""The documentation: the user guide's examples run and print what the guide shows; the Sphinx
build (API reference from the numpydoc docstrings + guide) passes with warnings as errors and
nitpicky references, and a broken reference does fail it."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLES = sorted((DOCS / "guide" / "examples").glob("*.py"))
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?|nan")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def _same_text_and_numbers(got: str, expected: str, rel: float = 1e-6, abs_: float = 2e-6) -> list[str]:
    """Lines differing in text, or in a number by more than the tolerance (floats differ across BLAS)."""
    problems = []
    got_lines, expected_lines = got.strip().splitlines(), expected.strip().splitlines()
    if len(got_lines) != len(expected_lines):
        return [f"{len(got_lines)} lines printed, the guide shows {len(expected_lines)}"]
    for line, shown in zip(got_lines, expected_lines, strict=True):
        if NUMBER.sub("#", line) != NUMBER.sub("#", shown):
            problems.append(f"{line!r} != {shown!r}")
            continue
        for a, b in zip(NUMBER.findall(line), NUMBER.findall(shown), strict=True):
            if a == b == "nan":
                continue
            if a == "nan" or b == "nan" or abs(float(a) - float(b)) > abs_ + rel * abs(float(b)):
                problems.append(f"{line!r} != {shown!r}")
    return problems


def test_the_guide_has_three_worked_examples() -> None:
    assert [p.stem for p in EXAMPLES] == ["calibrate_from_cmm_files", "gauge_block_to_20C", "verify_fitting_software"]
    for script in EXAMPLES:
        page = (DOCS / "guide" / f"{script.stem}.rst").read_text(encoding="utf-8")
        assert f"examples/{script.name}" in page and f"examples/{script.stem}.out" in page


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_guide_example_prints_what_the_guide_shows(script: Path, tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=_env(), cwd=tmp_path,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    shown = script.with_suffix(".out").read_text(encoding="utf-8")
    assert _same_text_and_numbers(done.stdout, shown) == []


def test_text_comparison_catches_changed_numbers_and_words() -> None:
    assert _same_text_and_numbers("d = 314.476 mm", "d = 314.476 mm") == []
    assert _same_text_and_numbers("d = 314.4760000001 mm", "d = 314.476 mm") == []
    assert _same_text_and_numbers("d = 314.477 mm", "d = 314.476 mm") != []
    assert _same_text_and_numbers("d = 314.476 um", "d = 314.476 mm") != []
    assert _same_text_and_numbers("a\nb", "a") != []


def _sphinx(source: Path, out: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n", "-q", "-d", str(out / ".doctrees"),
         str(source), str(out / "html")],
        capture_output=True, text=True, env=_env(), timeout=900,
    )


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The whole site, built once per test session from a copy of ``docs/`` with warnings as errors and
    nitpicky references.

    Parallel workers (pytest-xdist) share one build: the first to take the lock builds it in the session's
    common temporary folder, the others wait and read it (a failed build is reported by each).
    """
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # common to the session's workers
    folder = root / "docs-site"
    with _session_lock(root / "docs-site.lock"):
        outcome = folder / "outcome.txt"
        if not outcome.exists():
            if folder.exists():
                shutil.rmtree(folder)
            source = folder / "docs"
            shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("_build", "generated"))
            done = _sphinx(source, folder / "build")
            outcome.write_text("ok" if done.returncode == 0 else done.stderr[-6000:] or "failed", encoding="utf-8")
    result = outcome.read_text(encoding="utf-8")
    assert result == "ok", result
    return folder / "build" / "html"


@contextlib.contextmanager
def _session_lock(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` across processes (POSIX ``flock``; elsewhere workers build their own site)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def test_docs_build_with_warnings_as_errors_and_nitpicky_references(site: Path) -> None:
    calibration = (site / "api" / "generated" / "pcmm_geo.machine.calibration.result.html").read_text(encoding="utf-8")
    assert "beta_deg" in calibration and "TetrahedronCalibration" in calibration
    guide = (site / "guide" / "calibrate_from_cmm_files.html").read_text(encoding="utf-8")
    assert "calibrate_tetrahedron" in guide and "314.476" in guide


def _public_objects() -> dict[int, tuple[object, set[str]]]:
    """Every function and class in the ``__all__`` of a public module: ``{id: (object, public names)}``."""
    import importlib
    import inspect
    import pkgutil

    import pcmm_geo

    found: dict[int, tuple[object, set[str]]] = {}
    names = ["pcmm_geo"] + [info.name for info in pkgutil.walk_packages(pcmm_geo.__path__, "pcmm_geo.")]
    for module_name in names:
        parts = module_name.split(".")
        if any(part.startswith("_") for part in parts) or parts[1:2] in (["cli"], ["data"]):
            continue
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                found.setdefault(id(obj), (obj, set()))[1].add(f"{module_name}.{name}")
    return found


def test_the_api_index_links_every_public_function_and_class(site: Path) -> None:
    from html.parser import HTMLParser

    class Links(HTMLParser):
        def __init__(self) -> None:
            super().__init__()
            self.hrefs: list[str] = []
            self.ids: set[str] = set()

        def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
            values = dict(attrs)
            if tag == "a" and values.get("href"):
                self.hrefs.append(str(values["href"]))
            if values.get("id"):
                self.ids.add(str(values["id"]))

    index = Links()
    index.feed((site / "api" / "index.html").read_text(encoding="utf-8"))
    pages: dict[str, Links] = {}
    missing = []
    public = _public_objects()
    assert len(public) > 300  # the walk reaches the sub-packages
    for obj, names in public.values():
        anchors = {f"{obj.__module__}.{obj.__qualname__}", *names}
        links = [href for href in index.hrefs if href.split("#")[-1] in anchors]
        if not links:
            missing.append(f"{sorted(names)[0]}: no link")
            continue
        page, anchor = links[0].split("#") if "#" in links[0] else (links[0], "")
        target = (site / "api" / page).resolve() if page else site / "api" / "index.html"
        if str(target) not in pages:
            pages[str(target)] = Links()
            pages[str(target)].feed(target.read_text(encoding="utf-8"))
        if anchor not in pages[str(target)].ids:
            missing.append(f"{sorted(names)[0]}: {links[0]} leads nowhere")
    assert missing == []


def test_the_markdown_topics_are_pages_of_the_site(site: Path) -> None:
    topics = (site / "topics.html").read_text(encoding="utf-8")
    for name in sorted(path.stem for path in DOCS.glob("*.md")):  # every Markdown page is in the site
        assert f'href="{name}.html"' in topics, name
        page = (site / f"{name}.html").read_text(encoding="utf-8")
        heading = (DOCS / f"{name}.md").read_text(encoding="utf-8").splitlines()[0].lstrip("# ").strip()
        assert heading.split("`")[0][:20] in page, name
    assert 'href="topics.html"' in (site / "index.html").read_text(encoding="utf-8")


def test_a_result_page_lists_each_field_once_without_internals(site: Path) -> None:
    import re

    page = (site / "api" / "generated" / "pcmm_geo.fit.cylinder.html").read_text(encoding="utf-8")
    section = page[page.index('id="pcmm_geo.fit.cylinder.CylinderFit"'):page.index('id="pcmm_geo.fit.cylinder.axis')]
    assert "&lt;factory&gt;" not in section and "extra" not in section
    assert not re.search(r"r_in</span></span><span[^>]*>\s*=\s*nan", section)
    for field in ("point", "axis", "radius", "r_in, r_out"):
        assert section.count(f"<strong>{field}</strong>") == 1, field  # once, in the Attributes list
    assert 'id="pcmm_geo.fit.cylinder.CylinderFit.point"' not in section  # no second, empty entry


def test_a_broken_reference_fails_the_build(tmp_path: Path) -> None:
    source = tmp_path / "docs"
    source.mkdir()
    shutil.copy(DOCS / "conf.py", source / "conf.py")
    page = "Broken\n======\n\nSee :func:`pcmm_geo.fit.no_such_function`.\n"
    (source / "index.rst").write_text(page, encoding="utf-8")
    done = _sphinx(source, tmp_path / "build")
    assert done.returncode != 0
    assert "py:func reference target not found: pcmm_geo.fit.no_such_function" in done.stderr
