import os

import pytest
import torch

torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture()
def pendulum() -> str:
    return PENDULUM


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory):
    """A private bench cache (demo pools) shared by one test module, so pools are recorded once."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("cache")
    mp.setattr("bench.paths.CACHE_DIR", root)
    yield root
    mp.undo()
