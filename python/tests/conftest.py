"""What the Ray driver's tests share: the binary, the scene, the flags of a
small stereo orbit, and renders by the binary alone to compare with.

The binary: $TWINRAY_BIN, else target/release/twinray of this repository.
"""

import os
import signal
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENE = str(REPO / "scenes" / "example.nff")
BIN = os.environ.get("TWINRAY_BIN", str(REPO / "target" / "release" / "twinray"))

# The Ctrl-C tests need SIGINT to arrive: a shell that starts pytest in the
# background leaves it ignored, and every child would inherit that.
signal.signal(signal.SIGINT, signal.default_int_handler)

# 8 frames of a stereo orbit, side by side: one file a frame.
FRAMES = ["--frames", "0..7", "--orbit", "360", "--stereo", "--layout", "sbs", "--size", "48x36"]


@pytest.fixture(scope="session", autouse=True)
def binary():
    if not Path(BIN).is_file():
        pytest.fail(f"no twinray binary at {BIN}: cargo build --release first, or set TWINRAY_BIN")


def twinray(*args, cwd=None):
    """Runs the binary alone (quietly); fails the test if it fails."""
    subprocess.run([BIN, *args], check=True, capture_output=True, cwd=cwd)


def direct_frames(folder: Path, *flags) -> Path:
    """The frames of `flags` (FRAMES if none) rendered by the binary alone."""
    folder.mkdir(parents=True)
    twinray("render", SCENE, "-o", str(folder / "f_####.png"), "-q", *(flags or FRAMES))
    return folder


def images(folder: Path):
    """The images in `folder`, by name."""
    return sorted(p.name for p in folder.iterdir() if p.suffix == ".png")


def same_images(a: Path, b: Path):
    """Asserts that two folders hold the same images, bit for bit."""
    assert images(a) == images(b)
    for name in images(a):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def journal_names(journal: Path):
    """The file names a journal lists, in its order."""
    if not journal.exists():
        return []
    return [Path(line.split(" ", 1)[1]).name for line in journal.read_text().splitlines()]
