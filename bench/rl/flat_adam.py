"""Adam over one flat buffer: `torch.optim.Adam`'s arithmetic, a handful of kernels per step
for a whole small network instead of a handful per parameter tensor."""

from __future__ import annotations

from collections.abc import Iterable

import torch

ALIGN = 16
"""Floats between parameter starts: 64 bytes, where the allocator starts a tensor of its own.
A matrix product may round differently with its operand at another alignment, so every
parameter keeps the alignment it had."""


def _skip_dynamo_import() -> None:
    """Keep `torch.optim.Optimizer`'s bookkeeping from importing torch._dynamo.

    torch wraps `add_param_group` (so every optimizer's construction), `state_dict`,
    `load_state_dict` and `zero_grad` in `torch._disable_dynamo`, which imports torch._dynamo
    on their first call (1.3 s: a third of a trial worker's start, paid again by every fresh
    process) to keep them out of torch.compile's graphs, then caches the excluded function on
    the original. Nothing here is compiled, so the original is cached as its own exclusion:
    the same function runs, without the import. Where torch's layout differs, nothing changes.
    (torch's own `Adam.step` still imports it; FlatAdam's does not.)"""
    for name in ("add_param_group", "state_dict", "load_state_dict", "zero_grad"):
        original = getattr(getattr(torch.optim.Optimizer, name), "__wrapped__", None)
        if original is not None and not hasattr(original, "__dynamo_disable"):
            setattr(original, "__dynamo_disable", original)


_skip_dynamo_import()


class FlatAdam(torch.optim.Adam):
    """`torch.optim.Adam` at its defaults but the learning rate (its single-tensor path, the one
    a CPU takes), for a small network whose every parameter takes part in every step.

    On a 64 x 64 value MLP, Adam's step and zero_grad cost about as much as the minibatch's
    forward pass: six kernels per parameter tensor, each mostly dispatch. Here the parameters,
    their gradients and both moments are views into four flat buffers, so a step is six
    kernels whatever the depth, and gradients accumulate in place (zero_grad zeroes one
    buffer). The elementwise arithmetic is Adam's own, in its order, so the parameters are
    the same to the bit; so is `state_dict`, which torch's Adam loads, and which loads here.
    """

    def __init__(self, params: Iterable[torch.nn.Parameter], lr: float) -> None:
        super().__init__(params, lr=lr)
        self.params = [p for group in self.param_groups for p in group["params"]]
        if len(self.param_groups) > 1 or any(not _flattens(p) for p in self.params):
            raise ValueError("FlatAdam takes one group of float32 parameters on the CPU")
        self.offsets, size = [], 0
        for p in self.params:
            self.offsets.append(size)
            size += -(-p.numel() // ALIGN) * ALIGN
        self.flat, self.grad, self.avg, self.avg_sq = (torch.zeros(size) for _ in range(4))
        with torch.no_grad():
            for p, view in zip(self.params, self.views(self.flat), strict=True):
                view.copy_(p)
                p.data = view
        self.grads = self.views(self.grad)
        self.steps = 0

    def views(self, buffer: torch.Tensor) -> list[torch.Tensor]:
        """Each parameter's part of `buffer`, shaped like it."""
        return [
            buffer[start : start + p.numel()].view_as(p)
            for p, start in zip(self.params, self.offsets, strict=True)
        ]

    def zero_grad(self, set_to_none: bool = True) -> None:
        """Zero the gradient buffer (never None: backward then adds into it in place)."""
        self.grad.zero_()
        for p, grad in zip(self.params, self.grads, strict=True):
            if p.grad is not grad:
                p.grad = grad

    def gather_grads(self) -> None:
        """Bring into the buffer any gradient that lives elsewhere (a module's own zero_grad
        set it to None, and backward made a new one); a missing one counts as 0."""
        for p, grad in zip(self.params, self.grads, strict=True):
            if p.grad is not grad:
                if p.grad is None:
                    grad.zero_()
                else:
                    grad.copy_(p.grad)
                p.grad = grad

    @torch.no_grad()
    def step(self, closure: None = None) -> None:
        """`torch.optim.adam._single_tensor_adam` without weight decay, amsgrad or maximize,
        on all parameters at once (padding stays 0: its gradient and moments are 0)."""
        self.gather_grads()
        group = self.param_groups[0]
        (beta1, beta2), lr, eps = group["betas"], group["lr"], group["eps"]
        self.steps += 1
        step = float(self.steps)  # torch keeps it in a float tensor and reads it back
        self.avg.lerp_(self.grad, 1 - beta1)
        self.avg_sq.mul_(beta2).addcmul_(self.grad, self.grad, value=1 - beta2)
        bias_correction1 = 1 - beta1**step
        bias_correction2 = 1 - beta2**step
        step_size = lr / bias_correction1
        bias_correction2_sqrt = bias_correction2**0.5
        denom = (self.avg_sq.sqrt() / bias_correction2_sqrt).add_(eps)
        self.flat.addcdiv_(self.avg, denom, value=-step_size)

    def state_dict(self) -> dict:
        """torch's Adam's: per parameter its step count and both moments."""
        if self.steps:
            step = torch.tensor(float(self.steps))
            for p, avg, avg_sq in zip(
                self.params, self.views(self.avg), self.views(self.avg_sq), strict=True
            ):
                self.state[p] = {"step": step.clone(), "exp_avg": avg, "exp_avg_sq": avg_sq}
        return super().state_dict()

    def load_state_dict(self, state_dict: dict) -> None:
        """From this class's `state_dict` or torch's Adam's."""
        super().load_state_dict(state_dict)
        with torch.no_grad():
            steps = set()
            for p, avg, avg_sq in zip(
                self.params, self.views(self.avg), self.views(self.avg_sq), strict=True
            ):
                saved = self.state.get(p)
                if not saved:
                    avg.zero_()
                    avg_sq.zero_()
                    steps.add(0)
                    continue
                avg.copy_(saved["exp_avg"])
                avg_sq.copy_(saved["exp_avg_sq"])
                steps.add(int(saved["step"]))
        if len(steps) > 1:
            raise ValueError(f"FlatAdam's parameters step together, not at {sorted(steps)}")
        self.steps = steps.pop()
        self.state.clear()


def adam(params: Iterable[torch.nn.Parameter], lr: float) -> torch.optim.Optimizer:
    """Adam for a small network's parameters: `FlatAdam` where they are float32 on the CPU,
    else (a GPU's) torch's foreach Adam, one batched kernel per operation. Both compute torch's
    single-tensor arithmetic, so the numbers are the same whichever runs."""
    params = list(params)
    if all(_flattens(p) for p in params):
        return FlatAdam(params, lr=lr)
    return torch.optim.Adam(params, lr=lr, foreach=True)


def _flattens(p: torch.Tensor) -> bool:
    """Whether `p` can live in FlatAdam's buffers (float32, on the CPU)."""
    return p.device.type == "cpu" and p.dtype == torch.float32
