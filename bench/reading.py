"""The one way ifo-bench reads a small file that a stranger may have put in its way.

Suites, settings files and trial records are read whole. A path where such a file is expected
may instead be a FIFO (reading it waits for a writer forever), a device (`/dev/zero` never
ends), a /proc file (its size says 0) or just huge: each is refused here in one line, before
it can hang a command or fill the machine's memory, and nothing of what it holds is echoed.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from bench.errors import BadInput


class UnreadableFile(BadInput, OSError):
    """A path that does not hold a regular file of a sensible size."""


def read_bytes(path: str | Path, limit: int, what: str = "file") -> bytes:
    """The bytes of the regular file at `path` (symlinks followed), if it holds at most `limit`
    of them; else UnreadableFile naming the problem. Opened without blocking, so a FIFO is
    refused rather than waited on."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise UnreadableFile(f"{path}: no such {what}") from None
    except OSError as e:
        raise UnreadableFile(f"{path}: cannot read this {what}: {e.strerror}") from None
    kind = os.fstat(fd).st_mode
    if not stat.S_ISREG(kind):  # a folder opens too, and only fdopen would refuse it
        os.close(fd)
        raise UnreadableFile(f"{path}: not a regular file (a {_kind(kind)}), not a {what}")
    with os.fdopen(fd, "rb") as f:
        data = f.read(limit + 1)  # a /proc file says it holds 0 bytes: read, and count
    if len(data) > limit:
        raise UnreadableFile(f"{path}: more than {_size(limit)}: too large for a {what}")
    return data


def read_text(path: str | Path, limit: int, what: str = "file") -> str:
    """`read_bytes` decoded as UTF-8; undecodable text is UnreadableFile too."""
    try:
        return read_bytes(path, limit, what).decode("utf-8")
    except UnicodeDecodeError as e:
        raise UnreadableFile(f"{path}: not UTF-8 text (byte {e.start}), not a {what}") from None


def _kind(mode: int) -> str:
    kinds = {
        stat.S_ISDIR: "folder",
        stat.S_ISFIFO: "FIFO",
        stat.S_ISCHR: "character device",
        stat.S_ISBLK: "block device",
        stat.S_ISSOCK: "socket",
    }
    return next((name for test, name in kinds.items() if test(mode)), "special file")


def _size(n: int) -> str:
    return f"{n / 2**20:g} MiB" if n >= 2**20 else f"{n:,} bytes"
