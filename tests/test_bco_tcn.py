"""BCO and TCN for real: tiny-budget trials through the runner, the inverse model, TCN's sampling."""

import dataclasses
import types

import numpy as np
import pytest
import torch

from algorithms import bco, tcn
from bench import envs
from bench.harness import registry
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialSpec
from bench.imitation import embedding, inverse_dynamics
from bench.imitation.data import Demos
from bench.rl.rollout import VecCollector

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture(scope="module")
def cache(module_cache):
    """One demo pool (recorded with the shipped expert) for the whole module, in a temp folder."""
    return module_cache


def run_state_only(name: str, budget: int, monkeypatch, **hp):
    """run_trial with `name`'s train wrapped to check it is handed state-only Demos."""
    algo = registry.get(name)
    handed = []

    def checked(task, demos, *args):
        handed.append(type(demos))
        return algo.train(task, demos, *args)

    monkeypatch.setitem(registry._ALGORITHMS, name, dataclasses.replace(algo, train=checked))
    spec = TrialSpec("t", PENDULUM, name, 1, 0, budget, 2, hp)
    inputs = plan(spec).inputs()
    assert type(inputs) is Demos and not hasattr(inputs, "actions")
    result = run_trial(spec, inputs)
    assert result.status == "ok", result.traceback
    assert handed == [Demos]
    assert len(result.returns) == 2 and np.all(np.isfinite(result.returns))
    return result


@pytest.mark.slow
def test_bco_trains_through_the_runner_within_its_budget(cache, monkeypatch):
    # 2000 random steps, then chunks of 1000 policy steps; the last chunk is cut to 500.
    hp = dict(pre_demo_steps=2000, alpha=0.5, inverse_steps=300, bc_steps=200, n_envs=4)
    result = run_state_only("bco", 4500, monkeypatch, **hp)
    assert result.env_steps == 4500  # every random and policy step counted, none past the budget
    assert result.logs["env_steps"] == [2000, 3000, 4000, 4500]
    assert all(r2 > 0.5 for r2 in result.logs["inverse_val_r2"])
    assert len(result.curve) >= 2

    plain = run_state_only("bco", 4500, monkeypatch, **{**hp, "alpha": 0.0})  # BCO(0)
    assert plain.env_steps == 2000 and plain.logs["env_steps"] == [2000]

    # Collection goes in whole rounds of n_envs: a 500-step remainder over 8 envs is 496 steps.
    rounded = run_state_only("bco", 4500, monkeypatch, **{**hp, "n_envs": 8})
    assert rounded.env_steps == 4496 and rounded.logs["env_steps"] == [2000, 3000, 4000, 4496]


def test_tcn_trains_through_the_runner_within_its_budget(cache, monkeypatch):
    result = run_state_only("tcn", 5000, monkeypatch, embed_steps=100, n_envs=4)
    assert result.env_steps == 4096  # whole TRPO batches of 4 x 256 only
    assert {"triplet_loss", "embed_dist2", "kl"} <= set(result.logs)
    assert len(result.curve) >= 2


