"""twinray-ray on a local Ray cluster started in this process
(ray.init(num_cpus=2)): frames and tiles equal the binary's own renders bit
for bit; a worker killed mid-run still leaves every frame written and
nothing partial; a re-run renders nothing; a frame or tile is reused only if
the same job made it; an error twinray reports is not retried, a twinray
killed by a signal is; progress advances frame by frame while a task is
still rendering.
"""

import json
import os
import shlex
import signal
from pathlib import Path

import pytest
import ray

from conftest import BIN, FRAMES, SCENE, direct_frames, images, journal_names, same_images, twinray
from twinray_ray import cli, driver
from twinray_ray.record import RECORD_SUFFIX


@pytest.fixture(scope="module", autouse=True)
def cluster():
    cli.connect(None, 2)  # a local cluster of 2 CPUs, as twinray-ray starts one
    yield
    ray.shutdown()


def ray_render(*args):
    return cli.main(["render", SCENE, "--twinray", BIN, "-q", *args])


def record_of(output: Path) -> dict:
    return json.loads(Path(str(output) + RECORD_SUFFIX).read_text())


def wrapper(path: Path, body: str) -> str:
    """An executable script standing in for twinray: `body`, with $BIN the
    real binary."""
    path.write_text(f"#!/bin/bash\nBIN={shlex.quote(BIN)}\n{body}\n")
    path.chmod(0o755)
    return str(path)


def test_frames_equal_the_binarys_own_render(tmp_path):
    out = tmp_path / "ray"
    out.mkdir()
    assert ray_render("-o", str(out / "f_####.png"), "--chunk", "3", *FRAMES) == 0
    same_images(out, direct_frames(tmp_path / "direct"))
    record = record_of(out / "f_####.png")
    assert sorted(record["done"]) == sorted(f"frame {i}" for i in range(8))
    assert record["job"]["camera"]["size"] == [48, 36]


def test_tiles_merge_into_the_binarys_whole_image(tmp_path):
    flags = ["--size", "64x64", "--stereo", "--layout", "sbs", "--samples", "4", "--filter", "tent"]
    assert ray_render("-o", str(tmp_path / "big.png"), "--tiles", "4", *flags) == 0
    twinray("render", SCENE, "-o", str(tmp_path / "whole.png"), "-q", *flags)
    assert (tmp_path / "big.png").read_bytes() == (tmp_path / "whole.png").read_bytes()
    assert len([n for n in images(tmp_path) if "_tile" in n]) == 4


def test_the_output_folder_is_created(tmp_path):
    out = tmp_path / "shots" / "take 1"
    assert ray_render("-o", str(out / "f_####.png"), *FRAMES[:2], "--size", "16x12") == 0
    assert images(out) == [f"f_{i:04}.png" for i in range(8)]


