"""A report is a lab record a calibration laboratory can file (ISO/IEC 17025 7.8).

Each identity item is asserted against what was given (options, ``pcmm.toml``) or against an
independent source (the clock, ``git``, hashlib over the package's files); the decision is
stated once, in ISO 14253-1 terms, with U wherever the evaluation has one.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
from datetime import UTC, datetime
from html.parser import HTMLParser
from pathlib import Path

import pytest

import pcmm_geo
from pcmm_geo.cli import main

EXAMPLES = Path(pcmm_geo.__file__).parent / "data" / "examples"
GAUGE = str(EXAMPLES / "gauge_block.csv")
LENGTHS = str(EXAMPLES / "iso10360_2_lengths.csv")
SPHERE = str(EXAMPLES / "iso10360_5_sphere.csv")
RING = str(EXAMPLES / "roundness_ring.csv")

IDENTITY = {
    "--report-id": "DML-2026-0042",
    "--laboratory": "Dimensional Metrology Laboratory, 1 Example Road, Stellenbosch",
    "--customer": "Example Gauges Ltd",
    "--item": "gauge block 100 mm, steel, serial 7781",
    "--instrument": "micro-CMM serial 001",
    "--operator": "A. Operator",
    "--approved-by": "B. Approver",
    "--measurement-date": "2026-11-20",
    "--supersedes": "DML-2026-0041",
}
REFERENCE = "name=gauge block 100 mm grade K;certificate=CAL-2025-0417;U_um=0.05;k=2;calibrated=2025-04-17"
LABELS = {"--report-id": "report id", "--laboratory": "laboratory", "--customer": "customer",
          "--item": "item measured", "--instrument": "measuring instrument", "--operator": "operator",
          "--approved-by": "approved by", "--measurement-date": "measurement date"}


def _markdown_tables(text: str) -> dict[str, list[list[str]]]:
    """``{title: rows}`` of the pipe tables of a Markdown report (escapes removed)."""
    tables: dict[str, list[list[str]]] = {}
    title = None
    for line in text.splitlines():
        if line.startswith("## "):
            title = line[3:].replace("\\", "")
            tables[title] = []
        elif line.startswith("| ") and title is not None and not set(line) <= set("|-: "):
            tables[title].append([cell.strip().replace("\\", "") for cell in line.strip("|").split(" | ")])
    return {name: rows[1:] for name, rows in tables.items()}  # without the header row


def _rows(tables: dict[str, list[list[str]]], title: str) -> dict[str, str]:
    return {row[0]: row[1] for row in tables[title]}


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _identity_argv() -> list[str]:
    return [item for pair in IDENTITY.items() for item in pair] + ["--reference", REFERENCE]


def _git(*arguments: str) -> str:
    root = Path(pcmm_geo.__file__).resolve().parents[1]
    done = subprocess.run(["git", "-C", str(root), *arguments], capture_output=True, text=True, check=True,
                          env={**os.environ, "GIT_OPTIONAL_LOCKS": "0"})
    return done.stdout.strip()


def _package_digest() -> str:
    root = Path(pcmm_geo.__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0"
                      + hashlib.sha256(path.read_bytes()).hexdigest().encode() + b"\n")
    return digest.hexdigest()


def test_every_identity_item_is_in_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "gauge.md"
    before = datetime.now(UTC).replace(microsecond=0)
    code, out, err = _run(["gauge-block", GAUGE, "--nominal-mm", "100", "--tolerance-um", "0.3",
                           "--uncertainty-um", "0.1", "--report", str(report), *_identity_argv()], capsys)
    after = datetime.now(UTC)
    assert code == 0, err
    text = report.read_text(encoding="utf-8")
    tables = _markdown_tables(text)
    identity = _rows(tables, "Report")
    for option, label in LABELS.items():
        assert identity[label] == IDENTITY[option], option
    assert "DML-2026-0041" in identity["supersedes"]
    assert text.splitlines()[2] == "**Amended report: replaces report DML-2026-0041.**"
    issued = datetime.fromisoformat(identity["date of issue (UTC)"])
    assert issued.utcoffset().total_seconds() == 0 and before <= issued <= after
    assert identity["method"].startswith("ISO 3650:1998, clause 3")
    # the reference standard with its certificate and calibration uncertainty
    assert tables["Reference standards"] == [["gauge block 100 mm grade K", "CAL-2025-0417", "U = 0.05 µm (k = 2)",
                                              "2025-04-17"]]
    # no temperature entered this evaluation: said so once, with the consequence
    conditions = _rows(tables, "Environmental conditions")
    assert list(conditions) == ["correction to 20 °C"]
    assert conditions["correction to 20 °C"].startswith("none applied") and "no temperature was entered" in \
        conditions["correction to 20 °C"] and "20 °C (ISO 1)" in conditions["correction to 20 °C"]
    # the closing statement and the approval
    assert "*The results relate only to the item measured, as received, under the conditions stated.*" in text
    approval = _rows(tables, "Approval")
    assert approval["approved by (name, function)"] == "B. Approver"
    assert set(approval["signature"]) == set(approval["date"]) == {"_"}  # room to sign and date
    # the software: version, the git revision of this checkout (dirty when it is), the package digest
    software = _rows(tables, "Software")
    assert software["pcmm_geo version"] == pcmm_geo.__version__
    assert software["package files SHA-256"].split()[0] == _package_digest()
    if shutil.which("git") and (Path(pcmm_geo.__file__).resolve().parents[1] / ".git").exists():
        revision = software["source revision (git)"]
        assert revision.split()[0] == _git("rev-parse", "HEAD")
        assert ("dirty" in revision) == bool(_git("status", "--porcelain"))
    assert f"report written to {report}" in out


def test_pcmm_toml_gives_the_defaults_and_an_option_wins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "pcmm.toml").write_text(
        'laboratory = "Lab from the file"\noperator = "File Operator"\ninstrument = "CMM from the file"\n'
        '[[reference]]\nname = "sphere 25 mm"\ncertificate = "S-9"\nU_mm = 0.0002\nk = 2\n'
        '[environment]\n"air temperature" = "20.1 °C ± 0.2 K"\n"relative humidity / %" = 45\n',
        encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(["iso10360-5", SPHERE, "--report", "r.md", "--operator", "Command-line Operator"], capsys)
    assert code == 0, err
    tables = _markdown_tables((tmp_path / "r.md").read_text(encoding="utf-8"))
    identity = _rows(tables, "Report")
    assert identity["laboratory"] == "Lab from the file" and identity["measuring instrument"] == "CMM from the file"
    assert identity["operator"] == "Command-line Operator" and identity["customer"] == "not stated"
    assert tables["Reference standards"][0][:3] == ["sphere 25 mm", "S-9", "U = 0.0002 mm (k = 2)"]
    conditions = _rows(tables, "Environmental conditions")
    correction = conditions.pop("correction to 20 °C")  # the command used none: said once, not "none entered"
    assert correction.startswith("none applied") and "recorded, not used" in correction
    assert conditions == {"air temperature": "20.1 °C ± 0.2 K", "relative humidity / %": "45"}
    assert "temperature" not in conditions and "none entered" not in (tmp_path / "r.md").read_text(encoding="utf-8")
    inputs = [row[0] for row in tables["Inputs"]]
    assert str((tmp_path / "pcmm.toml").resolve()) in inputs  # the settings file is an input of the record
    # --config names another file; its reference replaces none given on the command line
    other = tmp_path / "other.toml"
    other.write_text('customer = "Customer from --config"\n', encoding="utf-8")
    assert _run(["iso10360-5", SPHERE, "--report", "s.md", "--config", str(other)], capsys)[0] == 0
    identity = _rows(_markdown_tables((tmp_path / "s.md").read_text(encoding="utf-8")), "Report")
    assert identity["customer"] == "Customer from --config" and identity["laboratory"] == "not stated"


@pytest.mark.parametrize(("content", "needle"), [
    ('laboratory = "x"\nsignature = "y"\n', "'signature'"),
    ("laboratory = 3\n", "laboratory"),
    ('[[reference]]\nname = "a"\ncertificate = "b"\n', "U_um or U_mm"),
    ("laboratory = \n", "TOML"),
])
def test_a_bad_pcmm_toml_is_refused_before_any_work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str], content: str,
                                                   needle: str) -> None:
    (tmp_path / "pcmm.toml").write_text(content, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(["iso10360-5", SPHERE, "--report", "r.md", "--plot", "p.png"], capsys)
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and "pcmm.toml" in err and needle in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pcmm.toml"]


def test_pcmm_toml_keys_are_spelled_as_the_options(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "pcmm.toml").write_text('approved-by = "B. Approver"\ncustomer = "C"\n[[reference]]\nname = "s"\n'
                                        'certificate = "S-1"\nU-um = 0.1\n', encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(["iso10360-5", SPHERE, "--report", "r.md"], capsys)
    assert code == 0 and err == ""
    tables = _markdown_tables((tmp_path / "r.md").read_text(encoding="utf-8"))
    assert _rows(tables, "Report")["approved by"] == "B. Approver"
    assert tables["Reference standards"][0][:3] == ["s", "S-1", "U = 0.1 µm (k = 2)"]
    # both spellings of one key, a wrong value: one line each, the file's path once
    for content, needle in (('approved-by = "A"\napproved_by = "B"\n', "given twice"),
                            ("customer = 3\n", "customer: expected text"),
                            ('[environment]\nair = [1]\n', "[environment] 'air'")):
        (tmp_path / "pcmm.toml").write_text(content, encoding="utf-8")
        code, _, err = _run(["iso10360-5", SPHERE, "--report", "s.md"], capsys)
        assert code == 2 and len(err.splitlines()) == 1 and needle in err, err
        assert err.count("pcmm.toml") == 1


def test_generated_ids_are_unique_and_options_need_a_report(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    ids = set()
    for name in ("a.md", "b.md"):
        assert _run(["fit", "sphere", SPHERE, "--report", str(tmp_path / name)], capsys)[0] == 0
        identity = _rows(_markdown_tables((tmp_path / name).read_text(encoding="utf-8")), "Report")
        assert re.fullmatch(r"PCMM-\d{8}-\d{6}-[0-9A-F]{8} \(generated\)", identity["report id"])
        ids.add(identity["report id"])
    assert len(ids) == 2
    code, out, err = _run(["fit", "sphere", SPHERE, "--operator", "A"], capsys)
    assert code == 2 and "--report" in err and out == ""
    for bad in (["--report-id", "has space"], ["--measurement-date", "20.11.2026"],
                ["--reference", "name=x;certificate=y"], ["--reference", "name=x;certificate=y;U_um=-1"]):
        code, _, err = _run(["fit", "sphere", SPHERE, "--report", str(tmp_path / "c.md"), *bad], capsys)
        assert code == 2 and bad[0] in err and not (tmp_path / "c.md").exists(), bad


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.text: list[str] = []

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def test_html_prints_with_the_report_id_and_page_numbers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "r.html"
    assert _run(["iso10360-2", LENGTHS, "--mpe-a-um", "3", "--mpe-k", "250", "--uncertainty-um", "0.5",
                 "--report", str(report), *_identity_argv()], capsys)[0] == 0
    page = report.read_text(encoding="utf-8")
    style = page[page.index("<style>"):page.index("</style>")]
    assert re.search(r'@page\{[^@]*@top-left\{content:"pcmm iso10360-2 - report DML-2026-0042"', style)
    assert 'counter(page) " of " counter(pages)' in style
    parser = _Text()
    parser.feed(page)
    text = "".join(parser.text)
    assert "The results relate only to the item measured" in text and "Amended report: replaces" in text


# ---------------------------------------------------------------- the decision, once, with U

def _decision(path: Path) -> dict[str, str]:
    return _rows(_markdown_tables(path.read_text(encoding="utf-8")), "Decision")


@pytest.mark.parametrize(("argv", "verdict", "u_text", "conformity"), [
    (["iso10360-2", LENGTHS, "--mpe-a-um", "3", "--mpe-k", "250", "--uncertainty-um", "0.5"],
     "ISO 10360-2: PASS (105 values, 105 PASS, 0 NOT PROVEN, 0 FAIL)", "U = 0.5 µm (k = 2)", "conformity proven"),
    (["iso10360-2", LENGTHS, "--mpe-a-um", "1.5", "--mpe-k", "333", "--uncertainty-um", "0.6"],
     "ISO 10360-2: NOT PROVEN (105 values, 101 PASS, 4 NOT PROVEN, 0 FAIL)", "U = 0.6 µm (k = 2)",
     "neither conformity nor nonconformity proven"),
    (["iso10360-5", SPHERE, "--mpe-form-um", "1.5", "--mpe-size-um", "1.5", "--uncertainty-um", "0.3", "0.4"],
     "ISO 10360-5: PASS (P_FTU PASS, P_STU PASS)", "U(P_FTU) = 0.3 µm, U(P_STU) = 0.4 µm (k = 2)",
     "conformity proven"),
    (["iso10360-5", SPHERE, "--mpe-form-um", "1.0", "--mpe-size-um", "1.5", "--uncertainty-um", "0.1", "0.4"],
     "ISO 10360-5: FAIL (P_FTU FAIL, P_STU PASS)", "U(P_FTU) = 0.1 µm, U(P_STU) = 0.4 µm (k = 2)",
     "nonconformity proven"),
    (["gauge-block", GAUGE, "--nominal-mm", "100", "--tolerance-um", "0.3", "--uncertainty-um", "0.1"],
     "gauge block: PASS (deviation +0.089 µm)", "U = 0.1 µm (k = 2)", "conformity proven"),
    (["gauge-block", GAUGE, "--nominal-mm", "100", "--tolerance-um", "0.15", "--uncertainty-um", "0.1"],
     "gauge block: NOT PROVEN (deviation +0.089 µm)", "U = 0.1 µm (k = 2)",
     "neither conformity nor nonconformity proven"),
])
def test_each_verdict_with_u_states_it_once(argv: list[str], verdict: str, u_text: str, conformity: str,
                                           tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for suffix in (".md", ".html"):
        report = tmp_path / f"r{suffix}"
        code, out, err = _run([*argv, "--report", str(report)], capsys)
        assert code in (0, 1), err
        text = report.read_text(encoding="utf-8")
        body = text.replace("\\", "") if suffix == ".md" else "".join(_feed(text))  # Markdown escapes removed
        assert body.count(verdict) == 1, (suffix, verdict)
        assert body.lower().count("decision rule") == 1
        assert u_text in body and conformity in body
    decision = _decision(tmp_path / "r.md")
    assert decision["result"] == verdict and decision["conformity (ISO 14253-1)"].startswith(conformity)
    assert decision["expanded uncertainty U"].startswith(u_text)
    # the terminal says it once too
    assert out.count("verdict: ") == 1 and out.count("decision rule: ") == 1 and u_text in out


def _feed(page: str) -> list[str]:
    parser = _Text()
    parser.feed(page)
    return parser.text


@pytest.mark.parametrize(("argv", "basis"), [
    (["form", RING, "--element", "circle", "--two-d", "--tolerance-mm", "0.010"], "minimum-zone width 8.000 µm"),
    (["iso10360-2", LENGTHS, "--mpe-a-um", "3", "--mpe-k", "250"], "the E0 values alone"),
    (["gauge-block", GAUGE, "--nominal-mm", "100", "--tolerance-um", "0.3"], "the measured central length alone"),
])
def test_a_verdict_without_u_says_what_it_rests_on(argv: list[str], basis: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run([*argv, "--report", str(tmp_path / "r.md")], capsys)
    assert code in (0, 1), err
    decision = _decision(tmp_path / "r.md")
    stated = decision["expanded uncertainty U"]
    assert stated.startswith("none stated: ") and basis in stated
    assert decision["conformity (ISO 14253-1)"].startswith("conformity not proven in ISO 14253-1 terms")
    assert out.count("rests on: ") == 1 and basis in out.split("rests on: ")[1].splitlines()[0]


def test_iso10360_5_without_mpe_makes_no_decision_and_counts_carry_no_unit(tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "r.md"
    code, out, _ = _run(["iso10360-5", SPHERE, "--report", str(report)], capsys)
    assert code == 0
    text = report.read_text(encoding="utf-8")
    assert text.lower().count("decision") == 2  # the heading and its one row
    assert "simple acceptance" not in text and "guard band" not in text
    assert _decision(report) == {"decision": "no conformity statement: this evaluation has no specification to "
                                             "decide on"}
    rows = _markdown_tables(text)["ISO 10360-5 probing test"]
    assert ["points", "25", ""] in rows
    assert "no verdict: no MPE stated" in out and "decision rule" not in out


def test_a_task_uncertainty_report_states_u_and_the_temperatures_used(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "u.md"
    code, _, err = _run(["uncertainty", "distance", "--trials", "200", "--length-mm", "50",
                         "--workpiece-temperature", "20.4", "--report", str(report)], capsys)
    assert code == 0, err
    tables = _markdown_tables(report.read_text(encoding="utf-8"))
    summary = tables["Task-specific uncertainty: distance"]
    assert summary[0][0] == "Monte Carlo" and float(summary[0][3]) > 0  # U / µm
    conditions = {row[0]: (row[1], row[2]) for row in tables["Environmental conditions"]}
    assert conditions["workpiece temperature"] == ("20.400000", "°C")
    assert conditions["machine temperature"] == ("20.000000", "°C")
    assert _rows(tables, "Report")["method"].startswith("ISO 15530-4:2008")