def test_inverse_model_recovers_random_actions():
    """Fit on 8k random pendulum transitions, judge on 2k fresh ones against the true actions."""
    cfg = bco.BCOConfig(inverse_steps=1500)
    rng = np.random.default_rng(0)

    def uniform(obs):
        return rng.uniform(-1, 1, size=(len(obs), 1)).astype(np.float32)

    def transitions(n: int, seed: int):
        rollouts = VecCollector([envs.make(PENDULUM, seed + i) for i in range(4)], seed)
        try:
            batch = rollouts.run(uniform, n // 4)
        finally:
            rollouts.close()
        return tuple(torch.from_numpy(batch.flat(k)) for k in ("obs", "actions", "next_obs"))

    s, a, s_next = train = transitions(8000, 0)
    model = inverse_dynamics.InverseModel(s.shape[1], a.shape[1], cfg.inverse_hidden)
    model.update_norms(s.numpy(), s_next.numpy())
    torch.manual_seed(0)
    opt = torch.optim.Adam(model.net.parameters(), lr=cfg.inverse_lr)
    inverse_dynamics.fit_inverse(
        model, opt, train, cfg.inverse_steps, cfg.minibatch, torch.Generator().manual_seed(0)
    )
    error = inverse_dynamics.inverse_error(model, transitions(2000, 50))
    assert error["inverse_val_r2"] > 0.95, error  # actions have variance 1/3; MSE < 0.017


def test_transition_rows_read_as_the_concatenated_chunks():
    """Rows grown chunk by chunk read back as np.concatenate would give them, dtype included
    (BCO's first chunk has float32 actions, its policy's later ones float64), and a view taken
    earlier keeps its rows through later appends and regrowths."""
    rng = np.random.default_rng(0)
    chunks = [
        (rng.random((n, 3), np.float32), rng.random((n, 2)).astype(dtype))
        for n, dtype in [(5, np.float32), (0, np.float32), (7, np.float64), (40, np.float64)]
    ]
    rows = inverse_dynamics.TransitionRows()
    early = None
    for i, chunk in enumerate(chunks):
        rows.append(*chunk)
        if i == 0:
            early = [t.clone() for t in rows.tensors()], rows.tensors()
    assert len(rows) == 52
    for got, parts in zip(rows.tensors(), zip(*chunks, strict=True), strict=True):
        want = np.concatenate(parts)
        assert got.numpy().dtype == want.dtype and np.array_equal(got.numpy(), want)
    for kept, view in zip(*early, strict=True):
        assert torch.equal(kept, view)


def test_bco_clones_on_normalized_or_raw_inputs():
    """input_norm picks what the cloned policy's inputs are scaled by; only its two values."""
    gen = torch.Generator().manual_seed(0)
    s = torch.randn(512, 3, generator=gen, dtype=torch.float64).float() * 0.01 + 2.0
    a = torch.tanh(s.sum(1, keepdim=True) - 6.0)
    task = types.SimpleNamespace(obs_dim=3, act_dim=1)
    fast = dict(bc_steps=5, minibatch=64)
    by_demos, _ = bco.clone(s, a, task, bco.BCOConfig(**fast), gen)
    raw, _ = bco.clone(s, a, task, bco.BCOConfig(input_norm="none", **fast), gen)
    assert torch.allclose(by_demos.norm.mean.float(), s.mean(0), atol=1e-5)
    assert torch.allclose(by_demos.norm.var.float(), s.var(0, unbiased=False), rtol=1e-3)
    assert torch.equal(raw.norm.mean, torch.zeros(3, dtype=torch.float64))
    assert torch.equal(raw.norm.var, torch.ones(3, dtype=torch.float64))
    with pytest.raises(ValueError, match="input_norm must be one of 'demos', 'none'"):
        bco.BCOConfig(input_norm="agent")


def test_triplets_respect_window_and_margin():
    cfg = tcn.TCNConfig(pos_window=3, neg_margin=15)
    lengths = np.array([200, 20, 10])  # the last has no step 15 away from another: never drawn
    ep, a, p, n = embedding.sample_triplets(lengths, 20_000, cfg, np.random.default_rng(0))
    assert set(ep) == {0, 1}
    gap_p, gap_n = np.abs(p - a), np.abs(n - a)
    assert gap_p.min() == 1 and gap_p.max() == 3 and gap_n.min() >= 15
    assert (n >= 0).all() and (n < lengths[ep]).all() and (p < lengths[ep]).all()


def test_demo_targets_hold_the_last_state():
    cfg = tcn.TCNConfig(embed_dim=4)
    embed = embedding.Embedding(2, cfg)
    long, short = np.random.default_rng(0).normal(size=(2, 6, 2)).astype(np.float32)
    short = short[:3]
    targets = embedding.demo_targets(embed, Demos(PENDULUM, (long, short)))
    with torch.no_grad():
        e_long, e_short = embed(torch.from_numpy(long)), embed(torch.from_numpy(short))
    assert targets.shape == (6, 4)
    torch.testing.assert_close(targets[1], (e_long[1] + e_short[1]) / 2)
    torch.testing.assert_close(targets[5], (e_long[5] + e_short[2]) / 2)
