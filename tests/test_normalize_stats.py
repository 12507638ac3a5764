"""Normalization against random/expert, and the rliable wrappers on 4x2 matrices."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from bench.analysis import agreement, stats
from bench.analysis.normalize import NormalizationError, normalize, reference_returns

from frames import described


def trials(rows: list[tuple]) -> pd.DataFrame:
    return described(
        pd.DataFrame(rows, columns=["env_id", "algorithm", "n_demos", "seed", "status", "return"])
    )


REFS = [
    ("A", "random", 0, 0, "ok", 0.0),
    ("A", "random", 0, 1, "ok", 20.0),  # mean 10
    ("A", "random", 0, 2, "failed", math.nan),
    ("A", "expert", 0, 0, "ok", 110.0),
    ("B", "random", 0, 0, "ok", -1.0),
    ("B", "expert", 0, 0, "ok", 1.0),
]


def test_reference_returns():
    refs = reference_returns(trials(REFS))
    assert refs.to_dict("list") == {
        "env_id": ["A", "B"],
        "random": [10.0, -1.0],
        "expert": [110.0, 1.0],
    }


def test_normalize():
    frame = trials(REFS + [("A", "gaifo", 5, 0, "ok", 60.0), ("B", "gaifo", 5, 0, "ok", 0.0)])
    out = normalize(frame)
    assert list(out.columns) == [*frame.columns, "normalized"]
    by_row = out.set_index(["env_id", "algorithm", "seed"])["normalized"]
    assert by_row[("A", "gaifo", 0)] == pytest.approx(0.5)
    assert by_row[("B", "gaifo", 0)] == pytest.approx(0.5)
    assert by_row[("A", "expert", 0)] == pytest.approx(1.0)
    assert by_row[("A", "random", 0)] == pytest.approx(-0.1)
    assert math.isnan(by_row[("A", "random", 2)])  # failed trials stay NaN


def test_normalize_curves_with_the_trials_references():
    curves = pd.DataFrame(
        {"env_id": ["A", "A"], "algorithm": ["gaifo"] * 2, "return": [10.0, 110.0]}
    )
    out = normalize(curves, reference_returns(trials(REFS)))
    assert out["normalized"].tolist() == [0.0, 1.0]


@pytest.mark.parametrize(
    "rows, message",
    [
        (
            [r for r in REFS if r[:2] != ("B", "expert")],
            "B: no ok trial of expert to normalize against",
        ),
        (
            [r for r in REFS if r[0] != "A" or r[1] != "random"],
            "A: no ok trial of random to normalize",
        ),
        (
            [r for r in REFS if r[0] != "B"] + [("B", "gaifo", 1, 0, "ok", 1.0)],
            "B: no ok trial of random or expert",
        ),
        (
            [("A", "random", 0, 0, "ok", 5.0), ("A", "expert", 0, 0, "ok", 5.0)],
            "A: expert return 5 is not above random 5",
        ),
        (
            [("A", "random", 0, 0, "failed", math.nan), ("A", "expert", 0, 0, "ok", 5.0)],
            "A: no ok trial of random",
        ),
    ],
)
def test_missing_references_name_env_and_reference(rows, message):
    with pytest.raises(NormalizationError, match=message) as info:
        normalize(trials(rows))
    assert "\n" not in str(info.value)


def test_two_records_of_one_seed_are_refused():
    # e.g. a suite rerun into the same folder after its budget changed
    frame = trials(REFS + [("A", "gaifo", 5, 0, "ok", 60.0), ("A", "gaifo", 5, 0, "ok", 90.0)])
    with pytest.raises(NormalizationError, match="A: gaifo with 5 demos, seed 0, has 2 records"):
        normalize(frame)


# ---------------------------------------------------------------- stats


def scores(algorithm: str, matrix, n_demos=5) -> pd.DataFrame:
    """A normalized frame from a (seeds x envs) matrix."""
    matrix = np.asarray(matrix, dtype=float)
    rows = pd.DataFrame(
        [
            {
                "env_id": f"env{t}",
                "algorithm": algorithm,
                "n_demos": n_demos,
                "seed": s,
                "normalized": matrix[s, t],
            }
            for s in range(matrix.shape[0])
            for t in range(matrix.shape[1])
        ]
    )
    return described(rows)


ONE_TO_EIGHT = np.arange(1, 9).reshape(4, 2)  # runs x tasks


def test_score_dict_pivots_runs_by_tasks():
    frame = pd.concat(
        [scores("gaifo", ONE_TO_EIGHT), scores("bco", -ONE_TO_EIGHT), scores("random", [[0, 0]], 0)]
    )
    got = stats.score_dict(frame, n_demos=5)
    assert list(got) == ["bco", "gaifo"]
    np.testing.assert_array_equal(got["gaifo"], ONE_TO_EIGHT)
    np.testing.assert_array_equal(got["bco"], -ONE_TO_EIGHT)


def test_score_dict_includes_demo_free_learners_at_every_count():
    frame = pd.concat(
        [
            scores("gaifo", ONE_TO_EIGHT),
            scores("survival", ONE_TO_EIGHT / 10, n_demos=0),
            scores("random", np.zeros((4, 2)), n_demos=0),
        ]
    )
    assert list(stats.score_dict(frame, n_demos=5)) == ["gaifo", "survival"]
    named = stats.score_dict(frame, n_demos=5, algorithms=["gaifo", "random"])
    np.testing.assert_array_equal(named["random"], np.zeros((4, 2)))


def test_score_dict_drops_to_common_seeds_with_a_warning():
    frame = scores("gaifo", ONE_TO_EIGHT)
    frame = frame[~((frame["seed"] == 3) & (frame["env_id"] == "env1"))]  # seed 3 lacks env1
    with pytest.warns(UserWarning, match=r"gaifo: dropped seed\(s\) \[3\]"):
        got = stats.score_dict(frame, n_demos=5)
    np.testing.assert_array_equal(got["gaifo"], ONE_TO_EIGHT[:3])


def test_score_dict_drops_failed_runs_with_a_warning():
    frame = scores("gaifo", ONE_TO_EIGHT)
    frame.loc[0, "normalized"] = math.nan
    with pytest.warns(UserWarning, match=r"dropped seed\(s\) \[0\]"):
        assert stats.score_dict(frame, n_demos=5)["gaifo"].shape == (3, 2)


def test_score_dict_keeps_common_envs_and_given_algorithms():
    frame = pd.concat([scores("gaifo", ONE_TO_EIGHT), scores("bco", ONE_TO_EIGHT[:, :1])])
    with pytest.warns(UserWarning, match=r"gaifo: dropped env\(s\) \['env1'\]"):
        got = stats.score_dict(frame, n_demos=5, algorithms=["gaifo", "bco"])
    assert list(got) == ["gaifo", "bco"]
    assert got["gaifo"].shape == got["bco"].shape == (4, 1)
    with pytest.raises(ValueError, match="n_demos=5 for tcn"):
        stats.score_dict(frame, n_demos=5, algorithms=["gaifo", "tcn"])


def test_score_dict_without_the_demo_count_fails():
    with pytest.raises(ValueError, match="no scores with n_demos=7"):
        stats.score_dict(scores("gaifo", ONE_TO_EIGHT), n_demos=7)


def test_aggregate_scores_by_hand():
    table = stats.aggregate_scores({"a": ONE_TO_EIGHT.astype(float)}, reps=200)
    est = table.set_index("metric")["estimate"]
    # mean of all = 4.5; median of task means (4, 5) = 4.5; IQM of 1..8 = mean(3, 4, 5, 6) = 4.5
    assert est.to_dict() == {"mean": 4.5, "median": 4.5, "iqm": 4.5}
    assert (table["lo"] <= table["estimate"]).all() and (table["estimate"] <= table["hi"]).all()
    assert (table["hi"] - table["lo"] > 0).all()
    assert list(table.columns) == ["algorithm", "metric", "estimate", "lo", "hi"]


def test_aggregate_scores_iqm_trims_the_tails():
    skewed = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 1.0], [100.0, 100.0]])
    table = stats.aggregate_scores({"a": skewed}, reps=50).set_index("metric")
    assert table.loc["iqm", "estimate"] == 1.0
    assert table.loc["mean", "estimate"] == 25.5


def test_constant_scores_have_a_point_interval():
    table = stats.aggregate_scores({"a": np.full((4, 2), 0.7)}, reps=100)
    np.testing.assert_allclose(table[["estimate", "lo", "hi"]].to_numpy(), 0.7)


def test_aggregate_scores_is_reproducible_and_leaves_global_rng_alone():
    np.random.seed(123)
    expected_next = np.random.rand()
    np.random.seed(123)
    first = stats.aggregate_scores({"a": ONE_TO_EIGHT.astype(float)}, reps=100, seed=1)
    assert np.random.rand() == expected_next
    again = stats.aggregate_scores({"a": ONE_TO_EIGHT.astype(float)}, reps=100, seed=1)
    pd.testing.assert_frame_equal(first, again)


def test_probability_of_improvement():
    better = ONE_TO_EIGHT + 100.0
    table = stats.probability_of_improvement(
        {"gaifo": better, "bco": ONE_TO_EIGHT.astype(float), "same": better.copy()}, reps=100
    )
    assert list(table.columns) == ["algorithm", "other", "estimate", "lo", "hi"]
    rows = table.set_index("other")
    assert rows.loc["bco", "estimate"] == 1.0  # every gaifo run beats every bco run
    assert rows.loc["same", "estimate"] == 0.5
    assert set(table["algorithm"]) == {"gaifo"}


def test_probability_of_improvement_needs_the_target():
    with pytest.raises(ValueError, match="'gaifo' not among"):
        stats.probability_of_improvement({"bco": ONE_TO_EIGHT.astype(float)}, reps=10)


def test_performance_profile():
    taus = np.array([0.0, 4.5, 8.0])
    profile = stats.performance_profile({"a": ONE_TO_EIGHT.astype(float)}, taus, reps=50)
    assert list(profile.columns) == ["algorithm", "tau", "fraction", "lo", "hi"]
    # fraction of the 8 runs x tasks scoring above tau
    assert profile["fraction"].tolist() == [1.0, 0.5, 0.0]
    assert (profile["lo"] <= profile["fraction"]).all() and (
        profile["fraction"] <= profile["hi"]
    ).all()


def test_one_seed_has_no_interval():
    """Resampling one seed gives it back every time: no interval, not a zero-width one."""
    from bench.analysis import markdown, stats

    one, two = np.array([[0.5, 0.7]]), np.array([[0.4, 0.2], [0.6, 0.9]])
    cells = stats.aggregate_scores({"one": one, "two": two}, reps=200)
    assert cells[cells.algorithm == "one"][["lo", "hi"]].isna().all().all()
    assert cells[cells.algorithm == "two"][["lo", "hi"]].notna().all().all()
    row = cells[(cells.algorithm == "one") & (cells.metric == "iqm")].iloc[0]
    assert markdown.interval(row.estimate, row.lo, row.hi) == "0.60"
    pairs = stats.improvement_of_pairs({"one": one, "two": two}, [("one", "two")], reps=200)
    assert pairs[["lo", "hi"]].isna().all().all()


@pytest.mark.parametrize("alpha", [agreement.ALPHA, 0.05])
def test_the_verdict_says_differs_of_at_most_alpha_of_splits_of_one_sample(alpha):
    """Both halves of one sample of 10 seeds are draws of one distribution: over every split
    into 5 against 5, the rank test calls at most alpha of them different, even of bimodal
    scores where the bootstrap CI of the IQM difference called more."""
    import itertools

    scores = np.array([0.05, 0.1, 0.12, 0.9, 0.95, 0.97, 1.0, 1.01, 0.08, 0.99])
    calls = []
    for half in itertools.combinations(range(10), 5):
        a, b = scores[list(half)], np.delete(scores, list(half))
        seeds = pd.Series(a, index=list(half)), pd.Series(b)
        p = agreement.permutation_p(a, b)
        calls.append(agreement.verdict_of(*seeds, p, alpha) == "differs")
    assert np.mean(calls) <= alpha and (alpha < 0.05 or np.mean(calls) > 0)
    separated = agreement.permutation_p(np.zeros(5), np.ones(5))
    low, high = pd.Series(np.zeros(5)), pd.Series(np.ones(5))
    assert separated < agreement.ALPHA and agreement.verdict_of(low, high, separated) == "differs"
    # Identical: each seed of the run scores what the reference's same seed does, to the bit,
    # though the reference holds more seeds; the same scores on other seeds are not.
    reference = pd.Series(scores)
    assert agreement.verdict_of(reference[:5], reference, 1.0) == "identical"
    assert agreement.verdict_of(pd.Series(scores[:5], index=range(5, 10)), reference, 1.0) == (
        "agrees"
    )
    assert agreement.permutation_p(np.ones(3), np.zeros(3)) == pytest.approx(0.1)  # 3 seeds: never
