#!/usr/bin/env python3
"""Peak resident memory of a command and, apart, of its child processes
(twinray's ffmpeg): polls VmHWM in /proc every 0.2 s until it exits.

    bench/peak_rss.py twinray render ... -o shot.mp4 --frames 0..239 ...

Prints `twinray_peak_mib X  children_peak_mib Y  seconds Z`. GNU time's %M
cannot tell them apart: it reports the largest of the process and its
children (ffmpeg's x264 lookahead outgrows twinray on a long shot).
"""
import os
import subprocess
import sys
import time


def hwm_kib(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def children(pid):
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(d))
            except (OSError, IndexError, ValueError):
                pass
    return out


def main():
    start = time.time()
    proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    own = kids = 0
    while proc.poll() is None:
        own = max(own, hwm_kib(proc.pid))
        for c in children(proc.pid):
            kids = max(kids, hwm_kib(c))
        time.sleep(0.2)
    if proc.returncode != 0:
        sys.exit(f"exit status {proc.returncode}")
    print(f"twinray_peak_mib {own / 1024:.1f}  children_peak_mib {kids / 1024:.1f}  seconds {time.time() - start:.1f}")


if __name__ == "__main__":
    main()
