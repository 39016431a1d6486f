"""Every ``console`` block of the README, the user guide and docs/uncertainty.md runs and prints what the page shows.

A block is a shell session: ``$ pcmm ARGS`` (or ``$ ./dev pcmm ARGS``) lines, each followed by
the output the page documents.  The commands of one page run in order, in one fresh folder
that holds the repository's ``pcmm_geo`` and ``tests`` folders (links) and the files the guide
names as being in the working folder, so ``out/...`` written by one block is read by the next.
A block a unit-test run cannot afford (the demo, long acquisitions) is preceded by a comment
``<!-- docs-test: skip: REASON -->`` (Markdown) or ``.. docs-test: skip: REASON`` (RST); the
reason is kept in the test's report.

Output is compared line by line after whitespace is collapsed (column alignment follows the
numbers' widths):

* a line ``...`` stands for any number of lines, a token ``...`` for any number of tokens;
* date-times, generated report ids, the demo's run folders and temporary paths are masked;
* numbers are compared to a stated tolerance, never bit for bit: they agree when they differ
  by at most one unit of the last decimal the page prints (``100.000089`` accepts 100.000088
  to 100.000090: rounding of a value that moved in its 7th significant digit across BLAS
  builds), or when both are below 1e-9 in magnitude (round-off around zero, e.g. ``8.5e-11``
  against ``-2.8e-11``).
"""

from __future__ import annotations

