"""Bad input at the command line: one clear line, exit status 2, results untouched."""

import subprocess
from pathlib import Path

import pytest
from folders import copy_folder

PENDULUM = "InvertedPendulumBulletEnv-v0"
GOOD = (
    f"envs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\nalgorithms: [random, expert]\nseeds: 1\n"
)


@pytest.fixture(scope="module")
def finished_results(tmp_path_factory, cli) -> Path:
    """A results folder holding real records, which no bad command may touch."""
    root = tmp_path_factory.mktemp("cli")
    (root / "good.yaml").write_text("name: good\n" + GOOD)
    out = cli("run", str(root / "good.yaml"), "--results", str(root / "res"), "--jobs", "1")
    assert out.returncode == 0, out.stderr
    return root / "res"


def snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


BAD_SUITES = {
    "unknown top-level key": (GOOD + "seeeds: 3\n", "seeeds"),
    "unknown algorithm": (GOOD.replace("[random, expert]", "[random, expert, gaifoo]"), "gaifoo"),
    "unknown hyperparameter": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo: {lr: 0.1}}]"),
        "lr",
    ),
    "unknown env": (GOOD.replace(PENDULUM, "NoSuchEnv-v0"), "NoSuchEnv-v0"),
    "missing expert": (GOOD.replace(PENDULUM, "ReacherBulletEnv-v0"), "expert"),
    "too many demos": (GOOD.replace("demos: [1]", "demos: [1, 50]"), "demos"),
    "wrong type": (GOOD.replace("budget: 2048", "budget: lots"), "budget"),
    "empty list": (GOOD.replace("demos: [1]", "demos: []"), "demos"),
    "yaml syntax": ("envs: [unclosed\n", "yaml"),
    "unknown device": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo-sac: {device: gpu}}]"),
        "device must be cpu or cuda",
    ),
    "a string for a list": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo: {hidden: abc}}]"),
        "hidden: expected a list",
    ),
    "a value out of range": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo: {disc_steps: -5}}]"),
        "disc_steps must be >= 1",
    ),
    "a budget below one batch": (
        GOOD.replace("2048", "1000").replace("[random, expert]", "[random, expert, survival]"),
        "1000 env steps are fewer than survival needs to train (2048)",
    ),
    "a minibatch no batch can fill": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo: {disc_minibatch: 1000000000}}]"),
        "more than a TRPO batch holds",
    ),
    "a zero-width layer": (
        GOOD.replace("[random, expert]", "[random, expert, {gaifo: {disc_hidden: [64, 0]}}]"),
        "disc_hidden[1] must be >= 1",
    ),
    "a seed no generator takes": (
        GOOD.replace("seeds: 1", "seeds: [1, 100000000000000000000]"),
        "seeds[1]",
    ),
    "a seed count too large to expand": (
        GOOD.replace("seeds: 1", "seeds: 1000000000"),
        "at most 100,000 seeds",
    ),
    "a suite too large to run": (
        GOOD.replace("seeds: 1", "seeds: 100000")
        .replace("demos: [1]", "demos: [1, 2, 3, 4, 5, 6, 7]")
        .replace("[random, expert]", "[random, expert, gaifo, gail]"),
        "more than 1,000,000",
    ),
    "a bool for an int": (
        GOOD.replace("[random, expert]", "[random, expert, {survival: {n_envs: true}}]"),
        "n_envs: expected an integer",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_SUITES))
def test_bad_suite_is_one_line_exit_2_and_touches_nothing(
    case, finished_results, tmp_path, bench_here
):
    body, needle = BAD_SUITES[case]
    suite = tmp_path / "bad.yaml"
    suite.write_text(body)
    before = snapshot(finished_results)
    out = bench_here("run", str(suite), "--results", str(finished_results))
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert str(suite) in lines[0] and needle.lower() in lines[0].lower(), lines[0]
    assert snapshot(finished_results) == before


def test_run_of_an_env_not_in_the_suite(finished_results, tmp_path, bench_here):
    suite = tmp_path / "good.yaml"
    suite.write_text("name: good\n" + GOOD)
    before = snapshot(finished_results)
    out = bench_here(
        "run", str(suite), "--results", str(finished_results), "--env", "HopperBulletEnv-v0"
    )
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "HopperBulletEnv-v0" in out.stderr and "envs" in out.stderr
    assert snapshot(finished_results) == before


