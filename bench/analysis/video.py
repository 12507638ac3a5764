"""`bench video`: the expert and learned policies side by side, from the same start state.

A bar says how far a learner got; a video says how: whether GAIfO's hopper hops like the
expert or leans forward like the survival control. Each panel is one policy, filmed
deterministically in its own env reset with the same seed (so every panel starts from the
same state; `bench.harness.film` steps the envs), and titled with the normalized return its
record scored. A panel whose episode ended holds its last frame, dimmed. A pixel learner acts
on the frames it was trained on; its panel shows them, enlarged, beside the full view.

Choosing (which records, titled how: `panels`) is kept apart from filming (the harness's),
from drawing (`compose`) and from writing (`write`, imageio: .gif, or .mp4 where
imageio-ffmpeg is installed).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from bench.analysis import labels
from bench.analysis.labels import Names, is_reference
from bench.analysis.normalize import normalize
from bench.demos import experts
from bench.errors import BadInput
from bench.harness import frames, policies, store
from bench.harness.film import film_episode
from bench.harness.registry import Policy
from bench.harness.trial import EVAL_SEED
from bench.harness.types import TrialSpec

TITLE_HEIGHT = 22
"""Pixels above each panel for its title."""
FONT = ImageFont.load_default(size=14)


class VideoError(BadInput, ValueError):
    """A selection that matches nothing playable; the message is one line."""


@dataclass(frozen=True)
class Panel:
    """One policy of a video, as chosen and titled (`panels`), before it is filmed."""

    title: str
    """Its label and the normalized return its record scored: "GAIfO 0.93"."""
    policy: Policy
    """The kept policy (the expert's for the first panel)."""
    env_id: str
    """The env it is filmed in (the folder's env that `panels` chose)."""
    spec: TrialSpec | None = None
    """The learner's trial (None: the shipped expert)."""


def panels(
    results_dir: str | Path,
    env_id: str | None = None,
    algorithms: list[str] | None = None,
    n_demos: int | None = None,
    seed: int = 0,
) -> list[Panel]:
    """The expert, then one panel per learner (a label, in plot order) of `results_dir` with a
    kept policy: its trial at `n_demos` demonstrations (default the largest count run) and
    `seed`; demonstration-free controls at theirs. `env_id` may be left out where the folder
    holds one env. Raises VideoError naming what is missing."""
    trials = frames.load(results_dir)
    if trials.empty:
        raise VideoError(f"{results_dir}: no trial records")
    have = labels.env_order(trials["env_id"].unique())
    if env_id is None:
        if len(have) > 1:
            raise VideoError(
                f"{results_dir} holds {len(have)} envs: pick one with --env ({', '.join(have)})"
            )
        env_id = have[0]
    if env_id not in have:
        raise VideoError(f"{results_dir} has no trials of {env_id} (has: {', '.join(have)})")
    rows = normalize(trials[trials["env_id"] == env_id])
    rows = rows[(rows["status"] == "ok") & ~is_reference(rows)]
    counts = sorted(int(n) for n in rows["n_demos"].unique() if n > 0)
    n_demos = n_demos if n_demos is not None else (counts[-1] if counts else 0)
    if counts and n_demos not in counts:
        raise VideoError(f"no trials with {n_demos} demos on {env_id} (have: {counts})")
    at_count = rows[rows["n_demos"].isin([0, n_demos])]
    rows = at_count[at_count["seed"] == seed]
    if rows.empty and not at_count.empty:  # only the expert would be filmed
        have = sorted(at_count["seed"].unique())
        seeds = ", ".join(map(str, have if len(have) <= 12 else [*have[:3], "...", have[-1]]))
        raise VideoError(f"no learner's trial of seed {seed} on {env_id} (seeds: {seeds})")
    shown = Names.of(rows)
    names = shown.order(rows["algorithm"].unique())
    if algorithms:
        unknown = sorted(set(algorithms) - set(names))
        if unknown:
            raise VideoError(
                f"no {', '.join(unknown)} with seed {seed} on {env_id} (have: {', '.join(names)})"
            )
        names = [a for a in names if a in algorithms]
    result = [Panel("Expert 1.00", experts.load_expert(env_id), env_id)]
    for name in names:
        row = rows[rows["algorithm"] == name].iloc[0]
        record = store.read(store.record_path(results_dir, row["trial_id"]))
        file = policies.path(record.stored_in or results_dir, row["trial_id"])
        if not file.is_file():
            raise VideoError(
                f"{file}: no policy kept for {name}, seed {seed} (run before policies were kept?)"
            )
        spec = record.spec
        label = shown[name].label + (" (true reward)" if row["role"] == "ceiling" else "")
        result.append(Panel(f"{label} {row['normalized']:.2f}", policies.load(file), env_id, spec))
    return result


def compose(titles: list[str], films: list[list[np.ndarray]]) -> list[np.ndarray]:
    """One (H + title, sum of widths, 3) frame per step: the panels left to right, each under
    its title."""
    headers = []
    for title, film in zip(titles, films, strict=True):
        header = Image.new("RGB", (film[0].shape[1], TITLE_HEIGHT), "white")
        ImageDraw.Draw(header).text((4, 3), title, fill="black", font=FONT)
        headers.append(np.asarray(header))
    return [
        np.concatenate(
            [np.concatenate([h, f], axis=0) for h, f in zip(headers, step, strict=True)], axis=1
        )
        for step in zip(*films, strict=True)
    ]


def write(frames: list[np.ndarray], out: str | Path, fps: int = 30) -> Path:
    """Write `frames` as a GIF or an MP4 (by `out`'s suffix) with imageio."""
    import imageio.v3 as iio

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix == ".gif":
        iio.imwrite(out, np.stack(frames), duration=1000 / fps, loop=0)
    else:
        iio.imwrite(out, np.stack(frames), fps=fps)
    return out


MAX_BYTES = 2 * 2**30
"""A video's frames are held in memory until it is written: refused above this."""


def video(
    results_dir: str | Path,
    out: str | Path,
    env_id: str | None = None,
    algorithms: list[str] | None = None,
    n_demos: int | None = None,
    seed: int = 0,
    steps: int = 300,
    size: int = 200,
    episode_seed: int = EVAL_SEED,
    fps: int = 30,
) -> tuple[Path, list[str]]:
    """Render the chosen panels (`panels`) to `out`; return the path and the panels' titles.
    `episode_seed` resets every panel's env alike (default: the first evaluation episode of
    seed 0, as the runner scored it)."""
    chosen = panels(results_dir, env_id, algorithms, n_demos, seed)
    held = len(chosen) * (steps + 1) * size * size * 3 * 2  # the films, then the composed frames
    if held > MAX_BYTES:
        raise VideoError(
            f"video: {len(chosen)} panels of {steps} steps at {size} x {size} would hold"
            f" {held / 2**30:.1f} GiB of frames in memory (at most {MAX_BYTES / 2**30:.0f});"
            " film fewer steps, smaller panels, or fewer algorithms"
        )
    films = [film_episode(p.policy, p.env_id, size, steps, episode_seed, p.spec) for p in chosen]
    titles = [p.title for p in chosen]
    return write(compose(titles, films), out, fps), titles
