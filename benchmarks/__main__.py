"""``python -m benchmarks``: run the fast benchmarks, one process each, and list the others
with what they need. ``--list``: the catalogue only (name, what it measures, usage)."""

from __future__ import annotations

import argparse
import subprocess
import sys
import textwrap
import time

from . import FAST, NEEDS, catalogue


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("--list", action="store_true", help="print the catalogue, run nothing")
    parser.add_argument(
        "--only", metavar="NAME,...", help="run these fast benchmarks only (default: all)"
    )
    args = parser.parse_args(argv)
    entries = catalogue()
    if args.list:
        for bench in entries:
            kind = "fast" if bench.fast else "needs: " + NEEDS.get(bench.name, "see its usage")
            print(f"{bench.name} ({kind})")
            print(textwrap.fill(bench.summary, 96, initial_indent="  ",
                                subsequent_indent="  "))  # fmt: skip
            for line in bench.usage:
                print(f"  usage: {line}")
        return 0
    names = list(FAST) if not args.only else args.only.split(",")
    unknown = [n for n in names if n not in FAST]
    if unknown:
        parser.error(f"not a fast benchmark: {', '.join(unknown)} (fast: {', '.join(FAST)})")
    by_name = {b.name: b for b in entries}
    failed, times = [], {}
    for name in names:
        print(f"=== {name}", flush=True)
        start = time.perf_counter()
        done = subprocess.run([sys.executable, str(by_name[name].path), *FAST[name]])
        times[name] = time.perf_counter() - start
        if done.returncode:
            failed.append(name)
        print(flush=True)
    print("=== times")
    for name, seconds in times.items():
        print(f"  {name:<20} {seconds:6.1f} s{'  FAILED' if name in failed else ''}")
    print(f"  {'total':<20} {sum(times.values()):6.1f} s")
    print("=== not run (python -m benchmarks --list for their usage)")
    for bench in entries:
        if not bench.fast:
            print(f"  {bench.name:<22} {NEEDS.get(bench.name, 'see its usage')}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
