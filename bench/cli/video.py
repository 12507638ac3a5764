"""`bench video`: the learned policies side by side (chosen and laid out by
`bench.analysis.video`, filmed by `bench.harness.film`)."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

from bench.cli.args import at_least, out_file


def _video(args: argparse.Namespace) -> int:
    from bench.analysis.video import VideoError, video
    from bench.harness import store

    if not store.trials_dir(args.results).is_dir():
        raise FileNotFoundError(f"{args.results}: no trial records (no trials/ folder)")
    if args.out.suffix not in (".gif", ".mp4"):
        raise VideoError(f"video: --out must end in .gif or .mp4, not {args.out.name!r}")
    if args.out.suffix == ".mp4" and importlib.util.find_spec("imageio_ffmpeg") is None:
        raise VideoError(
            "video: an .mp4 needs imageio-ffmpeg (pip install 'ifo-bench[video]'); a .gif does not"
        )
    if args.out.is_dir():
        raise VideoError(f"video: --out {args.out} is a folder")
    out, titles = video(
        args.results,
        args.out,
        env_id=args.env,
        algorithms=args.algorithm,
        n_demos=args.demos,
        seed=args.seed,
        steps=args.steps,
        size=args.size,
        fps=args.fps,
    )
    print(f"wrote {out}: {', '.join(titles)}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    """The `video` command."""
    vid = sub.add_parser(
        "video",
        help="the expert and learned policies side by side, as a GIF or MP4",
        description="Roll out the expert and each learner's kept policy (one seed, one demo"
        " count) from the same start state and film them side by side, each titled with the"
        " normalized return its record scored.",
    )
    vid.add_argument("results", type=Path, help="a results folder, e.g. results/pybullet")
    vid.add_argument("--out", type=out_file, required=True, help="FILE.gif or FILE.mp4")
    vid.add_argument("--env", metavar="ID", help="the env (needed where the folder has several)")
    vid.add_argument(
        "--algorithm",
        action="append",
        metavar="NAME",
        help="a learner or label (repeatable; default all)",
    )
    vid.add_argument("--demos", type=int, help="demonstration count (default the largest run)")
    vid.add_argument("--seed", type=at_least(0), default=0, help="which trials (default 0)")
    vid.add_argument(
        "--steps", type=at_least(1), default=300, help="env steps filmed (default 300)"
    )
    vid.add_argument(
        "--size", type=at_least(16), default=200, help="panel side in pixels (default 200)"
    )
    vid.add_argument("--fps", type=at_least(1), default=30, help="frames per second (default 30)")
    vid.set_defaults(func=_video)
