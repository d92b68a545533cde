"""The ``tactile-bullet`` command line.

Each subcommand lives in its own module ``tactile_bullet.cli.<name>`` exposing
``add_parser(subparsers)`` and ``run(args) -> int``. Modules import heavy libraries (pybullet,
torch, matplotlib) inside ``run`` so that ``tactile-bullet --help`` starts fast.

Exit status: 0 success, 2 bad input (one line on stderr, no traceback), 1 internal failure.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback

from .. import __version__
from ..errors import UsageError

COMMANDS: tuple[str, ...] = (
    "shapes",
    "shape_info",
    "grasp",
    "generate",
    "train",
    "evaluate",
    "compare",
    "identify",
    "demo",
    "sequential",
    "plugins",
)


class _Parser(argparse.ArgumentParser):
    """argparse that reports bad usage as one line and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="tactile-bullet",
        description="In-hand tactile shape recognition with a simulated Shadow hand.",
    )
    parser.add_argument("--version", action="version", version=f"tactile-bullet {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"{__name__}.{name}":
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except UsageError as exc:
        print(f"tactile-bullet {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("tactile-bullet: interrupted", file=sys.stderr)
        return 130
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
