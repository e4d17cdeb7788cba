"""Ray tasks that run the twinray binary on shares of a render.

A share of an animation is ``twinray render SCENE -o OUT --frames A..B
--only C..D``: the camera motion and the shot's stereo rig are those of the
whole range ``A..B`` whatever share a task renders. A share of a still is
one tile, ``--tiles N --tile K``; the tiles are merged by ``twinray merge``
at the end. Every task runs twinray in the driver's working directory, so
relative paths mean on every node what they mean to the driver.

What is done is kept in a record beside the outputs (:mod:`.record`): a frame
or a tile is reused only if the record says the same job made it. While the
tasks run, each reports every file twinray writes (``frame N: wrote PATH``,
or ``wrote PATH`` for a tile) to a small actor (:class:`ProgressLog`); the
driver polls it, advances the progress bar and saves the record. A task
reads the record when it starts, so an attempt after one that died renders
only the frames of its share that the record does not have. twinray writes each file atomically under its final name, and a
task whose worker dies takes its twinray process with it (the child gets
SIGTERM, cancels its render and removes its temporary file), so nothing
partial is left.

Retries are for what a retry can mend: a worker or a twinray process that
died. An error twinray reports (a bad scene, a folder it cannot write) fails
the share at once.
"""

from __future__ import annotations

import ctypes
import json
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import ray

from .record import JobError, Record, keyed_job, print_job

# Environment variable: a file path. The first task attempt that finds it
# missing creates it and kills its own worker once its first file is
# recorded (a fault injected for the tests); files twinray finishes after
# that are listed in it.
FAULT_ENV = "TWINRAY_RAY_FAULT"

# How often the driver asks the progress log for news (seconds).
POLL_S = 0.2

# How long an interrupted driver waits for its tasks to stop and for the
# progress log's last news, and a task for twinray to stop (seconds).
STOP_S = 10

FRAME_LINE = re.compile(r"frame (\d+): wrote (.*)")
TILE_LINE = re.compile(r"wrote (.*)")


class TwinrayFailed(Exception):
    """twinray exited with an error of its own; a retry would meet it again."""


class TwinrayStopped(Exception):
    """twinray was stopped by a signal (its node shutting down, memory);
    a retry may succeed."""


class RenderFailed(Exception):
    """The run cannot go on, or a share failed; the message says why."""


class Interrupted(Exception):
    """The run was interrupted (Ctrl-C); what was done is recorded."""

    def __init__(self, done: int, total: int, unit: str, record: str):
        super().__init__(f"{done} of {total} {unit}s done")
        self.done, self.total, self.unit, self.record = done, total, unit, record


@dataclass
class Summary:
    """What a run did: the files written, the frames or tiles found done
    already, the images merged from tiles."""

    written: List[str] = field(default_factory=list)
    skipped: List[int] = field(default_factory=list)
    merged: List[str] = field(default_factory=list)


def parse_range(text: str, flag: str) -> Tuple[int, int]:
    """`A..B` (both included) as a pair."""
    m = re.fullmatch(r"\s*(\d+)\s*\.\.=?\s*(\d+)\s*", text)
    if not m or int(m.group(2)) < int(m.group(1)):
        raise RenderFailed(f"{flag} '{text}': give A..B, first and last included")
    return int(m.group(1)), int(m.group(2))


def runs(frames: Sequence[int]) -> List[Tuple[int, int]]:
    """Sorted frame numbers as ranges of consecutive ones."""
    out: List[Tuple[int, int]] = []
    for f in frames:
        if out and f == out[-1][1] + 1:
            out[-1] = (out[-1][0], f)
        else:
            out.append((f, f))
    return out


def chunks(frames: Sequence[int], size: int) -> List[Tuple[int, int]]:
    """Sorted frame numbers in ranges of consecutive ones, `size` at most."""
    size = max(1, size)
    return [(a, min(a + size - 1, b)) for a, b in runs(frames) for a in range(a, b + 1, size)]