@pytest.mark.parametrize("where", ["name", "results", "parent"])
def test_results_never_land_in_the_shipped_experts_folder(where, tmp_path, bench_here, monkeypatch):
    """A suite named `experts` run without --results, or --results naming the experts' folder
    or a folder above it, is refused before anything is written there."""
    from bench import paths

    experts = snapshot(paths.EXPERTS_DIR)
    monkeypatch.chdir(paths.EXPERTS_DIR.parent.parent)  # where `results/<name>` is results/experts
    suite = tmp_path / "experts.yaml"
    suite.write_text(GOOD)
    given = {"name": [], "results": ["--results", str(paths.EXPERTS_DIR)]}
    given["parent"] = ["--results", str(paths.EXPERTS_DIR.parent)]
    out = bench_here("run", str(suite), "--jobs", "1", *given[where])
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "shipped experts" in out.stderr
    assert snapshot(paths.EXPERTS_DIR) == experts
    assert not (paths.EXPERTS_DIR / "trials").exists()


def test_missing_suite_file(cli):
    out = cli("run", "no/such/suite.yaml")
    assert (
        out.returncode == 2 and out.stderr.count("\n") == 1 and "no/such/suite.yaml" in out.stderr
    )


@pytest.mark.slow
def test_plot_without_reference_trials_names_what_is_missing(tmp_path, cli):
    (tmp_path / "s.yaml").write_text("name: s\n" + GOOD.replace("[random, expert]", "[random]"))
    assert (
        cli(
            "run", str(tmp_path / "s.yaml"), "--results", str(tmp_path / "res"), "--jobs", "1"
        ).returncode
        == 0
    )
    out = cli("plot", str(tmp_path / "res"))
    assert out.returncode == 2 and "expert" in out.stderr and out.stderr.count("\n") == 1


def test_plot_of_missing_dir(bench_here):
    out = bench_here("plot", "no/such/results")
    assert out.returncode == 2 and "no/such/results" in out.stderr


def test_help_of_every_command(bench_here):
    for args in (
        ["--help"],
        ["run", "--help"],
        ["plot", "--help"],
        ["list", "--help"],
        ["experts", "train", "--help"],
    ):
        out = bench_here(*args)
        assert out.returncode == 0 and "usage: bench" in out.stdout


@pytest.mark.parametrize(
    ("hyperparams", "message"),
    [('{"hiden": [128]}', "ExpertTraining has no field 'hiden'"), ("[1]", "must be a JSON object")],
)
def test_expert_hyperparams_are_checked_before_training(hyperparams, message, tmp_path, bench_here):
    out = bench_here(
        "experts", "train", PENDULUM, "--hyperparams", hyperparams, "--out", str(tmp_path / "x")
    )
    assert out.returncode == 2 and message in out.stderr
    assert not (tmp_path / "x").exists()


SHIPPED = Path(__file__).resolve().parent.parent / "results" / "experts" / PENDULUM


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ([], "already has an expert"),  # the shipped one: only --out or --replace
        (["--out", str(SHIPPED)], "already has an expert"),  # named as a path, the same
        (["--out", str(SHIPPED.parent / "HopperBulletEnv-v0")], "is not InvertedPendulum"),
        (["--out", str(SHIPPED.parent / "new")], "only into its own env's folder"),
        (["--replace", "--steps", "2000"], "less than one TRPO batch"),
        (["--replace", "--hyperparams", '{"n_envs": 0}'], "n_envs must be >= 1"),
        (["--replace", "--hyperparams", '{"gamma": 2}'], "bad TRPO settings"),
        (["--replace", "--hyperparams", '{"hidden": "wide"}'], "bad TRPO settings"),
    ],
)
def test_experts_train_never_damages_the_shipped_expert(args, message, bench_here):
    experts = SHIPPED.parent
    before = {d.name: snapshot(d) for d in experts.iterdir()}
    out = bench_here("experts", "train", PENDULUM, "--steps", "4096", *args)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert {d.name: snapshot(d) for d in experts.iterdir()} == before


