"""`bench plot`, `bench report`, `bench compare` and `bench budgets`: what the records say."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from bench.cli.args import at_least, level, out_file, output_folder

if TYPE_CHECKING:
    import pandas as pd


def _plot(args: argparse.Namespace) -> int:
    from bench.analysis import labels, normalize, plot, tables
    from bench.harness import frames, store

    dirs = store.suite_dirs(args.results_dir)
    if args.out and len(dirs) > 1:
        from bench.errors import BadInput

        raise BadInput(
            f"plot: --out names one figure, and {args.results_dir} holds {len(dirs)} suites'"
            " records; name one suite's folder"
        )
    for d in dirs:
        trials = frames.load(d)
        if trials.empty:
            raise FileNotFoundError(f"{store.trials_dir(d)}: no readable trial record")
        df = normalize.normalize(trials)
        left_out = df[df["status"] != "ok"]
        if len(left_out):
            kinds = ", ".join(f"{n} {s}" for s, n in left_out["status"].value_counts().items())
            print(f"{d}: {len(left_out)} records left out ({kinds})", file=sys.stderr)
        written = []
        # --out sends everything elsewhere: a figure drawn from a folder still filling up
        # leaves the folder as it was
        out = Path(args.out) if args.out and len(dirs) == 1 else d / "figure2.png"
        if labels.Names.of(df).order(df["algorithm"].unique()):
            written = plot.figure2(df, out)
        else:
            print(f"{d}: no learner's records, only references: no figure", file=sys.stderr)
        summary = out.with_name("summary.csv")
        plot.write_summary_csv(df, summary)
        print(f"## {d}\n\n{tables.summary_table(df)}\n")
        print("wrote " + ", ".join(str(p) for p in [*written, summary]) + "\n")
    return 0


def _report(args: argparse.Namespace) -> int:
    from bench.analysis import report, tables
    from bench.analysis.comparisons import TARGET
    from bench.harness import frames, store

    focus = TARGET
    if args.focus is not None:
        for d in store.suite_dirs(args.results_dir):
            focus = _algorithm_named(args.focus, frames.load(d), d)
    for written in report.write_reports(args.results_dir, args.out, args.reps, focus):
        shown = tables.report_tables(written.aggregates, written.improvements, written.names)
        print(f"## {written.path}\n\n{shown}")
        print(f"wrote {written.path} (figures and aggregates.csv beside it)\n")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from bench.analysis import agreement, comparisons, labels, normalize, tables
    from bench.errors import BadInput

    if bool(args.reference) == (args.between is not None):
        raise BadInput("compare: name a reference folder, or two algorithms with --between A B")
    alpha = agreement.ALPHA if args.alpha is None else args.alpha
    if args.between is not None:
        trials = _one_suite(args.run)
        a, b = (_algorithm_named(name, trials, args.run) for name in args.between)
        if a == b:
            raise BadInput(f"compare --between: {a} against itself; name two algorithms")
        df = normalize.normalize(trials)
        run_df, ref_df = comparisons.between(df, a, b)
        names = labels.Names.of(df)
        comparison = agreement.compare(run_df, ref_df, reps=args.reps, alpha=alpha)
        table = tables.compare_table(comparison, names.label(a), names.label(b), names, alpha=alpha)
        print(table)
        return 0
    run = _one_suite(args.run)
    ref = agreement.pooled([(folder, _one_suite(folder)) for folder in args.reference])
    run_df, ref_df = normalize.normalized_alike(run, ref)
    comparison = agreement.compare(run_df, ref_df, reps=args.reps, alpha=alpha)
    names = labels.Names.of(run_df, ref_df)
    unlike = agreement.unlike(run_df, ref_df)
    reference = " + ".join(args.reference)
    print(tables.compare_table(comparison, str(args.run), reference, names, unlike, alpha))
    return 0


def _budgets(args: argparse.Namespace) -> int:
    from bench import atomic
    from bench.analysis import budgets, labels, plot, tables
    from bench.analysis.markdown import demos_title
    from bench.errors import BadInput
    from bench.harness import frames, store

    folders = [(folder, _one_suite(folder)) for folder in args.folders]
    curves_of = [frames.load_curves(store.suite_dirs(folder)[0]) for folder in args.folders]
    trials, curves = budgets.side_by_side(folders, curves_of)
    if args.demos:
        trials = trials[trials["n_demos"].isin(args.demos)]
        curves = curves[curves["n_demos"].isin(args.demos)]
        if trials.empty:
            raise BadInput(f"budgets: no learner ran with {args.demos} demonstrations")
    rows = budgets.statistics(trials, args.reps)
    names = labels.Names.of(trials)
    shown = tables.budgets_table(rows, names)
    out = args.out or store.suite_dirs(args.folders[-1])[0] / "budgets"
    out.mkdir(parents=True, exist_ok=True)
    figures = []
    if not curves.empty:
        iqm = budgets.curve_statistics(curves, args.reps)
        for n in sorted(iqm["n_demos"].unique()):
            at = iqm[iqm["n_demos"] == n]
            title = f"Each budget's curves: {demos_title(n).lower()}"
            name = f"budgets_{n}demos"
            plot.save(plot.draw_iqm_curves(at, title, names), out / name)
            figures.append(f"![{title}]({name}.png)")
    atomic.write_text(out / "budgets.csv", rows.to_csv(index=False))
    sources = ", ".join(f"`{folder}`" for folder in args.folders)
    text = "\n\n".join([f"# The same cells at each budget\n\nFrom {sources}.", shown, *figures])
    atomic.write_text(out / "budgets.md", text + "\n")
    print(f"{shown}\nwrote {out / 'budgets.md'} (budgets.csv and the figures beside it)")
    return 0


def _algorithm_named(name: str, trials: pd.DataFrame, folder: str | Path) -> str:
    """The algorithm `name` stands for in `trials` (its name as the records show it, or its
    label), or BadInput naming the ones there."""
    from bench.errors import BadInput

    shown = dict(zip(trials["algorithm"], trials["label"], strict=True))
    for algorithm, label in shown.items():
        if name in (algorithm, label):
            return algorithm
    raise BadInput(
        f"{folder}: no algorithm {name!r} in its records (there: {', '.join(sorted(shown))})"
    )


def _one_suite(folder: str) -> pd.DataFrame:
    """The trial records of the one suite in `folder` (FileNotFoundError where it has none)."""
    from bench.harness import frames, store

    dirs = store.suite_dirs(folder)
    if len(dirs) > 1:
        raise FileNotFoundError(
            f"{folder} holds {len(dirs)} suites' records ({', '.join(map(str, dirs))}); name one"
        )
    trials = frames.load(dirs[0])
    if trials.empty:
        raise FileNotFoundError(f"{store.trials_dir(dirs[0])}: no readable trial record")
    return trials


def add(sub: argparse._SubParsersAction) -> None:
    """The `plot`, `report`, `compare` and `budgets` commands."""
    plot = sub.add_parser(
        "plot",
        help="draw Figure 2, write summary.csv and print a table for each suite's results",
        description="Find every suite's records under RESULTS_DIR (experts skipped) and draw each.",
    )
    plot.add_argument("results_dir", help="e.g. results/ or results/quick")
    plot.add_argument(
        "--out",
        metavar="FILE",
        type=out_file,
        help="figure path (.png; a .pdf and summary.csv are written beside it)",
    )
    plot.set_defaults(func=_plot)

    rep = sub.add_parser(
        "report",
        help="aggregate statistics (IQM, CIs, probability of improvement) and a markdown report",
        description="Find every suite's records under RESULTS_DIR and write report.md with its figures.",
    )
    rep.add_argument("results_dir", help="e.g. results/ or results/quick")
    rep.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="report folder (default <suite dir>/report; one per suite)",
    )
    rep.add_argument(
        "--focus",
        metavar="NAME",
        help="the algorithm every comparison is about: P(NAME > each other learner), its"
        " floor and oracle (default gaifo); e.g. your own method's name",
    )
    _reps(rep)
    rep.set_defaults(func=_report)

    cmp = sub.add_parser(
        "compare",
        help="compare two results folders' IQMs per env, algorithm and demo count, or two"
        " algorithms of one folder",
        description="Per env, algorithm and demo count in both folders (or per env and demo"
        " count, two algorithms of one folder with --between): each side's IQM over seeds with"
        " a 95% CI, P(run > reference) with its CI, and a verdict: identical (each seed scores"
        " as the reference's same seed), differs (a rank test by permutation gives p < 0.01,"
        " or --alpha: of fresh draws of one distribution, that share of rows) or agrees.",
    )
    cmp.add_argument("run", help="a suite's results folder, e.g. runs/quick")
    cmp.add_argument(
        "reference",
        nargs="*",
        help="the folder to compare against, e.g. results/quick; several are pooled into one"
        " reference (the same suite on other seeds: results/quick results/quick-draws)",
    )
    cmp.add_argument(
        "--alpha",
        type=level,
        default=None,
        help="a row differs when the rank test's p is below this (default 0.01)",
    )
    cmp.add_argument(
        "--between",
        nargs=2,
        metavar=("A", "B"),
        help="compare algorithm A with algorithm B within RUN instead of two folders",
    )
    _reps(cmp)
    cmp.set_defaults(func=_compare)

    _add_budgets(sub)


def _add_budgets(sub: argparse._SubParsersAction) -> None:
    """The `budgets` command."""
    bud = sub.add_parser(
        "budgets",
        help="the same cells at several budgets, one folder per budget: IQMs, fractions of"
        " the oracle and each budget's learning curves side by side",
        description="Per env, demonstration count and learner that several folders hold at"
        " different budgets (e.g. results/mujoco at 1-2M and results/mujoco-converged at 5-10M):"
        " each budget's IQM over seeds with a 95% CI, its fraction of the oracle at that budget"
        " and the worst seed's, P(one of its runs beats one of its floor's), and the learning"
        " curves of every budget in one figure.",
    )
    bud.add_argument("folders", nargs="+", help="suite results folders, one per budget")
    bud.add_argument(
        "--demos",
        type=at_least(1),
        action="append",
        metavar="N",
        help="only the cells of N demonstrations (repeat for several; default every count)",
    )
    bud.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="where budgets.md, budgets.csv and the figures go (default <last folder>/budgets)",
    )
    _reps(bud)
    bud.set_defaults(func=_budgets)


def _reps(parser: argparse.ArgumentParser) -> None:
    """--reps: bootstrap resamples behind every interval (report and compare alike)."""
    parser.add_argument(
        "--reps",
        type=at_least(1),
        default=2000,
        metavar="N",
        help="bootstrap resamples per interval (default 2000)",
    )