def _die_with_parent() -> None:
    """In the child: SIGTERM when the worker that started it dies (Linux)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


@ray.remote(num_cpus=0)
class ProgressLog:
    """The files the tasks report written, in the order they arrive."""

    def __init__(self) -> None:
        self.events: List[Tuple[str, str]] = []

    def report(self, unit: str, path: str) -> None:
        self.events.append((unit, path))

    def since(self, start: int) -> List[Tuple[str, str]]:
        return self.events[start:]


def write_journal(journal: Optional[str], path: str) -> None:
    """Appends `wrote PATH` to the journal, if there is one."""
    if journal:
        with open(journal, "a", encoding="utf-8") as j:
            j.write(f"wrote {path}\n")


class _Reporter:
    """Tells the progress log of each file written. The calls are not waited
    for (a task waiting on Ray gives its CPU to another task meanwhile, and
    twinray would share it), except by `flush`, once twinray is done."""

    def __init__(self, log: "ray.actor.ActorHandle") -> None:
        self.log = log
        self.last = None

    def report(self, unit: str, path: str) -> None:
        self.last = self.log.report.remote(unit, path)

    def flush(self) -> None:
        if self.last is not None:
            ray.get(self.last)
            self.last = None


def _twinray(
    twinray: str,
    cwd: str,
    args: List[str],
    unit: Optional[str],
    journal: Optional[str],
    fault: Optional[Tuple[str, str]],
    reporter: _Reporter,
) -> List[str]:
    """Runs `twinray ARGS`, reporting each file it writes (under `frame N`,
    or under `unit` for a tile); returns the files."""
    proc = subprocess.Popen(
        [twinray, *args],
        cwd=cwd,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
    )
    assert proc.stderr is not None
    wrote: List[str] = []
    said: List[str] = []
    try:
        for line in proc.stderr:
            line = line.rstrip("\n")
            m = FRAME_LINE.match(line)
            if m:
                owner, path = f"frame {m.group(1)}", m.group(2)
            elif unit is not None and TILE_LINE.match(line):
                owner, path = unit, line[len("wrote ") :]
            else:
                said.append(line)
                continue
            wrote.append(path)
            write_journal(journal, path)
            reporter.report(owner, path)
            if fault and _claim(fault[0]):
                _die_on_purpose(proc, fault, owner, journal, reporter)
        code = proc.wait()
    except BaseException:
        # twinray removes its temporary file on SIGTERM.
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=STOP_S)
            except subprocess.TimeoutExpired:
                proc.kill()
        raise
    message = " / ".join(l for l in said if l.strip())
    if code == 0:
        return wrote
    if code < 0 or code == 130:
        raise TwinrayStopped(f"twinray stopped by a signal ({message or f'exit status {code}'})")
    raise TwinrayFailed(message or f"exit status {code}")


def _claim(marker: str) -> bool:
    """Creates the fault file if it is missing: whether this task did."""
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    return True


def _die_on_purpose(
    proc: subprocess.Popen,
    fault: Tuple[str, str],
    unit: str,
    journal: Optional[str],
    reporter: _Reporter,
) -> None:
    """The injected fault, once the driver has recorded the task's first
    file: twinray gets the SIGTERM it would get from the worker's death, and
    the worker dies. A file twinray finishes in the meantime is journaled (a
    real death can leave one behind) and listed in the fault file: no
    attempt reported it, so the retry makes it again."""
    marker, record = fault
    reporter.flush()
    for _ in range(int(60 / POLL_S)):  # a loaded machine's driver may be slow
        if unit in _done_in_record(record, None):
            break
        time.sleep(POLL_S)
    with open(marker, "a", encoding="utf-8") as f:
        f.write(f"worker {os.getpid()} killed mid-run after {unit}\n")
    proc.terminate()
    assert proc.stderr is not None
    for rest in proc.stderr:
        late = FRAME_LINE.match(rest.rstrip("\n"))
        if late:
            write_journal(journal, late.group(2))
            with open(marker, "a", encoding="utf-8") as f:
                f.write(f"late: {late.group(2)}\n")
    proc.wait()
    os._exit(1)  # the worker dies; Ray tries the task again


def _done_in_record(path: str, key: Optional[str]) -> set:
    """The units the record at `path` has done (if it is the record of
    `key`, when given)."""
    try:
        saved = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    if not isinstance(saved, dict) or (key is not None and saved.get("key") != key):
        return set()
    return set(saved.get("done") or {})


@ray.remote
def render_share(
    twinray: str,
    cwd: str,
    args: List[str],
    units: List[str],
    record: Tuple[str, str],
    journal: Optional[str],
    fault: Optional[str],
    log: "ray.actor.ActorHandle",
) -> Dict[str, List]:
    """Renders the units (``frame N`` or one ``tile K``) of a share that
    the job's record does not have done: frames as ``--only`` ranges, a tile
    as it is. The record is read from disk, so that an attempt after one
    that died skips what that one reported."""
    done = _done_in_record(*record)
    todo = [u for u in units if u not in done]
    skipped = [u for u in units if u in done]
    reporter = _Reporter(log)
    wrote: List[str] = []
    faulty = (fault, record[0]) if fault else None
    try:
        if units[0].startswith("frame "):
            numbers = sorted(int(u.split()[1]) for u in todo)
            for a, b in runs(numbers):
                args_ab = [*args, "--only", f"{a}..{b}"]
                wrote += _twinray(twinray, cwd, args_ab, None, journal, faulty, reporter)
        elif todo:
            wrote += _twinray(twinray, cwd, args, units[0], journal, faulty, reporter)
    finally:
        reporter.flush()
    return {"wrote": wrote, "skipped": skipped}


def _threads(extra: Sequence[str], cpus: float) -> List[str]:
    """`--threads` for the task's CPUs unless the caller chose."""
    if any(a == "--threads" or a.startswith("--threads=") for a in extra):
        return []
    return ["--threads", str(max(1, int(cpus)))]


