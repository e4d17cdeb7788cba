"""The `twinray-ray` command.

    twinray-ray render SCENE --frames 0..239 -o shots/f_####.png --stereo --layout sbs
    twinray-ray render SCENE --tiles 16 -o big.png --size 4096x4096 --address auto

Options it does not know are passed to `twinray render` as they are.
"""

from __future__ import annotations

import argparse
import logging
import os
import socket
import sys
from typing import List, Optional

from .binary import BinaryNotFound, find_twinray
from .driver import Interrupted, RenderFailed, run_frames, run_tiles


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
        help="Ray cluster to use: 'auto' (the one `ray start` runs on this machine) or HOST:PORT "
        "(default: $RAY_ADDRESS if set, else a local cluster started for the run)",
    )
    r.add_argument(
        "--twinray",
        metavar="PATH",
        help="twinray binary (default: $TWINRAY_BIN, twinray on the PATH, "
        "or target/release/twinray of the repository)",
    )
    r.add_argument("--chunk", type=int, default=4, metavar="K", help="frames a task renders (default 4)")
    r.add_argument(
        "--max-retries",
        type=int,
        default=2,
        help="retries of a task whose worker or twinray died (default 2: three attempts in all)",
    )
    r.add_argument(
        "--cpus-per-task",
        type=float,
        default=1,
        help="CPUs Ray reserves for a task; twinray gets as many threads (default 1)",
    )
    r.add_argument("--num-cpus", type=int, help="CPUs of the local cluster started without --address")
    r.add_argument("--journal", metavar="FILE", help="append a line to FILE for every file written")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no notes")
    return p


def _say(message: str) -> None:
    print(f"twinray-ray: {message}", file=sys.stderr)


def _reachable(address: str) -> Optional[str]:
    """None if something listens at HOST:PORT, else why not."""
    host, _, port = address.rpartition(":")
    if "://" in address or not host or not port.isdigit():
        return None  # Ray's own forms (ray://...): Ray says what is wrong
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=5).close()
    except OSError as e:
        return e.strerror or str(e)
    return None


START_ONE = (
    "start one with `ray start --head` (other machines join it with "
    "`ray start --address=HOST:6379`), or leave out --address to start a local one for this run"
)


def _auto_address() -> Optional[str]:
    """The address `--address auto` leads to, as Ray finds it (None if this
    Ray cannot say); raises ConnectionError if it finds none."""
    try:
        from ray._private.services import canonicalize_bootstrap_address
    except ImportError:
        return None
    return canonicalize_bootstrap_address("auto")


def connect(address: Optional[str], num_cpus: Optional[int]) -> None:
    """Joins the cluster at `address`, or starts a local one; raises
    RenderFailed in one line if there is none to join. An address that does
    not answer is said at once, where Ray would try for minutes."""
    import ray

    if address is None:
        # A Ray job's entrypoint is given its cluster in $RAY_ADDRESS.
        address = os.environ.get("RAY_ADDRESS") or None
    quiet = dict(log_to_driver=False, logging_level=logging.WARNING)
    if address is None:
        # Ray gives a node 30 s to start: a busy machine may need a second try.
        for attempt in (1, 2):
            try:
                ray.init(address="local", num_cpus=num_cpus, include_dashboard=False, **quiet)
                return
            except Exception as e:  # Ray's start-up failed (a busy machine, no /dev/shm, ...)
                ray.shutdown()
                if attempt == 2:
                    raise RenderFailed(f"cannot start a local Ray cluster: {_first_line(e)}") from None
    try:
        target = _auto_address() if address == "auto" else address
        if target:
            why = _reachable(target)
            if why and address == "auto":
                raise RenderFailed(
                    f"--address auto: the Ray cluster last started on this machine ({target}) "
                    f"does not answer ({why}); {START_ONE}"
                )
            if why:
                raise RenderFailed(
                    f"no Ray cluster answers at {address} ({why}): start one there with "
                    f"`ray start --head --port={address.rpartition(':')[2]}`, or leave out "
                    "--address to start a local one"
                )
        ray.init(address=address, **quiet)
    except ConnectionError:
        raise RenderFailed(
            f"--address {address}: no Ray cluster is running on this machine: {START_ONE}"
        ) from None
    except RenderFailed:
        raise
    except Exception as e:
        raise RenderFailed(f"--address {address}: cannot join the Ray cluster: {_first_line(e)}") from None


def _first_line(err: Exception) -> str:
    lines = [l for l in str(err).splitlines() if l.strip()]
    return lines[0] if lines else type(err).__name__


def main(argv: Optional[List[str]] = None) -> int:
    args, extra = parser().parse_known_args(argv)
    import ray

    started = False
    try:
        twinray = find_twinray(args.twinray)
        if not ray.is_initialized():
            connect(args.address, args.num_cpus)
            started = True
        common = dict(
            extra=extra,
            max_retries=args.max_retries,
            cpus_per_task=args.cpus_per_task,
            journal=args.journal,
            progress=not args.quiet,
            on_note=(lambda note: None) if args.quiet else None,
        )
        if args.frames:
            s = run_frames(twinray, args.scene, args.output, args.frames, chunk=args.chunk, **common)
            _say(f"{len(s.written)} file(s) written, {len(s.skipped)} frame(s) done already")
        else:
            s = run_tiles(twinray, args.scene, args.output, args.tiles, **common)
            _say(
                f"{len(s.written)} tile file(s) written, {len(s.skipped)} tile(s) done already; "
                f"merged {', '.join(s.merged)}"
            )
    except (BinaryNotFound, RenderFailed) as e:
        _say(str(e))
        return 1
    except Interrupted as e:
        _say(f"interrupted with {e}; the same command goes on from there (record: {e.record})")
        return 130
    except KeyboardInterrupt:
        _say("interrupted")
        return 130
    finally:
        if started:
            try:
                ray.shutdown()
            except KeyboardInterrupt:
                pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
