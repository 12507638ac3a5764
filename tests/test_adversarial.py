import torch

from algorithms.adversarial import REWARDS


def test_reward_forms_have_the_documented_signs():
    logit = torch.linspace(-5, 5, 11)
    assert (REWARDS["-log(1-D)"](logit) > 0).all()
    assert (REWARDS["log D"](logit) < 0).all()
    assert torch.equal(REWARDS["log D - log(1-D)"](logit), logit)
