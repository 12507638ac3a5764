"""One discriminator for every adversarial learner, on-policy or off: its settings
(`DiscriminatorConfig`), its network (`Discriminator`, over any features of a transition), one
loss (`discriminator_loss`), one training step (`discriminator_step`) and what is logged of it
(`discriminator_log`), the rewards it gives, and the expert's side of its data
(`expert_transitions`).

D outputs the logit of P(expert | transition). Training is binary cross-entropy with the expert
labelled 1 (`logistic`), plus a gradient penalty on interpolates that keeps D smooth, so the
policy's reward has a slope to climb even where D tells the two sides apart. The same network
trained on `wasserstein` instead is a Wasserstein critic (WAILfO's), and any `head` on the
features may stand for the MLP (AIRLfO's shaped one).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bench.fields import added_later
from bench.rl import absorbing
from bench.rl.absorbing import Transitions
from bench.rl.networks import ConvTrunk, ObsShape, PixelScale, RunningNorm, mlp, shape_of
from bench.validate import Checked, above, at_least, layers, one_of

REWARDS: dict[str, Callable[[torch.Tensor], torch.Tensor]] = {
    "-log(1-D)": lambda logit: F.softplus(logit),  # -log(1 - sigmoid(x)) = softplus(x) > 0
    "log D": lambda logit: -F.softplus(-logit),  # log sigmoid(x) < 0
    "log D - log(1-D)": lambda logit: logit,  # the logit itself, either sign
}


Objective = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]
"""objective(logit_p, logit_e) -> the scalar D minimizes, from its (N,) outputs on a minibatch
of the policy's rows and one of the expert's."""


def logistic(logit_p: torch.Tensor, logit_e: torch.Tensor) -> torch.Tensor:
    """Binary cross-entropy of each side, the expert labelled 1: D a classifier, its output the
    logit of P(expert) (GAN's, GAIfO's)."""
    return F.binary_cross_entropy_with_logits(
        logit_p, torch.zeros_like(logit_p)
    ) + F.binary_cross_entropy_with_logits(logit_e, torch.ones_like(logit_e))


def wasserstein(value_p: torch.Tensor, value_e: torch.Tensor) -> torch.Tensor:
    """E_policy[f] - E_expert[f]: with a gradient penalty towards norm 1 (`gp_target`), f is a
    critic whose minimum is minus the Wasserstein-1 distance between the two sides (WGAN-GP,
    Gulrajani et al. 2017; WAIL, Xiao et al. 2019), and f(x) the reward of x."""
    return value_p.mean() - value_e.mean()


@dataclass
class DiscriminatorConfig(Checked):
    """D's settings, the same fields and checks for every adversarial learner whatever its
    optimizer (TRPO's GAIfO and GAIL, SAC's, OPOLO's TD3): one D, one training step
    (`discriminator_step`)."""

    disc_hidden: tuple[int, ...] = (100, 100)
    """Hidden layer sizes of the discriminator MLP (tanh)."""
    disc_lr: float = 3e-4
    """Adam learning rate of the discriminator."""
    grad_penalty: float = 10.0
    """Weight of a gradient penalty on expert/policy interpolates (smooths D); 0 disables it."""
    gp_target: float = 0.0
    """Gradient norm the penalty pulls towards: 0 (zero-centred) or 1 (WGAN-GP style)."""
    disc_entropy: float = 0.0
    """Weight of a bonus on the entropy of D's predictions, which keeps D from certainty
    (OPOLO's 0.001); 0: none."""
    disc_noise: float = added_later(0.0)
    """Instance noise: the std of Gaussian noise added to both sides' normalized feature rows
    while D trains, not when it rewards; 0: none (docs/design/settings.md)."""
    disc_obs_dims: int | None = added_later(None)
    """D judges only the first this many entries of each state vector (the policy still sees
    all of them); None: all. States only, not frames (docs/design/settings.md)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        layers(self, "disc_hidden")
        above(self, 0, "disc_lr")
        at_least(self, 0, "grad_penalty", "gp_target", "disc_entropy", "disc_noise")
        at_least(self, 1, "disc_obs_dims")


@dataclass
class RewardingDiscriminatorConfig(DiscriminatorConfig):
    """D's settings where D's verdict is the policy's reward (GAIfO and GAIL on either
    optimizer); OPOLO's D shapes its critic instead and takes no reward choice."""

    reward: str = "log D - log(1-D)"
    """Policy reward as a function of D = P(expert): "log D - log(1-D)" (D's logit: either sign,
    so with absorbing states it pays neither for surviving nor for falling), "-log(1-D)" (always
    positive: pays for every step alive) or "log D" (always negative: pays for ending early)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        one_of(self, "reward", REWARDS)


def discriminator_loss(
    net: nn.Module,
    policy: torch.Tensor,
    expert: torch.Tensor,
    cfg: DiscriminatorConfig,
    gen: torch.Generator,
    objective: Objective = logistic,
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """D's loss on one minibatch of each side, (N, F) feature rows of the policy's and the
    expert's, and its parts: the `objective` (binary cross-entropy with the expert labelled 1), less
    `disc_entropy` times the entropy of D's predictions, plus `grad_penalty` times
    (||grad D|| - gp_target)^2 on random interpolates. `net` maps rows to (N, 1) logits. With
    `disc_noise`, both sides' rows first get Gaussian noise of that std added, the penalty's
    interpolates between the noisy rows. The noise and the interpolation weights are drawn
    from `gen` on the CPU whatever the rows' device (so a seed draws the same numbers
    anywhere), and only where they are used (so a run without them draws what it always did)."""
    if cfg.disc_noise > 0:
        policy = policy + cfg.disc_noise * normal_like(policy, gen)
        expert = expert + cfg.disc_noise * normal_like(expert, gen)
    logit_p, logit_e = net(policy).squeeze(-1), net(expert).squeeze(-1)
    value = objective(logit_p, logit_e)
    loss = value
    if cfg.disc_entropy > 0:
        logits = torch.cat([logit_p, logit_e])
        entropy = -(
            torch.sigmoid(logits) * F.logsigmoid(logits)
            + torch.sigmoid(-logits) * F.logsigmoid(-logits)
        ).mean()
        loss = loss - cfg.disc_entropy * entropy
    penalty = torch.zeros(())
    if cfg.grad_penalty > 0:
        # On normalized inputs: raw PyBullet features with tiny variance would make the
        # gradient w.r.t. raw inputs huge and the penalty would swamp the classifier.
        alpha = torch.rand(len(policy), 1, generator=gen).to(policy.device)
        mix = (alpha * expert + (1 - alpha) * policy).detach().requires_grad_(True)
        grad = torch.autograd.grad(net(mix).sum(), mix, create_graph=True)[0]
        penalty = (grad.norm(dim=1) - cfg.gp_target).square().mean()
        loss = loss + cfg.grad_penalty * penalty
    return loss, {"objective": value, "penalty": penalty, "logit_p": logit_p, "logit_e": logit_e}


def normal_like(rows: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
    """Standard normal draws of `rows`' shape, from `gen` on the CPU, on `rows`' device."""
    return torch.randn(rows.shape, generator=gen).to(rows.device)


def discriminator_step(
    net: nn.Module,
    opt: torch.optim.Optimizer,
    policy: torch.Tensor,
    expert: torch.Tensor,
    cfg: DiscriminatorConfig,
    gen: torch.Generator,
    learn: bool = True,
    objective: Objective = logistic,
) -> dict[str, torch.Tensor]:
    """One training step of D, whatever the learner: `opt`'s step on `discriminator_loss` of
    one minibatch of each side ((N, F) feature rows), and the loss's parts, for
    `discriminator_log`. `learn=False`: the parts alone, D left as it is."""
    loss, parts = discriminator_loss(net, policy, expert, cfg, gen, objective)
    if learn:
        opt.zero_grad()
        loss.backward()
        opt.step()
    return parts


def discriminator_log(parts: dict[str, torch.Tensor]) -> dict[str, float]:
    """What every adversarial learner logs of D's last step, by name: its objective
    (`disc_loss`: the cross-entropy, or a critic's E_policy[f] - E_expert[f]) and the share of
    each side's rows on its side of 0 (`disc_acc_policy`, `disc_acc_expert`)."""
    return {
        "disc_loss": parts["objective"].item(),
        "disc_acc_policy": (parts["logit_p"] < 0).float().mean().item(),
        "disc_acc_expert": (parts["logit_e"] > 0).float().mean().item(),
    }


Features = Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]
"""features(s, a, s') -> (N, F) D input, from normalized observations (N, O+1 with the absorbing
flag last, or N, O without absorbing states), (N, A) actions and next observations like s.
GAIfO uses (s, s'), GAIL (s, a)."""


