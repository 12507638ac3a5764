"""The researcher's path: a method of one's own, run beside the committed baselines.

A plugin's trials are decided by its code as well as its settings; a plugin that fails to
import runs nothing; its optimizer family is read from its config; and finished trials are
found in the checkout's committed results wherever a run writes its own.
"""

import json
from dataclasses import dataclass
from pathlib import Path

import pytest

from bench.harness import registry
from bench.harness.learners import ImitationTRPOConfig

ROOT = Path(__file__).resolve().parent.parent
ENV = "InvertedPendulum-v5"

# A plugin that trains nothing: a fixed linear policy, so a trial costs its evaluation only.
FIXED = """
from dataclasses import dataclass

import numpy as np

from bench.harness.registry import register

GAIN = {gain}


@dataclass
class FixedConfig:
    pass


@register("fixed", config=FixedConfig, inputs="none", family="trpo")
def train(task, demos, budget, seed, logger, config):
    \"\"\"Acts on a fixed gain of the state.\"\"\"
    weights = np.full((task.obs_dim, task.act_dim), GAIN, dtype=np.float32)
    return lambda obs: np.clip(obs @ weights, task.action_low, task.action_high)
"""


def _suite(tmp_path: Path, algorithms: str = "[random, expert, fixed]") -> Path:
    suite = tmp_path / "mine.yaml"
    suite.write_text(
        f"name: mine\nenvs: {{{ENV}: {{budget: 1000}}}}\ndemos: [1]\nseeds: 2\n"
        f"eval_episodes: 2\nalgorithms: {algorithms}\n"
    )
    return suite


def test_a_changed_plugin_runs_again_and_its_old_records_are_set_aside(
    tmp_path, cli, install_plugin
):
    env = install_plugin(tmp_path / "site", "fixed", "fixed = fixed_ifo", {})
    module = tmp_path / "site" / "fixed_ifo.py"
    module.write_text(FIXED.format(gain=0.1))
    suite, results = _suite(tmp_path), tmp_path / "runs" / "mine"
    out = cli("run", str(suite), "--results", str(results), "--jobs", "1", env=env)
    assert out.returncode == 0, out.stderr
    first = {p.name for p in (results / "trials").glob("*.json")}
    assert len(first) == 6
    records = [json.loads((results / "trials" / name).read_text()) for name in first]
    codes = {r["spec"].get("code") for r in records if r["spec"]["algorithm"] == "fixed"}
    assert len(codes) == 1 and None not in codes  # the plugin's records say its code
    assert all("code" not in r["spec"] for r in records if r["spec"]["algorithm"] != "fixed")

    module.write_text(FIXED.format(gain=-0.1))  # a new version of the plugin
    out = cli("run", str(suite), "--results", str(results), "--estimate", env=env)
    assert out.returncode == 0, out.stderr
    assert "2 of 6 trials pending" in out.stdout
    assert "2 records there were made with other settings or another version" in out.stdout
    out = cli("run", str(suite), "--results", str(results), "--jobs", "1", env=env)
    assert out.returncode == 0, out.stderr
    assert f"moved to {results}/set-aside/" in out.stdout
    now = {p.name for p in (results / "trials").glob("*.json")}
    aside = {p.name for p in (results / "set-aside").glob("*.json")}
    assert len(now) == 6 and len(aside) == 2  # nothing deleted, nothing reused
    assert aside <= first and not aside & now
    out = cli("plot", str(results), env=env)  # the folder is one setting again
    assert out.returncode == 0, out.stderr

    # Other settings supersede a cell's records as other code does: 3 evaluation episodes
    suite.write_text(suite.read_text().replace("eval_episodes: 2", "eval_episodes: 3"))
    out = cli("run", str(suite), "--results", str(results), "--jobs", "1", env=env)
    assert out.returncode == 0, out.stderr
    assert "6 records of these cells were made with other settings" in out.stdout
    assert len(list((results / "set-aside").glob("*.json"))) == 8
    assert cli("plot", str(results), env=env).returncode == 0


BROKEN_AFTER_REGISTERING = FIXED.format(gain=0.1) + "\nraise ImportError('no such helper')\n"


def test_a_plugin_that_fails_to_import_runs_nothing(tmp_path, cli, install_plugin):
    """Even where the module registered its algorithm before it failed."""
    env = install_plugin(
        tmp_path / "site", "fixed", "fixed = fixed_ifo", {"fixed_ifo": BROKEN_AFTER_REGISTERING}
    )
    results = tmp_path / "runs" / "mine"
    out = cli("run", str(_suite(tmp_path)), "--results", str(results), env=env)
    assert out.returncode == 2, out.stdout + out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert "'fixed' cannot run" in last and "ImportError: no such helper" in last
    assert not list(results.glob("trials/*.json"))


