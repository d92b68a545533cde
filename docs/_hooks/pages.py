"""MkDocs hook: the pages generated at build time, so that none of them can drift.

- ``reference/cli.md``: every ``tactile-bullet`` command, walked from the argparse parser
  the command line itself builds (:func:`tactile_bullet.cli.build_parser`): usage,
  description and every option with its help, choices and default.
- ``howto/plugin.md``: the example plugin's README, the one guide to writing a plugin.
- ``changelog.md``: the repository's CHANGELOG.

The last two are read from files outside ``docs/``; their links are rewritten to the site's
pages (``docs/X`` -> ``X``), and a link to any other file of the repository becomes its path
in code, since the site does not carry it.
"""

from __future__ import annotations

import argparse
import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File

REPO = Path(__file__).resolve().parents[2]

ROOT_PAGES = {
    "howto/plugin.md": "plugins/tactile-bullet-example/README.md",
    "changelog.md": "CHANGELOG.md",
}
"""Site page -> the repository file it is made from."""

WIDTH = 100
"""Columns of the usage lines (argparse otherwise follows the terminal's width)."""


def subcommands(parser: argparse.ArgumentParser) -> dict[str, tuple[str, argparse.ArgumentParser]]:
    """``{name: (one-line help, parser)}`` of the parser's subcommands, in ``--help`` order."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {choice.dest: choice.help or "" for choice in action._choices_actions}
    return {name: (helps.get(name, ""), sub) for name, sub in action.choices.items()}


def _option(formatter: argparse.HelpFormatter, action: argparse.Action) -> str:
    if action.option_strings:
        names = ", ".join(action.option_strings)
        if action.nargs != 0:
            metavar = formatter._get_default_metavar_for_optional(action)
            names += " " + formatter._format_args(action, metavar)
    else:
        metavar = formatter._get_default_metavar_for_positional(action)
        names = formatter._format_args(action, metavar)
    text = formatter._expand_help(action) if action.help else ""
    extra = []
    if action.choices is not None and not isinstance(action, argparse._SubParsersAction):
        extra.append("one of " + ", ".join(f"`{c}`" for c in action.choices))
    if (
        action.default not in (None, False, argparse.SUPPRESS)
        and action.nargs != 0
        and "default" not in text
    ):
        extra.append(f"default `{action.default}`")
    tail = f" ({'; '.join(extra)})" if extra else ""
    return f"- `{names}`: {_escape(text)}{tail}"


def _escape(text: str) -> str:
    """argparse help as Markdown: ``*`` and ``_`` outside code spans would start emphasis."""
    parts = re.split(r"(`[^`]*`)", " ".join(text.split()))
    return "".join(p if p.startswith("`") else re.sub(r"([*_<>])", r"\\\1", p) for p in parts)


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = argparse.HelpFormatter(prog=parser.prog, width=WIDTH)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip()


def _section(name: str, summary: str, parser: argparse.ArgumentParser) -> list[str]:
    formatter = argparse.HelpFormatter(prog=parser.prog, width=WIDTH)
    about = parser.description or (f"{summary[:1].upper()}{summary[1:]}." if summary else "")
    lines = [f"## `{name}`", "", _escape(about), ""]
    lines += ["```text", _usage(parser), "```", ""]
    for group in parser._action_groups:
        actions = [a for a in group._group_actions if a.help is not argparse.SUPPRESS]
        actions = [a for a in actions if not isinstance(a, argparse._HelpAction)]
        if not actions:
            continue
        lines += [f"**{group.title[0].upper()}{group.title[1:]}**", ""]
        lines += [_option(formatter, a) for a in actions]
        lines.append("")
    if parser.epilog:
        lines += [_escape(parser.epilog), ""]
    return lines


def cli_reference() -> str:
    """The command-line reference page, from the parser the CLI builds."""
    from tactile_bullet.cli import build_parser

    parser = build_parser()
    commands = subcommands(parser)
    lines = [
        "# Command-line reference",
        "",
        "Generated from the command line's own parser each time the site is built, so it is "
        "what `tactile-bullet COMMAND --help` prints. The rules every command keeps (offsets, "
        "limits, bad input, overwriting) are in [Using the command line](../cli.md); the "
        "`--json` documents in [JSON output](../json.md).",
        "",
        "```text",
        _usage(parser),
        "```",
        "",
        _escape(parser.description or ""),
        "",
        "| command | what it does |",
        "|---|---|",
        *(f"| [`{n}`](#{n}) | {_escape(s)} |" for n, (s, _) in commands.items()),
        "",
    ]
    for name, (summary, sub) in commands.items():
        lines += _section(name, summary, sub)
    return "\n".join(lines).rstrip() + "\n"


_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s#]*)(#[^)\s]*)?\)")


def rewrite_links(text: str, source: str, page: str) -> str:
    """Links of repository file ``source`` made right for site page ``page``."""
    here = posixpath.dirname(source)

    def fix(match: re.Match) -> str:
        bang, label, target, anchor = match.group(1), match.group(2), match.group(3), match.group(4)
        if not target or "://" in target or target.startswith("mailto:"):
            return match.group(0)
        path = posixpath.normpath(posixpath.join(here, target))
        if path.startswith("docs/"):
            relative = posixpath.relpath(path[len("docs/") :], posixpath.dirname(page) or ".")
            return f"{bang}[{label}]({relative}{anchor or ''})"
        if label.strip("`") in (target, path, posixpath.basename(path)):
            return f"`{path}`"
        return f"{label} (`{path}`)"

    return _LINK.sub(fix, text)


def root_page(page: str) -> str:
    source = ROOT_PAGES[page]
    return rewrite_links((REPO / source).read_text(encoding="utf-8"), source, page)


def on_files(files, config):
    files.append(File.generated(config, "reference/cli.md", content=cli_reference()))
    for page in ROOT_PAGES:
        files.append(File.generated(config, page, content=root_page(page)))
    return files
