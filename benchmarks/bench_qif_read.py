"""Benchmark of the QIF reader (issue 20): time and peak memory of a large measured point set.

Writes a QIF 3.0 results document holding one ``MeasuredPointSet`` of ``--points`` points (the
issue's figure: 10^7), then reads it in separate processes, each reporting its wall time and
peak resident memory (``ru_maxrss``):

- ``pcmm_geo``: :func:`pcmm_geo.io.cmm.read_qif` (defusedxml parser target, the point list
  streamed into one preallocated float64 array);
- ``lxml-tree``: ``lxml.etree.parse`` of the whole document, then the ``Points`` text split
  into a float array (a peer that holds the text and the tree);
- ``stdlib-iterparse``: ``xml.etree.ElementTree.iterparse`` with elements cleared, the ``Points``
  text converted with ``numpy.array(text.split())`` (what a careful hand-written reader does).

The points array itself is ``24 * points`` bytes; the memory column says how many copies each
reader needs.  The load average and the BLAS thread setting are printed beside the figures;
take speed figures from a quiet machine only.

Run: ``.venv/bin/python benchmarks/bench_qif_read.py [--points 1000000] [--keep FILE]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

_READERS = {
    "pcmm_geo": """
from pcmm_geo.io.cmm import read_qif
points = read_qif(PATH, max_bytes=1 << 40).point_sets[2].points
""",
    "lxml-tree": """
from lxml import etree
root = etree.parse(PATH, etree.XMLParser(huge_tree=True, resolve_entities=False, no_network=True)).getroot()
node = root.find(".//{http://qifstandards.org/xsd/qif3}Points")
points = np.array(node.text.split(), dtype=float).reshape(-1, 3)
""",
    "stdlib-iterparse": """
import xml.etree.ElementTree as ElementTree
points = None
for event, element in ElementTree.iterparse(PATH):
    if element.tag.endswith("}Points"):
        points = np.array(element.text.split(), dtype=float).reshape(-1, 3)
    element.clear()
""",
}

_CHILD = """
import json, resource, sys, time
import numpy as np
PATH = sys.argv[1]
start = time.perf_counter()
{code}
seconds = time.perf_counter() - start
print(json.dumps({{"seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                   "n": int(points.shape[0]), "checksum": float(points[::1000].sum())}}))
"""


def write_document(path: Path, n: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    with open(path, "w", encoding="utf-8") as stream:
        stream.write('<?xml version="1.0" encoding="UTF-8"?>\n<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" '
                     'versionQIF="3.0.0"><Results><MeasurementResultsSet n="1"><MeasurementResults id="1">'
                     f'<MeasuredPointSets n="1"><MeasuredPointSet id="2" count="{n}"><Points>\n')
        for start in range(0, n, 100_000):
            block = rng.normal(scale=200.0, size=(min(100_000, n - start), 3))
            np.savetxt(stream, block, fmt="%.9f")
        stream.write("</Points><Compensated>false</Compensated><ProbeRadius>1.5</ProbeRadius></MeasuredPointSet>"
                     "</MeasuredPointSets></MeasurementResults></MeasurementResultsSet></Results></QIFDocument>\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--keep", type=Path, help="write the document here and keep it")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    path = args.keep or folder / "large.qif"
    write_document(path, args.points)
    print(f"load average {os.getloadavg()}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'default')}")
    print(f"{args.points} points, file {path.stat().st_size / 2**20:.0f} MB, array {24 * args.points / 2**20:.0f} MB")
    print(f"{'reader':<18} {'time / s':>9} {'peak RSS / MB':>14}")
    checks = set()
    for name, code in _READERS.items():
        out = subprocess.run([sys.executable, "-c", _CHILD.format(code=code), str(path)], capture_output=True,
                             text=True, check=False)
        if out.returncode:
            print(f"{name:<18} failed: {out.stderr.strip().splitlines()[-1]}")
            continue
        result = json.loads(out.stdout)
        checks.add((result["n"], round(result["checksum"], 6)))
        print(f"{name:<18} {result['seconds']:>9.2f} {result['peak_mb']:>14.0f}")
    print("all readers agree" if len(checks) == 1 else f"readers DISAGREE: {checks}")
    if args.keep is None:
        path.unlink()
        folder.rmdir()


if __name__ == "__main__":
    main()
