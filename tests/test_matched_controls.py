"""The survival control must run exactly the TRPO settings of what it controls."""

import dataclasses

from algorithms.adversarial import AdversarialConfig
from bench import registry
from bench.rl.trpo import TRPOConfig


def test_survival_runs_the_adversarial_learners_trpo_settings():
    algos = registry.all_algorithms()
    survival = algos["survival"].config()
    for name in ("gaifo", "gail"):
        imitator = algos[name].config()
        assert isinstance(imitator, AdversarialConfig)
        for f in dataclasses.fields(TRPOConfig):
            assert getattr(survival, f.name) == getattr(imitator, f.name), (name, f.name)
