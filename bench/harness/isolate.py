"""Run a call in a child process of its own, so that a crash (a segfault, a kill for memory,
an `os._exit` or `sys.exit` inside it) ends that call and not the process that made it.

`isolated(fn, *args)` forks, runs `fn(*args)` in the child and returns what it returned, or
`Died` saying how the child ended. The child dies with its parent (Linux), so interrupting a
run never leaves trials training as orphans. Where there is no fork (Windows), the call runs
in this process, unguarded.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import select
import signal
import struct
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class Died:
    """How a child that returned nothing ended: its exit status, the signal that killed it, or
    the time limit it ran past (then it was killed)."""

    exit_status: int | None = None
    signal: int | None = None
    timed_out: float | None = None

    def __str__(self) -> str:
        if self.timed_out is not None:
            return f"it ran past its time limit ({self.timed_out:,.0f} s) and was stopped"
        if self.signal is not None:
            name = signal.Signals(self.signal).name
            hint = " (the kernel's out-of-memory killer sends this)" if name == "SIGKILL" else ""
            return f"its process was killed by signal {self.signal} ({name}){hint}"
        return f"its process exited with status {self.exit_status} before returning a result"


LENGTH = struct.Struct("<Q")
"""The result's length, sent before it: the parent reads that many bytes and stops, instead of
waiting for the pipe's end, which a process the call forked and left behind may hold open."""


def isolated(fn: Callable[..., Any], *args: Any, timeout: float | None = None) -> Any:
    """`fn(*args)` in a forked child: its return value (pickled back), or `Died`. An exception
    inside `fn` is raised here again. The child leads a process group of its own; whatever it
    started and left running is killed with the group once the call is over, and the whole
    group past `timeout` seconds (then `Died(timed_out=timeout)`)."""
    if not hasattr(os, "fork"):
        return fn(*args)
    read_end, write_end = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the child: run, send back, and leave without the parent's exit handlers
        os.close(read_end)
        os.setpgid(0, 0)
        die_with_parent(parent)
        _outlive_readers()
        code = 0
        try:
            try:
                payload = pickle.dumps((True, fn(*args)))
            except SystemExit as e:  # an exit inside the call: the child exits, as asked
                code = e.code if isinstance(e.code, int) else 1
                raise
            except BaseException as e:  # noqa: BLE001 - it travels back to be raised there
                payload = pickle.dumps((False, e))
            with os.fdopen(write_end, "wb") as pipe:
                pipe.write(LENGTH.pack(len(payload)) + payload)
        except BaseException:  # noqa: BLE001 - nothing can be sent: the parent reads EOF
            code = code or 70
        finally:
            os._exit(code)
    os.close(write_end)
    with contextlib.suppress(OSError):
        os.setpgid(pid, pid)  # as the child does: whichever runs first
    deadline = None if timeout is None else time.monotonic() + timeout
    try:
        with os.fdopen(read_end, "rb", buffering=0) as pipe:
            payload, status = _receive(pipe, pid, deadline)
    finally:
        with contextlib.suppress(OSError):
            os.killpg(pid, signal.SIGKILL)  # what the call left behind, or all of it if late
    if status is None:
        _, status = os.waitpid(pid, 0)
    if payload is None:
        return Died(timed_out=timeout)
    if not payload:
        if os.WIFSIGNALED(status):
            return Died(signal=os.WTERMSIG(status))
        return Died(exit_status=os.WEXITSTATUS(status))
    ok, value = pickle.loads(payload)
    if not ok:
        raise value
    return value


POLL_S = 1.0
"""How often the parent looks whether the child has ended without a word (its pipe may stay
open in a process it left behind, so the pipe's end alone does not say)."""


def _receive(pipe: Any, pid: int, deadline: float | None) -> tuple[bytes | None, int | None]:
    """The child's whole message (b"" where it ended without one; None past `deadline`), and
    its wait status where it was reaped here."""
    received = b""
    while True:
        wait = POLL_S if deadline is None else min(POLL_S, max(0.0, deadline - time.monotonic()))
        if not select.select([pipe], [], [], wait)[0]:
            reaped, status = os.waitpid(pid, os.WNOHANG)
            if reaped:  # gone: what it sent before it went is all there is
                while select.select([pipe], [], [], 0)[0] and (chunk := pipe.read(1 << 20)):
                    received += chunk
                return _message(received) or b"", status
            if deadline is not None and time.monotonic() >= deadline:
                return None, None
            continue
        chunk = pipe.read(1 << 20)
        if not chunk:
            return _message(received) or b"", None  # the pipe's end before a whole message
        received += chunk
        message = _message(received)
        if message is not None:
            return message, None


def _message(received: bytes) -> bytes | None:
    """The message in `received`, if all of it has arrived."""
    if len(received) < LENGTH.size:
        return None
    (length,) = LENGTH.unpack_from(received)
    whole = received[LENGTH.size : LENGTH.size + length]
    return whole if len(whole) == length else None


def _outlive_readers() -> None:
    """Writes to stdout or stderr whose reader has left (`bench run ... | head`) go nowhere
    from now on, instead of raising BrokenPipeError inside the call: a reader that leaves is
    no failure of what the call computes."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is not None:
            setattr(sys, name, _Unbroken(stream))


class _Unbroken:
    """A text stream that, once its reader has left, drops what is written to it."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._stream = open(os.devnull, "w")  # noqa: SIM115 - replaces the stream for good
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._stream = open(os.devnull, "w")  # noqa: SIM115

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def die_with_parent(parent: int | None = None) -> None:
    """Linux: have the kernel kill this process when its parent dies (a trial's process when
    the worker that forked it is gone, a worker when the run's driver is), so that nothing
    trains on as an orphan. `parent`: the pid it must still have, else it leaves now (the
    parent died before this was set)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        return
    if parent is not None and os.getppid() != parent:
        os._exit(70)
