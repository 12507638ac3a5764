"""Trial records: round trips, atomic writes, tolerant scans, tidy frames."""

from __future__ import annotations

import json
import math
import os
import shutil
import time
import warnings

import numpy as np
import pytest

from bench.harness import frames, registry, store
from bench.harness.types import CurvePoint, TrialResult, TrialSpec


def spec(algorithm="gaifo", seed=0, n_demos=5, env_id="HopperBulletEnv-v0") -> TrialSpec:
    return TrialSpec("quick", env_id, algorithm, n_demos, seed, 1000, 3, {"disc_lr": 0.001})


def result(s: TrialSpec | None = None, status="ok", returns=(1.0, 2.0, 3.0), **kw) -> TrialResult:
    s = s or spec()
    role, family, label = registry.describe(s.algorithm)
    fields = dict(
        spec=s,
        role=role,
        family=family,
        label=s.label or label,
        status=status,
        returns=list(returns),
        curve=[CurvePoint(500, 0.5), CurvePoint(1000, 2.0)],
        env_steps=1000,
        wall_time=12.5,
        versions={"torch": "2.3"},
        logs={"disc_acc": [0.5, 0.75]},
    )
    return TrialResult(**(fields | kw))


def test_round_trip(tmp_path):
    r = result()
    path = store.write(tmp_path, r)
    assert path == tmp_path / "trials" / f"{r.trial_id}.json"
    back = store.read(path)
    assert back == r
    assert isinstance(back.spec, TrialSpec) and isinstance(back.curve[0], CurvePoint)


def test_cpu_time_is_kept_where_measured_and_an_old_record_is_written_as_it_was(tmp_path):
    measured = result(cpu_time=11.25)
    assert store.read(store.write(tmp_path / "a", measured)) == measured
    path = store.write(tmp_path / "b", result())  # a record from before CPU time was measured
    assert "cpu_time" not in json.loads(path.read_text()) and store.read(path).cpu_time is None
    raw = json.loads(path.read_text()) | {"cpu_time": "11 s"}  # edited by hand: not trusted
    path.write_text(json.dumps(raw))
    assert store.read(path).cpu_time is None


def test_a_record_keeps_what_its_algorithm_was_and_an_old_one_is_told_by_the_registry(tmp_path):
    """Records say what their algorithm is (role, family, label), so analysis never guesses
    it from a name; a record from before they did is read as the registry describes it now."""
    plugin = result(spec(algorithm="my-ifo"), role="floor", family="trpo", label="Mine")
    assert store.read(store.write(tmp_path, plugin)) == plugin
    old = result(role=None, family=None, label=None)
    back = store.read(store.write(tmp_path, old))
    assert (back.role, back.family, back.label) == ("learner", "trpo", "GAIfO")
    row = frames.load(tmp_path).set_index("algorithm").loc["my-ifo"]
    assert (row["role"], row["family"], row["label"]) == ("floor", "trpo", "Mine")


def test_non_finite_numbers_become_null_and_come_back_as_nan(tmp_path):
    r = result(
        returns=[1.0, math.nan],
        curve=[CurvePoint(10, math.inf)],
        wall_time=math.nan,
        logs={"loss": [np.float32(0.5), -math.inf]},
    )
    path = store.write(tmp_path, r)

    def no_constants(name):
        raise AssertionError(f"{name} written to JSON")

    raw = json.loads(path.read_text(), parse_constant=no_constants)
    assert raw["returns"] == [1.0, None] and raw["wall_time"] is None
    back = store.read(path)
    assert back.returns[0] == 1.0 and math.isnan(back.returns[1])
    assert math.isnan(back.curve[0].mean_return) and math.isnan(back.wall_time)
    assert back.logs["loss"][0] == 0.5 and math.isnan(back.logs["loss"][1])


def test_numpy_returns_are_written_as_plain_numbers(tmp_path):
    path = store.write(tmp_path, result(returns=np.array([1.0, 2.0], dtype=np.float32)))
    assert store.read(path).returns == [1.0, 2.0]


def test_write_replaces_and_leaves_no_temp_files(tmp_path):
    store.write(tmp_path, result(returns=[1.0]))
    path = store.write(tmp_path, result(returns=[2.0]))
    assert store.read(path).returns == [2.0]
    assert sorted(p.name for p in (tmp_path / "trials").iterdir()) == [path.name]


def test_failed_write_leaves_neither_record_nor_temp(tmp_path, monkeypatch):
    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        store.write(tmp_path, result())
    assert list((tmp_path / "trials").iterdir()) == []


