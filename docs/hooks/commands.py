"""MkDocs hook: the command reference, rendered from the argument parser at build time.

The page ``reference/commands.md`` holds a marker line, ``<!-- commands -->``; this hook replaces it
with one section per ``mocap-bench`` sub-command (its help line, usage and every option with its
help, choices and default), read from :func:`scenarios.cli.build_parser`. Nothing there is typed
by hand, so the page follows the parser.
"""

from __future__ import annotations

import argparse
import copy
import html
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path

MARKER = "<!-- commands -->"
PAGE = "reference/commands.md"
ROOT = Path(__file__).resolve().parents[2]


def _text(value: str) -> str:
    """Help text as Markdown: backtick spans kept as code, the rest escaped for a table cell."""
    parts = re.split(r"(`[^`]*`)", " ".join(value.split()))
    out = []
    for part in parts:
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(part.replace("|", "\\|"))
        else:
            part = html.escape(part, quote=False)
            out.append(re.sub(r"([\\*_\[\]|])", r"\\\1", part))
    return "".join(out)


def _code(value: str) -> str:
    """Inline code for a table cell."""
    value = value.replace("|", "\\|")
    return f"``{value}``" if "`" in value else f"`{value}`"


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    if not action.help or action.help == argparse.SUPPRESS:
        return ""
    action = copy.copy(action)  # the choices have their own column: drop the help's list of them
    action.help = re.sub(r";? *(?:one|any) of %\(choices\)s", "", action.help)
    return parser._get_formatter()._expand_help(action)  # noqa: SLF001 (expands %(default)s)


def _invocation(action: argparse.Action) -> str:
    if action.option_strings:
        names = ", ".join(action.option_strings)
        if action.nargs == 0:
            return names
        if action.choices and action.metavar is None:  # the choices have their own column
            action = copy.copy(action)
            action.metavar = action.dest.upper()
        metavar = argparse.HelpFormatter("x")._format_args(action, action.dest.upper())  # noqa: SLF001
        return f"{names} {metavar}"
    return argparse.HelpFormatter("x")._metavar_formatter(action, action.dest)(1)[0]  # noqa: SLF001


def _default(action: argparse.Action) -> str:
    if action.required:
        return "required"
    if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction)):  # noqa: SLF001
        return "off (a flag)"
    if action.nargs == 0:
        return ""
    default = action.default
    if default is None or default == argparse.SUPPRESS:
        return ""
    if isinstance(default, Sequence) and not isinstance(default, str):
        default = " ".join(str(v) for v in default)
    return _code(str(default))


def _choices(action: argparse.Action) -> str:
    if not action.choices or isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
        return ""
    return ", ".join(_code(str(c)) for c in action.choices)


def _table(parser: argparse.ArgumentParser, actions: list[argparse.Action]) -> list[str]:
    rows = ["| argument | meaning | choices | default |", "| --- | --- | --- | --- |"]
    for action in actions:
        if isinstance(action, argparse._HelpAction):  # noqa: SLF001
            continue
        rows.append(f"| {_code(_invocation(action))} | {_text(_help(parser, action))} | "
                    f"{_choices(action)} | {_default(action)} |")
    return rows if len(rows) > 2 else []


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """``(name, help line, parser)`` of every sub-command, in the parser's order."""
    out = []
    for action in parser._actions:  # noqa: SLF001
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            helps = {a.dest: a.help or "" for a in action._choices_actions}  # noqa: SLF001
            for name, sub in action.choices.items():
                out.append((name, helps.get(name, ""), sub))
    return out


def _usage(parser: argparse.ArgumentParser) -> str:
    usage = parser.format_usage().strip()
    return usage[len("usage: "):] if usage.startswith("usage: ") else usage


def _section(name: str, line: str, parser: argparse.ArgumentParser, level: int) -> list[str]:
    hashes = "#" * level
    out = [f"{hashes} `{name}`", ""]
    if line:
        out += [_text(line[:1].upper() + line[1:]) + ".", ""]
    if parser.description:
        out += [_text(parser.description), ""]
    out += ["```text", _usage(parser), "```", ""]
    positionals = [a for a in parser._actions if not a.option_strings  # noqa: SLF001
                   and not isinstance(a, argparse._SubParsersAction)]  # noqa: SLF001
    options = [a for a in parser._actions if a.option_strings]  # noqa: SLF001
    for title, actions in (("Arguments", positionals), ("Options", options)):
        rows = _table(parser, actions)
        if rows:
            out += [f"**{title}**", "", *rows, ""]
    if parser.epilog:
        out += [_text(parser.epilog), ""]
    for sub_name, sub_line, sub in _subcommands(parser):
        out += _section(f"{name} {sub_name}", sub_line, sub, min(level + 1, 6))
    return out


def render() -> str:
    """The Markdown of every sub-command of ``mocap-bench``."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from scenarios.cli import build_parser

    os.environ["COLUMNS"] = "100"  # usage lines wrapped the same on every machine
    parser = build_parser()
    subs = _subcommands(parser)
    out = ["## Overview", "", "| command | what it does |", "| --- | --- |"]
    out += [f"| [`{name}`](#{name}) | {_text(line)} |" for name, line, _ in subs]
    out += ["", "## Global options", "", "Given before the command name, e.g. `mocap-bench -q fuse ...`.", "",
            "```text", _usage(parser), "```", ""]
    out += _table(parser, [a for a in parser._actions if a.option_strings]) + [""]  # noqa: SLF001
    for name, line, sub in subs:
        out += _section(name, line, sub, 2)
    return "\n".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ANN001, ARG001
    """Replace the marker of the command reference with the rendered parser."""
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise ValueError(f"{PAGE} lacks the marker line {MARKER!r} that the command reference replaces")
    return markdown.replace(MARKER, render())
