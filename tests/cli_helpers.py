"""Helpers for driving the CLI in-process from tests."""

from __future__ import annotations

from tactile_bullet.cli import main


def run_error(capsys, argv) -> str:
    """Run a command that must be refused: exit 2, one line on stderr, no traceback."""
    code = main(argv)
    _, err = capsys.readouterr()
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    return err