Head = Callable[[int, tuple[int, ...]], nn.Module]
"""head(in_dim, hidden) -> a module from (N, in_dim) feature rows to (N, 1) outputs."""


class Discriminator(nn.Module):
    """Logit of P(expert | transition), of observations scaled by `norm` (`disc_normalizer`).

    From frames, each observation first goes through D's own convolutional trunk, and D judges
    (and its gradient penalty smooths) the features of s and s' like state vectors.
    """

    def __init__(
        self,
        norm: RunningNorm | PixelScale,
        features: Features,
        obs_shape: ObsShape,
        act_dim: int,
        hidden: tuple[int, ...],
        with_absorbing: bool,
        obs_dims: int | None = None,
        head: Head | None = None,
    ) -> None:
        """`obs_shape`: (O,) or O for state vectors, (C, H, W) for flat frames. `obs_dims`: D
        judges only the first this many of a state vector's O entries (None: all). `head`: what
        maps the feature rows to D's outputs (None: an MLP of `hidden`, tanh)."""
        super().__init__()
        self.norm, self.features, self.with_absorbing = norm, features, with_absorbing
        shape = shape_of(obs_shape)
        if obs_dims is not None and (len(shape) != 1 or obs_dims > shape[0]):
            raise ValueError(
                f"disc_obs_dims ({obs_dims}) needs state vectors of at least that many entries,"
                f" not observations of shape {shape}"
            )
        self.obs_dims = obs_dims
        self.encoder = ConvTrunk(shape) if len(shape) == 3 else nn.Identity()
        zeros = torch.zeros(1, int(np.prod(shape)))
        state = self.state(zeros, torch.zeros(1, dtype=torch.bool))
        in_dim = features(state, torch.zeros(1, act_dim), state).shape[1]
        self.net = head(in_dim, hidden) if head is not None else mlp([in_dim, *hidden, 1])

    def state(self, obs: torch.Tensor, is_absorbing: torch.Tensor) -> torch.Tensor:
        """(N, F+1): the normalized observation (its trunk's features, from frames) and the
        absorbing flag; the absorbing state is (0, ..., 0, FLAG). (N, F), the observation
        alone, without absorbing states."""
        seen = self.encoder(self.norm(obs))
        if self.obs_dims is not None:
            seen = seen[:, : self.obs_dims]
        if not self.with_absorbing:
            return seen
        flag = is_absorbing.float().unsqueeze(1)
        return torch.cat([seen * (1.0 - flag), flag * absorbing.FLAG], dim=1)

    def inputs(self, x: Transitions) -> torch.Tensor:
        """The (N, F) feature rows D classifies."""
        return self.features(
            self.state(x.obs, x.obs_absorbing), x.actions, self.state(x.next_obs, x.next_absorbing)
        )

    def forward(self, x: Transitions) -> torch.Tensor:
        return self.net(self.inputs(x)).squeeze(-1)


def expert_transitions(
    observations: tuple[np.ndarray, ...],
    terminated: tuple[bool, ...],
    actions: tuple[np.ndarray, ...] | None,
    with_absorbing: bool,
    gamma: float,
) -> Transitions:
    """The demonstrations' transitions, with the absorbing tails of the episodes that terminated.

    observations: (T_i + 1, O) per episode; actions: (T_i, A) per episode, or None (state-only:
    the actions field then has width 0).
    """
    acts = actions or tuple(np.zeros((len(o) - 1, 0), np.float32) for o in observations)
    parts = [Transitions.real(o[:-1], a, o[1:]) for o, a in zip(observations, acts, strict=True)]
    finals = [o[-1] for o, t in zip(observations, terminated, strict=True) if t]
    if with_absorbing and finals:
        parts.append(absorbing.tails(np.stack(finals), acts[0].shape[1], gamma))
    return Transitions.concat(parts)