import math
import os
import re
import shlex
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from pcmm_runner import run_pcmm

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.rst")), ROOT / "docs" / "uncertainty.md"]
#: files a guide page says are in its working folder (copied there before the page runs)
_CMM = "pcmm_geo/data/examples/cmm_files/"
WORKING_FILES = {
    "files_from_your_cmm.rst": ["tests/data/qif/samples/QIF_PTS_SAMPLE.QIF",
                                *(_CMM + name for name in ("bracket.dmo", "nounits.dmo", "bracket_chr.txt", "ring.xyz",
                                                           "bare.csv", "broken.qif")),
                                *(f"tests/data/qif/hostile/{name}.qif" for name in ("billion_laughs", "deeply_nested",
                                                                                     "truncated"))],
    "calibrate_from_cmm_files.rst": ["pcmm_geo/data/appendix_cd/cmm_export.qif", "pcmm_geo/data/appendix_cd/lasers.csv",
                                     _CMM + "probings.qif", _CMM + "map.json"],
    "gdt_with_datums.rst": [f"pcmm_geo/data/examples/gdt/{name}" for name in
                            ("plan.toml", "A.csv", "B.csv", "C.csv", "H1.csv", "H2.csv", "H3.csv", "TOP.csv")],
}
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
MASKS = (
    (re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(?:\.\d+)?(?:[+-]\d{2}:\d{2}|Z)?"), "<TIME>"),
    (re.compile(r"PCMM-\d{8}-\d{6}-[0-9A-F]{8}"), "<REPORT-ID>"),
    (re.compile(r"run-\d{8}T\d{6,12}Z"), "run-<TIME>"),  # the demo's run folder
)
SKIP = re.compile(r"(?:<!--|\.\.)\s*docs-test:\s*skip:\s*(.+?)\s*(?:-->)?\s*$")


@dataclass
class Block:
    """One console block: where it is, its commands with their documented output, a skip reason."""

    page: str
    line: int
    commands: list[tuple[str, list[str]]] = field(default_factory=list)
    skip: str = ""


def _commands(lines: list[str]) -> list[tuple[str, list[str]]]:
    out: list[tuple[str, list[str]]] = []
    for line in lines:
        if line.startswith("$ "):
            out.append((line[2:].strip(), []))
        elif out:
            out[-1][1].append(line)
    return out


def console_blocks(path: Path) -> list[Block]:
    """The console blocks of a Markdown (```console) or reStructuredText (``code-block:: console``) page."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        line = lines[i]
        skip = ""
        for previous in reversed(lines[max(0, i - 3):i]):
            if previous.strip():
                match = SKIP.search(previous)
                skip = match.group(1) if match else ""
                break
        if line.strip() == "```console":
            end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
            blocks.append(Block(path.name, i + 1, _commands(lines[i + 1:end]), skip))
            i = end
        elif line.strip() == ".. code-block:: console":
            indent = len(line) - len(line.lstrip())
            body, j = [], i + 1
            while j < len(lines) and (not lines[j].strip() or len(lines[j]) - len(lines[j].lstrip()) > indent):
                body.append(lines[j])
                j += 1
            depth = min((len(b) - len(b.lstrip()) for b in body if b.strip()), default=0)
            text = [b[depth:] for b in body]
            while text and not text[-1].strip():
                text.pop()
            blocks.append(Block(path.name, i + 1, _commands(text), skip))
            i = j - 1
        i += 1
    return blocks


def _mask(text: str, folder: Path) -> str:
    text = text.replace(str(folder) + os.sep, "").replace(str(folder), ".")
    for pattern, replacement in MASKS:
        text = pattern.sub(replacement, text)
    return text


def _last_unit(text: str) -> float:
    """One unit of the last decimal ``text`` shows (``"1.2345"`` -> 1e-4, ``"2.1e-05"`` -> 1e-6, ``"12"`` -> 1)."""
    mantissa, _, exponent = text.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def numbers_agree(got: str, shown: str) -> bool:
    """The tolerance of the module docstring.

    Examples
    --------
    >>> numbers_agree("100.000090", "100.000089"), numbers_agree("100.000092", "100.000089")
    (True, False)
    >>> numbers_agree("-3e-22", "2.066919e-21"), numbers_agree("0.4", "0.6")
    (True, False)
    """
    a, b = float(got), float(shown)
    if abs(a) < 1e-9 and abs(b) < 1e-9:
        return True
    return abs(a - b) <= _last_unit(shown) * (1 + 1e-9)


def _token_match(got: str, shown: str) -> bool:
    if got == shown or (set(got) == set(shown) == {"-"}):
        return True
    if NUMBER.sub("#", got) != NUMBER.sub("#", shown):
        return False
    return all(numbers_agree(a, b) for a, b in zip(NUMBER.findall(got), NUMBER.findall(shown), strict=True))


def _glob(got: list[str], shown: list[str], same: object) -> bool:
    """``shown`` matches ``got`` item by item, an item ``...`` standing for any number of items.

    Dynamic programming over (shown items, got items), no recursion: a JSON output has a thousand lines.
    """
    # reach[i]: shown[:j] can match got[:i]
    reach = [True] + [False] * len(got)
    for item in shown:
        if item == "...":
            for i in range(1, len(got) + 1):
                reach[i] = reach[i] or reach[i - 1]
        else:
            reach = [False] + [reach[i - 1] and bool(same(got[i - 1], item)) for i in range(1, len(got) + 1)]  # type: ignore[operator]
    return reach[len(got)]


def line_matches(got: str, shown: str) -> bool:
    """One line against its documented form (tokens, ``...`` tokens, numbers to the tolerance)."""
    return _glob(got.split(), shown.split(), _token_match)


def output_matches(got: str, shown: list[str]) -> bool:
    """The printed output against the documented lines (blank lines ignored, ``...`` lines as wildcards)."""
    got_lines = [line for line in got.splitlines() if line.strip()]
    shown_lines = [line.strip() if line.strip() == "..." else line for line in shown if line.strip()]
    return _glob(got_lines, shown_lines, line_matches)


def _prepare(page: str, folder: Path) -> None:
    for name in ("pcmm_geo", "tests"):
        (folder / name).symlink_to(ROOT / name, target_is_directory=True)
    for relative in WORKING_FILES.get(page, ()):
        assert (ROOT / relative).is_file(), f"{page} uses {relative}, which the repository does not ship"
        shutil.copy(ROOT / relative, folder / Path(relative).name)


def run_page(path: Path, folder: Path) -> tuple[list[str], list[str], list[str]]:
    """Run every block of ``path`` in ``folder``: (commands run, mismatches, skipped blocks with reasons)."""
    _prepare(path.name, folder)
    ran, problems, skipped = [], [], []
    for block in console_blocks(path):
        if block.skip:
            skipped.append(f"{block.page}:{block.line}: {block.skip}")
            continue
        for command, shown in block.commands:
            words = shlex.split(command)
            if words[:2] == ["./dev", "pcmm"]:
                words = words[1:]
            elif words[:2] == ["./dev", "demo"]:
                words = ["pcmm", "demo"]
            if not words or words[0] != "pcmm" or any(word in ("|", ">", "&&") for word in words):
                problems.append(f"{block.page}:{block.line}: `{command}` is not a pcmm command: mark the block "
                                "<!-- docs-test: skip: REASON -->")
                continue
            done = run_pcmm(*words[1:], cwd=folder)
            got = _mask(done.stderr + done.stdout, folder)
            ran.append(command)
            if not output_matches(got, [_mask(line, folder) for line in shown]):
                problems.append(f"{block.page}:{block.line}: `{command}`\n--- printed:\n{got}\n--- the page shows:\n"
                                + "\n".join(shown))
    return ran, problems, skipped


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_every_console_block_prints_what_the_page_shows(page: Path, tmp_path: Path) -> None:
    ran, problems, skipped = run_page(page, tmp_path)
    assert problems == [], f"{len(problems)} of {len(ran)} commands differ:\n\n" + "\n\n".join(problems)
    assert all(reason.split(": ", 1)[1] for reason in skipped)


def test_the_comparison_catches_changed_numbers_words_and_missing_lines() -> None:
    shown = ["quantity   value", "---------  -----", "radius     12.500521", "...", "converged: True"]
    assert output_matches("quantity value\n----- -----\nradius   12.5005211\nx\ny\nconverged: True", shown)
    assert not output_matches("quantity value\n-----\nradius 12.500540\nconverged: True", shown)
    assert not output_matches("quantity value\n-----\nradius 12.500521\nconverged: False", shown)
    assert not output_matches("quantity value\n-----\nradius 12.500521", shown)  # a line missing
    assert line_matches("cylindricity 4.798418 3.1 µm", "cylindricity 4.798418 ... µm")
    assert not line_matches("cylindricity 4.798418 3.1 mm", "cylindricity 4.798418 ... µm")
    assert _mask("run PCMM-20261206-041407-CDF29B13 at 2026-12-06T04:14:07+00:00", Path("/x")) == \
        "run <REPORT-ID> at <TIME>"


def test_blocks_are_found_in_markdown_and_rst(tmp_path: Path) -> None:
    page = tmp_path / "p.md"
    page.write_text("<!-- docs-test: skip: takes a minute -->\n```console\n$ ./dev demo\nok\n```\n\n"
                    "```console\n$ pcmm fit x\ny\n```\n", encoding="utf-8")
    blocks = console_blocks(page)
    assert [(b.commands, b.skip) for b in blocks] == [([("./dev demo", ["ok"])], "takes a minute"),
                                                      ([("pcmm fit x", ["y"])], "")]
    rst = tmp_path / "p.rst"
    rst.write_text("Text\n\n* item:\n\n  .. code-block:: console\n\n     $ pcmm a\n     out\n\n  more\n",
                   encoding="utf-8")
    assert [b.commands for b in console_blocks(rst)] == [[("pcmm a", ["out"])]]
    assert math.isclose(_last_unit("2.1e-05"), 1e-6)