def test_a_killed_worker_leaves_every_frame_written(tmp_path, monkeypatch):
    marker, journal = tmp_path / "fault", tmp_path / "journal"
    out = tmp_path / "out"
    monkeypatch.setenv("TWINRAY_RAY_FAULT", str(marker))
    args = ["-o", str(out / "f_####.png"), "--chunk", "4", "--journal", str(journal), *FRAMES]
    assert ray_render(*args) == 0
    assert marker.exists(), "no fault was injected"
    # A frame the dead attempt had reported is not made again; one it
    # finished unreported (listed in the fault file) may be.
    late = [Path(l.split(": ", 1)[1]).name for l in marker.read_text().splitlines() if l.startswith("late: ")]
    written = journal_names(journal)
    once = [n for n in written if n not in late]
    assert sorted(once) == sorted(set(f"f_{i:04}.png" for i in range(8)) - set(late)), written
    assert images(out) == [f"f_{i:04}.png" for i in range(8)]  # nothing partial
    assert not [p for p in out.iterdir() if p.name.startswith(".")], "a temporary file is left"
    same_images(out, direct_frames(tmp_path / "direct"))

    # A re-run renders nothing: no file written, none touched, the record
    # included.
    monkeypatch.delenv("TWINRAY_RAY_FAULT")
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert ray_render(*args) == 0
    assert journal_names(journal) == written
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_a_rerun_with_another_size_or_sampling_renders_again(tmp_path, capsys):
    out, journal = tmp_path / "out", tmp_path / "journal"
    orbit = FRAMES[:-2]  # without --size
    names = [f"f_{i:04}.png" for i in range(8)]

    def run(*flags):
        assert ray_render("-o", str(out / "f_####.png"), "--journal", str(journal), *orbit, *flags) == 0
        same_images(out, direct_frames(tmp_path / "direct" / "_".join(flags), *orbit, *flags))

    run("--size", "48x36")
    run("--size", "40x30")
    assert sorted(journal_names(journal)) == sorted(names * 2)
    run("--size", "40x30", "--samples", "4")
    assert sorted(journal_names(journal)) == sorted(names * 3)
    run("--size", "40x30", "--samples", "4", "--threads", "2")  # the same images
    assert len(journal_names(journal)) == 24

    # Tiles: the merged image has the size asked for, not the old tiles'.
    big = tmp_path / "big.png"
    assert cli.main(["render", SCENE, "--twinray", BIN, "-o", str(big), "--tiles", "4", "--size", "96x96"]) == 0
    capsys.readouterr()
    assert cli.main(["render", SCENE, "--twinray", BIN, "-o", str(big), "--tiles", "4", "--size", "128x128"]) == 0
    err = capsys.readouterr().err
    assert "made by another job (camera.size was [96, 96], now [128, 128])" in err, err
    assert "4 tile file(s) written, 0 tile(s) done already" in err, err
    twinray("render", SCENE, "-o", str(tmp_path / "whole.png"), "--size", "128x128")
    assert big.read_bytes() == (tmp_path / "whole.png").read_bytes()


def test_frames_no_record_vouches_for_are_made_again(tmp_path):
    """Frames the binary wrote alone, at another size, under the names of
    the run: no record says which job made them, so they are made again.
    Then a frame whose file is gone is made again, and only that one."""
    out, journal = tmp_path / "out", tmp_path / "journal"
    out.mkdir()
    twinray("render", SCENE, "-o", str(out / "f_####.png"), "-q", *FRAMES[:-2], "--size", "40x30")
    args = ["-o", str(out / "f_####.png"), "--journal", str(journal), *FRAMES]
    assert ray_render(*args) == 0
    assert sorted(journal_names(journal)) == [f"f_{i:04}.png" for i in range(8)]
    same_images(out, direct_frames(tmp_path / "direct"))
    (out / "f_0005.png").unlink()
    assert ray_render(*args) == 0
    assert journal_names(journal)[8:] == ["f_0005.png"]
    same_images(out, tmp_path / "direct")


def test_an_error_of_twinray_is_not_retried(tmp_path, capsys):
    bad = tmp_path / "bad.nff"
    bad.write_text("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\ns 0 0 0\n")
    calls = tmp_path / "calls"
    counting = wrapper(tmp_path / "twinray-counting", f'echo "$*" >> {calls}\nexec "$BIN" "$@"')
    out = tmp_path / "f_####.png"
    code = cli.main(["render", str(bad), "--twinray", counting, "-q", "-o", str(out), "--frames", "0..7"])
    err = capsys.readouterr().err
    assert code == 1
    # The shares fail in whichever order they finish.
    assert ("2 share(s) failed: frames 0..3, frames 4..7: " in err
            or "2 share(s) failed: frames 4..7, frames 0..3: " in err), err
    assert "bad.nff:" in err and "(not retried" in err, err  # twinray's own message, with file:line
    renders = [l for l in calls.read_text().splitlines() if "--print-job" not in l]
    assert len(renders) == 2, renders  # one attempt a share
    assert not images(tmp_path)


def test_a_twinray_killed_by_a_signal_is_retried(tmp_path):
    once = tmp_path / "killed"
    dying = wrapper(
        tmp_path / "twinray-dying",
        f'if [[ "$*" == *--only* && ! -e {once} ]]; then touch {once}; kill -KILL $$; fi\nexec "$BIN" "$@"',
    )
    out = tmp_path / "out"
    assert cli.main(["render", SCENE, "--twinray", dying, "-q", "-o", str(out / "f_####.png"), *FRAMES]) == 0
    assert once.exists()
    same_images(out, direct_frames(tmp_path / "direct"))


