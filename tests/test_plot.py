"""Figures and tables from a small synthetic normalized frame."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.container import BarContainer
from matplotlib.patches import Rectangle

from bench.analysis import curves, labels, plot, stats, tables

from frames import described

ENVS = ["HopperBulletEnv-v0", "InvertedPendulumBulletEnv-v0"]  # Pendulum comes first in the paper
DEMOS = [1, 10]
SEEDS = [0, 1, 2]


def frame() -> pd.DataFrame:
    """2 envs x (random, expert at 0 demos; gaifo, gail at 1 and 10 demos) x 3 seeds."""
    rows = []
    for env_id in ENVS:
        for seed in SEEDS:
            rows.append((env_id, "random", 0, seed, 0.0 + 0.01 * seed))
            rows.append((env_id, "expert", 0, seed, 1.0 - 0.01 * seed))
            for n in DEMOS:
                rows.append((env_id, "gaifo", n, seed, 0.05 * n + 0.1 * seed))
                rows.append((env_id, "gail", n, seed, 0.06 * n + 0.1 * seed))
    df = pd.DataFrame(rows, columns=["env_id", "algorithm", "n_demos", "seed", "normalized"])
    inputs = df["algorithm"].map({"random": "none", "expert": "expert", "gail": "actions"})
    return df.assign(**{"return": 100 * df["normalized"], "inputs": inputs.fillna("states")})


def test_figure2_panels_bars_and_labels():
    fig = plot.draw_figure2(described(frame()))
    assert len(fig.axes) == len(ENVS)
    assert [ax.get_title() for ax in fig.axes] == ["InvertedPendulum", "Hopper"]
    for ax in fig.axes:
        bars = [p for p in ax.patches if isinstance(p, Rectangle)]
        assert len(bars) == 2 * len(DEMOS)  # gaifo and gail; random/expert are lines
        assert [t.get_text() for t in ax.get_xticklabels()] == ["1", "10"]
        assert {
            round(line.get_ydata()[0], 6) for line in ax.lines if line.get_linestyle() == "--"
        } == {
            0.0,
            1.0,
        }
    # bar height = mean over seeds: gaifo on Pendulum with 10 demos = 0.5 + mean(0, .1, .2)
    heights = sorted(round(p.get_height(), 6) for p in fig.axes[0].patches)
    assert 0.6 in heights
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == [
        "GAIfO",
        "GAIL*",
        "Random (0)",
        "Expert (1)",
    ]
    assert labels.ACTIONS_FOOTNOTE in [t.get_text() for t in fig.texts]
    assert fig.get_suptitle()


def test_figure2_legend_is_no_wider_than_the_figure():
    """Long control labels wrap the legend into more rows instead of widening the figure (which
    would shrink the panels wherever the figure is shown at a fixed width)."""
    one_env = frame().query("env_id == @ENVS[0]")
    df = pd.concat([one_env.assign(env_id=f"Env{i}BulletEnv-v0") for i in range(6)])
    controls = df[df["algorithm"] == "random"].assign(inputs="none")
    df = pd.concat(
        [
            df,
            controls.assign(algorithm="survival", normalized=0.3),
            controls.assign(algorithm="oracle", normalized=0.9),
        ],
        ignore_index=True,
    )
    fig = plot.draw_figure2(described(df))
    fig.draw_without_rendering()
    (legend,) = fig.legends
    assert len(legend.get_texts()) == 6
    assert legend.get_window_extent().width <= fig.bbox.width
    rows = {round(t.get_window_extent().y0) for t in legend.get_texts()}
    assert len(rows) > 1  # it did wrap: one row of these labels is wider than 3 panels


def test_figure2_repeats_demo_free_learners_at_every_count():
    df = frame()
    free = df[df["algorithm"] == "random"].assign(algorithm="no-demos-ifo", normalized=0.2)
    fig = plot.draw_figure2(described(pd.concat([df, free])))
    for ax in fig.axes:
        assert len(ax.patches) == 3 * len(DEMOS)
        assert [t.get_text() for t in ax.get_xticklabels()] == ["1", "10"]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[:3] == ["GAIfO", "GAIL*", "no-demos-ifo"]


def test_figure2_writes_png_and_pdf(tmp_path):
    paths = plot.figure2(described(frame()), tmp_path / "figs" / "figure2")
    assert paths == [tmp_path / "figs" / "figure2.png", tmp_path / "figs" / "figure2.pdf"]
    assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert paths[1].read_bytes()[:5] == b"%PDF-"


def test_figure2_without_action_users_has_no_footnote():
    df = frame()
    fig = plot.draw_figure2(described(df[df["algorithm"] != "gail"]))
    assert labels.ACTIONS_FOOTNOTE not in [t.get_text() for t in fig.texts]


def test_figure2_needs_a_learner():
    df = frame()
    with pytest.raises(ValueError, match="no trials of a learning algorithm"):
        plot.draw_figure2(described(df[df["algorithm"].isin(["random", "expert"])]))


def test_order_and_colors_are_fixed():
    assert labels.algorithm_order(["zeta", "tcn", "gaifo", "alpha"]) == [
        "gaifo",
        "tcn",
        "alpha",
        "zeta",
    ]
    names = labels.Names.of(described(frame()))
    assert names.order(["gail", "random", "gaifo", "expert"]) == ["gaifo", "gail"]  # by role
    assert names.in_order(["expert", "gail", "random"]) == ["gail", "expert", "random"]
    roles = {"survival": "floor", "oracle": "ceiling", "gaifo": "learner", "pwil": "learner"}
    by_role = labels.Names({a: labels.Shown(a, role, "trpo", a) for a, role in roles.items()})
    assert by_role.order(["oracle", "pwil", "survival", "gaifo"]) == [  # methods, then controls
        "gaifo",
        "pwil",
        "survival",
        "oracle",
    ]
    assert (
        plot.algorithm_colors(["gail"])["gail"]
        == plot.algorithm_colors(["gaifo", "gail", "x"])["gail"]
    )
    assert labels.env_order(["Pendulum-v1", *ENVS]) == [ENVS[1], ENVS[0], "Pendulum-v1"]
    assert labels.env_label("Walker2DBulletEnv-v0") == "Walker2D"
    assert labels.env_label("Pendulum-v1") == "Pendulum"


def test_summary_table(table_rows):
    table = tables.summary_table(described(frame()))
    rows = table_rows(table)
    assert rows[0] == ["env", "algorithm", "no demos", "1 demo", "10 demos"]
    assert ["InvertedPendulum", "GAIfO", "", "0.15 ± 0.10", "0.60 ± 0.10"] in rows
    assert ["InvertedPendulum", "Random", "0.01 ± 0.01", "", ""] in rows
    assert table.splitlines()[-1] == labels.ACTIONS_FOOTNOTE


def test_summary_csv(tmp_path):
    path = plot.write_summary_csv(frame(), tmp_path / "summary.csv")
    back = pd.read_csv(path)
    assert list(back.columns) == ["env", "algorithm", "demos", "seed", "return", "normalized"]
    assert len(back) == len(frame())


def test_iqm_learning_curves(tmp_path):
    rows = [
        (env_id, algo, 10, seed, step, step / 1000 * (0.9 if algo == "gaifo" else 0.8))
        for env_id in ENVS
        for algo in ("gaifo", "gail")
        for seed in SEEDS
        for step in (0, 500, 1000)
    ]
    learning = pd.DataFrame(
        rows, columns=["env_id", "algorithm", "n_demos", "seed", "env_steps", "normalized"]
    )
    names = labels.Names.of(described(learning))
    fig = plot.draw_iqm_curves(curves.iqm_curves(learning, reps=20), "Learning curves", names)
    assert len(fig.axes) == len(ENVS)
    assert [len(ax.lines) for ax in fig.axes] == [2 + 2] * len(ENVS)  # two algorithms, 0 and 1
    assert plot.save(fig, tmp_path / "curves")[0].is_file()


def test_performance_profile_plot(tmp_path):
    scores = {"gaifo": np.arange(1, 9).reshape(4, 2) / 8, "gail": np.full((4, 2), 0.5)}
    profile = stats.performance_profile(scores, np.linspace(0, 1, 5), reps=20)
    names = labels.Names(
        {
            "gaifo": labels.Shown("GAIfO", "learner", "trpo", "gaifo"),
            "gail": labels.Shown("GAIL", "learner", "trpo", "gail", uses_actions=True),
        }
    )
    fig = plot.draw_performance_profile(profile, names)
    assert [line.get_label() for line in fig.axes[0].lines] == ["GAIfO", "GAIL*"]
    assert plot.save(fig, tmp_path / "profile")[1].is_file()


def test_figure2_draws_the_controls_as_lines_not_bars():
    df = frame()
    experts = df[df["algorithm"] == "expert"]
    oracle = experts.assign(algorithm="oracle", normalized=[0.8, 0.9, 0.7] * len(ENVS))
    survival = experts.assign(algorithm="survival-b", method="survival", normalized=0.3)
    fig = plot.draw_figure2(described(pd.concat([df, oracle.assign(method="oracle"), survival])))
    for ax in fig.axes:
        bars = [bar for c in ax.containers if isinstance(c, BarContainer) for bar in c]
        assert len(bars) == 2 * len(DEMOS)  # gaifo and gail; the controls' bands are no bars
        levels = {line.get_linestyle(): round(line.get_ydata()[0], 6) for line in ax.lines}
        assert levels["-."] == 0.8 and levels[":"] == 0.3  # oracle and survival: seed means
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "Oracle (ceiling: the true reward)" in legend
    assert "survival-b (floor: paid to stay alive)" in legend


def test_figure2_of_controls_alone_draws_them_as_bars():
    df = frame()
    survival = df[df["algorithm"] == "expert"].assign(algorithm="survival", normalized=0.3)
    fig = plot.draw_figure2(
        described(pd.concat([df[df["algorithm"].isin(["random", "expert"])], survival]))
    )
    assert [len(ax.patches) for ax in fig.axes] == [1] * len(ENVS)  # one bar: no demo counts
