"""FlatAdam is torch's Adam to the bit: the same parameters step by step, and state dicts that
each loads from the other."""

import copy

import pytest
import torch
from torch import nn

from bench.rl.flat_adam import FlatAdam
from bench.rl.networks import mlp


def _regress(net: nn.Module, opt: torch.optim.Optimizer, steps: int, seed: int) -> list[float]:
    """`steps` Adam steps of a value-style regression on random minibatches; the losses."""
    gen = torch.Generator().manual_seed(seed)
    x, y = torch.randn(512, 11, generator=gen), torch.randn(512, generator=gen)
    losses = []
    for _ in range(steps):
        idx = torch.randperm(512, generator=gen)[:64]
        loss = (net(x[idx]).squeeze(-1) - y[idx]).square().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    return losses


def _pair(hidden=(64, 64)) -> tuple[nn.Module, nn.Module]:
    torch.manual_seed(0)
    net = mlp([11, *hidden, 1])
    return net, copy.deepcopy(net)


@pytest.mark.parametrize("hidden", [(64, 64), (5, 7)])  # 7: parameters off the 16-float grid
def test_steps_are_torchs_to_the_bit(hidden):
    ours, theirs = _pair(hidden)
    flat = FlatAdam(ours.parameters(), lr=3e-3)
    adam = torch.optim.Adam(theirs.parameters(), lr=3e-3)
    assert _regress(ours, flat, 300, 1) == _regress(theirs, adam, 300, 1)
    for a, b in zip(ours.parameters(), theirs.parameters(), strict=True):
        assert torch.equal(a, b)
    assert all(p.data_ptr() % 64 == 0 for p in ours.parameters())  # each where its own would be


def test_state_dicts_load_both_ways_and_training_goes_on_alike(tmp_path):
    ours, theirs = _pair()
    flat = FlatAdam(ours.parameters(), lr=1e-3)
    adam = torch.optim.Adam(theirs.parameters(), lr=1e-3)
    _regress(ours, flat, 50, 2)
    _regress(theirs, adam, 50, 2)
    saved = tmp_path / "opt.pt"
    torch.save({"flat": flat.state_dict(), "adam": adam.state_dict()}, saved)
    states = torch.load(saved, weights_only=True)
    assert states["flat"]["param_groups"] == states["adam"]["param_groups"]
    for i, state in states["adam"]["state"].items():
        assert state.keys() == states["flat"]["state"][i].keys()
        assert all(torch.equal(state[k], states["flat"]["state"][i][k]) for k in state)

    # a FlatAdam resumed from torch's state, and a torch Adam from FlatAdam's
    resumed, resumed_torch = copy.deepcopy(theirs), copy.deepcopy(ours)
    flat_from_torch = FlatAdam(resumed.parameters(), lr=1e-3)
    flat_from_torch.load_state_dict(states["adam"])
    torch_from_flat = torch.optim.Adam(resumed_torch.parameters(), lr=1e-3)
    torch_from_flat.load_state_dict(states["flat"])
    ahead = _regress(theirs, adam, 40, 3)
    assert _regress(resumed, flat_from_torch, 40, 3) == ahead
    assert _regress(resumed_torch, torch_from_flat, 40, 3) == ahead


def test_it_refuses_what_it_cannot_flatten():
    net = mlp([3, 4, 1]).double()
    with pytest.raises(ValueError, match="float32"):
        FlatAdam(net.parameters(), lr=1e-3)


def test_gradients_cleared_by_the_module_still_reach_the_step():
    ours, theirs = _pair()
    flat = FlatAdam(ours.parameters(), lr=1e-3)
    adam = torch.optim.Adam(theirs.parameters(), lr=1e-3)
    x = torch.randn(32, 11, generator=torch.Generator().manual_seed(4))
    for net, opt in ((ours, flat), (theirs, adam)):
        for _ in range(3):
            net.zero_grad()  # the module's, not the optimizer's: gradients set to None
            net(x).square().mean().backward()
            opt.step()
    for a, b in zip(ours.parameters(), theirs.parameters(), strict=True):
        assert torch.equal(a, b)


def test_a_fresh_process_makes_steps_and_saves_optimizers_without_importing_dynamo():
    """torch imports torch._dynamo (over a second) on an optimizer's first bookkeeping call;
    every trial's worker would pay it. Adam's arithmetic is untouched: the tests above."""
    import subprocess
    import sys

    script = """
import sys, torch
from bench.rl.flat_adam import adam
net = torch.nn.Linear(3, 2)
opt = adam(net.parameters(), lr=1e-3)
net(torch.ones(3)).sum().backward()
opt.step()
opt.load_state_dict(opt.state_dict())
torch.optim.Adam(net.parameters()).zero_grad()
assert "torch._dynamo" not in sys.modules, "imported"
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
