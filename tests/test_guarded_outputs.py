"""Nothing a command writes lands among shipped experts, whatever folder holds them; `--out`
means one file; an empty cache variable is unset."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXPERT = ROOT / "results" / "experts" / "InvertedPendulum-v5"


@pytest.mark.parametrize(
    "args",
    [
        ("report", "results/quick", "--out", "results/experts/InvertedPendulum-v5"),
        ("plot", "results/quick", "--out", "results/experts/InvertedPendulum-v5/policy.png"),
        ("video", "results/quick", "--out", "results/experts/x.gif"),
        ("run", "suites/quick.yaml", "--tensorboard", "results/experts/tb", "--estimate"),
    ],
)
def test_no_output_goes_among_the_shipped_experts(args, bench_here, monkeypatch):
    monkeypatch.chdir(ROOT)
    before = sorted(p.name for p in EXPERT.parent.rglob("*"))
    out = bench_here(*args)
    assert out.returncode == 2 and "holds the shipped experts" in out.stderr, out.stderr
    assert sorted(p.name for p in EXPERT.parent.rglob("*")) == before


def test_a_folder_is_known_as_experts_by_what_it_holds(tmp_path, bench_here):
    """A second checkout's experts (not the ones this installation resolves) are as safe."""
    other = tmp_path / "clone" / "results" / "experts" / "InvertedPendulum-v5"
    shutil.copytree(EXPERT, other)
    out = bench_here("plot", str(ROOT / "results" / "quick"), "--out", str(other / "fig.png"))
    assert out.returncode == 2 and "holds the shipped experts" in out.stderr
    assert sorted(p.name for p in other.iterdir()) == ["meta.json", "policy.pt"]


def test_plot_out_with_several_suites_is_refused_before_any_figure(tmp_path, bench_here):
    out = bench_here("plot", str(ROOT / "results"), "--out", str(tmp_path / "f.png"))
    assert out.returncode == 2 and "--out names one figure" in out.stderr
    assert not list(tmp_path.iterdir())


def test_an_empty_cache_variable_is_unset(tmp_path):
    code = "from bench import paths; print(paths.CACHE_DIR, paths.EXPERTS_DIR)"
    env = {"IFO_BENCH_CACHE": "", "IFO_BENCH_EXPERTS": "", "PATH": ""}
    printed = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True
    ).stdout.split()
    assert printed == [str(ROOT / ".cache"), str(ROOT / "results" / "experts")]


@pytest.mark.parametrize(
    ("state", "said"),
    [
        ({"kind": "x", "class": "this:Nothing"}, "no registered algorithm's package"),
        ({"kind": "x", "class": "algorithms.gaifo:no_such"}, "which is no policy class"),
        ({"kind": "x", "class": "algorithms.gaifo:train"}, "which is no policy class"),
        ({"kind": "nothing"}, "unknown policy kind"),
    ],
)
def test_a_policy_file_names_only_registered_code(state, said, tmp_path, capsys):
    """A stranger's policy file is data: naming a module does not import it."""
    import torch

    from bench.harness import policies

    file = tmp_path / "p.pt"
    torch.save(state, file)
    with pytest.raises(policies.PolicyError, match=said):
        policies.load(file)
    assert "Zen of Python" not in capsys.readouterr().out  # `this` was never imported
    assert "this" not in sys.modules


def test_a_pickle_where_a_policy_should_be_is_one_line(tmp_path):
    import pickle

    from bench.harness import policies

    file = tmp_path / "p.pt"
    file.write_bytes(pickle.dumps(print))  # weights_only refuses it
    with pytest.raises(policies.PolicyError, match="not a policy file"):
        policies.load(file)
