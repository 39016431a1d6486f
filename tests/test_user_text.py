"""User-facing text says things one way: "centre" in figures, tables, command-line text, docs and README."""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _user_strings(path: Path) -> list[tuple[int, str]]:
    source = path.read_text(encoding="utf-8")
    if path.suffix != ".py":
        return list(enumerate(source.splitlines(), start=1))
    return [(token.start[0], token.string) for token in tokenize.generate_tokens(io.StringIO(source).readline)
            if token.type in (tokenize.STRING, tokenize.COMMENT)]


_CENTER = re.compile(r"(?<![\w`.\-])[Cc]enter(?:s|ed)?(?![\w`(=\-])")


def test_centre_is_spelt_one_way_in_user_facing_text() -> None:
    """Figures, tables, command-line text, the guide and README say "centre"; API names (``tip_center``) stay."""
    files = [*sorted((ROOT / "pcmm_geo" / "plots").rglob("*.py")), *sorted((ROOT / "pcmm_geo" / "cli").rglob("*.py")),
             ROOT / "pcmm_geo" / "demo.py", *sorted((ROOT / "docs").rglob("*.md")),
             *sorted((ROOT / "docs").rglob("*.rst")), ROOT / "README.md"]
    found = []
    for path in files:
        for line, text in _user_strings(path):
            prose = re.sub(r"``[^`]*``|`[^`]*`", "", text)
            if text.strip("\"'") in ("center", "centers") or re.search(r"(upper|lower) center", text):
                continue  # a dictionary key / matplotlib's own location names
            if _CENTER.search(prose):
                found.append(f"{path.relative_to(ROOT)}:{line}: {text.strip()[:80]}")
    assert found == []