def test_flags_the_driver_sets_are_refused(tmp_path, capsys):
    assert ray_render("-o", str(tmp_path / "f.png"), *FRAMES, "--only", "1..2") == 1
    assert "--only: twinray-ray sets the share of each task itself" in capsys.readouterr().err


def test_no_more_twinray_processes_run_than_cpus(tmp_path):
    """The cluster has 2 CPUs and a task reserves 1: at most 2 twinray
    processes at once. (A task that waited on Ray while twinray ran, to
    report a frame, would give its CPU to the next task meanwhile.)"""
    spans = tmp_path / "spans"
    timed = wrapper(
        tmp_path / "twinray-timed",
        f'[[ " $* " == *" --print-job "* ]] && exec "$BIN" "$@"\n'
        f'echo "start $(date +%s%N)" >> {spans}\n"$BIN" "$@"\ncode=$?\n'
        f'echo "end $(date +%s%N)" >> {spans}\nexit $code',
    )
    out = tmp_path / "out"
    flags = [*FRAMES[:-2], "--size", "96x72"]
    assert cli.main(["render", SCENE, "--twinray", timed, "-q", "-o", str(out / "f_####.png"), "--chunk", "2", *flags]) == 0
    running, most = 0, 0
    events = sorted((int(t), what) for what, t in (l.split() for l in spans.read_text().splitlines()))
    for _, what in events:
        running += 1 if what == "start" else -1
        most = max(most, running)
    assert len(events) == 8 and most <= 2, events


def test_progress_advances_per_frame_while_the_task_runs(tmp_path):
    """One task renders all 8 frames; twinray is held after its first frame
    until the driver has reported that frame (30 s at most). Progress per
    task would come only when the task ends, after the hold times out."""
    gate, verdict = tmp_path / "gate", tmp_path / "verdict"
    held = wrapper(
        tmp_path / "twinray-held",
        f"""# twinray, its messages passed on, held after the first frame's line
# until the driver has shown that frame (the gate file), or 30 s.
[[ " $* " == *" --print-job "* ]] && exec "$BIN" "$@"
set -o pipefail
"$BIN" "$@" 2>&1 >/dev/null | {{
    waited=0
    while IFS= read -r line; do
        printf '%s\\n' "$line" >&2
        if [ $waited = 0 ] && [[ $line == "frame "* ]]; then
            waited=1
            for i in $(seq 300); do [ -e {gate} ] && break; sleep 0.1; done
            if [ -e {gate} ]; then echo released > {verdict}; else echo timed-out > {verdict}; fi
        fi
    done
}}""",
    )
    out = tmp_path / "out"
    seen = []

    def on_progress(unit):
        seen.append(unit)
        gate.touch()

    summary = driver.run_frames(
        held, SCENE, str(out / "f_####.png"), "0..7", extra=FRAMES[2:], chunk=8,
        progress=False, on_progress=on_progress,
    )
    assert verdict.read_text().strip() == "released", "no progress while the task ran"
    assert seen == [f"frame {i}" for i in range(8)], seen  # one step a frame, each once
    assert images(out) == [f"f_{i:04}.png" for i in range(8)]
    assert len(summary.written) == 8


def test_progress_counts_each_frame_once_when_a_worker_dies(tmp_path, monkeypatch):
    """Frames done before the run (by a run of the same job) and frames
    written by an attempt that died count once each."""
    out = tmp_path / "out"
    assert ray_render("-o", str(out / "f_####.png"), *FRAMES) == 0
    for i in (0, 3, 4, 5, 6, 7):
        (out / f"f_{i:04}.png").unlink()
    monkeypatch.setenv("TWINRAY_RAY_FAULT", str(tmp_path / "fault"))
    seen = []
    summary = driver.run_frames(
        BIN, SCENE, str(out / "f_####.png"), "0..7", extra=FRAMES[2:], chunk=4,
        progress=False, on_progress=seen.append,
    )
    assert (tmp_path / "fault").exists(), "no fault was injected"
    assert sorted(seen, key=lambda u: int(u.split()[1])) == [f"frame {i}" for i in range(8)], seen
    # Skipped: frames 1 and 2, and the frame the dead attempt reported.
    assert {1, 2} < set(summary.skipped), summary.skipped
    assert images(out) == [f"f_{i:04}.png" for i in range(8)]
