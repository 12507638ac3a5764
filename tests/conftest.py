import contextlib
import io
import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import torch

torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture()
def pendulum() -> str:
    return PENDULUM


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory, pendulum_pool):
    """A private bench cache (demo pools) shared by one test module, so pools are recorded once,
    holding a copy of the pendulum's pool."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("cache")
    mp.setattr("bench.paths.CACHE_DIR", root)
    _copy_pendulum_pool(pendulum_pool)
    yield root
    mp.undo()


def _bench_cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "bench.cli", *args], capture_output=True, text=True, **kw
    )


@pytest.fixture(scope="session")
def cli():
    """`cli("run", suite, ...)` runs the bench command in a subprocess, as a user would."""
    return _bench_cli


def _bench_here(*args: str) -> subprocess.CompletedProcess:
    """`bench ARGS` through the command's own `main`, in this process: what `cli` does but for
    a new interpreter's imports (~3 s of CPU each, most of what a refused command costs).
    Warnings are lines of its stderr, in order, filtered as a fresh interpreter filters them."""
    from bench.cli import main

    out, err = io.StringIO(), io.StringIO()

    def show(message, category, filename, lineno, file=None, line=None):
        err.write(warnings.formatwarning(message, category, filename, lineno, line))

    captured = (contextlib.redirect_stdout(out), contextlib.redirect_stderr(err))
    with captured[0], captured[1], warnings.catch_warnings():
        warnings.simplefilter("default")
        for quiet in (
            DeprecationWarning,
            PendingDeprecationWarning,
            ImportWarning,
            ResourceWarning,
        ):
            warnings.filterwarnings("ignore", category=quiet)
        warnings.showwarning = show
        formatwarning = warnings.formatwarning
        try:
            code = main(list(args))
        except SystemExit as e:  # argparse: usage errors and --help
            code = e.code if isinstance(e.code, int) else 1
        finally:
            warnings.formatwarning = formatwarning  # main sets its own
    return subprocess.CompletedProcess(["bench", *args], code, out.getvalue(), err.getvalue())


@pytest.fixture(scope="session")
def bench_here():
    """`bench_here("run", suite, ...)`: `cli` in this process, for the many refusals of bad input
    (`cli` keeps checking the real command end to end)."""
    return _bench_here


@pytest.fixture()
def demo_cache(tmp_path, monkeypatch, pendulum_pool):
    """A private demo cache per test, for this process and any bench subprocess it starts,
    holding a copy of the pendulum's pool (`pendulum_pool`); every other pool is recorded in
    it as a user's cache records it."""
    monkeypatch.setenv("IFO_BENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr("bench.paths.CACHE_DIR", tmp_path / "cache")
    _copy_pendulum_pool(pendulum_pool)


@pytest.fixture(scope="session")
def pendulum_pool(tmp_path_factory) -> Path:
    """The pendulum expert's pool of demonstrations, recorded once per test process: most
    tests train on it, and recording it costs ~10 s of CPU, which a dozen tests each paid when
    every test recorded its own. A copy goes into each test's cache, so none sees another's."""
    from bench.demos import pools

    with pytest.MonkeyPatch.context() as mp:  # recorded as a user's cache records it
        mp.setattr("bench.paths.CACHE_DIR", tmp_path_factory.mktemp("pendulum-pool"))
        return pools.ensure_pool(PENDULUM)


def _copy_pendulum_pool(pool: Path) -> None:
    """Put a copy of `pool` where the bench cache (`bench.paths.CACHE_DIR`, as patched now)
    keeps the pendulum's pool."""
    from bench.demos import pools

    path = pools.pool_path(PENDULUM)
    path.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(pool, path)


@pytest.fixture(scope="session")
def on_dask():
    """`on_dask(specs, results, workers)` runs the trials as `bench run --backend dask` would,
    on a local cluster of `workers` worker processes (one thread each) started for the call,
    so workers see the environment as it is then. Skips where dask.distributed is missing."""
    distributed = pytest.importorskip("distributed")
    from bench.harness.runner import run_suite

    def run(specs, results, workers: int):
        with distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            return run_suite(
                specs, results, backend="dask", scheduler=cluster.scheduler_address, progress=False
            )

    return run


@pytest.fixture(scope="session")
def table_rows():
    """`table_rows(text)`: see `_table_rows`."""
    return _table_rows


def _table_rows(text: str) -> list[list[str]]:
    """The cells of every markdown table row in `text`, header rows included and rules left
    out, stripped of the padding that aligns them: tests check what a table says, not how
    wide its columns are."""
    rows = [
        [cell.strip() for cell in line.split("|")[1:-1]]
        for line in text.splitlines()
        if line.startswith("|")
    ]
    return [r for r in rows if not all(re.fullmatch(r":?-+:?", cell) for cell in r)]


@pytest.fixture(scope="session")
def table_rule():
    """`table_rule(text, header)`: see `_table_rule`."""
    return _table_rule


def _table_rule(text: str, header: list[str]) -> list[str]:
    """The rule under the table row `header` of `text` (e.g. `---:`, right-aligned), a cell
    per column."""
    lines = text.splitlines()
    at = next(i for i, line in enumerate(lines) if _table_rows(line) == [header])
    return [cell.strip() for cell in lines[at + 1].split("|")[1:-1]]


@pytest.fixture()
def install_plugin():
    """`install_plugin(root, name, entry_points, modules)`: see `_install_plugin`."""
    return _install_plugin


def _install_plugin(root, name: str, entry_points: str, modules: dict[str, str]) -> dict:
    """A plugin distribution as pip leaves one (a .dist-info with its entry points) under
    `root`, and the environment that puts it on a bench subprocess's path."""
    info = root / f"{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[ifo_bench.algorithms]\n{entry_points}\n")
    for module, code in modules.items():
        (root / f"{module}.py").write_text(code)
    return {**os.environ, "PYTHONPATH": str(root)}