def test_stray_temp_files_are_ignored_and_stale_ones_cleaned(tmp_path):
    done = store.write(tmp_path, result())
    folder = tmp_path / "trials"
    stale = folder / "deadbeef.123.tmp"
    stale.write_text('{"spec": {"suite"')  # what a killed writer leaves
    old = time.time() - 2 * store.STALE_TMP_SECONDS
    os.utime(stale, (old, old))
    live = folder / "cafe.456.tmp"  # a writer still at work elsewhere
    live.write_text("{")

    assert [(r.trial_id, r.status) for r in store.scan(tmp_path)] == [(done.stem, "ok")]
    assert not stale.exists()
    assert live.exists()


def test_corrupt_records_are_skipped_with_a_warning(tmp_path):
    good = store.write(tmp_path, result())
    (tmp_path / "trials" / "truncated.json").write_text('{"spec": {')
    (tmp_path / "trials" / "wrong.json").write_text('{"spec": {"suite": "x"}}')
    with pytest.warns(UserWarning) as caught:
        assert [(r.trial_id, r.status) for r in store.scan(tmp_path)] == [(good.stem, "ok")]
    assert ["truncated.json" in str(w.message) for w in caught] == [True, False]
    assert "wrong.json" in str(caught[1].message)
    with pytest.warns(UserWarning, match="skipping unreadable trial record"):
        assert len(frames.load(tmp_path)) == 1


def test_a_missing_folder_has_no_records(tmp_path):
    assert list(store.scan(tmp_path / "nothing")) == []
    frame = frames.load(tmp_path / "nothing")
    assert frame.empty and list(frame.columns) == frames.TRIAL_COLUMNS


def test_load_is_tidy(tmp_path):
    store.write(tmp_path, result(spec(seed=1), returns=[2.0, 4.0]))
    store.write(tmp_path, result(spec(seed=0), returns=[1.0, 1.0, 4.0]))
    store.write(tmp_path, result(spec(seed=2), status="failed", returns=[], traceback="boom"))
    store.write(tmp_path, result(spec("random", n_demos=0), returns=[0.0]))

    frame = frames.load(tmp_path)
    assert list(frame.columns) == frames.TRIAL_COLUMNS
    assert frame[["algorithm", "seed"]].values.tolist() == [
        ["gaifo", 0],
        ["gaifo", 1],
        ["gaifo", 2],
        ["random", 0],
    ]
    assert frame["return"].tolist()[:2] == [2.0, 3.0]
    assert frame["return_std"].tolist()[:2] == pytest.approx([np.std([1, 1, 4]), 1.0])
    failed = frame.iloc[2]
    assert failed["status"] == "failed" and math.isnan(failed["return"])
    assert frame["trial_id"].tolist()[0] == spec(seed=0).trial_id
    assert set(frame["suite"]) == {"quick"} and set(frame["env_steps"]) == {1000}


def test_load_curves_keeps_ok_trials_only(tmp_path):
    store.write(tmp_path, result(spec(seed=0)))
    store.write(tmp_path, result(spec(seed=1), status="failed", returns=[]))
    curves = frames.load_curves(tmp_path)
    assert list(curves.columns) == frames.CURVE_COLUMNS
    assert curves[["seed", "env_steps", "return"]].values.tolist() == [
        [0, 500, 0.5],
        [0, 1000, 2.0],
    ]


def test_load_logs_is_long(tmp_path):
    store.write(tmp_path, result())
    logs = frames.load_logs(tmp_path)
    assert list(logs.columns) == frames.LOG_COLUMNS
    assert logs[["key", "index", "value"]].values.tolist() == [
        ["disc_acc", 0, 0.5],
        ["disc_acc", 1, 0.75],
    ]


def test_find_result_dirs(tmp_path):
    for sub in [
        "trials",
        "quick/trials",
        "quick/old/trials",
        "experts/Hopper/trials",
        "empty",
        ".venv/x/trials",
    ]:
        (tmp_path / sub).mkdir(parents=True)
    (tmp_path / "quick" / "trials" / "nested" / "trials").mkdir(parents=True)  # not a suite
    assert store.find_result_dirs(tmp_path) == [
        tmp_path,
        tmp_path / "quick",
        tmp_path / "quick" / "old",
    ]
    assert store.find_result_dirs(tmp_path / "experts") == []
    assert store.find_result_dirs(tmp_path / "empty") == []


def test_the_search_for_results_stops_two_levels_down(tmp_path):
    """A run prices by the records under its results' parent; where that parent is `/` or a
    home folder, it reads `<parent>/<suite>/` and one level more, not the whole disk."""
    for sub in ["a/trials", "a/b/trials", "a/b/c/trials", "x/y/z/w/trials"]:
        (tmp_path / sub).mkdir(parents=True)
    assert store.find_result_dirs(tmp_path) == [tmp_path / "a", tmp_path / "a" / "b"]


