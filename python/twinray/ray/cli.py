"""The `twinray-ray` command.

    twinray-ray render SCENE --frames 0..239 -o shots/f_####.png --stereo --layout sbs
    twinray-ray render SCENE --tiles 16 -o big.png --size 4096x4096 --address auto

Options it does not know are passed to `twinray render` as they are.
"""

from __future__ import annotations

import argparse
import sys
from typing import List, Optional

try:
    import ray
except ImportError:  # Ray is the package's `ray` extra
    sys.exit("twinray-ray needs Ray: pip install 'twinray[ray]'")

from .driver import RenderFailed, find_twinray, run_frames, run_tiles


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="twinray-ray",
        description="Render twinray frames or tiles across a Ray cluster.",
        allow_abbrev=False,
    )
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser(
        "render",
        allow_abbrev=False,
        help="render frames (--frames) or tiles of a still (--tiles); other options go to twinray render",
    )
    r.add_argument("scene", help="scene file, as the workers see it (a shared file system)")
    r.add_argument("-o", "--output", required=True, help="output name, as for twinray render")
    what = r.add_mutually_exclusive_group(required=True)
    what.add_argument("--frames", metavar="A..B", help="frames A to B, both included")
    what.add_argument("--tiles", type=int, metavar="N", help="N tiles of one still, merged")
    r.add_argument(
        "--address",
        default=None,
        help="Ray cluster address ('auto': the cluster this machine joined; default: a local one)",
    )
    r.add_argument("--twinray", metavar="PATH", help="twinray binary (default: on the PATH)")
    r.add_argument("--chunk", type=int, default=4, metavar="K", help="frames a task renders (default 4)")
    r.add_argument(
        "--max-retries",
        type=int,
        default=2,
        help="retries of a failed task (default 2: three attempts in all)",
    )
    r.add_argument(
        "--cpus-per-task",
        type=float,
        default=1,
        help="CPUs Ray reserves for a task; twinray gets as many threads (default 1)",
    )
    r.add_argument("--num-cpus", type=int, help="CPUs of the local cluster started without --address")
    r.add_argument("--journal", metavar="FILE", help="append a line to FILE for every file written")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    args, extra = parser().parse_known_args(argv)
    try:
        twinray = find_twinray(args.twinray)
        if not ray.is_initialized():
            if args.address:
                ray.init(address=args.address, log_to_driver=False)
            else:
                ray.init(num_cpus=args.num_cpus, log_to_driver=False)
        common = dict(
            extra=extra,
            max_retries=args.max_retries,
            cpus_per_task=args.cpus_per_task,
            journal=args.journal,
            progress=not args.quiet,
        )
        if args.frames:
            s = run_frames(twinray, args.scene, args.output, args.frames, chunk=args.chunk, **common)
            print(
                f"twinray-ray: {len(s.written)} file(s) written, {len(s.skipped)} frame(s) done already",
                file=sys.stderr,
            )
        else:
            s = run_tiles(twinray, args.scene, args.output, args.tiles, **common)
            print(
                f"twinray-ray: {len(s.written)} tile file(s) written, {len(s.skipped)} tile(s) done already; "
                f"merged {', '.join(s.merged)}",
                file=sys.stderr,
            )
    except RenderFailed as e:
        print(f"twinray-ray: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
