"""Ray tasks that run the twinray binary on shares of a render.

A share of an animation is ``twinray render SCENE -o OUT --frames A..B
--only C..D --skip-existing``: the camera motion and the shot's stereo rig
are those of the whole range ``A..B`` whatever share a task renders, and
frames whose files exist are skipped, so a retried task (or a re-run)
renders only what is missing. A share of a still is one tile, ``--tiles N
--tile K``; the tiles are merged by ``twinray merge`` at the end.

twinray writes each file atomically under its final name; a task whose
worker dies takes its twinray process with it (the child gets SIGTERM,
cancels its render and removes its temporary file), so nothing partial is
left.

Progress is per frame, not per share: twinray prints ``frame N: wrote
PATH`` (or ``frame N: done already``) as each frame is finished; the task
reports the frame to a small actor (:class:`ProgressLog`) at once, and the
driver, polling it while it waits for the tasks, advances the bar by one
for every frame it has not seen (a frame written by an attempt that died,
then skipped by the retry, counts once).
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, List, Optional, Sequence, Tuple

import ray

# Environment variable: a file path. The first task attempt that finds it
# missing creates it and kills its own worker after its first frame (a
# fault injected for the tests).
FAULT_ENV = "TWINRAY_RAY_FAULT"


class TwinrayError(Exception):
    """twinray exited with an error; the message is its own."""


class RenderFailed(Exception):
    """A share failed on every attempt."""


@dataclass
class Summary:
    """What a run did."""

    written: List[str] = field(default_factory=list)
    skipped: List[int] = field(default_factory=list)
    merged: List[str] = field(default_factory=list)


def find_twinray(given: Optional[str]) -> str:
    """The twinray binary: `given`, or `twinray` on the PATH."""
    if given:
        path = Path(given)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise RenderFailed(f"--twinray {given}: not an executable file")
        return str(path.resolve())
    found = shutil.which("twinray")
    if not found:
        raise RenderFailed(
            "twinray is not on the PATH: build it (cargo build --release) and "
            "give --twinray PATH, or put target/release on the PATH"
        )
    return found


def parse_range(text: str, flag: str) -> Tuple[int, int]:
    """`A..B` (both included) as a pair."""
    m = re.fullmatch(r"\s*(\d+)\s*\.\.=?\s*(\d+)\s*", text)
    if not m or int(m.group(2)) < int(m.group(1)):
        raise RenderFailed(f"{flag} '{text}': give A..B, first and last included")
    return int(m.group(1)), int(m.group(2))


def chunks(first: int, last: int, size: int) -> List[Tuple[int, int]]:
    """`first..last` in consecutive ranges of `size` frames."""
    size = max(1, size)
    return [(a, min(a + size - 1, last)) for a in range(first, last + 1, size)]


def _die_with_parent() -> None:
    """In the child: SIGTERM when the worker that started it dies (Linux)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


@ray.remote(num_cpus=0)
class ProgressLog:
    """The frames the tasks report finished, in the order they arrive."""

    def __init__(self) -> None:
        self.units: List[str] = []

    def done(self, unit: str) -> None:
        self.units.append(unit)

    def since(self, start: int) -> List[str]:
        return self.units[start:]


# How often the driver asks the progress log for news (seconds).
POLL_S = 0.2

FRAME_LINE = re.compile(r"frame (\d+): (wrote (.*)|done already)")


def write_journal(journal: Optional[str], path: str) -> None:
    """Appends `wrote PATH` to the journal, if there is one."""
    if journal:
        with open(journal, "a", encoding="utf-8") as j:
            j.write(f"wrote {path}\n")