def test_a_learner_s_family_is_read_from_the_config_it_extends():
    @dataclass
    class OnTRPO(ImitationTRPOConfig):
        scale: float = 1.0

    @dataclass
    class OwnLoop:
        lr: float = 1e-3

    assert registry.family_of(OnTRPO) == "trpo"
    assert registry.family_of(OwnLoop) is None
    from bench.rl.sac import SACConfig
    from bench.rl.td3 import TD3Config

    assert registry.family_of(SACConfig) == "sac" and registry.family_of(TD3Config) == "td3"
    assert registry.get("gaifo").family == "trpo" and registry.get("gaifo").code is None


def test_committed_trials_are_reused_wherever_the_results_go(tmp_path, cli):
    """`make run` writes to runs/quick: the committed results/quick trials are linked there
    (the estimate says from where), not run again."""
    out = cli(
        "run", str(ROOT / "suites" / "quick.yaml"), "--results", str(tmp_path / "q"), "--estimate"
    )
    assert out.returncode == 0, out.stderr
    assert "0 of 50 trials pending" in out.stdout
    linked = out.stdout.splitlines()[1]
    assert linked.startswith("50 more finished by other runs, linked, not run again: ")
    assert "results/quick/" in linked  # some are links there to results/pybullet's


@pytest.mark.slow
def test_linked_committed_trials_are_never_written(tmp_path, cli):
    suite = ROOT / "suites" / "quick.yaml"
    committed = {p: p.read_bytes() for p in (ROOT / "results" / "quick" / "trials").glob("*")}
    out = cli(
        "run", str(suite), "--results", str(tmp_path / "q"), "--env", "InvertedPendulumBulletEnv-v0"
    )
    assert out.returncode == 0, out.stderr
    assert "0 trials done" in out.stdout and "by other suites (linked)" in out.stdout
    assert {p: p.read_bytes() for p in committed} == committed


PAGE = ROOT / "docs" / "guide" / "your-method.md"


@pytest.mark.slow
def test_the_evaluate_page_runs_as_written(tmp_path):
    """docs/guide/your-method.md, steps 1-4 as written (its ```bash blocks, in order, and its
    suite), in a fresh folder outside results/: only the plugin's trials run, and the report on
    it sets it against every baseline and its floor. One substitution: `pip install -e` goes to
    a folder of the test's own (`--target`), so the test leaves no package installed."""
    import os
    import re
    import subprocess
    import sys

    text = PAGE.read_text()
    suite = re.search(r"```yaml\n# (\S+)\n(.*?)```", text, re.S)
    (tmp_path / suite.group(1)).write_text(suite.group(2))
    site = tmp_path / "site"
    install = f"{sys.executable} -m pip install -q --no-deps --no-build-isolation --target {site}"
    bin_dir = Path(sys.executable).parent
    env = {
        **os.environ,
        "PYTHONPATH": str(site),
        "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
    }
    outputs = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for command in block.strip().splitlines():
            command = command.replace("pip install -e", install)
            out = subprocess.run(
                command, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True
            )
            assert out.returncode == 0, f"{command}: {out.stderr}"
            outputs.append(out.stdout)
    printed = "\n".join(outputs)
    assert "my-ifo" in printed  # bench list
    assert "2 of 82 trials pending" in printed
    assert "80 more finished by other runs, linked, not run again: 80 from" in printed
    assert "2 trials done, 0 failed, 80 already finished" in printed
    report = (tmp_path / "runs" / "pendulum" / "report" / "report.md").read_text()
    for other in ("GAIfO", "GAIL*", "BCO", "TCN", "Survival"):
        assert f"| my-ifo > {other} " in report, other
    assert "my-ifo / Oracle" in report  # its fraction of its own ceiling
    assert "| InvertedPendulum | my-ifo      | 5       |" in printed  # compare --between


def test_a_report_says_which_learner_has_no_floor_to_be_read_against():
    from bench.analysis import sections
    from bench.analysis.labels import Names, Shown

    names = Names(
        {
            "gaifo": Shown("GAIfO", "learner", "trpo", "gaifo"),
            "own-loop": Shown("own-loop", "learner", None, "own-loop"),
            "survival": Shown("Survival", "floor", "trpo", "survival"),
        }
    )
    text = sections.how_to_read(list(names), 100, names, focus="own-loop")
    assert "P(own-loop > X)" in text
    assert "**own-loop** has no optimizer family" in text and "**GAIfO** has" not in text


def test_the_scaffold_is_lint_clean_in_a_package_of_its_own(tmp_path, bench_here):
    """`bench new-algorithm` writes code a researcher's own ruff passes as it stands: its
    package is another project, where ifo-bench is a third-party import."""
    import subprocess
    import sys

    out = bench_here("new-algorithm", "my-ifo", str(tmp_path / "my-ifo"))
    assert out.returncode == 0, out.stderr
    for check in (["check", "."], ["format", "--check", "."]):
        ruff = [sys.executable, "-m", "ruff", *check]
        done = subprocess.run(ruff, cwd=tmp_path / "my-ifo", capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr
