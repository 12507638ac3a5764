"""What trials cost, learned from finished records (their CPU time where they measured it,
else their wall time): one price for the runner's dispatch order, its progress bar,
`bench run --time-limit` and `--estimate`."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

from bench.harness import registry
from bench.harness.types import TrialResult, TrialSpec


def observed(spec: TrialSpec) -> str | None:
    """How a trial sees its env, where that is not the state vector: "pixels", "video-reward",
    with the frame size where it is not the default ("pixels 32px")."""
    if spec.observation is None or spec.frame_size is None:
        return spec.observation
    return f"{spec.observation} {spec.frame_size}px"


def cost_kind(spec: TrialSpec) -> tuple[str, str]:
    """What a trial's cost per env step depends on: its env as observed, and its algorithm, or
    the variant of it its label names (wider networks or more value epochs cost otherwise).
    Frames cost ~100x states per step, so they are another kind: "ENV (pixels)"."""
    seen = observed(spec)
    return (spec.env_id if seen is None else f"{spec.env_id} ({seen})"), priced_as(spec)


def priced_as(spec: TrialSpec) -> str:
    """The name a trial's records are priced under: its variant's label, else its algorithm."""
    return spec.label or spec.algorithm


def tally_key(spec: TrialSpec) -> tuple[str | None, str, str]:
    """Under which key `CostModel.done` keeps a trial's records: how it sees its env, the env,
    and the name it is priced under."""
    return observed(spec), spec.env_id, priced_as(spec)


@dataclass
class Tally:
    """What the finished trials of one kind say about the cost of a like trial: the median
    of theirs, so that one record made while the machine was swamped (a trial paused for
    hours, a core shared five ways) does not price every like trial several times over."""

    rates: list[float] = field(default_factory=list)
    """Of the trials that trained (whose cost grows with their budget): wall seconds over
    budget."""
    fixed: list[float] = field(default_factory=list)
    """Of the trials that trained on no env step (the references, random and expert): wall
    seconds, their evaluation's, at any budget."""
    cpu_rates: list[float] = field(default_factory=list)
    """`rates` in CPU seconds, of the records that measured them. Where there are any, they
    are what prices: a core's cost whatever else loaded the machine, where the wall time of a
    trial that shared its core with another is twice its cost."""
    cpu_fixed: list[float] = field(default_factory=list)
    """`fixed` in CPU seconds, likewise."""
    _medians: tuple[float, float] | None = field(default=None, repr=False, compare=False)
    """(rate, fixed) medians, kept until the next record lands."""

    @property
    def trials(self) -> int:
        """How many records the price rests on."""
        return sum(map(len, self._priced()))

    @property
    def trained(self) -> int:
        return len(self.rates) + len(self.cpu_rates)

    def add(self, seconds: float, budget: int, trained: bool, cpu: bool = False) -> None:
        """A record that took `seconds` (CPU seconds where `cpu`, else wall seconds)."""
        if trained:  # training time scales with the budget
            (self.cpu_rates if cpu else self.rates).append(seconds / budget)
        else:
            (self.cpu_fixed if cpu else self.fixed).append(seconds)
        self._medians = None

    @property
    def cpu_priced(self) -> bool:
        """Whether a trained trial's price rests on CPU seconds (`_priced`)."""
        return bool(self.cpu_rates)

    def _priced(self) -> tuple[list[float], list[float]]:
        """The rates and fixed times that price: CPU-measured ones where there are any."""
        return self.cpu_rates or self.rates, self.cpu_fixed or self.fixed

    def seconds_per_step(self) -> float:
        """The median of the trials that trained (0 where none did)."""
        return self._median()[0]

    def at(self, budget: float) -> float:
        """What a like trial of `budget` steps takes: the trials that trained at their median
        rate, the others at their median time, weighted by how many there are of each."""
        rate, fixed = self._median()
        rates, fixeds = self._priced()
        return (rate * budget * len(rates) + fixed * len(fixeds)) / self.trials

    def _median(self) -> tuple[float, float]:
        if self._medians is None:  # prices are asked for far more often than records land
            self._medians = tuple(float(np.median(v)) if v else 0.0 for v in self._priced())
        return self._medians


@dataclass
class CostModel:
    """What a trial is expected to cost in seconds of one core, learned from finished
    records: their CPU seconds where they measured them (`TrialResult.cpu_time`), else their
    wall seconds. One price for everything that needs one: the runner's dispatch order (longest
    first, so a run does not end with one long trial on one core while the others idle), the
    progress bar's time left, `--time-limit` and `--estimate`.

    Records predict a like trial's cost in proportion to budget, by their median (`Tally`). A
    kind with no record on this env is scaled from the algorithms that have one here, by how its
    cost per step compares with theirs on the envs where both ran (a new task's GAIfO from its
    oracle screen, say); failing that, it goes by the slowest env measured for its algorithm,
    seen the same way (rough: envs step at different speeds; a state trial never goes by a
    pixel one's).
    Budget alone is a poor guide: at the same budget a BCO trial takes 3x a GAIfO one, and the
    references (random, expert) take almost nothing. Wall times made while the machine was
    busy make a price high (CPU times do not), and the median keeps one swamped record from
    setting it. So a kind timed here only by the wall, where other kinds here measured CPU time,
    is scaled from theirs as a new kind would be: HalfCheetah's 1M GAIL records, made two to a
    core before trials measured CPU time, priced its 5M trials at twice what GAIfO's took.
    """

    done: dict[tuple[str | None, str, str], Tally] = field(default_factory=dict)
    """Finished trials' timings by (how the env is seen, env, algorithm)."""
    lock: threading.Lock = field(default_factory=threading.Lock)  # joblib dispatches from a thread
    done_before: dict[str, float] = field(default_factory=dict)
    """Trial id -> the fraction of its budget a snapshot has behind it (`bench.harness.snapshots`):
    a resumed trial costs only what it has left."""
    pace: list[tuple[float, float]] = field(default_factory=list)
    """(expected, taken) wall seconds of the trials this run has finished: how fast this machine
    is today against the machines (or the load) the records were made on."""

    @classmethod
    def of(cls, records: Iterable[TrialResult]) -> CostModel:
        costs = cls()
        for record in records:
            costs.observe(record)
        return costs

    def observe(self, record: TrialResult) -> None:
        """Learn from a finished record (failed ones and zero budgets say nothing)."""
        if record.status == "ok" and record.spec.budget > 0:
            spec = record.spec
            with self.lock:
                tally = self.done.setdefault(tally_key(spec), Tally())
                measured = record.cpu_time is not None
                seconds = record.cpu_time if measured else record.wall_time
                tally.add(seconds, spec.budget, trained=record.env_steps > 0, cpu=measured)

    def finished(self, record: TrialResult) -> None:
        """Learn from a record this run has just written: what it took against what it was
        expected to take (`pace`), then its cost (`observe`). Only a price that rests on
        records of its own kind, measured as this one is, sets the pace: a CPU-timed trial
        against a price from wall times made on a loaded machine would say this machine is
        fast where that price is merely high (a 10M PyBullet oracle priced at 77 min, its
        records' wall time, took 52 min; a pace of 0.67 then made a 50-min trial fit in 36)."""
        spec = record.spec
        expected = self.seconds(spec)
        trained = record.status == "ok" and record.env_steps > 0 and not record.resumed_at
        with self.lock:
            tally = self.done.get(tally_key(spec))
            alike = tally is not None and tally.cpu_priced == (record.cpu_time is not None)
            if trained and expected and alike:
                self.pace.append((expected, record.wall_time))
        self.observe(record)

    def pace_factor(self) -> float:
        """This run's trials' seconds over what they were expected to take (1: no trial yet)."""
        with self.lock:
            expected = sum(e for e, _ in self.pace)
            taken = sum(t for _, t in self.pace)
        return taken / expected if expected > 0 else 1.0

    def price(self, spec: TrialSpec) -> tuple[float | None, str]:
        """Expected wall seconds of `spec` (None: nothing to go by), and what that rests on. A
        labelled variant goes by its own records; with none anywhere yet, by its algorithm's,
        and the basis says so (its settings may cost otherwise)."""
        name = priced_as(spec)
        with self.lock:
            variant_seen = any(n == name for (_, _, n) in self.done)
        if name != spec.algorithm and not variant_seen:
            seconds, basis = self._price(spec, spec.algorithm)
            return seconds, f"{basis}; {spec.algorithm}'s: no {name} trial yet"
        return self._price(spec, name)

    def _price(self, spec: TrialSpec, name: str) -> tuple[float | None, str]:
        """`price` from the records kept under `name`."""
        seen = observed(spec)
        with self.lock:
            by_env = {  # this env's, if measured, and every other env's seen the same way
                env: tally.at(spec.budget)
                for (o, env, algorithm), tally in self.done.items()
                if o == seen and algorithm == name
            }
            tally = self.done.get((seen, spec.env_id, name), Tally())
            measured = spec.env_id in by_env  # else: scaled from the algorithms measured here
            scaled = None if measured else self._scaled(seen, spec.env_id, name)
            # Wall times alone here, where others measured CPU time: go by theirs, scaled.
            wall_only = tally.trained and not tally.cpu_priced
            rescaled = self._scaled(seen, spec.env_id, name, cpu_only=True) if wall_only else None
        if measured and rescaled is not None:
            per_step, others = rescaled
            return per_step * spec.budget, (
                f"as {', '.join(others)} here, scaled by CPU times; its {tally.trials} here "
                "timed only the wall"
            )
        if measured:
            return by_env[spec.env_id], f"median of {tally.trials} trials"
        if scaled is not None:
            per_step, others = scaled
            return per_step * spec.budget, f"as {', '.join(others)} here, scaled"
        if by_env:
            slowest = max(by_env, key=by_env.get)
            shown = slowest if seen is None else f"{slowest} ({seen})"
            return by_env[slowest], f"rough: as on {shown}, the slowest measured"
        with self.lock:
            peers = self._family_here(seen, spec.env_id, spec.algorithm)
        if peers is not None:
            per_step, family, others = peers
            return per_step * spec.budget, f"rough: as the {family} learners here ({others})"
        return None, f"no finished {name} trial"

    def _family_here(
        self, seen: str | None, env_id: str, algorithm: str
    ) -> tuple[float, str, str] | None:
        """For a learner never timed anywhere (a plugin's first run): the median seconds per
        step of the learners of its optimizer family that trained on `env_id` (a new reward
        on TRPO costs about what GAIfO's does), the family, and their names. None where it has
        no family or none of its family trained here. Called with the lock held."""
        role, family, _ = registry.describe(algorithm)
        if role != "learner" or family is None:
            return None
        rates = {
            other: tally.seconds_per_step()
            for (o, env, other), tally in self.done.items()
            if o == seen
            and env == env_id
            and tally.trained
            and other != algorithm
            and registry.describe(other)[:2] == ("learner", family)
        }
        if not rates:
            return None
        return float(np.median(list(rates.values()))), family, ", ".join(sorted(rates))

    def _scaled(
        self, seen: str | None, env_id: str, algorithm: str, cpu_only: bool = False
    ) -> tuple[float, list[str]] | None:
        """Seconds per step of `algorithm` on `env_id` (seen as `seen`) from the algorithms
        that trained there: each one's rate here times the geometric mean, over the other envs
        where both trained, of `algorithm`'s rate over its; the geometric mean of those. And
        the algorithms it rests on. None where no algorithm here ran beside it elsewhere.
        `cpu_only`: from the kinds priced by CPU time alone. Called with the lock held."""
        rates: dict[str, dict[str, float]] = {}  # algorithm -> env -> seconds per step
        for (o, env, algo), tally in self.done.items():
            if o == seen and tally.trained and (tally.cpu_priced or not cpu_only):
                rates.setdefault(algo, {})[env] = tally.seconds_per_step()
        mine = rates.get(algorithm, {})
        guesses, others = [], []
        for other, theirs in sorted(rates.items()):
            shared = [e for e in theirs if e in mine and e != env_id]
            if other == algorithm or env_id not in theirs or not shared:
                continue
            ratio = np.mean([np.log(mine[e] / theirs[e]) for e in shared])
            guesses.append(np.log(theirs[env_id]) + ratio)
            others.append(other)
        return (float(np.exp(np.mean(guesses))), others) if guesses else None

    def seconds(self, spec: TrialSpec) -> float | None:
        """Expected wall seconds of `spec` (None: nothing to go by), less what its snapshot
        has behind it."""
        price = self.price(spec)[0]
        return None if price is None else price * (1 - self.done_before.get(spec.trial_id, 0.0))

    def wall_seconds(self, spec: TrialSpec) -> float | None:
        """`seconds` at this run's pace: what `spec` should take on the clock here, where a
        price in CPU seconds says what it costs a core (a core shared with other work, or a
        slower machine, takes longer; `pace_factor`)."""
        seconds = self.seconds(spec)
        return None if seconds is None else seconds * self.pace_factor()

    def priority(self, spec: TrialSpec) -> tuple[bool, int, float]:
        """Higher runs sooner: trials resuming from a snapshot first (finish work begun before
        starting new work), then unpriced kinds (by budget, to learn their cost), then by
        expected seconds."""
        resuming = self.done_before.get(spec.trial_id, 0.0) > 0
        seconds = self.seconds(spec)
        return (resuming, 1, float(spec.budget)) if seconds is None else (resuming, 0, seconds)

    def time_left(self, specs: Iterable[TrialSpec], workers: int) -> str:
        """What `specs` should take on `workers` cores, for a progress bar: "~2.5 h", with
        "+N unpriced" for trials with nothing to go by; corrected by this run's pace (a machine
        twice as slow as the records' doubles it after its first trials)."""
        expected = [self.seconds(spec) for spec in specs]
        unpriced = sum(s is None for s in expected)
        if expected and unpriced == len(expected):
            return f"unknown ({unpriced} trials of kinds never timed)"
        priced = sum(s for s in expected if s is not None) * self.pace_factor()
        hours = priced / 3600 / max(workers, 1)
        text = f"~{hours:.1f} h" if hours >= 1 else f"~{hours * 60:.0f} min"
        return text + (f" +{unpriced} unpriced" if unpriced else "")


@dataclass(frozen=True)
class Estimate:
    """`bench run --estimate`'s row: one (env, algorithm) of the pending trials."""

    env_id: str
    """The env id, with its observation in parentheses where it is not states."""
    algorithm: str
    trials: int
    seconds: float | None
    """Expected wall seconds of one trial on one core (None: nothing to go by)."""
    basis: str
    """What the estimate rests on."""


def estimate(
    specs: list[TrialSpec],
    records: Iterable[TrialResult],
    done_before: dict[str, float] | None = None,
) -> list[Estimate]:
    """Expected cost of `specs` per (env, algorithm) as `CostModel` prices them from `records`
    (less what their snapshots have behind them, `done_before`): one trial's mean price, and
    its basis."""
    costs = CostModel.of(records)
    costs.done_before = done_before or {}
    groups: dict[tuple[str, str], list[TrialSpec]] = {}
    for spec in specs:
        groups.setdefault(cost_kind(spec), []).append(spec)
    out = []
    for (env_id, algorithm), group in groups.items():
        basis = costs.price(group[0])[1]
        prices = [costs.seconds(spec) for spec in group]
        seconds = None if prices[0] is None else float(np.mean(prices))
        out.append(Estimate(env_id, algorithm, len(group), seconds, basis))
    return out


PAUSE_FLOOR_S = 300.0
"""Default least time left for which a trial that will not finish is still started under a time
limit, to pause at the deadline: with less, its start and its snapshot would be most of what it
did."""