@ray.remote
def render_share(
    twinray: str,
    args: List[str],
    journal: Optional[str],
    fault: Optional[str],
    progress: Optional["ray.actor.ActorHandle"] = None,
) -> dict:
    """Runs `twinray ARGS`; returns the files written and frames skipped,
    and reports each frame to `progress` as twinray finishes it."""
    proc = subprocess.Popen(
        [twinray, *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
    )
    wrote: List[str] = []
    skipped: List[int] = []
    said: List[str] = []
    assert proc.stderr is not None
    reported = set()

    def report(frame: Optional[int]) -> None:
        if progress is not None and frame is not None and frame not in reported:
            reported.add(frame)
            ray.get(progress.done.remote(f"frame {frame}"))

    for line in proc.stderr:
        line = line.rstrip("\n")
        m = FRAME_LINE.match(line)
        frame = None
        if m:  # a frame: `frame N: wrote PATH` or `frame N: done already`
            frame, path = int(m.group(1)), m.group(3)
            if path is None:
                skipped.append(frame)
                report(frame)
                continue
        elif line.startswith("wrote "):  # a tile: its files
            path = line[len("wrote ") :]
        else:
            said.append(line)
            continue
        wrote.append(path)
        write_journal(journal, path)
        if fault and not os.path.exists(fault):
            Path(fault).write_text(f"worker {os.getpid()} killed mid-run\n")
            # The injected death, made deterministic: twinray gets the
            # SIGTERM it would get from the worker's death, and whatever it
            # finished writing before it stopped is journaled, as a real
            # death can leave finished files behind for the retry to skip.
            proc.terminate()
            for rest in proc.stderr:
                late = FRAME_LINE.match(rest.rstrip("\n"))
                if late and late.group(3) is not None:
                    write_journal(journal, late.group(3))
            proc.wait()
            os._exit(1)  # the worker dies; Ray retries the task
        # After the journal and the fault: the actor call takes a moment
        # in which twinray goes on writing frames.
        report(frame)
    code = proc.wait()
    if code != 0:
        message = " / ".join(l for l in said if l.strip()) or f"exit status {code}"
        raise TwinrayError(message)
    return {"wrote": wrote, "skipped": skipped}


def _threads(extra: Sequence[str], cpus: float) -> List[str]:
    """`--threads` for the task's CPUs unless the caller chose."""
    if any(a == "--threads" or a.startswith("--threads=") for a in extra):
        return []
    return ["--threads", str(max(1, int(cpus)))]


def _why(err: Exception) -> str:
    """twinray's own message from a Ray task error."""
    cause = getattr(err, "cause", None)
    if isinstance(cause, TwinrayError):
        return str(cause)
    text = str(err).strip().splitlines()
    return text[-1] if text else type(err).__name__


def gather(
    tasks: dict,
    total: int,
    progress: bool,
    unit: str,
    log: Optional["ray.actor.ActorHandle"],
    on_progress: Optional[Callable[[str], None]],
) -> Tuple[List[dict], List[str]]:
    """Waits for every task with a progress bar; returns results and
    failures. With a progress `log` the bar advances per unit the tasks
    report (a frame); without, per task finished (a tile)."""
    from tqdm import tqdm

    results: List[dict] = []
    failures: List[str] = []
    seen: set = set()
    heard = 0
    pending = list(tasks)
    with tqdm(total=total, unit=unit, disable=not progress, file=sys.stderr) as bar:

        def advance(units: List[str]) -> None:
            for u in units:
                if u not in seen:
                    seen.add(u)
                    bar.update(1)
                    if on_progress:
                        on_progress(u)

        while pending:
            done, pending = ray.wait(pending, num_returns=1, timeout=POLL_S if log else None)
            if log is not None:
                news = ray.get(log.since.remote(heard))
                heard += len(news)
                advance(news)
            for ref in done:
                share, _ = tasks[ref]
                try:
                    results.append(ray.get(ref))
                except Exception as err:  # a share that failed every attempt
                    failures.append(f"{share}: {_why(err)}")
                if log is None:
                    advance([share])
    return results, failures


def _run_shares(
    twinray: str,
    shares: List[Tuple[str, int, List[str]]],
    max_retries: int,
    cpus_per_task: float,
    journal: Optional[str],
    progress: bool,
    unit: str,
    on_progress: Optional[Callable[[str], None]] = None,
) -> List[dict]:
    """One Ray task a share `(label, units, twinray args)`, each tried
    `max_retries + 1` times; raises RenderFailed with twinray's errors.
    Frames are reported one by one as the tasks finish them: to the bar,
    and to `on_progress` (``"frame N"``); tiles as their tasks end."""
    fault = os.environ.get(FAULT_ENV)
    options = dict(num_cpus=cpus_per_task, max_retries=max_retries, retry_exceptions=[TwinrayError])
    log = ProgressLog.remote() if unit == "frame" else None
    tasks = {}
    for label, units, args in shares:
        args = [*args, *_threads(args, cpus_per_task)]
        ref = render_share.options(**options).remote(twinray, args, journal, fault, log)
        tasks[ref] = (label, units)
    try:
        results, failures = gather(
            tasks, sum(u for _, u, _ in shares), progress, unit, log, on_progress
        )
    finally:
        if log is not None:
            ray.kill(log)
    if failures:
        raise RenderFailed(
            f"{len(failures)} share(s) failed {max_retries + 1} times: " + "; ".join(failures)
        )
    return results


def run_frames(
    twinray: str,
    scene: str,
    output: str,
    frames: str,
    extra: Sequence[str] = (),
    chunk: int = 4,
    max_retries: int = 2,
    cpus_per_task: float = 1,
    journal: Optional[str] = None,
    progress: bool = True,
    on_progress: Optional[Callable[[str], None]] = None,
) -> Summary:
    """Renders frames `frames` (A..B) of `scene` to `output` in chunks, one
    Ray task a chunk, each tried `max_retries + 1` times; `on_progress` is
    called with ``"frame N"`` as each frame is done (written or found)."""
    first, last = parse_range(frames, "--frames")
    base = ["render", scene, "-o", output, "--frames", f"{first}..{last}", "--skip-existing"]
    shares = [
        (f"frames {a}..{b}", b - a + 1, [*base, *extra, "--only", f"{a}..{b}"])
        for a, b in chunks(first, last, chunk)
    ]
    results = _run_shares(
        twinray, shares, max_retries, cpus_per_task, journal, progress, "frame", on_progress
    )
    summary = Summary()
    for r in results:
        summary.written += r["wrote"]
        summary.skipped += r["skipped"]
    return summary


def tile_files(output: str, count: int) -> dict:
    """The tile files of `output` on disk: {suffix: {index: path}}."""
    out = Path(output)
    pattern = re.compile(
        re.escape(out.stem) + r"_tile(\d+)of" + str(count) + r"(.*)" + re.escape(out.suffix) + "$"
    )
    found: dict = {}
    directory = out.parent if str(out.parent) else Path(".")
    for p in directory.iterdir() if directory.is_dir() else []:
        m = pattern.match(p.name)
        if m:
            found.setdefault(m.group(2), {})[int(m.group(1))] = str(p)
    return found


def run_tiles(
    twinray: str,
    scene: str,
    output: str,
    count: int,
    extra: Sequence[str] = (),
    max_retries: int = 2,
    cpus_per_task: float = 1,
    journal: Optional[str] = None,
    progress: bool = True,
) -> Summary:
    """Renders `scene` as `count` tiles, one Ray task a tile not yet on disk,
    then merges them (per eye where the views are separate files)."""
    if count < 1:
        raise RenderFailed("--tiles must be at least 1")
    have = tile_files(output, count)
    done = set.intersection(*(set(v) for v in have.values())) if have else set()
    base = ["render", scene, "-o", output, "--tiles", str(count), *extra]
    shares = [(f"tile {k}", 1, [*base, "--tile", str(k)]) for k in range(count) if k not in done]
    results = _run_shares(twinray, shares, max_retries, cpus_per_task, journal, progress, "tile")
    summary = Summary(skipped=sorted(done))
    for r in results:
        summary.written += r["wrote"]
    out = Path(output)
    for suffix, tiles in sorted(tile_files(output, count).items()):
        if sorted(tiles) != list(range(count)):
            raise RenderFailed(f"tiles of '{suffix or out.name}' missing after the run: have {sorted(tiles)}")
        target = str(out.with_name(out.stem + suffix + out.suffix))
        inputs = [tiles[k] for k in range(count)]
        result = subprocess.run(
            [twinray, "merge", "-o", target, *inputs], capture_output=True, text=True
        )
        if result.returncode != 0:
            raise RenderFailed(f"twinray merge: {result.stderr.strip()}")
        summary.merged.append(target)
    return summary
