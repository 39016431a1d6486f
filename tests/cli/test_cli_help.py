"""``pcmm --help`` groups the commands by task; parser errors are one line that says what to do."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from pcmm_runner import run_pcmm

from pcmm_geo.cli import build_parser
from pcmm_geo.cli._help import ALIASES, COMMAND_GROUPS, grouped_commands

QIF_SAMPLE = Path(__file__).parents[1] / "data" / "qif" / "samples" / "QIF_PTS_SAMPLE.QIF"


def _commands() -> set[str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return set(sub.choices)


def test_help_lists_every_command_once_under_its_group() -> None:
    done = run_pcmm("--help")
    assert done.returncode == 0
    text = done.stdout
    titles = [title for title, _ in COMMAND_GROUPS]
    listed: dict[str, str] = {}
    group = None
    for line in text.splitlines():
        if line.endswith(":") and line[:-1] in [*titles, "other commands"]:
            group = line[:-1]
        elif group and (match := re.match(r"  (\S+)", line)) and not line.startswith("   "):
            assert match.group(1) not in listed, f"{match.group(1)} listed twice"
            listed[match.group(1)] = group
    # every registered name once; ``qif`` is listed as its alias ``results``
    assert set(listed) == _commands() - set(ALIASES.values())
    assert "other commands" not in listed.values()  # every command has its group
    assert listed["results"] == listed["convert"] == titles[1]
    assert listed["iso10360-2"] == listed["gauge-block"] == "artefacts and standards"
    assert listed["calibrate"] == listed["acquire"] == titles[4]
    assert listed["fit"] == "measure and evaluate" and listed["uncertainty"] == "uncertainty"
    assert "DMIS" in text and "CALYPSO" in text


def test_commands_being_added_have_a_group_and_unknown_ones_go_to_other() -> None:
    names = {name: title for title, members in COMMAND_GROUPS for name in members}
    assert names["inspect"].startswith("CMM files") and names["serve"].startswith("the micro-CMM")
    parser = argparse.ArgumentParser(prog="pcmm")
    sub = parser.add_subparsers()
    for name in ("serve", "inspect", "brand-new", "qif"):
        sub.add_parser(name, help=f"{name} help")
    groups = dict(grouped_commands(sub))
    assert [name for name, _ in groups["other commands"]] == ["brand-new"]
    assert [name for name, _ in groups["the micro-CMM: acquire, calibrate, process"]] == ["serve"]
    assert [name for name, _ in groups["CMM files (QIF, DMIS, CALYPSO; point clouds and meshes)"]] == \
        ["results", "inspect"]


def test_results_is_the_qif_command_under_its_own_name() -> None:
    by_results = run_pcmm("results", "show", str(QIF_SAMPLE), "--json")
    by_qif = run_pcmm("qif", "show", str(QIF_SAMPLE), "--json")
    assert by_results.returncode == by_qif.returncode == 0
    assert by_results.stdout == by_qif.stdout and by_results.stdout.startswith("{")


def test_a_command_without_its_action_lists_the_actions() -> None:
    done = run_pcmm("thermal")
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert lines[0] == "pcmm thermal: error: choose an action:"
    actions = [line.split()[0] for line in lines[1:-1]]
    assert actions == ["rtd", "thermistor", "correct-length", "triangle", "table"]
    assert "usage:" not in done.stderr and "required" not in done.stderr


def test_a_renamed_option_is_one_line_without_the_usage() -> None:
    done = run_pcmm("iso10360-2", "x.csv", "--mpe-a", "1", "--mpe-k", "100")
    assert done.returncode == 2
    assert done.stderr.splitlines() == ["pcmm iso10360-2: error: --mpe-a is now --mpe-a-um (the unit is in the "
                                        "name); the old name is refused, so no number is read in a unit it was not "
                                        "written in"]


def test_shell_completion_scripts_complete_commands_actions_and_options(tmp_path: Path) -> None:
    import shutil
    import subprocess

    done = run_pcmm("--print-completion", "bash")
    assert done.returncode == 0 and "_shtab_pcmm" in done.stdout
    if shutil.which("bash") is None:
        return
    script = tmp_path / "pcmm.bash"
    script.write_text(done.stdout, encoding="utf-8")

    def complete(*words: str) -> list[str]:
        line = " ".join(("pcmm", *words))
        program = (f"source {script}; COMP_WORDS=(pcmm {' '.join(words)}); COMP_CWORD={len(words)}; "
                   f"COMP_LINE='{line}'; COMP_POINT={len(line)}; _shtab_pcmm; printf '%s\\n' \"${{COMPREPLY[@]}}\"")
        return subprocess.run(["bash", "-c", program], capture_output=True, text=True, timeout=60).stdout.split()

    assert complete("res") == ["results"]
    assert complete("thermal", "c") == ["correct-length"]
    assert complete("iso10360-2", "--mpe-") == ["--mpe-a-um", "--mpe-k", "--mpe-b-um"]
    assert complete("iso10360-2", "--mpe-a") == ["--mpe-a-um"]  # the refused old name --mpe-a is not offered
