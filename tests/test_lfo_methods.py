"""The field's methods since the paper, checked against values worked out by hand: AIRLfO's
shaped discriminator, WAILfO's critic objective (and that it learns the Wasserstein distance),
and PWIL's greedy coupling and reward, carried across TRPO's batches."""

import numpy as np
import pytest
import torch

from algorithms.airlfo import ShapedHead
from algorithms.pwil import PWILConfig, PWILReward, expert_atoms, horizon_on
from algorithms.wailfo import WAILfOConfig
from bench.imitation.coupling import SPARE, couple, standardizer
from bench.imitation.data import Demos
from bench.imitation.discriminator import DiscriminatorConfig, discriminator_loss, wasserstein
from bench.rl.networks import mlp
from bench.rl.rollout import Batch


def linear(layer: torch.nn.Sequential, weight: list[float], bias: float) -> None:
    with torch.no_grad():
        layer[0].weight.copy_(torch.tensor([weight]))
        layer[0].bias.fill_(bias)


def test_airlfo_logit_is_a_state_reward_plus_a_potential_difference():
    head = ShapedHead(4, (), gamma=0.9)  # rows (s, s') of 2-d states; g and h linear
    linear(head.g, [1.0, 0.0], 0.0)  # g(s) = s_0
    linear(head.h, [0.0, 2.0], 1.0)  # h(s) = 2 s_1 + 1
    rows = torch.tensor([[0.5, 1.0, -3.0, 2.0], [1.0, 0.0, 1.0, 0.0]])
    # 0.5 + 0.9 * (2 * 2 + 1) - (2 * 1 + 1) = 2.0;  1 + 0.9 * 1 - 1 = 0.9
    assert head(rows).squeeze(-1).tolist() == pytest.approx([2.0, 0.9])
    # Along a path the potential telescopes: sum_t gamma^t f = sum_t gamma^t g(s_t)
    # + gamma^T h(s_T) - h(s_0), whatever h is.
    path = torch.randn(6, 2, generator=torch.Generator().manual_seed(0))
    f = head(torch.cat([path[:-1], path[1:]], dim=1)).squeeze(-1)
    discount = 0.9 ** torch.arange(5.0)
    g, h = path[:-1, 0], 2 * path[:, 1] + 1
    assert (discount * f).sum().item() == pytest.approx(
        ((discount * g).sum() + 0.9**5 * h[-1] - h[0]).item(), abs=1e-5
    )


