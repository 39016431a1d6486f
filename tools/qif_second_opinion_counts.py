"""Counts of the second opinion on every public QIF results file: agrees / disagrees / not computable per file.

Walks the given folders (the shipped samples, a checkout of qif-community, any other folder)
for ``.qif`` files that hold characteristic measurements, runs
:func:`pcmm_geo.gdt.qif.characteristics.verify_characteristics` on each, and prints one row per
file (the numbers of docs/guide/files_from_your_cmm.rst).  ``--reasons`` also lists every
characteristic that disagrees or is not computable with its reason.

Usage::

    python tools/qif_second_opinion_counts.py tests/data/qif/samples [QIF_COMMUNITY_CHECKOUT ...] [--reasons]
    [--json out/counts.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def _files(folders: list[str]) -> list[Path]:
    found = []
    for folder in folders:
        root = Path(folder)
        candidates = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.suffix.lower() == ".qif")
        for path in candidates:
            with path.open("rb") as stream:
                if b"CharacteristicMeasurement" in stream.read():
                    found.append(path)
    return found


def main(argv: list[str] | None = None) -> int:
    from pcmm_geo.errors import PcmmGeoError
    from pcmm_geo.gdt.qif.characteristics import verify_characteristics
    from pcmm_geo.io.cmm import read_qif

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+")
    parser.add_argument("--reasons", action="store_true")
    parser.add_argument("--json", metavar="OUT")
    args = parser.parse_args(argv)
    rows = []
    for path in _files(args.folders):
        try:
            verification = verify_characteristics(read_qif(path))
        except PcmmGeoError as exc:
            print(f"{path}: not read: {exc}")
            continue
        counts = verification.summary()
        rows.append({"file": str(path), "total": len(verification.checks), **counts})
        print(f"{len(verification.checks):5d} {counts['agrees']:5d} {counts['disagrees']:5d} "
              f"{counts['not_computable']:5d}  {path}")
        if args.reasons:
            for check in verification.checks:
                if check.status != "agrees":
                    print(f"      {check.id} {check.name} {check.type} [{check.status}] reported {check.reported} "
                          f"recomputed {check.recomputed}: {check.reason}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
