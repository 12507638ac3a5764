"""`bench`: run suites, plot and report results, train and list experts.

One module per group of commands (`run`, `results`, `experts`, `video`), each adding its
subcommands to the parser; argument types and the one-line parser are in `args`."""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Callable

from bench.cli import experts, results, run, video
from bench.cli.args import OneLineParser
from bench.errors import BadInput


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="bench",
        description="ifo-bench: compare imitation-from-observation algorithms on PyBullet.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    for command in (run, results, experts, video):
        command.add(sub)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"bench: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    warnings.formatwarning = _one_line_warning  # a line each, not the source line under it
    args = build_parser().parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except (BadInput, FileNotFoundError) as e:  # bench's own errors, and a missing path
        print(f"bench: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `bench ... | head`: the reader left; say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
