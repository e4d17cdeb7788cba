"""twinray-ray on a local Ray cluster (ray.init(num_cpus=2)): frames and
tiles equal the binary's own renders bit for bit; a worker killed mid-run
still leaves every frame written once and nothing partial; a re-run renders
nothing; a share that fails every attempt is reported with twinray's error;
progress advances frame by frame while a task is still rendering.

The binary: $TWINRAY_BIN, else target/release/twinray of this repository.
"""

import os
import shlex
import subprocess
from pathlib import Path

import pytest
import ray

from twinray_ray import cli, driver

REPO = Path(__file__).resolve().parents[2]
SCENE = str(REPO / "scenes" / "example.nff")
BIN = os.environ.get("TWINRAY_BIN", str(REPO / "target" / "release" / "twinray"))

FRAMES = ["--frames", "0..7", "--orbit", "360", "--stereo", "--layout", "sbs", "--size", "48x36"]


@pytest.fixture(scope="module", autouse=True)
def cluster():
    if not Path(BIN).is_file():
        pytest.fail(f"no twinray binary at {BIN}: cargo build --release first, or set TWINRAY_BIN")
    ray.init(num_cpus=2, log_to_driver=False, include_dashboard=False)
    yield
    ray.shutdown()


def twinray(*args):
    subprocess.run([BIN, *args], check=True, capture_output=True)


def ray_render(*args):
    return cli.main(["render", SCENE, "--twinray", BIN, "-q", *args])


def files(d: Path):
    return sorted(p.name for p in d.iterdir())


def test_frames_equal_the_binarys_own_render(tmp_path):
    on_ray, direct = tmp_path / "ray", tmp_path / "direct"
    on_ray.mkdir()
    direct.mkdir()
    assert ray_render("-o", str(on_ray / "f_####.png"), "--chunk", "3", *FRAMES) == 0
    twinray("render", SCENE, "-o", str(direct / "f_####.png"), "-q", *FRAMES)
    assert files(on_ray) == [f"f_{i:04}.png" for i in range(8)]
    for name in files(direct):
        assert (on_ray / name).read_bytes() == (direct / name).read_bytes(), name


def test_tiles_merge_into_the_binarys_whole_image(tmp_path):
    flags = ["--size", "64x64", "--stereo", "--layout", "sbs", "--samples", "4", "--filter", "tent"]
    assert ray_render("-o", str(tmp_path / "big.png"), "--tiles", "4", *flags) == 0
    twinray("render", SCENE, "-o", str(tmp_path / "whole.png"), "-q", *flags)
    assert (tmp_path / "big.png").read_bytes() == (tmp_path / "whole.png").read_bytes()
    assert len([n for n in files(tmp_path) if "_tile" in n]) == 4


def test_a_killed_worker_leaves_every_frame_written_once(tmp_path, monkeypatch):
    marker, journal = tmp_path / "fault", tmp_path / "journal"
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.setenv("TWINRAY_RAY_FAULT", str(marker))
    args = ["-o", str(out / "f_####.png"), "--chunk", "4", "--journal", str(journal), *FRAMES]
    assert ray_render(*args) == 0
    assert marker.exists(), "no fault was injected"
    written = journal.read_text().splitlines()
    names = sorted(Path(line.split(" ", 1)[1]).name for line in written)
    assert names == [f"f_{i:04}.png" for i in range(8)], written  # each once
    assert files(out) == [f"f_{i:04}.png" for i in range(8)]  # nothing partial
    direct = tmp_path / "direct"
    direct.mkdir()
    twinray("render", SCENE, "-o", str(direct / "f_####.png"), "-q", *FRAMES)
    for name in files(direct):
        assert (out / name).read_bytes() == (direct / name).read_bytes(), name

    # A re-run renders nothing: no file written, none touched.
    monkeypatch.delenv("TWINRAY_RAY_FAULT")
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert ray_render(*args) == 0
    assert journal.read_text().splitlines() == written
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_a_share_failing_every_attempt_is_reported(tmp_path, capsys):
    bad = tmp_path / "bad.nff"
    bad.write_text("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\ns 0 0 0\n")
    code = cli.main(
        ["render", str(bad), "--twinray", BIN, "-q", "-o", str(tmp_path / "f.png"), "--frames", "0..1"]
    )
    err = capsys.readouterr().err
    assert code == 1
    assert "failed 3 times" in err, err
    assert "bad.nff:" in err, err  # twinray's own message, with file:line
    assert not any(p.suffix == ".png" for p in tmp_path.iterdir())


def test_progress_advances_per_frame_while_the_task_runs(tmp_path):
    """One task renders all 8 frames; twinray is held after its first frame
    until the driver has reported that frame (30 s at most). Progress per
    task would come only when the task ends, after the hold times out."""
    gate, verdict = tmp_path / "gate", tmp_path / "verdict"
    held = tmp_path / "twinray-held"
    held.write_text(
        f"""#!/bin/bash
# twinray, its messages passed on, held after the first frame's line
# until the driver has shown that frame (the gate file), or 30 s.
set -o pipefail
{shlex.quote(BIN)} "$@" 2>&1 >/dev/null | {{
    waited=0
    while IFS= read -r line; do
        printf '%s\\n' "$line" >&2
        if [ $waited = 0 ] && [[ $line == "frame "* ]]; then
            waited=1
            for i in $(seq 300); do [ -e {gate} ] && break; sleep 0.1; done
            if [ -e {gate} ]; then echo released > {verdict}; else echo timed-out > {verdict}; fi
        fi
    done
}}
"""
    )
    held.chmod(0o755)
    out = tmp_path / "out"
    out.mkdir()
    seen = []

    def on_progress(unit):
        seen.append(unit)
        gate.touch()

    summary = driver.run_frames(
        str(held),
        SCENE,
        str(out / "f_####.png"),
        "0..7",
        extra=FRAMES[2:],
        chunk=8,
        progress=False,
        on_progress=on_progress,
    )
    assert verdict.read_text().strip() == "released", "no progress while the task ran"
    assert seen == [f"frame {i}" for i in range(8)], seen  # one step a frame, each once
    assert files(out) == [f"f_{i:04}.png" for i in range(8)]
    assert len(summary.written) == 8


def test_progress_counts_each_frame_once_when_a_worker_dies(tmp_path, monkeypatch):
    """Frames written by an attempt that died and skipped by its retry, and
    frames done already before the run, each count once."""
    out = tmp_path / "out"
    out.mkdir()
    twinray("render", SCENE, "-o", str(out / "f_####.png"), "-q", *FRAMES, "--only", "1..2")
    monkeypatch.setenv("TWINRAY_RAY_FAULT", str(tmp_path / "fault"))
    seen = []
    summary = driver.run_frames(
        BIN, SCENE, str(out / "f_####.png"), "0..7", extra=FRAMES[2:], chunk=4,
        progress=False, on_progress=seen.append,
    )
    assert (tmp_path / "fault").exists(), "no fault was injected"
    assert sorted(seen, key=lambda u: int(u.split()[1])) == [f"frame {i}" for i in range(8)], seen
    # Skipped: frames 1 and 2, and the frame the dead attempt wrote.
    assert {1, 2} < set(summary.skipped), summary.skipped
    assert files(out) == [f"f_{i:04}.png" for i in range(8)]