def test_experts_train_refuses_a_file_as_its_folder(tmp_path, bench_here):
    (tmp_path / "file").write_text("mine")
    out = bench_here(
        "experts", "train", PENDULUM, "--steps", "4096", "--out", str(tmp_path / "file")
    )
    assert out.returncode == 2 and "is a file" in out.stderr
    assert (tmp_path / "file").read_text() == "mine"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "{suite}", "--jobs", "0"], "--jobs: must be >= 1, or -1"),
        (["run", "{suite}", "--time-limit", "90"], "not a duration like 90m"),
        (["run", "{suite}", "--time-limit", "0h"], "must be longer than 0"),
        (["run", "{suite}", "--no-pause"], "--no-pause says which trials to start before a"),
        (["run", "{suite}", "--results", "{file}"], "is a file, not a folder"),
        (["run", "{suite}", "--results", "{file}/under"], "is a file, not a folder"),
        (["plot", "{results}", "--out", "{file}/figure.png"], "is a file, not a folder"),
        (["report", "{results}", "--out", "{file}/report"], "is a file, not a folder"),
        (["video", "{results}", "--out", "{file}/v.gif"], "is a file, not a folder"),
        (["experts", "train", PENDULUM, "--out", "{file}/expert"], "is a file, not a folder"),
        (["run", "{suite}", "--tensorboard", "{file}"], "is a file, not a folder"),
        (["report", "{results}", "--reps", "0"], "--reps: must be >= 1, not 0"),
        (["report", "{results}", "--out", "{file}"], "is a file, not a folder"),
        (["compare", "{results}", "{results}", "--reps", "-3"], "must be >= 1"),
        (["compare", "{results}", "{results}", "--alpha", "5"], "not a level between 0 and 1"),
        (["compare", "{results}", "--between", "random", "random"], "random against itself"),
        (["demos", "export", PENDULUM, "{file}", "--references", "{results}"], "is a file"),
        (["experts", "train", PENDULUM, "--n-envs", "0"], "--n-envs: must be >= 1"),
        (["video", "{results}", "--out", "{file}.gif", "--steps", "0"], "--steps: must be >= 1"),
    ],
)
def test_unusable_arguments_are_one_line_before_any_work(
    args, message, finished_results, tmp_path, bench_here
):
    (tmp_path / "good.yaml").write_text("name: good\n" + GOOD)
    (tmp_path / "file").write_text("mine")
    before = snapshot(finished_results)
    paths = {
        "suite": tmp_path / "good.yaml",
        "file": tmp_path / "file",
        "results": finished_results,
    }
    out = bench_here(*(a.format(**paths) for a in args))
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert snapshot(finished_results) == before and (tmp_path / "file").read_text() == "mine"


@pytest.mark.slow
def test_a_second_run_into_a_busy_folder_is_refused(tmp_path, cli):
    import subprocess
    import sys
    import time

    (tmp_path / "slow.yaml").write_text(
        f"name: slow\nenvs: {{{PENDULUM}: {{budget: 200000}}}}\ndemos: [1]\n"
        "algorithms: [survival]\nseeds: 1\n"
    )
    first = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "bench.cli",
            "run",
            str(tmp_path / "slow.yaml"),
            "--results",
            str(tmp_path / "res"),
            "--jobs",
            "1",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.time() + 60
        while first.stderr.readline() and time.time() < deadline:  # its first line: it has begun
            break
        second = cli("run", str(tmp_path / "slow.yaml"), "--results", str(tmp_path / "res"))
        assert second.returncode == 2 and "being written by another bench run" in second.stderr
    finally:
        first.kill()
        first.wait()
    assert not list((tmp_path / "res" / "trials").glob("*.json"))  # the second ran nothing


def _copy(results: Path, to: Path) -> Path:
    import shutil

    return Path(shutil.copytree(results, to))


def test_plot_of_references_only_writes_the_table_without_a_figure(
    finished_results, tmp_path, bench_here
):
    results = _copy(finished_results, tmp_path / "res")
    out = bench_here("plot", str(results))
    assert out.returncode == 0, out.stderr
    assert "only references: no figure" in out.stderr and (results / "summary.csv").is_file()
    assert not (results / "figure2.png").exists()


def test_plot_elsewhere_leaves_the_results_folder_as_it_was(finished_results, tmp_path, bench_here):
    # a figure drawn from a folder a run is still filling must not add files to it
    results = _copy(finished_results, tmp_path / "res")
    before = sorted(results.rglob("*"))
    out = bench_here("plot", str(results), "--out", str(tmp_path / "look" / "figure.png"))
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "look" / "summary.csv").is_file()
    assert sorted(results.rglob("*")) == before


def test_plot_and_report_of_unreadable_records_are_one_line(finished_results, tmp_path, bench_here):
    results = _copy(finished_results, tmp_path / "res")
    for record in (results / "trials").glob("*.json"):
        record.write_text(record.read_text()[:40])  # truncated
    for command in ("plot", "report"):
        out = bench_here(command, str(results))
        assert out.returncode == 2 and "no readable trial record" in out.stderr.splitlines()[-1]
        assert "Traceback" not in out.stderr


def test_a_record_of_another_budget_is_refused_not_averaged_in(
    finished_results, tmp_path, bench_here
):
    import json

    results = _copy(finished_results, tmp_path / "res")
    record = next((results / "trials").glob("*.json"))
    raw = json.loads(record.read_text())
    raw["spec"]["budget"] *= 10
    from bench.harness.types import TrialSpec

    foreign = TrialSpec(**raw["spec"]).trial_id  # named as a record of that trial would be
    (results / "trials" / f"{foreign}.json").write_text(json.dumps(raw))
    for command in ("plot", "report"):
        out = bench_here(command, str(results))
        assert out.returncode == 2, out.stderr
        assert "2 budgets in one results folder" in out.stderr.splitlines()[-1]


