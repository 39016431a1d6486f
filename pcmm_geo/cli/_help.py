"""``pcmm --help`` grouped by what a person is doing, and the parser's one-line errors.

:data:`COMMAND_GROUPS` places every sub-command in one group (measure and evaluate; CMM files;
artefacts and standards; uncertainty; the micro-CMM); a command missing from the table is
listed under "other commands", so a new command shows up before anyone places it.
:class:`PcmmParser` is the parser class of ``pcmm`` and of every sub-command (argparse gives
sub-parsers their parent's class): a sub-command that needs an action (``pcmm thermal``)
lists its actions instead of printing "the following arguments are required".
"""

from __future__ import annotations

import argparse
import shutil
import textwrap
from typing import NoReturn

#: (group title, command names in the order listed); a name not registered is skipped
COMMAND_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("measure and evaluate", ("fit", "form", "compare", "segment", "thermal", "batch")),
    ("CMM files (QIF, DMIS, CALYPSO; point clouds and meshes)", ("results", "inspect", "convert")),
    ("artefacts and standards", ("gauge-block", "iso10360-2", "iso10360-5", "iso10360-6", "micrometer")),
    ("uncertainty", ("uncertainty",)),
    ("the micro-CMM: acquire, calibrate, process", (
        "demo", "acquire", "serve", "process-log", "calibrate", "numcal", "kinematics", "sensitivity",
        "repeatability", "laser-ratio")),
)
#: another name that runs the same command (``pcmm qif ...`` keeps working as ``pcmm results ...``)
ALIASES = {"results": "qif"}
#: the help line of an alias, where the command's own line would name only one format
ALIAS_HELP = {"results": "CMM result files (QIF 3.0, DMIS output .dmo, CALYPSO *_chr.txt tables): show what one "
                         "holds, verify its results by refitting, validate it (also: pcmm qif)"}


def _width() -> int:
    return max(60, min(shutil.get_terminal_size().columns, 100) - 2)


def command_help_lines(subparsers: argparse._SubParsersAction) -> dict[str, str]:
    """``{command: its one-line help}`` of every registered sub-command (aliases with :data:`ALIAS_HELP`)."""
    lines = {action.dest: action.help or "" for action in subparsers._choices_actions}
    for alias, target in ALIASES.items():
        if target in lines:
            lines[alias] = ALIAS_HELP.get(alias, lines[target])
    return lines


def grouped_commands(subparsers: argparse._SubParsersAction) -> list[tuple[str, list[tuple[str, str]]]]:
    """The registered commands as ``[(group title, [(command, help), ...]), ...]``, unknown ones under "other".

    A command with an alias is listed once, under the alias (``results``), never twice.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="pcmm")
    >>> sub = parser.add_subparsers()
    >>> _ = sub.add_parser("fit", help="fit an element"); _ = sub.add_parser("new-tool", help="something new")
    >>> grouped_commands(sub)
    [('measure and evaluate', [('fit', 'fit an element')]), ('other commands', [('new-tool', 'something new')])]
    """
    helps = command_help_lines(subparsers)
    shown = set(ALIASES.values()) & set(helps)  # listed under their alias
    groups = []
    for title, names in COMMAND_GROUPS:
        members = [(name, helps[name]) for name in names if name in helps]
        shown.update(name for name, _ in members)
        if members:
            groups.append((title, members))
    other = [(name, text) for name, text in helps.items() if name not in shown]
    if other:
        groups.append(("other commands", other))
    return groups


def grouped_help_text(subparsers: argparse._SubParsersAction) -> str:
    """The grouped command list as the text ``pcmm --help`` prints after its usage."""
    groups = grouped_commands(subparsers)
    names = [name for _, members in groups for name, _ in members]
    column = min(max(len(name) for name in names) + 4, 20) if names else 4
    width = _width()
    out = []
    for title, members in groups:
        out.append(f"{title}:")
        for name, text in members:
            first = f"  {name}".ljust(column)
            if len(first) > column:  # a long name: its help on the next line
                out.append(first.rstrip())
                first = " " * column
            out.extend(textwrap.wrap(text, width, initial_indent=first, subsequent_indent=" " * column) or [first])
        out.append("")
    out.append("pcmm COMMAND --help shows a command's options.")
    return "\n".join(out)


