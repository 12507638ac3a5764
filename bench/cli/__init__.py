"""`bench`: run suites, plot and report results, train and list experts.

One module per group of commands (`run`, `results`, `experts`, `video`, `verify`,
`scaffold`), each adding its
subcommands to the parser; argument types and the one-line parser are in `args`."""

from __future__ import annotations

import argparse
import errno
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable

from bench.cli import experts, results, run, scaffold, verify, video
from bench.cli.args import OneLineParser
from bench.errors import BadInput


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="bench",
        description="ifo-bench: compare imitation-from-observation algorithms on MuJoCo and"
        " PyBullet.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    for command in (run, results, experts, video, verify, scaffold):
        command.add(sub)
    return parser


WRITE_FAILURES = {
    errno.ENOSPC,
    errno.EDQUOT,
    errno.EACCES,
    errno.EPERM,
    errno.EROFS,
    errno.EFBIG,
    errno.ENOTDIR,
}
"""Errors of a write the machine refused, reported in one line rather than as a traceback."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (a scheduler's end of a job, `kill`): unwound like Ctrl-C, so that what is
    being written is finished or left out whole and the run's workers stop before it exits."""


def _terminate(signum, frame) -> None:
    raise Terminated


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"bench: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    warnings.formatwarning = _one_line_warning  # a line each, not the source line under it
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # to start it again, pinned
    func: Callable[[argparse.Namespace], int] = args.func
    in_main_thread = threading.current_thread() is threading.main_thread()
    before = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    try:
        return func(args)
    except Terminated:
        print("bench: terminated; the same command resumes where this one stopped", file=sys.stderr)
        return 128 + signal.SIGTERM
    except (BadInput, FileNotFoundError) as e:  # bench's own errors, and a missing path
        print(f"bench: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `bench ... | head`: the reader left; say nothing more. An
        # OSError itself, so caught before OSError is.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as e:
        if e.errno not in WRITE_FAILURES:
            raise
        # A write the machine refused (disk full, no permission, read-only): what was being
        # written is left out whole (`bench.atomic`), and the user is told where and why.
        where = f" {e.filename}" if e.filename else ""
        print(f"bench: error: cannot write{where}: {e.strerror or e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted", file=sys.stderr)
        return 130
    finally:
        if before is not None:
            signal.signal(signal.SIGTERM, before)


if __name__ == "__main__":
    sys.exit(main())