def test_an_ok_record_without_a_finite_return_is_reported(finished_results, tmp_path, bench_here):
    import json

    results = _copy(finished_results, tmp_path / "res")
    from bench.harness.types import TrialSpec

    raw = json.loads(next((results / "trials").glob("*.json")).read_text())
    raw["spec"]["seed"], raw["returns"] = 7, [None, None]  # a second seed, with no return
    trial_id = TrialSpec(**raw["spec"]).trial_id
    (results / "trials" / f"{trial_id}.json").write_text(json.dumps(raw))
    out = bench_here("plot", str(results))
    assert out.returncode == 0 and "1 records left out (1 no finite return)" in out.stderr


@pytest.mark.slow
def test_an_unreachable_dask_scheduler_is_one_line_before_anything_is_touched(
    finished_results, bench_here
):
    """Refused before the run links what the folder beside it finished (seed 0 here)."""
    pytest.importorskip("distributed")
    root = finished_results.parent
    suite = root / "more.yaml"
    suite.write_text("name: good\n" + GOOD.replace("seeds: 1", "seeds: 2"))
    before = snapshot(finished_results)
    args = ["--backend", "dask", "--scheduler", "tcp://127.0.0.1:1"]
    out = bench_here("run", str(suite), "--results", str(root / "more"), *args)
    assert out.returncode == 2 and "cannot reach the dask scheduler" in out.stderr
    assert "Traceback" not in out.stderr and not list((root / "more").rglob("*.json"))
    assert snapshot(finished_results) == before


@pytest.mark.parametrize("command", ["report", "plot"])
def test_a_full_disk_is_one_line_and_leaves_nothing_partial(command, tmp_path):
    """Writes refused by the machine (here a file-size limit, as a full disk refuses them)
    are one line and exit 2; what was being written is not left half-written."""
    import resource
    import subprocess
    import sys

    reference = Path(__file__).parents[1] / "results" / "quick"
    copy_folder(reference, tmp_path / "quick")
    out_arg = {"report": ["--out", str(tmp_path / "rep")], "plot": []}[command]

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    out = subprocess.run(
        [sys.executable, "-m", "bench.cli", command, str(tmp_path / "quick"), *out_arg],
        capture_output=True,
        text=True,
        preexec_fn=small_files,
    )
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "cannot write" in out.stderr and "File too large" in out.stderr
    big = [p for p in tmp_path.rglob("*") if p.is_file() and p.stat().st_size >= 20_000]
    assert all(p.parent.name == "trials" or p.name.endswith(".json") for p in big), big


def test_a_demonstration_cache_under_a_file_is_one_line(tmp_path, bench_here, monkeypatch):
    (tmp_path / "file").write_text("mine")
    monkeypatch.setattr("bench.paths.CACHE_DIR", tmp_path / "file" / "cache")
    suite = tmp_path / "s.yaml"
    suite.write_text(GOOD)
    out = bench_here("run", str(suite), "--results", str(tmp_path / "res"))
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "IFO_BENCH_CACHE" in out.stderr and not (tmp_path / "res").exists()


def test_a_reader_that_leaves_early_ends_the_output_quietly(tmp_path):
    """`bench run SUITE --estimate | head -1`: the reader closes the pipe (here before the
    first line); the command stops writing without a traceback."""
    import subprocess
    import sys

    suite = Path(__file__).parents[1] / "suites" / "pybullet.yaml"
    bench = subprocess.Popen(
        [sys.executable, "-m", "bench.cli", "run", str(suite), "--estimate"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    bench.stdout.close()
    stderr = bench.stderr.read()
    assert bench.wait() == 0 and "Traceback" not in stderr, stderr


def test_no_reuse_trains_what_the_committed_results_hold(bench_here, tmp_path):
    """`make run` checks the committed reference by training its trials anew: without
    --no-reuse the run would link them from results/quick and compare them with themselves."""
    from bench import paths

    suite = str(paths.REPO_ROOT / "suites" / "quick.yaml")
    where = ["--results", str(tmp_path / "quick"), "--estimate"]
    linked = bench_here("run", suite, *where)
    assert linked.returncode == 0 and "0 of 50 trials pending" in linked.stdout, linked
    fresh = bench_here("run", suite, *where, "--no-reuse")
    assert fresh.returncode == 0 and "50 of 50 trials pending" in fresh.stdout, fresh
    both = bench_here("run", suite, *where, "--no-reuse", "--reuse", str(tmp_path))
    assert both.returncode == 2 and "not allowed with" in both.stderr
    # and compares them with the reference pooled with its fresh draws (55 seeds a cell)
    plan = subprocess.run(
        ["make", "-n", "run"], cwd=paths.REPO_ROOT, capture_output=True, text=True, check=True
    )
    assert "bench compare runs/quick results/quick results/quick-draws" in plan.stdout
