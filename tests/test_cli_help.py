"""Every command-line option explains itself: help text, and the default where there is one.

Walks the whole argparse tree (the top level and every subcommand, plugins' included) so that
an option added later without help fails here.
"""

from __future__ import annotations

import argparse

import pytest

from tactile_bullet.cli import build_parser


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _options(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        yield action


def _has_default(action: argparse.Action) -> bool:
    """Whether the option stores a value of its own when not given (flags and "none" do not)."""
    if action.default in (None, False, argparse.SUPPRESS) or action.nargs == 0:
        return False
    return not isinstance(action, argparse._StoreTrueAction | argparse._VersionAction)


PARSER = build_parser()
COMMANDS = _subparsers(PARSER)


def test_the_top_level_help_says_where_to_start():
    text = PARSER.format_help()
    assert "tactile-bullet demo" in text


def test_the_commands_are_all_walked():
    assert {"grasp", "generate", "compare", "sequential", "shapes", "plugins"} <= set(COMMANDS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_has_a_description(name):
    sub = COMMANDS[name]
    assert sub.description and sub.description.strip(), f"{name} has no description"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_has_help_and_names_its_default(name):
    missing, no_default = [], []
    for action in _options(COMMANDS[name]):
        label = "/".join(action.option_strings) or action.dest
        if not action.help or action.help == argparse.SUPPRESS or not action.help.strip():
            missing.append(label)
        elif _has_default(action) and "default" not in action.help:
            no_default.append(f"{label} (default {action.default!r})")
    assert not missing, f"{name}: options without help: {missing}"
    assert not no_default, f"{name}: help does not state the default: {no_default}"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_help_renders(name):
    assert COMMANDS[name].format_help()  # a stray % in a help text breaks argparse here


def test_the_grasp_help_quotes_the_controller_defaults():
    from tactile_bullet.records import ControllerSettings

    defaults = ControllerSettings()
    helps = {a.dest: a.help for a in _options(COMMANDS["grasp"])}
    assert f"default {defaults.delta:g})" in helps["delta"]
    assert f"default {defaults.thres_t:g})" in helps["thres"]
    assert f"default {defaults.max_time:g})" in helps["max_time"]
    assert f"default {defaults.mode})" in helps["mode"]
