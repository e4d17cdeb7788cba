"""The record beside a run's outputs: which job made them, and which of its
frames or tiles are done.

A frame or a tile is reused only if the record says that the same job made
it. The job is what ``twinray render --print-job`` prints for the command,
less what changes no pixel (the threads) and what the driver sets for each
task (the task's share, ``--skip-existing``), with the contents of the files
it names itself (scene, camera path, environment) by their SHA-256; its key
is the SHA-256 of that. The record is ``OUTPUT.twinray-ray.json`` (for
``-o shots/f_####.png``, ``shots/f_####.png.twinray-ray.json``), rewritten
whole under a temporary name and renamed, so it is never half written.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import subprocess
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

RECORD_SUFFIX = ".twinray-ray.json"
FORMAT = 1


class JobError(Exception):
    """twinray refused the job; the message is its own."""


def print_job(twinray: str, cwd: Path, args: Sequence[str]) -> dict:
    """The job `twinray ARGS` describes, as `--print-job` prints it."""
    result = subprocess.run(
        [twinray, *args, "--print-job"],
        cwd=cwd,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
    )
    if result.returncode != 0:
        lines = [l for l in result.stderr.splitlines() if l.strip()]
        raise JobError(" / ".join(lines) or f"twinray --print-job: exit status {result.returncode}")
    try:
        return json.loads(result.stdout)
    except json.JSONDecodeError as e:
        raise JobError(f"twinray --print-job printed no job ({e})") from e


def _digest(path: Path) -> Optional[str]:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None  # twinray says why when it reads it
    return h.hexdigest()


def keyed_job(spec: dict, cwd: Path) -> dict:
    """The part of `spec` that decides the outputs' pixels."""
    job = copy.deepcopy(spec)
    job.get("trace", {}).pop("threads", None)
    animation = job.get("animation") or {}
    animation.pop("only", None)
    animation.pop("skip_existing", None)
    if job.get("tile"):
        job["tile"].pop("index", None)
    # The record sits beside the outputs: their name is where it is.
    job.get("output", {}).pop("path", None)
    inputs = {
        "scene": job.get("scene"),
        "camera path": animation.get("path"),
        "environment": (job.get("studio") or {}).get("env"),
    }
    job["inputs"] = {
        name: {"path": str((cwd / p).resolve()), "sha256": _digest(cwd / p)}
        for name, p in inputs.items()
        if p
    }
    return job


def key_of(job: dict) -> str:
    text = json.dumps(job, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _flat(value, prefix: str = "") -> Dict[str, object]:
    if isinstance(value, dict):
        out: Dict[str, object] = {}
        for k, v in value.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else k))
        return out
    return {prefix: value}


def _short(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:16] + "…"


def differences(old: dict, new: dict, most: int = 3) -> str:
    """The settings that differ between two jobs, as `a.b was X, now Y`."""
    a, b = _flat(old), _flat(new)
    changed = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    said = [f"{k} was {_short(a.get(k))}, now {_short(b.get(k))}" for k in changed[:most]]
    if len(changed) > most:
        said.append(f"{len(changed) - most} more")
    return "; ".join(said)


class Record:
    """The job's key and the units (``frame N``, ``tile K``) it has done,
    each with the files it wrote."""

    def __init__(
        self, path: Path, name: str, key: str, job: dict, done: Dict[str, List[str]], saved: bool
    ):
        # Where it is, and as the user named the outputs (for messages).
        self.path = path
        self.name = name
        self.key = key
        self.job = job
        self.done = done
        # Whether the file on disk says what this object does.
        self.saved = saved

    @classmethod
    def open(cls, output: str, cwd: Path, job: dict) -> Tuple["Record", Optional[str]]:
        """The record of `job` beside `output`: the one on disk if the same
        job made it, else a new one (not yet saved), with a note saying
        what changed since the record on disk."""
        path = cwd / (output + RECORD_SUFFIX)
        key = key_of(job)
        name = output + RECORD_SUFFIX
        note = None
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            old = None
        except (OSError, ValueError) as e:
            old = None
            note = f"{name} is unreadable ({e}): the outputs are made again"
        if isinstance(old, dict) and old.get("format") == FORMAT and old.get("key") == key:
            done = {str(u): [str(f) for f in files] for u, files in (old.get("done") or {}).items()}
            return cls(path, name, key, job, done, True), None
        if isinstance(old, dict):
            what = differences(old.get("job") or {}, job)
            note = (
                f"the outputs at {output} were made by another job ({what or 'another record format'}): "
                "they are made again"
            )
        return cls(path, name, key, job, {}, False), note

    def files_there(self, unit: str, cwd: Path) -> bool:
        """Whether `unit` is done and every file it wrote is still there."""
        files = self.done.get(unit)
        return bool(files) and all((cwd / f).is_file() for f in files)

    def keep(self, units: Sequence[str]) -> None:
        """Forgets every unit but `units`."""
        keep = set(units)
        kept = {u: f for u, f in self.done.items() if u in keep}
        if kept != self.done:
            self.done, self.saved = kept, False

    def add(self, unit: str, path: str) -> None:
        files = self.done.setdefault(unit, [])
        if path not in files:
            files.append(path)
            self.saved = False

    def save(self) -> None:
        """Writes the record, if it has changed."""
        if self.saved:
            return
        text = json.dumps(
            {"format": FORMAT, "key": self.key, "job": self.job, "done": self.done},
            indent=1,
        )
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        tmp.write_text(text + "\n", encoding="utf-8")
        os.replace(tmp, self.path)
        self.saved = True
