"""`bench compare RUN REFERENCE`: per-row IQMs with CIs and a verdict, on real records."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from folders import copy_folder

from bench.analysis import agreement
from bench.harness import frames, store

REFERENCE = Path(__file__).parents[1] / "results" / "quick"
DRAWS = REFERENCE.with_name("quick-draws")  # the quick suite on 50 more seeds


def verdicts(stdout: str) -> dict[tuple[str, str, str], str]:
    """{(env, algorithm, demos): verdict} from the printed markdown table."""
    rows = [line.split("|")[1:-1] for line in stdout.splitlines() if line.startswith("| Inv")]
    return {(r[0].strip(), r[1].strip(), r[2].strip()): r[-1].strip(" *") for r in rows}


def gaifo_rows(found: dict) -> dict:
    return {key: v for key, v in found.items() if key[1] == "GAIfO"}


def rewrite(folder: Path, change) -> None:
    """Replace every record of `folder` by change(record) (or drop it if that returns None)."""
    for path in sorted(store.trials_dir(folder).glob("*.json")):
        result = change(store.read(path))
        path.unlink()
        if result is not None:
            store.write(folder, result)


def test_iqm_difference_of_identical_and_shifted_samples():
    scores = np.array([0.2, 0.5, 0.9, 1.0, 1.0, 0.7, 0.95, 1.0])
    same = agreement.iqm_difference(scores, scores.copy(), reps=500)
    assert same["diff"] == 0.0 and same["diff_lo"] <= 0.0 <= same["diff_hi"]
    shifted = agreement.iqm_difference(scores - 0.5, scores, reps=500)
    assert shifted["diff"] == pytest.approx(-0.5) and shifted["diff_hi"] < 0


def test_improvement_counts_wins_and_half_ties_by_hand():
    # x = [1, 2, 3] against y = [2, 0]: of 6 pairs 1 > 0, 2 > 0, 3 > 2, 3 > 0 win, 2 = 2 ties
    found = agreement.improvement(np.array([1.0, 2.0, 3.0]), np.array([2.0, 0.0]), reps=500)
    assert found["better"] == pytest.approx(4.5 / 6)
    assert found["better_lo"] <= found["better"] <= found["better_hi"]
    apart = agreement.improvement(np.array([2.0, 3.0]), np.array([0.0, 1.0]), reps=500)
    assert (apart["better"], apart["better_lo"], apart["better_hi"]) == (1.0, 1.0, 1.0)
    scores = np.array([0.2, 0.5, 0.9])
    assert agreement.improvement(scores, scores.copy(), reps=500)["better"] == 0.5


def test_identical_folders_agree(tmp_path, cli):
    run = tmp_path / "run"
    copy_folder(REFERENCE, run)
    out = cli("compare", str(run), str(REFERENCE), "--reps", "500")
    assert out.returncode == 0, out.stderr
    found = verdicts(out.stdout)
    assert gaifo_rows(found) and set(found.values()) == {"identical"}  # the same scores


def test_gaifo_at_random_level_differs(tmp_path, cli):
    run = tmp_path / "run"
    copy_folder(REFERENCE, run)
    records = frames.load(run)
    random_returns = records[records.algorithm == "random"].groupby("env_id")["return"]
    random_level = random_returns.mean().to_dict()

    def to_random_level(result):
        if result.spec.algorithm != "gaifo":
            return result
        level = random_level[result.spec.env_id]
        return dataclasses.replace(result, returns=[level] * len(result.returns))

    rewrite(run, to_random_level)
    out = cli("compare", str(run), str(REFERENCE), "--reps", "500")
    assert out.returncode == 0, out.stderr
    found = verdicts(out.stdout)
    assert len(gaifo_rows(found)) >= 2 and set(gaifo_rows(found).values()) == {"differs"}
    assert {v for key, v in found.items() if key[1] != "GAIfO"} == {"identical"}


def test_folders_without_overlap_give_one_line(tmp_path, cli):
    run = tmp_path / "run"
    copy_folder(REFERENCE, run)
    rewrite(
        run,
        lambda r: dataclasses.replace(
            r, spec=dataclasses.replace(r.spec, env_id="HopperBulletEnv-v0")
        ),
    )
    before = sorted(p.read_bytes() for p in store.trials_dir(run).iterdir())
    out = cli("compare", str(run), str(REFERENCE))
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "share no env" in out.stderr
    assert sorted(p.read_bytes() for p in store.trials_dir(run).iterdir()) == before


def test_only_like_is_compared_with_like(tmp_path, cli):
    """GAIfO run at another budget in the run folder is no row of the comparison: the rest
    is compared, and the output says how many cells had no like; folders that share no
    setting at all are one line that names the budgets."""
    run = tmp_path / "run"
    copy_folder(REFERENCE, run)

    def other_budget(result, algorithms=("gaifo",)):
        if result.spec.algorithm not in algorithms:
            return result
        spec = dataclasses.replace(result.spec, budget=result.spec.budget * 2)
        return dataclasses.replace(result, spec=spec)

    rewrite(run, other_budget)
    out = cli("compare", str(run), str(REFERENCE), "--reps", "200")
    assert out.returncode == 0, out.stderr
    found = verdicts(out.stdout)
    assert not gaifo_rows(found) and found  # the rest still compared
    assert "Not compared:" in out.stdout and "another budget" in out.stdout

    every = tmp_path / "every"
    copy_folder(REFERENCE, every)
    rewrite(every, lambda r: other_budget(r, algorithms=(r.spec.algorithm,)))
    out = cli("compare", str(every), str(REFERENCE), "--reps", "200")
    assert out.returncode == 2 and out.stderr.count("\n") == 1
    assert "budgets" in out.stderr, out.stderr


def test_a_reference_pooled_from_folders_of_other_seeds(tmp_path, cli):
    """`bench compare RUN REF MORE`: the reference is the records of both (55 seeds a cell);
    the reference's own 5 seeds are identical to their like in the pool, 5 of the fresh
    draws agree with it, and two folders that both hold one seed are refused in one line."""
    out = cli("compare", str(REFERENCE), str(REFERENCE), str(DRAWS), "--reps", "200")
    assert out.returncode == 0, out.stderr
    assert set(verdicts(out.stdout).values()) == {"identical"} and "(55)" in out.stdout
    five = copy_folder(DRAWS, tmp_path / "five", keep=lambda r: r.spec.seed in range(5, 10))
    rest = copy_folder(DRAWS, tmp_path / "rest", keep=lambda r: r.spec.seed not in range(5, 10))
    out = cli("compare", str(five), str(REFERENCE), str(rest), "--reps", "200")
    assert out.returncode == 0, out.stderr
    assert set(verdicts(out.stdout).values()) == {"agrees"} and "(50)" in out.stdout
    out = cli("compare", str(REFERENCE), str(five), str(DRAWS))
    assert out.returncode == 2 and out.stderr.count("\n") == 1
    assert "both hold" in out.stderr and "seed 5" in out.stderr
    empty = tmp_path / "empty"
    (empty / "trials").mkdir(parents=True)
    out = cli("compare", str(five), str(REFERENCE), str(empty))
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "no readable trial record" in out.stderr
