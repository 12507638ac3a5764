"""Figures, and the per-trial CSV beside them, from the tidy normalized frame (frames.load ->
normalize); the markdown table of the same means is `bench.analysis.tables.summary_table`.

Nothing here computes a statistic beyond grouping: means and standard
deviations over seeds are seaborn's or pandas'. Figures are built on
`matplotlib.figure.Figure` directly (rendered by Agg), not pyplot, so drawing
needs no display and leaves no global state behind.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable
from itertools import product
from pathlib import Path

import pandas as pd
import seaborn as sns
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import EngFormatter

from bench.analysis.labels import (
    ACTIONS_FOOTNOTE,
    PAPER_ALGORITHMS,
    Names,
    algorithm_order,
    env_label,
    env_order,
    is_reference,
)
from bench.analysis.normalize import demo_free
from bench.harness.registry import CONTROL_ROLES

"""Normalized to 0 and 1 by construction: drawn as lines, not bars."""
PALETTE = "colorblind"
DPI = 200
REFERENCE_LINES = {"random": ("0.45", "Random (0)"), "expert": ("0.1", "Expert (1)")}
CONTROL_LINES = {
    "floor": ({"linestyle": ":", "linewidth": 1.5}, "floor: paid to stay alive"),
    "ceiling": ({"linestyle": "-.", "linewidth": 1.3}, "ceiling: the true reward"),
}
"""The controls are references, not competitors: in Figure 2 each is a line across its panel
at its mean over seeds with a band of one standard deviation, not a bar (by role, so a
labelled variant of one, or a plugin's control, is drawn alike)."""


# ---------------------------------------------------------------- order, names, colors


def algorithm_colors(names: Iterable[str]) -> dict[str, tuple[float, float, float]]:
    """A color per learner; the paper's algorithms keep theirs whatever else is plotted."""
    order = algorithm_order(names)
    others = [a for a in order if a not in PAPER_ALGORITHMS]
    slots = {a: i for i, a in enumerate(PAPER_ALGORITHMS)}
    slots |= {a: len(PAPER_ALGORITHMS) + i for i, a in enumerate(others)}
    palette = sns.color_palette(PALETTE, max(slots.values(), default=0) + 1)
    return {a: palette[slots[a]] for a in order}


def repeat_demo_free(df: pd.DataFrame) -> pd.DataFrame:
    """Rows of algorithms seen only with n_demos=0, copied to every positive demo count in `df`."""
    demos = sorted(n for n in df["n_demos"].unique() if n > 0)
    free = demo_free(df)
    if not demos or not free.any():
        return df
    copies = [df[free].assign(n_demos=n) for n in demos]
    return pd.concat([df[~free], *copies], ignore_index=True)


# ---------------------------------------------------------------- Figure 2


def draw_figure2(df: pd.DataFrame) -> Figure:
    """The paper's Figure 2: per env, normalized return against number of demonstrations.

    One bar per learner and demo count: mean over seeds, error bar one
    standard deviation. Learners that take no demonstrations (n_demos=0) score
    the same at every count, so their bar repeats; the controls (survival,
    oracle) are drawn as lines across the panel instead (CONTROL_LINES).
    Needs columns env_id, algorithm, n_demos, normalized.
    """
    learners = df[~is_reference(df)]
    if learners.empty:
        raise ValueError("no trials of a learning algorithm to plot (only random/expert)")
    names = Names.of(learners)
    is_control = learners["role"].isin(CONTROL_ROLES)
    if is_control.all():  # nothing to set against them: the controls are the bars
        is_control = is_control & False
    controls, learners = learners[is_control], repeat_demo_free(learners[~is_control])
    envs = env_order(learners["env_id"].unique())
    algos = algorithm_order(learners["algorithm"].unique())
    demos = sorted(learners["n_demos"].unique())
    colors = algorithm_colors([*algos, *controls["algorithm"].unique()])

    with sns.axes_style("whitegrid"), sns.plotting_context("paper"):
        fig, axes = _panels(len(envs), width=2.35, height=1.9)  # 3 across = 7 in, a page
        for ax, env_id in zip(axes, envs, strict=False):
            sns.barplot(
                data=learners[learners["env_id"] == env_id],
                x="n_demos",
                y="normalized",
                hue="algorithm",
                order=demos,
                hue_order=algos,
                palette=colors,
                errorbar="sd",
                capsize=0.2,
                err_kws={"linewidth": 0.8, "color": "0.15"},
                saturation=1.0,
                legend=False,
                ax=ax,
            )
            _control_lines(ax, controls[controls["env_id"] == env_id], colors, names)
            _reference_lines(ax)
            ax.set_title(env_label(env_id))
            ax.set_xlabel("")
            ax.set_ylabel("")
            ax.grid(axis="x", visible=False)
        fig.supxlabel("Number of demonstration trajectories", fontsize="medium")
        fig.supylabel("Normalized return", fontsize="medium")
        handles = [Patch(facecolor=colors[a], label=names.label(a)) for a in algos]
        handles += [
            Line2D(
                [],
                [],
                color=colors[a],
                **CONTROL_LINES[names[a].role][0],
                label=f"{names.label(a)} ({CONTROL_LINES[names[a].role][1]})",
            )
            for a in algorithm_order(controls["algorithm"].unique())
        ]
        _legend_and_titles(
            fig,
            handles,
            "Imitation performance vs. number of demonstrations",
            names.starred(algos),
        )
    return fig


def figure2(df: pd.DataFrame, out: str | Path) -> list[Path]:
    """Draw Figure 2 and write it as `out`.png (dpi 200) and `out`.pdf; return both paths."""
    return save(draw_figure2(df), out)


# ---------------------------------------------------------------- later-report figures


def draw_iqm_curves(frame: pd.DataFrame, title: str, names: Names) -> Figure:
    """Per env, IQM normalized return against env steps, band the 95% CI (from `curves.iqm_curves`).
    Legend labels from `names` (a * for those given expert actions).

    With a `budget` column (`bench budgets`: the same cells at several budgets), every budget's
    curves are drawn, the shorter ones dashed and ended by a dotted line, so a short run's end
    is seen on the way of the longest."""
    budgets = frame["budget"] if "budget" in frame else pd.Series(0, index=frame.index)
    envs = env_order(frame["env_id"].unique())
    algos = algorithm_order(frame["algorithm"].unique())
    colors = algorithm_colors(algos)
    with sns.axes_style("whitegrid"), sns.plotting_context("paper"):
        fig, axes = _panels(len(envs), width=2.35, height=1.9)
        for ax, env_id in zip(axes, envs, strict=False):
            here = frame["env_id"] == env_id
            longest = budgets[here].max()
            for budget in sorted(budgets[here].unique()):
                style = {"ls": "--", "lw": 1.0} if budget < longest else {"lw": 1.3}
                for a in algos:
                    rows = frame[here & (budgets == budget) & (frame["algorithm"] == a)]
                    rows = rows.sort_values("env_steps")
                    ax.plot(rows["env_steps"], rows["iqm"], color=colors[a], **style)
                    ax.fill_between(
                        rows["env_steps"], rows["lo"], rows["hi"], color=colors[a], alpha=0.2, lw=0
                    )
                if budget < longest:
                    ax.axvline(budget, color="0.5", lw=0.8, ls=":")
            _reference_lines(ax)
            ax.set_title(env_label(env_id))
            ax.set_xlim(left=0)
            ax.xaxis.set_major_formatter(EngFormatter(sep=""))  # 200k, 1M: no offset text
        # The panels share one y scale, fixed by the first panel's reference lines: widen it
        # where a later panel's curves leave it (a long run's oracle may end well above 1).
        lo, hi = axes[0].get_ylim()
        bottom, top = frame["lo"].min(), frame["hi"].max()
        if bottom < lo or top > hi:
            axes[0].set_ylim(min(lo, bottom - 0.05), max(hi, top + 0.05))
        fig.supxlabel("Environment steps", fontsize="medium")
        fig.supylabel("Normalized return (IQM)", fontsize="medium")
        handles = [Line2D([], [], color=colors[a], label=names.label(a)) for a in algos]
        if budgets.nunique() > 1:
            handles += [
                Line2D([], [], color="0.3", lw=1.3, label="longest budget"),
                Line2D(
                    [], [], color="0.3", ls="--", lw=1.0, label="a shorter one, to the dotted line"
                ),
            ]
        _legend_and_titles(fig, handles, title, names.starred(algos))
    return fig


def draw_seed_curves(curves: pd.DataFrame, title: str, names: Names) -> Figure:
    """Every seed's own learning curve (normalized `curves` of one demo count): a row of
    panels per env, one panel per learner, one line per seed. Where the IQM shows a slow
    average, this shows whether all seeds are slow or one stands still."""
    envs = env_order(curves["env_id"].unique())
    algos = algorithm_order(curves["algorithm"].unique())
    colors = algorithm_colors(algos)
    with sns.axes_style("whitegrid"), sns.plotting_context("paper"):
        fig = Figure(figsize=(1.7 * len(algos) + 0.6, 1.45 * len(envs) + 0.9), layout="constrained")
        grid = fig.subplots(len(envs), len(algos), squeeze=False, sharex="row", sharey=True)
        for (i, env_id), (j, a) in product(enumerate(envs), enumerate(algos)):
            ax = grid[i, j]
            rows = curves[(curves["env_id"] == env_id) & (curves["algorithm"] == a)]
            for _, seed in rows.sort_values("env_steps").groupby("seed"):
                ax.plot(seed["env_steps"], seed["normalized"], color=colors[a], lw=0.8, alpha=0.8)
            _reference_lines(ax)
            ax.set_xlim(left=0)
            ax.xaxis.set_major_formatter(EngFormatter(sep=""))
            ax.tick_params(labelsize="x-small")
            if i == 0:
                ax.set_title(names.label(a), fontsize="small")
            if j == 0:
                ax.set_ylabel(env_label(env_id), fontsize="small")
        fig.supxlabel("Environment steps (each line one seed)", fontsize="medium")
        fig.suptitle(title, fontweight="bold")
    return fig


def draw_performance_profile(
    profile: pd.DataFrame, names: Names, title: str | None = None
) -> Figure:
    """Score distributions from stats.performance_profile: fraction of runs above tau, with CI band.
    With a `title`, the legend goes under the axes, off the curves (as in the report).
    Legend labels from `names` (a * for those given expert actions)."""
    algos = algorithm_order(profile["algorithm"].unique())
    colors = algorithm_colors(algos)
    with sns.axes_style("whitegrid"), sns.plotting_context("paper"):
        fig = Figure(figsize=(3.6, 2.8), layout="constrained")
        ax = fig.subplots()
        for a in algos:
            rows = profile[profile["algorithm"] == a].sort_values("tau")
            label = names.label(a)
            ax.plot(rows["tau"], rows["fraction"], color=colors[a], label=label)
            ax.fill_between(rows["tau"], rows["lo"], rows["hi"], color=colors[a], alpha=0.2, lw=0)
        ax.set_xlabel(r"Normalized score $\tau$")
        ax.set_ylabel(r"Fraction of runs with score $> \tau$")
        ax.set_ylim(-0.02, 1.02)  # lines at exactly 0 or 1 stay visible
        ax.legend(frameon=False)
        if names.starred(algos):
            ax.set_title(ACTIONS_FOOTNOTE, loc="right", fontsize="small", color="0.3")
        if title is not None:
            handles, labels = ax.get_legend_handles_labels()
            ax.get_legend().remove()
            fig.suptitle(title, fontweight="bold", fontsize="medium")
            fig.legend(
                handles,
                labels,
                loc="outside lower center",
                ncol=min(4, len(labels)),
                frameon=False,
                handlelength=1.6,
                columnspacing=1.2,
            )
    return fig


# ---------------------------------------------------------------- csv


def write_summary_csv(df: pd.DataFrame, path: str | Path) -> Path:
    """One row per trial: env, algorithm, demos, seed, return, normalized."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    table = df.rename(columns={"env_id": "env", "n_demos": "demos"})
    columns = ["env", "algorithm", "demos", "seed", "return", "normalized"]
    table[columns].sort_values(columns[:4]).to_csv(path, index=False)
    return path


# ---------------------------------------------------------------- helpers


def save(fig: Figure, out: str | Path) -> list[Path]:
    """Write `fig` as out.png (dpi 200) and out.pdf, whatever suffix `out` has. The PDF carries
    no creation date, so redrawing unchanged records leaves committed figures unchanged."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    paths = [out.with_suffix(".png"), out.with_suffix(".pdf")]
    for path in paths:
        metadata = {"CreationDate": None} if path.suffix == ".pdf" else None
        fig.savefig(path, dpi=DPI, bbox_inches="tight", metadata=metadata)
    return paths


def _panels(n: int, width: float, height: float) -> tuple[Figure, list[Axes]]:
    """A grid of n panels, at most 3 per row (4 as 2 x 2); unused cells removed."""
    ncols = 2 if n == 4 else min(3, n)
    nrows = math.ceil(n / ncols)
    width *= {1: 1.4, 2: 1.2, 3: 1.0}[ncols]  # room for the title and legend when few panels
    fig = Figure(figsize=(width * ncols, height * nrows + 0.9), layout="constrained")
    # One y scale for all: normalized returns are comparable across envs by design.
    axes = list(fig.subplots(nrows, ncols, squeeze=False, sharey=True).flat)
    for ax in axes[n:]:
        fig.delaxes(ax)
    return fig, axes[:n]


def _control_lines(ax: Axes, controls: pd.DataFrame, colors: dict, names: Names) -> None:
    """Each control (or labelled variant of one) of one env as a line at its mean normalized
    return over seeds, and a band of one standard deviation around it."""
    for name, rows in controls.groupby("algorithm"):
        mean, sd = rows["normalized"].mean(), rows["normalized"].std()
        style = CONTROL_LINES[names[name].role][0]
        ax.axhline(mean, color=colors[name], zorder=2.5, **style)
        if pd.notna(sd):
            ax.axhspan(mean - sd, mean + sd, color=colors[name], alpha=0.12, lw=0, zorder=0.4)


def _reference_lines(ax: Axes) -> None:
    """Dashed lines at 0 (random) and 1 (expert), both kept in view."""
    for level, name in enumerate(REFERENCE_LINES):
        color, _ = REFERENCE_LINES[name]
        ax.axhline(level, color=color, linestyle="--", linewidth=1.0, zorder=0.5)
    lo, hi = ax.get_ylim()
    ax.set_ylim(min(lo, -0.1), max(hi, 1.1))


def _legend_and_titles(fig: Figure, handles: list, title: str, starred: Collection[str]) -> None:
    """Suptitle on top; legend, then the footnote on expert actions if any label is `starred`,
    under the figure.

    The legend hangs below the canvas (save uses bbox_inches="tight") because
    constrained layout stacks an "outside" legend on top of supxlabel/suptitle.
    """
    handles = handles + [
        Line2D([], [], color=color, linestyle="--", linewidth=1.0, label=label)
        for color, label in REFERENCE_LINES.values()
    ]
    fig.suptitle(title, fontweight="bold")
    # As few rows as fit, then more while the legend is wider than the figure: a legend that
    # overhangs widens the saved figure (bbox_inches="tight"), so a page or a README shrinks
    # the panels, and their text, to fit it.
    columns = _legend_columns(len(handles), panels_across=min(3, len(fig.axes)))
    while True:
        legend = fig.legend(
            handles=handles,
            loc="upper center",
            bbox_to_anchor=(0.5, 0.0),
            ncol=columns,
            frameon=False,
            handlelength=1.6,
            columnspacing=1.2,
        )
        fig.draw_without_rendering()  # lay out, so the legend's extent is known
        if columns == 1 or legend.get_window_extent().width <= fig.bbox.width:
            break
        legend.remove()
        rows = math.ceil(len(handles) / columns) + 1
        columns = min(columns - 1, math.ceil(len(handles) / rows))
    if starred:  # under the legend, where the last layout put it
        box = legend.get_window_extent().transformed(fig.transFigure.inverted())
        fig.text(
            box.x1, box.y0, ACTIONS_FOOTNOTE, ha="right", va="top", fontsize="small", color="0.3"
        )


def _legend_columns(entries: int, panels_across: int) -> int:
    """As few legend rows as fit: about 3 entries per panel width, at most 8 per row."""
    per_row = min(8, 3 * panels_across)
    rows = math.ceil(entries / per_row)
    return math.ceil(entries / rows)
