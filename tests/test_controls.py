"""The controls: one floor and one ceiling per optimizer family, registered by one function."""

from algorithms.controls import register_controls
from bench.harness import registry


def test_each_optimizer_family_has_one_floor_and_one_ceiling_on_its_learners_settings():
    algos = registry.all_algorithms()
    controls = {(a.family, a.role): a for a in algos.values() if a.role in ("floor", "ceiling")}
    assert {(family, role): a.name for (family, role), a in controls.items()} == {
        ("trpo", "floor"): "survival",
        ("trpo", "ceiling"): "oracle",
        ("sac", "floor"): "survival-sac",
        ("sac", "ceiling"): "oracle-sac",
        ("td3", "floor"): "survival-td3",
        ("td3", "ceiling"): "oracle-td3",
    }
    # the learners that run their family's optimizer (BCO clones; it is read against TRPO's)
    learners = [a for a in algos.values() if a.role == "learner" and registry.family_of(a.config)]
    assert {a.name for a in learners} >= {"gaifo", "gail", "tcn", "gaifo-sac", "gail-sac", "opolo"}
    for learner in learners:
        for role in ("floor", "ceiling"):
            control = controls[learner.family, role]
            # a learner's settings extend its controls': a default changed for one changes for both
            assert issubclass(learner.config, control.config), (learner.name, control.name)


def test_a_family_of_its_own_gets_both_controls_from_one_call(monkeypatch):
    monkeypatch.setattr(registry, "_ALGORITHMS", dict(registry.all_algorithms()))
    trained_on = []

    def on_reward(task, budget, seed, logger, config, reward_fn):
        trained_on.append(reward_fn)
        return "policy"

    def alive(batch):
        return 1.0

    register_controls(
        "mine",
        on_reward,
        alive,
        names=("survival-mine", "oracle-mine"),
        labels=("Survival (mine)", "Oracle (mine)"),
        optimizer="Mine",
        config=registry.get("survival").config,
        min_budget=lambda config: 1,
    )
    floor, ceiling = registry.get("survival-mine"), registry.get("oracle-mine")
    assert (floor.role, floor.family, floor.label) == ("floor", "mine", "Survival (mine)")
    assert (ceiling.role, ceiling.family, ceiling.label) == ("ceiling", "mine", "Oracle (mine)")
    assert floor.inputs == ceiling.inputs == "none" and floor.resumable and ceiling.resumable
    config = floor.make_config({})
    assert floor.train(None, None, 1, 0, None, config) == "policy"
    assert ceiling.train(None, None, 1, 0, None, config) == "policy"
    assert trained_on == [alive, None]  # +1 per step alive, then the env's own reward