def test_wasserstein_objective_and_its_penalty_by_hand():
    assert wasserstein(torch.tensor([1.0, 3.0]), torch.tensor([5.0, 7.0])).item() == -4.0
    net = mlp([2, 1])  # f(x) = 3 x_0 + 4 x_1: gradient norm 5 everywhere
    linear(net, [3.0, 4.0], 0.0)
    policy, expert = torch.tensor([[1.0, 0.0]]), torch.tensor([[0.0, 1.0]])
    cfg = WAILfOConfig()
    loss, parts = discriminator_loss(net, policy, expert, cfg, torch.Generator(), wasserstein)
    assert parts["objective"].item() == pytest.approx(3.0 - 4.0)
    assert parts["penalty"].item() == pytest.approx((5.0 - 1.0) ** 2)  # gp_target 1
    assert loss.item() == pytest.approx(-1.0 + 10.0 * 16.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wailfo_critic_learns_the_wasserstein_distance_of_two_blobs(seed):
    """Policy rows at x = 0, expert rows at x = 3 (std 0.1): W1 = 3, and the best 1-Lipschitz
    critic rises with slope 1 from one to the other; a classifier's logit would keep growing."""
    torch.manual_seed(seed)
    net = mlp([2, 64, 64, 1])
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    gen = torch.Generator().manual_seed(seed)
    cfg = WAILfOConfig()
    for _ in range(800):
        policy = 0.1 * torch.randn(256, 2, generator=gen)
        expert = policy + torch.tensor([3.0, 0.0])
        loss, _ = discriminator_loss(net, policy, expert, cfg, gen, wasserstein)
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        gap = net(torch.tensor([[3.0, 0.0]])) - net(torch.tensor([[0.0, 0.0]]))
    assert gap.item() == pytest.approx(3.0, abs=0.5)


def test_wailfo_refuses_settings_that_read_a_classifier():
    with pytest.raises(ValueError, match="critic's value"):
        WAILfOConfig(reward="-log(1-D)")
    with pytest.raises(ValueError, match="gradient penalty"):
        WAILfOConfig(grad_penalty=0.0)
    assert isinstance(WAILfOConfig(), DiscriminatorConfig)


def test_greedy_coupling_by_hand():
    atoms = np.array([0.0, 1.0, 2.0, 3.0])  # mass 1/4 each
    left = np.full((1, 4), 0.25)
    agent = np.abs(atoms - 0.1)[None]  # a state at 0.1: its distances to the atoms
    # Mass 1/2 - SPARE: all of atom 0 (distance 0.1), then atom 1 (0.9) up to the spare.
    first = couple(left, agent, 0.5)
    assert first[0] == pytest.approx(0.25 * 0.1 + (0.25 - SPARE) * 0.9)
    assert left[0].tolist() == pytest.approx([0.0, SPARE, 0.25, 0.25])
    # The same state again: atom 0 is spent, so the rest of 1, then 2, then 3 (1.9, 2.9).
    second = couple(left, agent, 0.5)
    expected = SPARE * 0.9 + 0.25 * 1.9 + (0.25 - 2 * SPARE) * 2.9
    assert second[0] == pytest.approx(expected)
    assert left.sum() == pytest.approx(2 * SPARE)


def test_standardizer_keeps_constant_features_in_their_units():
    mean, scale = standardizer(np.array([[1.0, 5.0], [3.0, 5.0]]))
    assert mean.tolist() == [2.0, 5.0] and scale.tolist() == [1.0, 1.0]


def _batch(next_obs: np.ndarray, timesteps: np.ndarray) -> Batch:
    """A (T, E) batch of 1-d states: only next_obs and timesteps matter to PWIL."""
    steps, n_envs = timesteps.shape
    zeros = np.zeros((steps, n_envs), np.float32)
    return Batch(
        obs=next_obs,
        actions=np.zeros((steps, n_envs, 1), np.float32),
        next_obs=next_obs,
        rewards=zeros,
        terminated=zeros.astype(bool),
        truncated=zeros.astype(bool),
        timesteps=timesteps,
        episode_returns=[],
    )


def test_pwil_reward_by_hand_carried_across_batches_and_reset_by_episodes():
    atoms = np.array([[0.0], [2.0]])  # standardized: mean 1, scale 1 -> -1 and 1
    reward = PWILReward(atoms, n_envs=2, horizon=2, sigma=1.0, alpha=5.0)
    # Env 0 sits on atom 0 for two steps of one episode; env 1 restarts its episode each step.
    states = np.array([[[0.0], [0.0]]], np.float32)
    first = reward(_batch(states, np.array([[0, 0]]))).per_step
    # Step 1: mass 1/2 - SPARE, all onto atom 0 (distance 0): reward 5 for both envs.
    assert first[0].tolist() == pytest.approx([5.0, 5.0])
    second = reward(_batch(states, np.array([[1, 0]]))).per_step
    # Env 0, step 2: atom 0 has SPARE left, the rest goes to atom 1, 2 away; env 1 starts again.
    cost = SPARE * 0.0 + (0.5 - 2 * SPARE) * 2.0
    assert second[0].tolist() == pytest.approx([5.0 * np.exp(-cost), 5.0])
    # The mass left is part of the trial's snapshot.
    assert reward.state_dict()["left"].shape == (2, 2)


def test_pwil_atoms_are_the_reached_states_subsampled_from_an_offset():
    obs = np.arange(11, dtype=np.float32)[:, None]
    demos = Demos("Line-v0", observations=(obs,), terminated=(False,))
    all_of_them = expert_atoms(demos, 1, np.random.default_rng(0))
    assert all_of_them[:, 0].tolist() == list(range(1, 11))
    every_fourth = expert_atoms(demos, 4, np.random.default_rng(0))[:, 0]
    offset = every_fourth[0] - 1
    assert 0 <= offset < 4 and every_fourth.tolist() == list(np.arange(1 + offset, 11, 4))
    with pytest.raises(ValueError, match="subsampling"):
        PWILConfig(subsampling=0)


def test_pwil_horizon_is_the_time_limit_and_never_shorter():
    """Steps past T would find every atom spent and earn the top reward: refused."""
    from bench import envs
    from bench.harness.registry import Task

    env_id = "InvertedPendulum-v5"  # episodes of up to 1,000 steps
    obs_dim, act_dim, low, high = envs.spaces(env_id)
    task = Task(env_id, obs_dim, act_dim, low, high, lambda s: envs.make(env_id, s))
    assert horizon_on(task, 0, None) == 1000
    # a longer horizon leaves mass over at the end: the cost of a short episode
    assert horizon_on(task, 0, 1500) == 1500
    with pytest.raises(ValueError, match=r"horizon \(999\) is shorter than InvertedPendulum-v5"):
        horizon_on(task, 0, 999)
