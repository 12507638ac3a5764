"""Which CPU kernels a trial's floats come from, and pinning them so that any x86-64 CPU
computes a trial alike.

Why. A trial's numbers depend on more than its spec: MKL (torch's BLAS) and ATen pick their
kernels by the CPU they run on, and the kernels of two CPUs sum in different orders. The
difference is in the last bits of one matrix product, and training amplifies it: measured on
the committed MuJoCo records (docs/design/reproducibility.md), a HalfCheetah-v5 GAIfO trial
that reproduces to the bit on one Xeon parts from the record at its first update on another
CPU, and the expert's own HalfCheetah episodes, which the demonstration pools are recorded
from, differ by thousands in return, so every imitator there is handed other demonstrations.

`portable` pins what the CPU would otherwise choose, through each library's own switch, read
when the library first computes: MKL's conditional numerical reproducibility on its AVX2
branch in strict mode (the same results on every CPU with AVX2, Intel's or AMD's), ATen's
AVX2 kernels, and NumPy's dispatch below AVX-512. A suite asks for it (`kernels: portable`);
`bench run` then runs in a process started with these set, so the driver (which records the
demonstration pools) and every worker it starts compute alike. `native` (the default, and what
every committed record ran with) leaves each library its own choice: the fastest kernels, and
numbers that hold on one kind of CPU only.
"""

from __future__ import annotations

import os
from typing import Literal

Kernels = Literal["native", "portable"]
KINDS: tuple[Kernels, ...] = ("native", "portable")
PORTABLE = {
    "MKL_CBWR": "AVX2,STRICT",
    "ATEN_CPU_CAPABILITY": "avx2",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
}
"""The environment a portable process starts with: each library reads its switch once."""


def pins(kind: Kernels) -> dict[str, str]:
    """The environment variables `kind` needs set before a process computes anything."""
    return dict(PORTABLE) if kind == "portable" else {}


def active() -> Kernels:
    """The kernels this process computes with: portable where it was started with every pin."""
    return "portable" if all(os.environ.get(k) == v for k, v in PORTABLE.items()) else "native"


def describe() -> str:
    """This process's kernels as a record keeps them: "portable" or "native", with the CPU
    capability ATen runs at ("native: ATen AVX512")."""
    import torch

    return f"{active()}: ATen {torch.backends.cpu.get_cpu_capability()}"


class NotPinned(RuntimeError):
    """A trial that needs portable kernels, in a process started without them."""


def require(kind: Kernels | None) -> None:
    """Raise NotPinned where a trial asks for `kind` and this process does not compute so:
    a dask worker started by hand without the pins, say."""
    if kind == "portable" and active() != "portable":
        settings = " ".join(f"{k}='{v}'" for k, v in PORTABLE.items())
        raise NotPinned(
            f"this trial needs portable kernels and its process was started without them: start"
            f" its worker with {settings}"
        )
