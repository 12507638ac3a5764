import os

import pytest
import torch

torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture()
def pendulum() -> str:
    return PENDULUM