def _why(err: Exception, attempts: int) -> str:
    """What made a share fail, from a Ray task error: twinray's own message,
    or the last line of Ray's."""
    cause = getattr(err, "cause", None)
    if isinstance(cause, TwinrayFailed):
        return f"{cause} (not retried: the same job fails the same way)"
    if isinstance(cause, TwinrayStopped):
        return f"{cause}, {attempts} times"
    text = str(err).strip().splitlines()
    return f"{text[-1] if text else type(err).__name__} ({attempts} attempts)"


def _say(note: str) -> None:
    print(f"twinray-ray: note: {note}", file=sys.stderr)


@dataclass
class Share:
    label: str
    units: List[str]
    args: List[str]


def _run_shares(
    twinray: str,
    cwd: Path,
    record: Record,
    units: List[str],
    shares: List[Share],
    max_retries: int,
    cpus_per_task: float,
    journal: Optional[str],
    progress: bool,
    unit: str,
    on_progress: Optional[Callable[[str], None]],
) -> List[dict]:
    """Runs one Ray task a share; the bar counts `units`, those done
    already at once. Saves the record as files are reported; raises
    RenderFailed with the shares' errors, Interrupted on Ctrl-C."""
    from tqdm import tqdm

    fault = os.environ.get(FAULT_ENV)
    done_before = [u for u in units if u in record.done]
    if not shares:
        for u in done_before if on_progress else []:
            on_progress(u)
        return []
    log = ProgressLog.remote()
    options = dict(
        num_cpus=cpus_per_task, max_retries=max_retries, retry_exceptions=[TwinrayStopped]
    )
    tasks = {}
    for share in shares:
        args = [*share.args, *_threads(share.args, cpus_per_task)]
        ref = render_share.options(**options).remote(
            twinray, str(cwd), args, share.units, (str(record.path), record.key), journal, fault, log
        )
        tasks[ref] = share
    results: List[dict] = []
    failures: Dict[str, List[str]] = {}
    seen: set = set()
    heard = 0
    pending = list(tasks)
    with tqdm(total=len(units), unit=unit, disable=not progress, file=sys.stderr) as bar:

        def advance(new: List[str]) -> None:
            for u in new:
                if u not in seen:
                    seen.add(u)
                    bar.update(1)
                    if on_progress:
                        on_progress(u)

        def poll(timeout: Optional[float] = None) -> None:
            nonlocal heard
            news = ray.get(log.since.remote(heard), timeout=timeout)
            for u, path in news:
                record.add(u, path)
            record.save()
            # Counted once saved: a poll cut short by Ctrl-C is done again.
            heard += len(news)
            advance([u for u, _ in news])

        advance(done_before)
        try:
            while pending:
                finished, pending = ray.wait(pending, num_returns=1, timeout=POLL_S)
                poll()
                for ref in finished:
                    try:
                        results.append(ray.get(ref))
                    except Exception as err:  # a share that failed
                        why = _why(err, max_retries + 1)
                        failures.setdefault(why, []).append(tasks[ref].label)
        except KeyboardInterrupt:
            # The tasks' workers are ended: their twinray processes get
            # SIGTERM, stop within a row and remove their temporary files.
            # What was reported is kept in the record.
            for ref in pending:
                ray.cancel(ref, force=True)
            ray.wait(pending, num_returns=len(pending), timeout=STOP_S)
            try:
                poll(STOP_S)
            except Exception:
                pass  # what did not come in time is rendered again
            done = len([u for u in units if u in record.done])
            raise Interrupted(done, len(units), unit, record.name) from None
        finally:
            ray.kill(log)
    if failures:
        raise RenderFailed(
            f"{sum(len(v) for v in failures.values())} share(s) failed: "
            + "; ".join(f"{', '.join(labels)}: {why}" for why, labels in failures.items())
        )
    return results


def _refuse_driver_flags(extra: Sequence[str]) -> None:
    """Refuses the twinray flags the driver sets itself."""
    for flag in ("--only", "--tile", "--skip-existing", "--job", "--print-job"):
        if any(a == flag or a.startswith(flag + "=") for a in extra):
            raise RenderFailed(
                "--job: give twinray-ray the flags, not a job file"
                if flag == "--job"
                else f"{flag}: twinray-ray sets the share of each task itself"
            )


