"""Run the NIST I++ DME Test Suite's ``.prg`` programs against the server; check every response with its parser.

The suite (NIST I++ DME Test Suite 3.0; a public mirror is github.com/aschet/nistippdmetestsuite)
is *not* part of this repository: point ``PCMM_IPPDME_NIST_SUITE`` at a local copy (the folder
holding ``testSuiteUtilities/`` and ``standAloneTestSuiteComponents/``).  The suite's stand-alone
response parser (``ParserResPC/source``) is compiled with g++ and reads the responses in the
suite's ``.res`` layout (each response, CR LF, ``\\\\`` CR LF; ``:`` ends the file).

Run as a script for the counts quoted in docs/guide/ippdme.rst::

    PYTHONPATH=. python tests/ippdme/nist_harness.py /path/to/nistippdmetestsuite
"""

from __future__ import annotations

import json
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

ENV = "PCMM_IPPDME_NIST_SUITE"
_TAG = re.compile(rb"^((?!00000)[0-9]{5}|E(?!0000)[0-9]{4})")


def suite_root() -> Path | None:
    value = os.environ.get(ENV)
    if not value:
        return None
    root = Path(value)
    return root if (root / "testSuiteUtilities" / "I++test_files").is_dir() else None


def compile_parser(root: Path, folder: Path) -> Path | None:
    """The suite's response parser built with g++ (None without g++)."""
    gxx = shutil.which("g++")
    if gxx is None:
        return None
    source = root / "standAloneTestSuiteComponents" / "ParserResPC" / "source"
    exe = folder / "parserRes"
    subprocess.run([gxx, "-O1", "-w", "-DPARSER_MAIN", "-o", str(exe), str(source / "parserRes.cpp"),
                    str(source / "IppCmdRes.cpp")], check=True, capture_output=True, timeout=300)
    return exe


def program_lines(path: Path) -> list[bytes]:
    """Command lines of a ``.prg`` file (entries separated by ``\\\\`` lines, ``:`` ends it)."""
    lines = []
    for raw in path.read_bytes().split(b"\n"):
        line = raw.rstrip(b"\r")
        if line == b":":
            break
        if line and line != b"\\\\":
            lines.append(line)
    return lines


def run_program(port: int, lines: list[bytes], timeout: float = 15.0) -> tuple[list[str], int, bool]:
    """Send each line and read until its ``%`` (or an E0000 error for an untagged line).

    Returns (every response line, commands completed, hung).
    """
    sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    buffer = b""
    responses: list[str] = []
    done = 0
    try:
        for line in lines:
            sock.sendall(line + b"\r\n")
            match = _TAG.match(line)
            tag = match.group(1).decode() if match else None
            deadline = time.monotonic() + timeout
            finished = False
            while not finished:
                while b"\r\n" not in buffer:
                    if time.monotonic() > deadline:
                        return responses, done, True
                    try:
                        chunk = sock.recv(65536)
                    except TimeoutError:
                        return responses, done, True
                    if not chunk:
                        return responses, done, False
                    buffer += chunk
                raw, buffer = buffer.split(b"\r\n", 1)
                text = raw.decode("ascii", "replace")
                responses.append(text)
                if tag is None or tag == "E0000":
                    finished = text.startswith("E0000 !")
                else:
                    finished = text == f"{tag} %"
            done += 1
        sock.settimeout(0.3)  # events that follow the last command
        try:
            while True:
                chunk = sock.recv(65536)
                if not chunk:
                    break
                buffer += chunk
        except TimeoutError:
            pass
        responses += [x.decode("ascii", "replace") for x in buffer.split(b"\r\n") if x]
    finally:
        sock.close()
    return responses, done, False


def parse_responses(parser: Path, responses: list[str], folder: Path, name: str) -> tuple[int, list[str]]:
    """(parsed clean, messages of the refused) with the suite's parser."""
    res = folder / f"{name}.res"
    res.write_bytes(b"".join(r.encode("ascii", "replace") + b"\r\n\\\\\r\n" for r in responses) + b":\r\n:\r\n")
    out = subprocess.run([str(parser)], input=f"n\n{res}\nq\n".encode(), capture_output=True, timeout=60)
    parsed = out.stdout.count(b"\\\\\r\n")
    errors = [x for x in out.stderr.decode("ascii", "replace").splitlines() if x.strip()]
    return parsed, errors


def run_suite(root: Path, folder: Path, make_server: Any) -> dict[str, Any]:
    """Counts over every ``.prg`` of ``testSuiteUtilities/I++test_files`` (one fresh server each)."""
    parser = compile_parser(root, folder)
    programs = sorted((root / "testSuiteUtilities" / "I++test_files").glob("*.prg"))
    summary: dict[str, Any] = {"programs": len(programs), "run": 0, "parsed_clean": 0, "refused": 0, "hung": [],
                               "responses": 0, "responses_parsed": 0, "error_responses": 0, "errors": Counter(),
                               "not_parsed": {}}
    for prg in programs:
        with make_server() as server:
            responses, _, hung = run_program(server.port, program_lines(prg))
        if hung:
            summary["hung"].append(prg.name)
            continue
        summary["run"] += 1
        summary["responses"] += len(responses)
        errors = [r for r in responses if r[6:8] == "! "]
        summary["error_responses"] += len(errors)
        summary["errors"].update(re.findall(r"Error\(\d, (\d{4})", " ".join(errors)))
        if errors:
            summary["refused"] += 1
        if parser is not None:
            parsed, messages = parse_responses(parser, responses, folder, prg.stem)
            summary["responses_parsed"] += parsed
            if parsed == len(responses):
                summary["parsed_clean"] += 1
            else:
                summary["not_parsed"][prg.name] = messages[:6]
    summary["errors"] = dict(sorted(summary["errors"].items()))
    summary["parser"] = "suite's ParserResPC (g++)" if parser is not None else "not compiled (no g++)"
    return summary


def main(argv: list[str]) -> int:  # pragma: no cover - the documented command
    import tempfile

    sys.path.insert(0, str(Path(__file__).parent))
    from conftest import running_server

    from pcmm_geo.demo import demo_calibrated_machine
    from pcmm_geo.ippdme.machine import MachineModel
    from pcmm_geo.ippdme.workpieces import SphereWorkpiece

    machine, radius, covariance, center = demo_calibrated_machine()
    model = MachineModel(machine, radius, covariance.model_covariance()[1])
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_suite(Path(argv[0]), Path(tmp),
                            lambda: running_server(model, [SphereWorkpiece(center, 20.0)]))
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main(sys.argv[1:]))