@dataclass(frozen=True)
class TimeLimit:
    """A wall-clock end for a run, so that a run on a cluster's wall-clock allowance or in a
    session that ends loses no work: a trial fits if its expected seconds fit in what is left
    (one with nothing to go by never fits). The runner starts the trials that fit and, where
    snapshots are on, resumable ones that do not, which pause at the deadline."""

    deadline: float
    """On `clock`'s scale."""
    clock: Callable[[], float] = time.monotonic
    pause_floor_s: float = PAUSE_FLOOR_S
    """The least time left for which a trial that will not finish is still started."""
    pause: bool = True
    """Whether trials that will not finish are started at all, to pause at the deadline. Not
    where the disk does not outlive the run (a machine wiped at the end of its lease): their
    snapshots would be lost with it, and all they did."""

    @classmethod
    def starting_now(
        cls,
        limit: float,
        clock: Callable[[], float] = time.monotonic,
        pause_floor_s: float = PAUSE_FLOOR_S,
        pause: bool = True,
    ) -> TimeLimit:
        return cls(clock() + limit, clock, pause_floor_s, pause)

    def fits(self, expected: float | None) -> bool:
        return expected is not None and self.clock() + expected <= self.deadline

    def left(self) -> float:
        """Seconds to the deadline (negative past it)."""
        return self.deadline - self.clock()

    def worth_pausing(self) -> bool:
        """Whether a trial that will not finish is still worth starting, to pause at the
        deadline."""
        return self.pause and self.left() >= self.pause_floor_s

    def wall_deadline(self) -> float:
        """The deadline as a `time.time()`, which workers in other processes can read."""
        return time.time() + self.left()
