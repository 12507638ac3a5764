"""`bench verify`: a record that this machine computes is identical, an edited one differs."""

import json

PENDULUM = "InvertedPendulum-v5"
SUITE = f"""name: v
envs:
  {PENDULUM}: {{budget: 4096}}
demos: [1]
algorithms: [random, {{gaifo: {{n_envs: 2, steps_per_env: 512}}}}]
seeds: 1
eval_episodes: 2
"""


def test_verify_says_identical_then_where_an_edited_record_parts(tmp_path, cli):
    suite = tmp_path / "v.yaml"
    suite.write_text(SUITE)
    results = tmp_path / "r"
    assert cli("run", str(suite), "--results", str(results), "--jobs", "1").returncode == 0

    out = cli("verify", str(results), "--steps", "3072")
    assert out.returncode == 0, out.stderr
    assert "2 of 2 identical" in out.stdout
    assert "first 2 updates" in out.stdout and "whole trial" in out.stdout  # gaifo, random

    (gaifo,) = [p for p in (results / "trials").glob("*.json") if '"gaifo"' in p.read_text()]
    record = json.loads(gaifo.read_text())
    record["logs"]["disc_loss"][0] += 1e-7  # the first update's loss, as another CPU's
    gaifo.write_text(json.dumps(record))
    out = cli("verify", str(results), "--steps", "3072", "--algorithm", "gaifo")
    assert out.returncode == 1
    assert "**differs** | parts at update 1 of 2: disc_loss" in out.stdout
    assert "0 of 1 identical, 1 differ" in out.stdout


def test_verify_refuses_a_trial_it_does_not_hold(tmp_path, cli):
    (tmp_path / "r" / "trials").mkdir(parents=True)
    out = cli("verify", str(tmp_path / "r"), "--trial", "0123456789abcdef")
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1
