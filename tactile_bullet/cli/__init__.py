"""The ``tactile-bullet`` command line.

Each subcommand lives in its own module ``tactile_bullet.cli.<name>`` exposing
``add_parser(subparsers)`` and ``run(args) -> int``. Modules import heavy libraries (pybullet,
torch, matplotlib) inside ``run`` so that ``tactile-bullet --help`` starts fast.

Exit status: 0 success, 2 bad input (one line on stderr, no traceback), 1 internal failure,
130 interrupted (Ctrl-C), 143 terminated (SIGTERM, unwound like Ctrl-C: workers stopped,
temporary files removed, a dataset left for ``generate --resume``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
import traceback

from .. import __version__
from ..errors import UsageError

COMMANDS: tuple[str, ...] = (
    "shapes",
    "shape_info",
    "make_objects",
    "grasp",
    "generate",
    "verify",
    "train",
    "evaluate",
    "compare",
    "benchmark",
    "calibrate",
    "adapt",
    "identify",
    "explore",
    "demo",
    "sequential",
    "temporal",
    "plugins",
    "import",
    "export",
    "convert_hand",
)
MODULES: dict[str, str] = {"import": "import_"}
"""Commands whose module name differs (``import`` is a Python keyword)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds as Ctrl-C does."""


def _terminate(signum: int, frame) -> None:
    if os.getpid() != _main_pid:  # a forked worker inherited this handler: just die
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
        return
    raise Terminated


_main_pid = os.getpid()


class _Parser(argparse.ArgumentParser):
    """argparse that reports bad usage as one line and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="tactile-bullet",
        description="In-hand tactile shape recognition with a simulated Shadow hand.",
        epilog="New here? Start with `tactile-bullet demo`: it simulates, trains and reports "
        "in a few minutes. `tactile-bullet COMMAND --help` describes each command.",
    )
    parser.add_argument("--version", action="version", version=f"tactile-bullet {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        path = f"{__name__}.{MODULES.get(name, name)}"
        try:
            module = importlib.import_module(path)
        except ModuleNotFoundError as exc:
            if exc.name == path:
                continue
            raise
        module.add_parser(sub)
    return parser


_NEGATIVE = re.compile(r"-\.?\d")
"""A value such as ``-0.01,0,0`` or ``-5``: a number, never an option (none starts so)."""


def join_negative_values(argv: list[str]) -> list[str]:
    """``--offset -0.01,0,0`` -> ``--offset=-0.01,0,0``: argparse takes a value that starts
    with '-' and is not a plain number (a vector is not) for an option, and would refuse it."""
    out: list[str] = []
    for i, token in enumerate(argv):
        previous = out[-1] if out else ""
        if (
            _NEGATIVE.match(token)
            and i > 0
            and previous.startswith("--")
            and "=" not in previous
            and previous == argv[i - 1]
        ):
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(join_negative_values(sys.argv[1:] if argv is None else list(argv)))
    except SystemExit as exc:  # --help, --version, or bad usage (already printed, one line)
        return exc.code if isinstance(exc.code, int) else 2
    global _main_pid
    _main_pid = os.getpid()
    try:
        previous = signal.signal(signal.SIGTERM, _terminate)
    except ValueError:  # main() called from another thread: leave signals to the host
        previous = None
    try:
        from ..console import log_lines, reporting
        from .common import hand_calibration_scope

        with reporting(log_lines(bool(getattr(args, "json", False)))), hand_calibration_scope(args):
            return int(args.run(args) or 0)
    except UsageError as exc:
        print(f"tactile-bullet {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        terminated = isinstance(exc, Terminated)
        print(f"tactile-bullet: {'terminated' if terminated else 'interrupted'}", file=sys.stderr)
        return 143 if terminated else 130
    except BrokenPipeError:  # `tactile-bullet shapes --json | head`: the reader left
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:  # noqa: BLE001 - the CLI's last line of defence
        if os.environ.get("TACTILE_BULLET_DEBUG"):
            traceback.print_exc()
        print(
            f"tactile-bullet {args.command}: internal error: {type(exc).__name__}: {exc} "
            "(set TACTILE_BULLET_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
