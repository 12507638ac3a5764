"""`bench budgets`: the same cells at several budgets, on real records (Figure 2's Walker2d-v5 at
2M beside the oracle screen's 10M)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from folders import copy_folder

from bench.analysis import bootstrap
from bench.harness import frames

RESULTS = Path(__file__).parents[1] / "results"
WALKER = "Walker2d-v5"


@pytest.fixture(scope="module")
def two_budgets(tmp_path_factory) -> tuple[Path, Path]:
    """Figure 2's Walker2d-v5 records (2M) and its oracle screen's (10M, three seeds)."""
    root = tmp_path_factory.mktemp("budgets")
    on_walker = lambda r: r.spec.env_id == WALKER  # noqa: E731
    return (
        copy_folder(RESULTS / "mujoco", root / "figure2", on_walker),
        copy_folder(RESULTS / "mujoco-converged-screen", root / "screen", on_walker),
    )


def test_each_cell_stands_beside_its_longer_run(two_budgets, bench_here, tmp_path):
    short, long = two_budgets
    out = bench_here("budgets", str(short), str(long), "--out", str(tmp_path), "--reps", "200")
    assert out.returncode == 0, out.stderr
    rows = pd.read_csv(tmp_path / "budgets.csv")
    assert set(rows["budget"]) == {2_000_000, 10_000_000}
    oracle = rows[rows["algorithm"] == "oracle"].set_index(["n_demos", "budget"])
    assert (oracle["seeds"].xs(10_000_000, level="budget") == 3).all()  # the screen's seeds
    # the oracle, with no demonstrations, stands beside every count the learners ran with
    assert sorted(oracle.index.get_level_values("n_demos").unique()) == [1, 5, 10, 25]

    trials = frames.load(short)
    random, expert = (trials[trials.algorithm == a]["return"].mean() for a in ("random", "expert"))

    def normalized(algorithm: str, n_demos: int) -> pd.Series:
        rows = trials[(trials.algorithm == algorithm) & (trials.n_demos == n_demos)]
        return (rows["return"] - random) / (expert - random)

    gaifo = rows[(rows.algorithm == "gaifo") & (rows.n_demos == 5)].iloc[0]
    assert gaifo["budget"] == 2_000_000 and gaifo["seeds"] == 10
    assert gaifo["iqm"] == pytest.approx(bootstrap.iqm(normalized("gaifo", 5).to_numpy()))
    assert gaifo["lo"] <= gaifo["iqm"] <= gaifo["hi"]
    ceiling = bootstrap.iqm(normalized("oracle", 0).to_numpy())
    assert gaifo["of_oracle"] == pytest.approx(gaifo["iqm"] / ceiling)
    assert gaifo["worst_of_oracle"] == pytest.approx(normalized("gaifo", 5).min() / ceiling)
    # no learner but the oracle ran at 10M: nothing to read as a fraction of it there
    assert np.isnan(oracle.loc[(5, 10_000_000), "of_oracle"])
    # P(a GAIfO run beats a survival run): the share of seed pairs it wins, ties half
    mine, floor = normalized("gaifo", 5).to_numpy(), normalized("survival", 0).to_numpy()
    wins = (mine[:, None] > floor[None, :]) + 0.5 * (mine[:, None] == floor[None, :])
    assert gaifo["over_floor"] == pytest.approx(wins.mean())
    assert gaifo["over_floor_lo"] <= gaifo["over_floor"] <= gaifo["over_floor_hi"]
    assert oracle[["over_floor"]].isna().all().all()  # a control is not read against the floor

    assert "### Walker2d" in out.stdout and "| 5       | GAIfO " in out.stdout
    assert "10.00M: of oracle (worst)" in out.stdout and "2.00M: P(> floor)" in out.stdout
    page = (tmp_path / "budgets.md").read_text()
    assert "budgets_5demos.png" in page and (tmp_path / "budgets_5demos.png").stat().st_size


def test_one_env_at_one_budget_in_two_folders_is_one_line(two_budgets, bench_here, tmp_path):
    short, _ = two_budgets
    out = bench_here("budgets", str(short), str(short), "--out", str(tmp_path / "o"))
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert f"both hold {WALKER} at 2,000,000 steps" in out.stderr
    assert not (tmp_path / "o").exists()


def test_folders_without_a_cell_at_two_budgets_are_one_line(two_budgets, bench_here, tmp_path):
    short, _ = two_budgets
    out = bench_here("budgets", str(short), "--out", str(tmp_path / "o"))
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "no env at two budgets" in out.stderr


def test_demos_keeps_only_those_counts(two_budgets, bench_here, tmp_path):
    short, long = two_budgets
    args = ("budgets", str(short), str(long), "--out", str(tmp_path), "--reps", "50")
    out = bench_here(*args, "--demos", "5", "--demos", "25")
    assert out.returncode == 0, out.stderr
    assert set(pd.read_csv(tmp_path / "budgets.csv")["n_demos"]) == {5, 25}
    refused = bench_here(*args, "--demos", "3")
    assert refused.returncode == 2 and "no learner ran with [3] demonstrations" in refused.stderr
