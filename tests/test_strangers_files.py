"""What a stranger's file can do when it is not what it claims: a FIFO or a device where a suite,
settings or a record is expected, a YAML alias bomb, a settings path out of the suite's folder,
a snapshot under another trial's name or a folder in its place. Each is one line (exit 2) or a
warning, never a hang, a traceback or a read of the machine's files."""

import os
import threading
import time
import warnings
from pathlib import Path

import pytest
import torch

from bench.harness import store
from bench.harness.snapshots import SnapshotPlan

ROOT = Path(__file__).resolve().parent.parent
QUICK = (ROOT / "suites" / "quick.yaml").read_text()


def refused_quickly(bench_here, *args, within: float = 20.0):
    """Run `bench *args` in this process on a thread; fail if it does not end by `within` s."""
    out: list = []
    worker = threading.Thread(target=lambda: out.append(bench_here(*args)), daemon=True)
    worker.start()
    worker.join(within)
    assert not worker.is_alive(), f"bench {' '.join(args)} hung"
    return out[0]


def test_a_fifo_a_device_or_a_folder_where_a_suite_is_expected_is_one_line(tmp_path, bench_here):
    fifo, folder = tmp_path / "suite.yaml", tmp_path / "folder.yaml"
    os.mkfifo(fifo)
    folder.mkdir()
    for path in (fifo, Path("/dev/zero"), folder):
        out = refused_quickly(bench_here, "run", str(path), "--estimate")
        assert out.returncode == 2 and "not a regular file" in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1


def test_a_huge_suite_or_an_alias_bomb_is_refused_before_it_is_expanded(tmp_path, bench_here):
    bomb = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    bomb += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 9)]
    (tmp_path / "bomb.yaml").write_text("\n".join(bomb) + "\n" + QUICK)
    (tmp_path / "huge.yaml").write_text(QUICK + "#" + "x" * 2**21 + "\n")
    for name, said in (("bomb", "values once its aliases are expanded"), ("huge", "too large")):
        start = time.monotonic()
        out = bench_here("run", str(tmp_path / f"{name}.yaml"), "--estimate")
        assert out.returncode == 2 and said in out.stderr, out.stderr
        assert time.monotonic() - start < 10


def test_settings_are_read_only_beside_the_suite_or_shipped(tmp_path, bench_here):
    secret = tmp_path / "elsewhere" / "secret.yaml"
    secret.parent.mkdir()
    secret.write_text("the secret first line\n")
    suite_dir = tmp_path / "mine"
    suite_dir.mkdir()
    for named in (str(secret), "../elsewhere/secret.yaml", "/etc/passwd"):
        (suite_dir / "s.yaml").write_text(QUICK.replace("settings:", f"settings: {named} #"))
        out = bench_here("run", str(suite_dir / "s.yaml"), "--estimate")
        assert out.returncode == 2 and "leads out of the suite's folder" in out.stderr, out.stderr
        assert "secret first line" not in out.stderr and "root:x" not in out.stderr
    (suite_dir / "link.yaml").symlink_to(secret)  # a link beside the suite, out of its folder
    (suite_dir / "s.yaml").write_text(QUICK.replace("settings:", "settings: link.yaml #"))
    out = bench_here("run", str(suite_dir / "s.yaml"), "--estimate")
    assert out.returncode == 2 and "leads out of the suite's folder" in out.stderr
    (suite_dir / "list.yaml").write_text("- the secret first line\n")
    (suite_dir / "s.yaml").write_text(QUICK.replace("settings:", "settings: list.yaml #"))
    out = bench_here("run", str(suite_dir / "s.yaml"), "--estimate")
    assert out.returncode == 2 and "expected a mapping of env ids" in out.stderr
    assert "secret" not in out.stderr


def test_a_fifo_among_the_records_is_skipped_not_waited_on(tmp_path):
    trials = tmp_path / "trials"
    trials.mkdir()
    os.mkfifo(trials / "0123456789abcdef.json")
    found: list = []
    worker = threading.Thread(target=lambda: found.extend(store.scan(tmp_path)), daemon=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        worker.start()
        worker.join(10)
    assert not worker.is_alive() and found == []
    assert any("not a regular file" in str(w.message) for w in caught)


def test_a_snapshot_knows_its_trial(tmp_path):
    plan = SnapshotPlan.of(tmp_path)
    plan.write("aaaa", {"weights": torch.ones(2)}, 10, 100)
    assert torch.equal(plan.read("aaaa")["weights"], torch.ones(2))
    plan.path("aaaa").rename(plan.path("bbbb"))  # copied under another trial's name
    with pytest.warns(UserWarning, match="snapshot of trial aaaa, not of bbbb"):
        assert plan.read("bbbb") is None


def test_a_damaged_snapshot_is_passed_over_and_its_trial_starts_afresh(tmp_path):
    plan = SnapshotPlan.of(tmp_path)
    plan.write("dddd", {"weights": torch.ones(2)}, 10, 100)
    whole = plan.path("dddd").read_bytes()
    plan.path("dddd").write_bytes(whole[: len(whole) // 2])  # cut off, as a full disk leaves it
    with pytest.warns(UserWarning, match="does not load .*the trial starts afresh"):
        assert plan.read("dddd") is None


def test_a_folder_where_a_snapshot_goes_is_a_warning_not_a_failure(tmp_path):
    plan = SnapshotPlan.of(tmp_path)
    plan.path("cccc").mkdir(parents=True)
    with pytest.warns(UserWarning, match="cannot keep a snapshot"):
        plan.write("cccc", {"weights": torch.ones(2)}, 10, 100)
    assert plan.read("cccc") is None
    plan.discard("cccc")  # after the record: nothing to remove, nothing raised
