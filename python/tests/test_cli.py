"""The `twinray-ray` command as a user runs it, each run its own process:
`--address auto` with no cluster and an address that does not answer are
said in one line; without --address it starts a local cluster, creates the
output folder, and Ctrl-C (SIGINT) stops it with one line and a record from
which the same command goes on; the binary is found as the README installs
it. These run before test_ray.py, whose cluster `--address auto` would find.
"""

import os
import shlex
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import BIN, FRAMES, SCENE, direct_frames, images, journal_names, same_images
from twinray_ray import binary
from twinray_ray.record import RECORD_SUFFIX

# The command pip installs beside the interpreter.
COMMAND = Path(sys.executable).parent / "twinray-ray"


def command(*args, **kw):
    if not COMMAND.is_file():
        pytest.fail(f"no {COMMAND}: pip install ./python first")
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env["TWINRAY_BIN"] = BIN
    return subprocess.Popen(
        [str(COMMAND), "render", SCENE, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        **kw,
    )


def lines(text):
    return [l for l in text.splitlines() if l.strip()]


def gcs_servers():
    """Ray clusters running on this machine (their GCS processes)."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            if b"gcs_server" in (proc / "cmdline").read_bytes().split(b"\0")[0]:
                found.append(proc.name)
        except OSError:
            pass
    return found


def test_address_auto_without_a_cluster_says_to_start_one(tmp_path):
    assert not gcs_servers(), "a Ray cluster is running on this machine: this test needs none"
    p = command("--frames", "0..1", "-o", str(tmp_path / "f_####.png"), "--address", "auto")
    out, err = p.communicate(timeout=120)
    assert p.returncode == 1, err
    assert "Traceback" not in err + out, err
    said = [l for l in lines(err) if l.startswith("twinray-ray:")]
    assert len(said) == 1 and "`ray start --head`" in said[0], err


def test_an_address_that_does_not_answer_is_said_at_once(tmp_path):
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    p = command("--frames", "0..1", "-o", str(tmp_path / "f_####.png"), "--address", f"127.0.0.1:{port}")
    out, err = p.communicate(timeout=120)
    assert p.returncode == 1
    assert lines(err) == [
        f"twinray-ray: no Ray cluster answers at 127.0.0.1:{port} (Connection refused): start one there "
        f"with `ray start --head --port={port}`, or leave out --address to start a local one"
    ], err


def test_a_local_cluster_stopped_by_ctrl_c_goes_on_where_it_stopped(tmp_path):
    """twinray's messages are held after each task's first frame until the
    gate file exists, so the run is under way when SIGINT comes: frames 0 and
    4 are recorded, the others are not (whatever twinray has written). The
    same command then renders only those others."""
    gate, journal = tmp_path / "gate", tmp_path / "journal"
    held = tmp_path / "twinray-held"
    held.write_text(
        f"""#!/bin/bash
[[ " $* " == *" --print-job "* ]] && exec {shlex.quote(BIN)} "$@"
worker=$PPID
exec {shlex.quote(BIN)} "$@" 2> >(
    held=0
    while IFS= read -r line; do
        printf '%s\\n' "$line" >&2
        if [ $held = 0 ] && [[ $line == "frame "* ]]; then
            held=1
            for i in $(seq 1200); do
                [ -e {gate} ] && break
                kill -0 $worker 2>/dev/null || exit 0
                sleep 0.1
            done
        fi
    done
)
"""
    )
    held.chmod(0o755)
    out = tmp_path / "shots" / "new"  # missing: the run creates it
    args = ["-o", str(out / "f_####.png"), "--chunk", "4", "--num-cpus", "2", "--twinray", str(held)]
    args += ["--journal", str(journal), *FRAMES]
    record = Path(str(out / "f_####.png") + RECORD_SUFFIX)

    run = command(*args, start_new_session=True)
    deadline = time.monotonic() + 180
    while not (record.exists() and '"frame 0"' in record.read_text() and '"frame 4"' in record.read_text()):
        assert run.poll() is None, run.communicate()
        assert time.monotonic() < deadline, "frames 0 and 4 never recorded"
        time.sleep(0.05)
    run.send_signal(signal.SIGINT)
    stdout, err = run.communicate(timeout=60)
    assert run.returncode == 130, err
    assert "Traceback" not in stdout + err and "KeyboardInterrupt" not in stdout + err, err
    said = [l for l in lines(err) if "interrupt" in l.lower()]
    assert said == [
        f"twinray-ray: interrupted with 2 of 8 frames done; the same command goes on from there "
        f"(record: {record})"
    ], err
    assert lines(err)[-1] == said[0], err

    # Nothing of the run is left running, nor half written.
    deadline = time.monotonic() + 30
    while any(str(tmp_path).encode() in (p / "cmdline").read_bytes() for p in _procs()):
        assert time.monotonic() < deadline, "a process of the run is still running"
        time.sleep(0.1)
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")], "a temporary file is left"

    gate.touch()
    first = journal_names(journal)
    again = command(*args)
    stdout, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert "6 file(s) written, 2 frame(s) done already" in err, err
    assert sorted(journal_names(journal)[len(first) :]) == [f"f_{i:04}.png" for i in (1, 2, 3, 5, 6, 7)]
    same_images(out, direct_frames(tmp_path / "direct"))


def _procs():
    for p in Path("/proc").iterdir():
        if p.name.isdigit() and int(p.name) != os.getpid():
            try:
                (p / "cmdline").read_bytes()
            except OSError:
                continue
            yield p


def _executable(path: Path) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#!/bin/sh\n")
    path.chmod(0o755)
    return str(path)


def test_the_binary_is_found_as_the_readme_installs_it(tmp_path, monkeypatch):
    repo = tmp_path / "repo"
    (repo / "python" / "twinray_ray").mkdir(parents=True)
    (repo / "Cargo.toml").write_text("[workspace]\n")
    installed = tmp_path / "site-packages" / "twinray_ray"  # pip install ./python
    installed.mkdir(parents=True)
    monkeypatch.delenv("TWINRAY_BIN", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "bin"))
    monkeypatch.setattr(binary, "PACKAGE_DIR", installed)

    # Nothing built: the message says what was tried.
    with pytest.raises(binary.BinaryNotFound) as e:
        binary.find_twinray(cwd=repo / "scenes")
    assert str(e.value) == (
        "no twinray binary: tried $TWINRAY_BIN (not set), twinray on the PATH (none), "
        f"{repo}/target/release/twinray (missing); build it with `cargo build --release` "
        "in the repository, or give --twinray PATH"
    )

    # cargo build --release, then twinray-ray run in the repository or below.
    built = _executable(repo / "target" / "release" / "twinray")
    assert binary.find_twinray(cwd=repo) == built
    assert binary.find_twinray(cwd=repo / "scenes") == built
    # From elsewhere, with the package installed from the repository in
    # place (pip install -e ./python).
    monkeypatch.setattr(binary, "PACKAGE_DIR", repo / "python" / "twinray_ray")
    assert binary.find_twinray(cwd=tmp_path) == built

    # The PATH before the repository, $TWINRAY_BIN before the PATH, --twinray
    # before all.
    on_path = _executable(tmp_path / "bin" / "twinray")
    assert binary.find_twinray(cwd=repo) == on_path
    named = _executable(tmp_path / "named" / "twinray")
    monkeypatch.setenv("TWINRAY_BIN", named)
    assert binary.find_twinray(cwd=repo) == named
    assert binary.find_twinray(built, cwd=repo) == built
    monkeypatch.setenv("TWINRAY_BIN", str(tmp_path / "nothing"))
    with pytest.raises(binary.BinaryNotFound, match=r"^\$TWINRAY_BIN=.*/nothing: not an executable file$"):
        binary.find_twinray(cwd=repo)
