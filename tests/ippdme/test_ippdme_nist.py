"""The NIST I++ DME Test Suite's programs against the server, every response checked by the suite's parser.

Runs only with a local copy of the suite (``PCMM_IPPDME_NIST_SUITE``, see nist_harness.py) and
g++; the suite's files are not part of this repository.  The counts are recorded in
docs/guide/ippdme.rst.
"""

from __future__ import annotations

import shutil

import pytest
from conftest import running_server
from nist_harness import ENV, run_suite, suite_root

from pcmm_geo.ippdme.workpieces import SphereWorkpiece

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(suite_root() is None, reason=f"no local NIST I++ DME test suite ({ENV} not set)"),
    pytest.mark.skipif(shutil.which("g++") is None, reason="g++ is needed to build the suite's response parser"),
]


def test_every_program_runs_and_every_response_parses(model, center, tmp_path) -> None:
    root = suite_root()
    assert root is not None
    summary = run_suite(root, tmp_path, lambda: running_server(model, [SphereWorkpiece(center, 20.0)]))
    assert summary["programs"] >= 60
    assert summary["hung"] == []  # never a hang: every command got its transaction complete
    assert summary["run"] == summary["programs"]
    assert summary["responses_parsed"] == summary["responses"], summary["not_parsed"]
    assert summary["parsed_clean"] == summary["run"]
    # what the micro-CMM cannot do is refused with the spec's errors, e.g. scanning with 0501
    assert summary["errors"].get("0501", 0) > 0
    assert 0 < summary["refused"] < summary["run"]
