"""Options name their unit: a length option ends in ``-mm`` or ``-um``, an old bare name is refused.

The parsers are walked as built (:func:`pcmm_geo.cli.build_parser`), so a new option that takes
a length without saying its unit in its name, or a renamed option whose old name still parses,
fails here.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from collections.abc import Iterator

import pytest

from pcmm_geo.cli import build_parser, main
from pcmm_geo.cli._output import _RenamedOption

#: unit suffixes an option name may end in
UNIT_SUFFIXES = ("-mm", "-um", "-rad", "-deg")
#: help text that says an option's number is a length
LENGTH_WORDS = re.compile(r"\bmm\b|micrometre|µm|\bum\b")
#: options whose help speaks of lengths but whose number is not one
NOT_LENGTHS = {"--mpe-k",  # K of MPE_E0 = A + L/K is a ratio, mm of L per µm of MPE
               "--characteristic-fraction"}  # qif verify: a fraction of the tolerance (at least 1 µm)


def _parsers(parser: argparse.ArgumentParser, prefix: str = "pcmm") -> Iterator[tuple[str, argparse.ArgumentParser]]:
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from _parsers(child, f"{prefix} {name}")


PARSERS = dict(_parsers(build_parser()))


def _length_options() -> list[tuple[str, argparse.Action]]:
    found = []
    for command, parser in PARSERS.items():
        for action in parser._actions:
            if (action.option_strings and action.type is float and LENGTH_WORDS.search(action.help or "")
                    and not NOT_LENGTHS & set(action.option_strings)):
                found.append((command, action))
    return found


def _renamed() -> list[tuple[str, _RenamedOption]]:
    return [(command, action) for command, parser in PARSERS.items() for action in parser._actions
            if isinstance(action, _RenamedOption)]


def test_every_length_option_names_its_unit() -> None:
    options = _length_options()
    assert len(options) >= 40  # the walk reaches the sub-commands' options
    unnamed = [f"{command} {action.option_strings}" for command, action in options
               if not all(name.endswith(UNIT_SUFFIXES) for name in action.option_strings)]
    assert unnamed == []


@pytest.mark.parametrize(("old", "new"), [("--mpe-a", "--mpe-a-um"), ("--tolerance", "--tolerance-mm"),
                                          ("--uncertainty", "--uncertainty-um"), ("--mpe-size", "--mpe-size-um")])
def test_old_names_of_the_readme_examples_are_refused(old: str, new: str) -> None:
    table = {(command, action.option_strings[0]): action.new for command, action in _renamed()}
    assert new in table.values() and any(key[1] == old for key in table)


def test_every_old_name_is_refused_naming_the_new_one(capsys: pytest.CaptureFixture[str]) -> None:
    renamed = _renamed()
    assert len(renamed) >= 40
    for command, action in renamed:
        old = action.option_strings[0]
        argv = [*command.split()[1:], old, "1"]
        with pytest.raises(SystemExit) as stop:
            main(argv)
        err = capsys.readouterr().err
        assert stop.value.code == 2, argv
        assert f"{old} is now {action.new}" in err.splitlines()[-1], (argv, err)
        assert any(action.new in other.option_strings for other in PARSERS[command]._actions), (command, action.new)


def test_iso10360_5_mpe_size_is_micrometres_and_iso10360_6_mpe_size_is_millimetres() -> None:
    five = {name for action in PARSERS["pcmm iso10360-5"]._actions for name in action.option_strings}
    six = {name for action in PARSERS["pcmm iso10360-6"]._actions for name in action.option_strings}
    assert {"--mpe-size-um", "--mpe-form-um", "--uncertainty-um", "--reference-diameter-mm"} <= five
    assert {"--mpe-size-mm", "--mpe-position-mm", "--mpe-orientation-rad", "--mpe-angle-rad"} <= six


def test_pcmm_alone_prints_usage_on_stderr_and_exits_2() -> None:
    done = subprocess.run([sys.executable, "-m", "pcmm_geo"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr.startswith("usage: pcmm") and "COMMAND" in done.stderr


def test_pcmm_fit_takes_the_element_names_of_the_fits() -> None:
    from pcmm_geo import fit
    from pcmm_geo.cli.measure.fit import ELEMENTS

    assert ELEMENTS == fit.ELEMENTS and all(callable(getattr(fit, f"fit_{name}")) for name in ELEMENTS)
