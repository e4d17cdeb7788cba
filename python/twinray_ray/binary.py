"""Where the twinray binary is.

The README builds it with cargo in the repository (``target/release/twinray``)
and installs this package with ``pip install ./python``, so the binary is
looked for as a user who followed it has it: the path given, then
``$TWINRAY_BIN``, then ``twinray`` on the PATH, then ``target/release/twinray``
of the repository this package's source lives in, or of the current
directory or one above it.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Iterator, List, Optional

# Environment variable naming the binary.
BIN_ENV = "TWINRAY_BIN"

RELEASE = Path("target") / "release" / "twinray"

# Where this package's source is (in the repository, for an editable install).
PACKAGE_DIR = Path(__file__).resolve().parent


class BinaryNotFound(Exception):
    """No usable twinray binary; the message says where it was looked for."""


def _executable(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


def _workspaces(start: Path) -> Iterator[Path]:
    """`start` and the folders above it that hold a Cargo workspace."""
    for folder in [start, *start.parents]:
        if (folder / "Cargo.toml").is_file():
            yield folder


def find_twinray(given: Optional[str] = None, cwd: Optional[Path] = None) -> str:
    """The absolute path of the twinray binary (see the module's doc for the
    order); raises BinaryNotFound saying what was tried."""
    if given:
        if not _executable(Path(given)):
            raise BinaryNotFound(f"--twinray {given}: not an executable file")
        return str(Path(given).absolute())
    env = os.environ.get(BIN_ENV)
    if env:
        if not _executable(Path(env)):
            raise BinaryNotFound(f"${BIN_ENV}={env}: not an executable file")
        return str(Path(env).absolute())
    tried: List[str] = [f"${BIN_ENV} (not set)", "twinray on the PATH (none)"]
    on_path = shutil.which("twinray")
    if on_path:
        return str(Path(on_path).absolute())
    seen = set()
    for start in (PACKAGE_DIR, (cwd or Path.cwd()).resolve()):
        for workspace in _workspaces(start):
            candidate = workspace / RELEASE
            if candidate in seen:
                continue
            seen.add(candidate)
            if _executable(candidate):
                return str(candidate)
            tried.append(f"{candidate} (missing)")
    if not seen:
        tried.append(f"target/release/twinray of a Cargo workspace at or above {cwd or Path.cwd()} (none)")
    raise BinaryNotFound(
        "no twinray binary: tried "
        + ", ".join(tried)
        + "; build it with `cargo build --release` in the repository, or give --twinray PATH"
    )
