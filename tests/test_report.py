"""`bench report` on synthetic records: statistics, markdown, figures, CLI."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from rliable import metrics

from bench import cli
from bench.analysis import bootstrap, comparisons, curves, findings, labels, report, sections
from bench.harness import frames, store
from bench.harness.types import CurvePoint, TrialResult, TrialSpec

from frames import names

ENVS = {"InvertedPendulumBulletEnv-v0": (20.0, 1000.0), "HopperBulletEnv-v0": (-5.0, 2500.0)}
"""env -> (random return, expert return)."""
DEMOS = [1, 5]
SKILL = {"gaifo": 0.6, "gail": 0.4, "survival": 0.2}
"""Normalized score each learner converges to (plus a little per seed)."""
BUDGET = 1000
REPS = 100


def trial(env_id: str, algorithm: str, n_demos: int, seed: int, **changes) -> TrialResult:
    random, expert = ENVS[env_id]
    spec = TrialSpec("synthetic", env_id, algorithm, n_demos, seed, BUDGET, eval_episodes=3)
    if algorithm in ("random", "expert"):
        level = (0.0 if algorithm == "random" else 1.0) + 0.01 * (-1) ** seed  # mean 0 or 1
        curve = []
    else:
        level = SKILL[algorithm] + 0.02 * n_demos + 0.05 * seed
        curve = [
            CurvePoint(step, random + (expert - random) * level * step / BUDGET)
            for step in range(0, BUDGET + 1, BUDGET // 4)
        ]
    ret = random + (expert - random) * level
    fields = dict(
        spec=spec,
        status="ok",
        returns=[ret - 1.0, ret, ret + 1.0],
        curve=curve,
        env_steps=BUDGET,
        wall_time=12.5,
        versions={"ifo-bench": "test"},
        inputs={"random": "none", "expert": "expert", "gail": "actions"}.get(algorithm, "states"),
        state_distance=3.0 * (1.0 - level),  # the more skilled, the closer to the expert's states
    )
    return TrialResult(**(fields | changes))


def write_suite(
    results_dir: Path, seeds=range(4), algorithms=("gaifo", "gail"), envs=ENVS, demos=DEMOS
) -> Path:
    for env_id in envs:
        for seed in seeds:
            for algorithm in ("random", "expert", "survival"):
                store.write(results_dir, trial(env_id, algorithm, 0, seed))
            for algorithm in algorithms:
                for n in demos:
                    store.write(results_dir, trial(env_id, algorithm, n, seed))
    return results_dir


PENDULUM = next(iter(ENVS))


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> Path:
    """2 envs x 2 demo counts x 5 algorithms x 4 seeds, and a failed fifth seed of gaifo."""
    results = write_suite(tmp_path_factory.mktemp("report") / "synthetic")
    failed = trial(PENDULUM, "gaifo", 5, 4, status="failed", returns=[], curve=[])
    store.write(results, failed)
    return report.write_report(results, reps=REPS).path


def test_report_has_every_table_and_figure(written, table_rows):
    assert written == written.parent / "report.md" and written.parent.name == "report"
    text = written.read_text()
    rows = table_rows(text)
    for row in (
        ["algorithm", "runs (seeds × envs)", "mean [95% CI]", "median [95% CI]", "IQM [95% CI]"],
        ["comparison", "P(improvement) [95% CI]"],
        ["GAIfO > GAIL*", "1.00 [1.00, 1.00]"],
        ["GAIL* > Survival", "1.00 [1.00, 1.00]"],
        ["IQM [95% CI] (seeds)", "InvertedPendulum", "Hopper", "pooled"],
        ["envs pooled", "2", "2"],  # at a glance, each count over both envs
    ):
        assert row in rows, row
    assert any(r[0] == "seeds per cell" and r[1].startswith("4 ") for r in rows)
    software = next(r[1] for r in rows if r[0] == "software")  # what the records ran with
    assert software == "ifo-bench test"
    for needle in (
        "# ifo-bench report: synthetic",
        "## How to read this report",
        "## At a glance",
        "## Reference returns",
        "### Probability of improvement",
        "## Per env, 5 demonstrations",
        "## 1 demonstration",
        "## 5 demonstrations",
        "![Performance profile, 5 demonstrations](profile_5demos.png)",
        "![Learning curves, 1 demonstration](curves_1demos.png)",
        "Env steps to 0.8 normalized",
        "![Normalized return per env against number of demonstrations](figure2.png)",
        "\\* has access to expert actions",  # escaped: not a list item
    ):
        assert needle in text, needle
    for label in ("GAIfO", "GAIL*", "Survival", "Random", "Expert"):
        assert any(r[0] == label for r in rows), label
    for name in (
        "figure2",
        "profile_1demos",
        "profile_5demos",
        "curves_1demos",
        "curves_5demos",
        "seeds_1demos",
        "seeds_5demos",
    ):
        assert (written.parent / f"{name}.png").read_bytes()[:4] == b"\x89PNG", name
        assert f"({name}.png)" in text
    assert "nan" not in text.lower()


def test_failed_trials_are_named_and_left_out(written, table_rows):
    text = written.read_text()
    assert ["trials", "57 (1 failed)"] in table_rows(text)
    assert "- InvertedPendulum, GAIfO, 5 demonstrations, seed 4" in text
    assert "- gaifo: dropped seed(s) [4]" in text


def test_report_numbers(written, table_rows):
    aggregates = pd.read_csv(written.parent / "aggregates.csv")
    assert set(aggregates["algorithm"]) == {"gaifo", "gail", "survival"}  # references left out
    assert sorted(aggregates["n_demos"].unique()) == DEMOS
    # gaifo with 5 demos, seeds 0-3 on both envs: 0.7 + 0.05 * seed; the middle half is seeds 1, 2
    iqm = aggregates.set_index(["n_demos", "algorithm", "metric"]).loc[(5, "gaifo", "iqm")]
    assert iqm["estimate"] == pytest.approx(0.7 + 0.05 * 1.5)
    assert iqm["lo"] <= iqm["estimate"] <= iqm["hi"]
    improvement = pd.read_csv(written.parent / "improvement.csv")
    assert set(improvement["other"]) == {"gail", "survival"}
    assert (improvement["estimate"] > 0.5).all()
    # the raw references, mean ± std over the 4 seeds
    assert ["Hopper", "-5.0 ± 28.9 (4 seeds)", "2500.0 ± 28.9 (4 seeds)"] in table_rows(
        written.read_text()
    )


@pytest.mark.slow
def test_per_env_statistics_keep_every_seed_an_env_has(tmp_path):
    """Hopper has two more GAIfO seeds than the pendulum: pooling drops them, its own column not."""
    results = write_suite(tmp_path / "synthetic", demos=[5])
    hopper = list(ENVS)[1]
    for seed in (4, 5):
        store.write(results, trial(hopper, "gaifo", 5, seed))
    report.write_report(results, reps=REPS)
    rows = pd.read_csv(results / "report" / "per_env.csv")
    iqm = rows[rows["statistic"] == "iqm"].set_index(["env_id", "algorithm"])
    # gaifo on Hopper: 0.7 + 0.05 seed for seeds 0-5; the middle half is seeds 2, 3 (and halves of 1, 4)
    assert iqm.loc[(hopper, "gaifo"), "seeds"] == 6
    assert iqm.loc[(hopper, "gaifo"), "estimate"] == pytest.approx(0.7 + 0.05 * 2.5)
    assert iqm.loc[(comparisons.POOLED, "gaifo"), "estimate"] == pytest.approx(0.7 + 0.05 * 1.5)
    improved = rows[rows["statistic"] == "p_improvement"].set_index(
        ["env_id", "algorithm", "other"]
    )
    # every gail run beats every survival run, on each env
    for env_id in (*ENVS, comparisons.POOLED):
        assert improved.loc[(env_id, "gail", "survival"), "estimate"] == 1.0
        assert improved.loc[(env_id, "gaifo", "gail"), "estimate"] == 1.0


def test_improvement_pairs_set_gaifo_against_all_and_all_against_their_floor():
    def pairs(shown: list[str]) -> list[tuple[str, str]]:
        return comparisons.improvement_pairs(shown, names(shown))

    assert pairs(["survival", "bco", "gaifo", "gail"]) == [
        ("gaifo", "gail"),
        ("gaifo", "bco"),
        ("gaifo", "survival"),
        ("gail", "survival"),
        ("bco", "survival"),
    ]
    assert pairs(["gail", "survival"]) == [("gail", "survival")]
    assert pairs(["gail", "bco"]) == []
    # each learner against the floor of its own optimizer; the ceilings are no rivals
    assert pairs(["gail-sac", "survival", "survival-sac", "oracle-sac"]) == [
        ("gail-sac", "survival-sac")
    ]
    assert pairs(["opolo", "survival", "survival-sac"]) == []  # no TD3 floor ran
    assert pairs(["opolo", "survival", "survival-td3"]) == [("opolo", "survival-td3")]


def test_distance_to_the_expert_states(written, table_rows):
    text = written.read_text()
    assert "## Distance to the expert's states, 5 demonstrations" in text
    header = ["algorithm", "runs", "IQM distance [95% CI]", "P(GAIfO closer) [95% CI]"]
    assert header in table_rows(text)
    matched = pd.read_csv(written.parent / "state_match.csv").set_index(["n_demos", "algorithm"])
    # gaifo with 5 demos: distance 3 (1 - (0.7 + 0.05 seed)); the middle half is seeds 1, 2
    assert matched.loc[(5, "gaifo"), "iqm"] == pytest.approx(3.0 * (1 - 0.7 - 0.05 * 1.5))
    # every gaifo run is closer than every survival run, and every expert run than any gaifo run
    assert matched.loc[(5, "survival"), "p_closer"] == 1.0
    assert matched.loc[(5, "expert"), "p_closer"] == 0.0


def test_no_distance_section_without_distances(tmp_path):
    results = tmp_path / "old"
    for algorithm, n in (("random", 0), ("expert", 0), ("gaifo", 1), ("survival", 0)):
        for seed in range(3):
            store.write(results, trial(PENDULUM, algorithm, n, seed, state_distance=None))
    text = report.write_report(results, reps=REPS).path.read_text()
    assert "Distance to the expert" not in text and "nan" not in text.lower()


def test_cost_per_trial(written, table_rows, table_rule):
    text = written.read_text()
    assert "## Cost per trial" in text
    rows = table_rows(text)
    # 4 ok seeds x 2 demo counts of 12.5 s; the failed fifth seed is not counted
    assert ["InvertedPendulum", "GAIfO", "1,000", "8", "12 s", "0.03"] in rows
    assert ["Hopper", "Random", "1,000", "4", "12 s", "0.01"] in rows
    header = ["env", "algorithm", "budget (env steps)", "trials", "wall time per trial"]
    rule = table_rule(text, [*header, "core-hours"])
    assert [cell.endswith(":") for cell in rule] == [False, False, True, True, True, True]


def test_a_report_where_every_learner_failed_says_why_not_a_traceback(tmp_path):
    """A plugin that fails on every trial still gets its report: the failed trials named with
    what each raised, and no statistics, in words."""
    for seed in range(2):
        for algorithm in ("random", "expert"):
            store.write(tmp_path, trial(PENDULUM, algorithm, 0, seed))
        raised = "Traceback (most recent call last):\n  ...\nValueError: the policy returned NaN"
        store.write(
            tmp_path,
            trial(
                PENDULUM, "gaifo", 1, seed, status="failed", returns=[], curve=[], traceback=raised
            ),
        )
    text = report.write_report(tmp_path, reps=REPS).path.read_text()
    assert "GAIfO, 1 demonstration, seed 0: `ValueError: the policy returned NaN`" in text
    assert "No aggregate statistics: no learner has a finished trial on every env" in text


def test_cost_per_trial_adds_cpu_time_where_records_measured_it(tmp_path, table_rows):
    for seed, cpu in ((0, 6.0), (1, 8.0)):
        store.write(tmp_path, trial(PENDULUM, "gaifo", 5, seed, cpu_time=cpu))
        store.write(tmp_path, trial(PENDULUM, "random", 0, seed))  # older than the measure
    text = sections.costs(frames.load(tmp_path))
    assert "CPU time is what the trial's own process took" in text
    rows = table_rows(text)
    assert rows[0][-1] == "CPU time per trial"
    assert ["InvertedPendulum", "GAIfO", "1,000", "2", "12 s", "0.01", "7 s"] in rows
    assert ["InvertedPendulum", "Random", "1,000", "2", "12 s", "0.01", "-"] in rows


def test_fast_metrics_are_rliables_to_the_bit():
    """The bootstraps' IQM and probability of improvement, against rliable's own, on score
    tables of every shape a suite gives: ties (scores on a grid), equal columns, one run."""
    rng = np.random.default_rng(0)
    for case in range(600):
        runs_x, runs_y, tasks = rng.integers(1, 11, size=3)
        if case % 3 == 0:  # ties
            x, y = (rng.integers(0, 3, size=(n, tasks)) / 3 for n in (runs_x, runs_y))
        else:
            x, y = (rng.normal(size=(n, tasks)) for n in (runs_x, runs_y))
        if case % 3 == 2:  # columns that are equal
            y = x.copy()
        assert bootstrap.probability_of_improvement_over(x, y) == (
            metrics.probability_of_improvement(x, y)
        ), (x, y)
        assert bootstrap.aggregate_iqm(x) == metrics.aggregate_iqm(x), x


def test_iqm_curves_are_rliable_iqm_per_step():
    rows = [
        ("E", "gaifo", 1, seed, step, value)
        for seed, values in enumerate([[0, 1], [2, 3], [4, 5], [6, 7]])
        for step, value in zip((0, 100), values, strict=True)
    ]
    learning = pd.DataFrame(
        rows, columns=["env_id", "algorithm", "n_demos", "seed", "env_steps", "normalized"]
    )
    frame = curves.iqm_curves(learning, reps=REPS)
    assert frame["env_steps"].tolist() == [0, 100]
    assert frame["iqm"].tolist() == [
        metrics.aggregate_iqm(np.array([0.0, 2, 4, 6])),
        metrics.aggregate_iqm(np.array([1.0, 3, 5, 7])),
    ]
    assert frame["iqm"].tolist() == [3.0, 4.0]
    assert (frame["lo"] <= frame["iqm"]).all() and (frame["iqm"] <= frame["hi"]).all()
    assert (frame["seeds"] == 4).all()


def test_steps_to_a_level_are_the_first_evaluation_at_or_above_it_per_seed():
    values = {0: [0.1, 0.8, 0.5], 1: [0.85, 0.9, 1.0], 2: [0.2, 0.3, 0.79]}  # seed 2 never
    rows = [
        ("E", "a", 5, seed, step, value)
        for seed, curve in values.items()
        for step, value in zip((0, 100, 200), curve, strict=True)
    ]
    learning = pd.DataFrame(
        rows, columns=["env_id", "algorithm", "n_demos", "seed", "env_steps", "normalized"]
    )
    steps = curves.steps_to(learning, 0.8)
    assert steps["steps"].tolist() == [100, 0, np.inf]  # reached once counts, even if lost
    cell = curves.time_to(steps).iloc[0]
    assert (cell["seeds"], cell["median"], cell["worst"], cell["short"]) == (3, 100, np.inf, 1)
    assert curves.time_to(steps[steps["seed"] < 2]).iloc[0]["worst"] == 100


def test_iqm_curves_put_seeds_on_shared_steps():
    rows = [("E", "a", 1, 0, s, s / 100) for s in (0, 50, 100)]
    rows += [("E", "a", 1, 1, s, s / 100) for s in (10, 60, 90)]
    learning = pd.DataFrame(
        rows, columns=["env_id", "algorithm", "n_demos", "seed", "env_steps", "normalized"]
    )
    frame = curves.iqm_curves(learning, reps=20)
    assert frame["env_steps"].tolist() == [10, 50, 60, 90]  # inside both seeds' range
    np.testing.assert_allclose(frame["iqm"], [0.1, 0.5, 0.6, 0.9])


def test_one_env_one_seed_no_gaifo_no_curves(tmp_path, table_rows):
    results = tmp_path / "small"
    env_id = next(iter(ENVS))
    for algorithm in ("random", "expert", "survival"):
        store.write(results, trial(env_id, algorithm, 0, 0))
    store.write(results, trial(env_id, "gail", 5, 0, curve=[]))
    text = report.write_report(results, tmp_path / "out", reps=20).path.read_text()
    assert "gaifo has no scores with 5 demonstrations" in text  # no record says its label
    assert "| 0.49 " in text and "[0.49, 0.49]" not in text  # gail: one seed, no interval
    assert any(r[:2] == ["GAIL*", "1 × 1"] for r in table_rows(text))
    assert "No learning curve recorded for GAIL*" in text
    assert (tmp_path / "out" / "curves_5demos.png").is_file()  # survival's
    assert not (tmp_path / "out" / "profile_1demos.png").exists()


@pytest.fixture()
def two_suites(tmp_path) -> Path:
    """Suite a has a learner; suite b only the references, which still makes a report."""
    write_suite(tmp_path / "results" / "a", range(2), ("gaifo",), [PENDULUM], demos=[5])
    for seed in range(2):
        for algorithm in ("random", "expert"):
            store.write(tmp_path / "results" / "b", trial(PENDULUM, algorithm, 0, seed))
    return tmp_path / "results"


def test_cli_writes_a_report_per_suite(two_suites, tmp_path, capsys, table_rows):
    out = tmp_path / "out"
    assert cli.main(["report", str(two_suites), "--out", str(out), "--reps", "50"]) == 0
    stdout = capsys.readouterr().out
    for suite in ("a", "b"):
        assert f"wrote {out / suite / 'report.md'}" in stdout
        assert not (two_suites / suite / "report").exists()
    rows = table_rows(stdout)
    assert stdout.count("IQM [95% CI]") == 1 and any(r[:2] == ["GAIfO", "2 × 1"] for r in rows)
    assert any(r[:2] == ["Survival", "2 × 1"] and r[2].startswith("0.23 [") for r in rows)
    assert ["GAIfO > Survival", "1.00 [1.00, 1.00]"] in rows
    assert "no learning algorithm" in stdout  # suite b
    only_references = (out / "b" / "report.md").read_text()
    assert "No learning algorithm was run" in only_references
    assert ["InvertedPendulum", "20.0 ± 13.9 (2 seeds)", "1000.0 ± 13.9 (2 seeds)"] in table_rows(
        only_references
    )


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_report_says_what_it_is_at_on_a_terminal_and_nothing_elsewhere(
    two_suites, tmp_path, monkeypatch, capsys
):
    """A large folder's report takes a minute: on a terminal one line says which step it is at
    (and is cleared when it is done); piped, stderr stays empty."""
    args = ["report", str(two_suites / "a"), "--out", str(tmp_path / "out"), "--reps", "50"]
    assert cli.main(args) == 0
    assert capsys.readouterr().err == ""
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert cli.main(args) == 0
    shown = terminal.getvalue()
    for stage in ("reading the records", "statistics", "figure figure2", "tables"):
        assert f"report {two_suites / 'a'}: {stage}" in shown, shown
    assert "wrote" not in shown and "wrote" in capsys.readouterr().out


@pytest.mark.slow
def test_python_m_bench_cli_report(two_suites):
    out = subprocess.run(
        [sys.executable, "-m", "bench.cli", "report", str(two_suites / "b")],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    assert (two_suites / "b" / "report" / "report.md").is_file()


@pytest.mark.parametrize("folder", ["empty", "empty/trials", "nothing"])
def test_cli_without_trials_is_one_line_exit_2(folder, tmp_path, capsys):
    (tmp_path / "empty" / "trials").mkdir(parents=True)
    assert cli.main(["report", str(tmp_path / folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("bench: error: ") and str(tmp_path) in err


@pytest.mark.slow
def test_learners_are_read_as_fractions_of_their_matched_oracle(tmp_path):
    """An oracle at 0.8 and a variant at 0.5: GAIfO (0.7-0.85) reads against the plain one,
    gaifo-fast against oracle-fast; the oracles are not rivals in P(improvement)."""
    results = write_suite(tmp_path / "synthetic", demos=[5])
    for env_id in ENVS:
        random, expert = ENVS[env_id]
        for seed in range(4):
            for label, level in (("oracle", 0.8), ("oracle-fast", 0.5), ("gaifo-fast", 0.45)):
                algorithm = label.split("-")[0]
                n = 0 if algorithm == "oracle" else 5
                # a variant is other settings (its label alone would make it the same trial)
                settings = {"max_kl": 0.02} if label.endswith("fast") else {}
                spec = TrialSpec(
                    "synthetic", env_id, algorithm, n, seed, BUDGET, 3, settings, label=label
                )
                ret = random + (expert - random) * (level + 0.01 * seed)
                store.write(results, trial(env_id, "gaifo", 5, seed, spec=spec, returns=[ret]))
    report.write_report(results, reps=REPS)
    rows = pd.read_csv(results / "report" / "per_env.csv")
    fractions = rows[rows["statistic"] == "of_oracle"].set_index(["env_id", "algorithm"])
    hopper = list(ENVS)[1]
    assert fractions.loc[(hopper, "gaifo"), "other"] == "oracle"
    assert fractions.loc[(hopper, "gaifo"), "estimate"] == pytest.approx(0.775 / 0.815)
    assert fractions.loc[(hopper, "gaifo-fast"), "other"] == "oracle-fast"
    assert fractions.loc[(hopper, "gaifo-fast"), "estimate"] == pytest.approx(0.465 / 0.515)
    lo, hi = fractions.loc[(hopper, "gaifo"), ["lo", "hi"]]
    assert lo <= 0.775 / 0.815 <= hi
    worst = rows[rows["statistic"] == "worst_of_oracle"].set_index(["env_id", "algorithm"])
    assert worst.loc[(hopper, "gaifo"), "estimate"] == pytest.approx(0.7 / 0.815)  # seed 0
    assert worst.loc[(hopper, "gaifo-fast"), "estimate"] == pytest.approx(0.45 / 0.515)
    assert worst.loc[(hopper, "gaifo"), ["lo", "hi"]].isna().all()
    improved = rows[rows["statistic"] == "p_improvement"]
    assert not {"oracle", "oracle-fast"} & (set(improved["algorithm"]) | set(improved["other"]))
    text = (results / "report" / "report.md").read_text()
    assert "IQM / oracle's IQM" in text and "Worst seed / oracle's IQM" in text


def test_the_ceiling_is_of_the_learners_family_and_its_variant_suffix_else_the_plain_one():
    def ceiling_of(learner: str, methods: dict[str, str]) -> str | None:
        return comparisons.control_of(learner, "ceiling", methods, names(methods))

    methods = {
        "gaifo": "gaifo",
        "gaifo-b1024": "gaifo",
        "oracle": "oracle",
        "oracle-b1024": "oracle",
    }
    assert ceiling_of("gaifo-b1024", methods) == "oracle-b1024"
    assert ceiling_of("gaifo", methods) == "oracle"
    assert ceiling_of("gail-x", methods | {"gail-x": "gail"}) == "oracle"
    assert ceiling_of("gaifo", {"gaifo": "gaifo"}) is None
    sac = {
        "gaifo": "gaifo",
        "gaifo-sac": "gaifo-sac",
        "oracle": "oracle",
        "oracle-sac": "oracle-sac",
        "opolo": "opolo",
    }
    assert ceiling_of("gaifo-sac", sac) == "oracle-sac"  # each optimizer's own ceiling
    assert ceiling_of("gaifo", sac) == "oracle"
    assert ceiling_of("opolo", sac) is None  # TD3's: neither TRPO's nor SAC's oracle
    assert ceiling_of("opolo", sac | {"oracle-td3": "oracle-td3"}) == "oracle-td3"


def test_screen_variants_on_one_env_each_leave_the_pooled_statistics_not_the_others():
    """A screen often runs a variant on one env only. Pooling over envs then keeps the learners
    run on every env the widest share, and says which it left out, instead of no statistics."""
    import pandas as pd

    from bench.analysis.comparisons import pooled

    rows = [("A", "gaifo"), ("B", "gaifo"), ("A", "gail"), ("B", "gail"), ("A", "gaifo-x")]
    rows += [("B", "gaifo-y")]
    df = pd.DataFrame([{"env_id": e, "algorithm": a, "n_demos": 5} for e, a in rows])
    left_out: list[str] = []
    assert pooled(df, 5, ["gaifo", "gaifo-x", "gaifo-y", "gail"], left_out) == ["gaifo", "gail"]
    assert len(left_out) == 2 and "gaifo-x: left out" in left_out[0]
    assert left_out[0].endswith("run on A only, not on all of A, B")
    assert pooled(df, 5, ["gaifo", "gaifo-x"], []) == ["gaifo", "gaifo-x"]  # they share env A


def test_at_a_glance_says_when_its_counts_pool_different_envs(table_rows):
    def aggregates(envs_per_count: dict[int, int]) -> pd.DataFrame:
        return pd.DataFrame(
            [[n, "gaifo", 5, envs, "iqm", 0.5, 0.4, 0.6] for n, envs in envs_per_count.items()],
            columns=findings.AGGREGATE_COLUMNS,
        )

    empty = pd.DataFrame(columns=findings.IMPROVEMENT_COLUMNS)
    partial = sections.at_a_glance(aggregates({1: 2, 5: 6}), empty, names(["gaifo"]))
    assert ["envs pooled", "2", "6"] in table_rows(partial)
    assert "read down a column, not across a row" in partial
    whole = sections.at_a_glance(aggregates({1: 6, 5: 6}), empty, names(["gaifo"]))
    assert ["envs pooled", "6", "6"] in table_rows(whole) and "across a row" not in whole


def test_per_env_across_counts_gives_each_env_iqm_at_every_count(written, table_rows):
    text = written.read_text()
    assert "## Per env, across demonstration counts" in text
    per_env = pd.read_csv(written.parent / "per_env.csv")
    iqm = per_env[per_env["statistic"] == "iqm"].set_index(["algorithm", "env_id", "n_demos"])
    pi = per_env[per_env["statistic"] == "p_improvement"]
    pi = pi.set_index(["algorithm", "other", "env_id", "n_demos"])
    section = text.split("## Per env, across demonstration counts")[1].split("\n## ")[0]
    header, *rows = table_rows(section)
    assert header[0] == "at 1 / 5 demos"
    pairs = ["GAIfO > GAIL*", "GAIfO > Survival"]
    assert [r[0] for r in rows] == ["GAIfO", "GAIL*", "Survival", *pairs]
    for column, env_id in ((1, PENDULUM), (2, "HopperBulletEnv-v0")):
        assert header[column] == labels.env_label(env_id)
        for row, algorithm in zip(rows, ("gaifo", "gail", "survival"), strict=False):
            at = [iqm.loc[(algorithm, env_id, n), "estimate"] for n in DEMOS]
            assert row[column] == " / ".join(f"{v:.2f}" for v in at)
        for row, other in zip(rows[3:], ("gail", "survival"), strict=True):
            at = [pi.loc[("gaifo", other, env_id, n), "estimate"] for n in DEMOS]
            assert row[column] == " / ".join(f"{v:.2f}" for v in at)


def test_per_env_across_counts_marks_a_count_without_runs(table_rows):
    rows = [
        [1, PENDULUM, "iqm", "gaifo", None, 5, 0.5, 0.4, 0.6],
        [25, PENDULUM, "iqm", "gaifo", None, 5, 0.9, 0.8, 1.0],
        [25, PENDULUM, "iqm", "bco", None, 3, 0.25, 0.2, 0.3],
        [25, "pooled", "iqm", "bco", None, 3, 0.25, 0.2, 0.3],
    ]
    per_env = pd.DataFrame(rows, columns=comparisons.PER_ENV_COLUMNS)
    header, *body = table_rows(sections.env_by_count(per_env, names(["gaifo", "gail", "bco"])))
    assert header == ["at 1 / 25 demos", labels.env_label(PENDULUM)]
    assert body == [["GAIfO", "0.50 / 0.90"], ["BCO", "- / 0.25"]]