def _prepare(
    twinray: str, cwd: Path, scene: str, output: str, job_args: List[str], on_note
) -> Record:
    """Checks the job with twinray, creates the output folder and opens the
    job's record there."""
    try:
        spec = print_job(twinray, cwd, ["render", scene, "-o", output, *job_args])
    except JobError as e:
        raise RenderFailed(str(e)) from None
    folder = (cwd / output).parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise RenderFailed(f"cannot create the output folder {folder}: {e.strerror}") from None
    record, note = Record.open(output, cwd, keyed_job(spec, cwd))
    if note:
        (on_note or _say)(note)
    return record


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
    on_note: Optional[Callable[[str], None]] = None,
    cwd: Optional[str] = None,
) -> Summary:
    """Renders frames `frames` (A..B) of `scene` to `output`, one Ray task
    a chunk of frames not done yet; `on_progress` is called with ``"frame
    N"`` as each frame is done (written, or found done before the run)."""
    first, last = parse_range(frames, "--frames")
    _refuse_driver_flags(extra)
    here = Path(cwd or os.getcwd())
    base = ["render", scene, "-o", output, "--frames", f"{first}..{last}", *extra]
    record = _prepare(twinray, here, scene, output, base[4:], on_note)
    units = [f"frame {f}" for f in range(first, last + 1)]
    kept = {u for u in units if record.files_there(u, here)}
    record.keep(kept)
    record.save()
    todo = [f for f in range(first, last + 1) if f"frame {f}" not in kept]
    shares = [
        Share(f"frames {a}..{b}", [f"frame {f}" for f in range(a, b + 1)], base)
        for a, b in chunks(todo, chunk)
    ]
    results = _run_shares(
        twinray, here, record, units, shares, max_retries, cpus_per_task, journal,
        progress, "frame", on_progress,
    )
    summary = Summary(skipped=sorted(int(u.split()[1]) for u in kept))
    for r in results:
        summary.written += r["wrote"]
        summary.skipped += [int(u.split()[1]) for u in r["skipped"]]
    summary.skipped.sort()
    return summary


def _tile_suffix(path: str, output: Path, index: int, count: int) -> str:
    """The view suffix of a tile file (``_L``, ``""``)."""
    name = Path(path).name
    head = f"{output.stem}_tile{index}of{count}"
    if not (name.startswith(head) and name.endswith(output.suffix)):
        raise RenderFailed(f"tile {index}: twinray wrote {path}, not a tile of {output}")
    return name[len(head) : len(name) - len(output.suffix)]


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
    on_note: Optional[Callable[[str], None]] = None,
    cwd: Optional[str] = None,
) -> Summary:
    """Renders `scene` as `count` tiles, one Ray task a tile not done yet,
    then merges them (per view where the views are separate files)."""
    if count < 1:
        raise RenderFailed("--tiles must be at least 1")
    _refuse_driver_flags(extra)
    here = Path(cwd or os.getcwd())
    base = ["render", scene, "-o", output, "--tiles", str(count), *extra]
    record = _prepare(twinray, here, scene, output, [*base[4:], "--tile", "0"], on_note)
    units = [f"tile {k}" for k in range(count)]
    kept = {u for u in units if record.files_there(u, here)}
    record.keep(kept)
    record.save()
    shares = [Share(u, [u], [*base, "--tile", u.split()[1]]) for u in units if u not in kept]
    results = _run_shares(
        twinray, here, record, units, shares, max_retries, cpus_per_task, journal,
        progress, "tile", None,
    )
    summary = Summary(skipped=sorted(int(u.split()[1]) for u in kept))
    for r in results:
        summary.written += r["wrote"]
    out = Path(output)
    views: Dict[str, Dict[int, str]] = {}
    for k in range(count):
        for path in record.done.get(f"tile {k}", []):
            views.setdefault(_tile_suffix(path, out, k, count), {})[k] = path
    for suffix, tiles in sorted(views.items()):
        if sorted(tiles) != list(range(count)):
            missing = sorted(set(range(count)) - set(tiles))
            raise RenderFailed(f"tiles {missing} of '{out.stem}{suffix}{out.suffix}' missing after the run")
        target = str(out.with_name(out.stem + suffix + out.suffix))
        result = subprocess.run(
            [twinray, "merge", "-o", target, *(tiles[k] for k in range(count))],
            cwd=here,
            capture_output=True,
            text=True,
        )
        if result.returncode != 0:
            raise RenderFailed(f"twinray merge: {result.stderr.strip()}")
        summary.merged.append(target)
    return summary
