"""Run a call in a child process of its own, so that a crash (a segfault, a kill for memory,
an `os._exit` or `sys.exit` inside it) ends that call and not the process that made it.

`isolated(fn, *args)` forks, runs `fn(*args)` in the child and returns what it returned, or
`Died` saying how the child ended. The child dies with its parent (Linux), so interrupting a
run never leaves trials training as orphans. Where there is no fork (Windows), the call runs
in this process, unguarded.
"""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class Died:
    """How a child that returned nothing ended: its exit status, or the signal that killed it."""

    exit_status: int | None = None
    signal: int | None = None

    def __str__(self) -> str:
        if self.signal is not None:
            name = signal.Signals(self.signal).name
            hint = " (the kernel's out-of-memory killer sends this)" if name == "SIGKILL" else ""
            return f"its process was killed by signal {self.signal} ({name}){hint}"
        return f"its process exited with status {self.exit_status} before returning a result"


def isolated(fn: Callable[..., Any], *args: Any) -> Any:
    """`fn(*args)` in a forked child: its return value (pickled back), or `Died`. An exception
    inside `fn` is raised here again."""
    if not hasattr(os, "fork"):
        return fn(*args)
    read_end, write_end = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the child: run, send back, and leave without the parent's exit handlers
        os.close(read_end)
        die_with_parent(parent)
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
                pipe.write(payload)
        except BaseException:  # noqa: BLE001 - nothing can be sent: the parent reads EOF
            code = code or 70
        finally:
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as pipe:
        payload = pipe.read()
    _, status = os.waitpid(pid, 0)
    if not payload:
        if os.WIFSIGNALED(status):
            return Died(signal=os.WTERMSIG(status))
        return Died(exit_status=os.WEXITSTATUS(status))
    ok, value = pickle.loads(payload)
    if not ok:
        raise value
    return value


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