def test_find_result_dirs_follows_linked_folders_once(tmp_path):
    """A suite's folder linked in from elsewhere (scratch space) is found; a loop ends."""
    elsewhere = tmp_path / "scratch" / "offpolicy"
    (elsewhere / "trials").mkdir(parents=True)
    results = tmp_path / "results"
    (results / "quick" / "trials").mkdir(parents=True)
    (results / "offpolicy").symlink_to(elsewhere, target_is_directory=True)
    (results / "quick" / "loop").symlink_to(results, target_is_directory=True)
    assert store.find_result_dirs(results) == [results / "offpolicy", results / "quick"]


def test_scan_under_leaves_out_a_folder_read_already(tmp_path):
    """The runner reads its own folder's records first; pricing by the records of every folder
    beside it must not read them again (linked in from elsewhere or not)."""
    results = tmp_path / "results"
    store.write(results / "quick", result(spec(seed=1)))
    store.write(tmp_path / "scratch" / "offpolicy", result(spec(seed=2)))
    (results / "offpolicy").symlink_to(tmp_path / "scratch" / "offpolicy")
    seeds = [r.spec.seed for r in store.scan_under(results, besides=results / "quick")]
    assert seeds == [2]
    seeds = [r.spec.seed for r in store.scan_under(results, besides=tmp_path / "scratch/offpolicy")]
    assert seeds == [1]
    assert sorted(r.spec.seed for r in store.scan_under(results)) == [1, 2]


@pytest.mark.parametrize(
    ("edit", "named"),
    [
        (lambda raw: raw | {"env_steps": "many"}, "env_steps is 'many'"),
        (lambda raw: raw | {"spec": raw["spec"] | {"seed": "3"}}, "spec.seed is '3'"),
        (lambda raw: raw | {"returns": ["high"]}, "returns[0] is 'high'"),
        (lambda raw: raw | {"wall_time": True}, "wall_time is True"),
        (lambda raw: {k: v for k, v in raw.items() if k != "status"}, "status is None"),
    ],
)
def test_a_malformed_record_is_named_once_and_left_out(tmp_path, edit, named):
    """A record with a wrong type or a missing field never reaches costs, reports or links."""
    from bench.harness.costs import CostModel

    folder = tmp_path / "res"
    good = store.write(folder, result(spec(seed=1)))
    bad = store.write(folder, result())
    bad.write_text(json.dumps(edit(json.loads(bad.read_text()))))
    with pytest.warns(UserWarning) as caught:
        records = list(store.scan(folder))
    assert [r.trial_id for r in records] == [good.stem]
    assert (
        len(caught) == 1 and named in str(caught[0].message) and bad.name in str(caught[0].message)
    )
    with pytest.warns(UserWarning):
        assert CostModel.of(store.scan(folder)).seconds(spec()) is not None
        assert list(frames.load(folder)["trial_id"]) == [good.stem]
    assert store.find(tmp_path, {bad.stem, good.stem}) == {good.stem: good}


def test_a_renamed_record_is_left_out_and_an_ok_one_without_returns_is_retried(tmp_path):
    from bench.harness.runner import pending

    path = store.write(tmp_path, result())
    path.rename(path.with_name("0123456789abcdef.json"))
    with pytest.warns(UserWarning, match="not to its file name"):
        assert list(store.scan(tmp_path)) == []
    empty = store.write(tmp_path, result(spec(seed=2), returns=()))
    with pytest.warns(UserWarning, match="not to its file name"):  # still there, still out
        (record,) = [r for r in store.scan(tmp_path) if r.trial_id == empty.stem]
    have = {record.trial_id: store.status_of(record)}
    assert have == {empty.stem: store.NO_RETURN}
    assert pending([record.spec], have, retry_failed=False) == []
    assert pending([record.spec], have, retry_failed=True) == [record.spec]


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_files_are_written_with_the_users_umask(tmp_path, umask, mode):
    from bench import atomic

    before = os.umask(umask)
    try:
        path = atomic.write_text(tmp_path / "record.json", "{}")
    finally:
        os.umask(before)
    assert path.stat().st_mode & 0o777 == mode


def test_links_a_copy_broke_are_one_warning_for_all_of_them(tmp_path):
    """A folder copied without the folder its links point into: every link is broken, and a
    warning apiece would bury the report; one says how many, and the rest reads as before."""
    theirs, mine = tmp_path / "theirs", tmp_path / "mine"
    for seed in range(3):
        r = result(spec(seed=seed))
        store.link(mine, r.spec, "GAIfO", store.write(theirs, r))
    kept = result(spec(seed=9))
    store.write(mine, kept)
    shutil.rmtree(theirs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert [r.trial_id for r in store.scan(mine)] == [kept.trial_id]
    said = [str(w.message) for w in caught]
    assert len(said) == 1 and "skipping 3 records" in said[0] and "not there" in said[0], said