class PcmmParser(argparse.ArgumentParser):
    """The parser of ``pcmm`` and its sub-commands: a missing action is answered with the list of actions."""

    def error(self, message: str) -> NoReturn:
        actions = next((a for a in self._actions if isinstance(a, argparse._SubParsersAction)), None)
        if actions is not None and "required" in message and str(actions.metavar or actions.dest) in message:
            helps = command_help_lines(actions)
            width = max(len(name) for name in helps) + 4
            listing = "\n".join(f"  {name.ljust(width)}{text}" for name, text in helps.items())
            self.exit(2, f"{self.prog}: error: choose an action:\n{listing}\n"
                         f"({self.prog} ACTION --help shows an action's options)\n")
        super().error(message)


class _PrintCompletion(argparse.Action):
    """``--print-completion SHELL``: the shell completion script of ``pcmm`` (shtab, extra ``[completion]``)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        from pcmm_geo._optional import require
        from pcmm_geo.errors import MissingDependencyError

        try:
            shtab = require("shtab", purpose="shell completion")
        except MissingDependencyError as exc:  # parsing has not reached the command's error handling yet
            parser.exit(2, f"{parser.prog}: error: {' '.join(str(exc).split())}\n")
        commands = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        for action in commands:  # hidden from --help (the grouped list replaces it), not from completion
            action.help = "command"
        print(shtab.complete(parser, shell=str(values)))
        parser.exit(0)


def add_completion_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--print-completion {bash,zsh,tcsh}`` (imports shtab only when used).

    ``pcmm --print-completion bash > ~/.local/share/bash-completion/completions/pcmm`` completes
    the commands, actions, options and their choices.
    """
    parser.add_argument("--print-completion", choices=("bash", "zsh", "tcsh"), action=_PrintCompletion,
                        help="print a shell completion script for pcmm (needs the completion extra: shtab)")


def _renamed(parser: argparse.ArgumentParser, name: str, alias: str) -> argparse.ArgumentParser:
    """A copy of a command's parser whose usage, help and errors say ``pcmm ALIAS`` (its actions' too)."""
    import copy

    renamed = copy.deepcopy(parser)
    old, new = parser.prog, parser.prog[: len(parser.prog) - len(name)] + alias
    stack = [renamed]
    while stack:
        current = stack.pop()
        if current.prog == old or current.prog.startswith(old + " "):
            current.prog = new + current.prog[len(old):]
        for action in current._actions:
            if isinstance(action, argparse._SubParsersAction):
                action._prog_prefix = new + action._prog_prefix[len(old):] if action._prog_prefix.startswith(
                    old) else action._prog_prefix
                stack.extend(action.choices.values())
    return renamed


def install_grouped_help(parser: argparse.ArgumentParser, subparsers: argparse._SubParsersAction) -> None:
    """Add the aliases and make ``parser``'s help list the commands by group (:data:`COMMAND_GROUPS`)."""
    for alias, target in ALIASES.items():
        if target in subparsers.choices and alias not in subparsers.choices:
            subparsers.choices[alias] = _renamed(subparsers.choices[target], target, alias)
            # a command of its own for completion (shtab lists the choices that have an entry here)
            subparsers._choices_actions.append(
                subparsers._ChoicesPseudoAction(alias, (), ALIAS_HELP.get(alias, "")))  # type: ignore[attr-defined]
    parser.epilog = grouped_help_text(subparsers)
    # set after the sub-parsers took their prog from the default usage
    parser.usage = f"{parser.prog} [-h] [--version] [--print-completion SHELL] COMMAND ..."
    subparsers.help = argparse.SUPPRESS


