#!/usr/bin/env python3
"""The automatic rig and the disparity report on every SPD scene and the
bundled ones: the table of docs/stereo.md ("The automatic rig measured") and
its anaglyph pictures (docs/images/budget/).

usage (from the project root, after cargo build --release):
    python3 bench/depth_budget.py [--images] > table.md
environment: TWINRAY (default target/release/twinray), SPD (default
../shared/scenes/spd). Standard library only.

For each scene, at its own resolution, three stereo renders:
  * auto:     --stereo (interaxial and convergence fitted to -1%,+2%);
  * near:     --stereo --convergence near;
  * explicit: --stereo --interaxial 0.1 (the SPD figures' value), converged at
              the scene's 'at' point as before the automatic rig.
Each writes --stats; the table reads the rig chosen, the disparity report and
the times. With --images, an anaglyph of the automatic rig at 160 px wide
(its rig fitted at that size) for each scene.
"""

import glob
import json
import os
import subprocess
import sys
import tempfile

TWINRAY = os.environ.get("TWINRAY", "target/release/twinray")
SPD = os.environ.get("SPD", "../shared/scenes/spd")


def scenes():
    bundled = [f"scenes/{n}.nff" for n in ("example", "probe", "shelf", "deep")]
    return sorted(glob.glob(os.path.join(SPD, "*.nff"))) + bundled


def render(scene, out, extra, stats):
    cmd = [TWINRAY, "render", scene, "-o", out, "-q", "--stats", stats] + extra
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {done.stderr}")
    with open(stats) as f:
        return json.load(f), done.stderr


def pct(span):
    return f"{span['near']:+.2f} … {span['far']:+.2f}"


def violations(d):
    v = d["window_violations"]
    if not v:
        return "none"
    return ", ".join(
        f"{x['edge']} rows {x['first_row']}–{x['last_row']} ({x['disparity_px']:+.1f} px)"
        for x in v
    )


def main():
    images = "--images" in sys.argv[1:]
    rows_auto, rows_cmp = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes():
            name = os.path.splitext(os.path.basename(scene))[0]
            out = os.path.join(tmp, "pair.png")
            st = os.path.join(tmp, "s.json")
            auto, _ = render(scene, out, ["--stereo"], st)
            near, _ = render(scene, out, ["--stereo", "--convergence", "near"], st)
            expl, warn = render(scene, out, ["--stereo", "--interaxial", "0.1"], st)
            d, rc = auto["disparity"], auto["rig_choice"]
            depth = d["depth"]
            rows_auto.append(
                f"| {name} | {auto['width']}×{auto['height']} "
                f"| {depth['nearest']:.3g} – {depth['farthest']:.3g} "
                f"| {rc['interaxial']:.4g} | {auto['effective_convergence']:.4g} "
                f"| {pct(d['adjacent_percent'])} | {violations(d)} "
                f"| {d['floating_window']['left_px']} / {d['floating_window']['right_px']} "
                f"| {auto['time']['depth_s'] * 1000:.0f} ms / {auto['time']['render_s']:.2f} s |"
            )
            nd, ed = near["disparity"], expl["disparity"]
            rows_cmp.append(
                f"| {name} | {near['rig_choice']['interaxial']:.4g} | {pct(nd['adjacent_percent'])} "
                f"| {len(nd['window_violations'])} "
                f"| {pct(ed['adjacent_percent'])} | {violations(ed)} "
                f"| {'yes' if 'exceed the depth budget' in warn else 'no'} |"
            )
            # The size variants (balls_s2, balls_s5, tetra_s8) look like their
            # base scene: no picture of their own.
            if images and "_s" not in name:
                size = "160x120" if auto["width"] != auto["height"] else "160x160"
                if name in ("probe",):
                    size = "160x80"
                if name == "deep":
                    size = "160x90"
                pic = f"docs/images/budget/{name}-anaglyph.png"
                render(scene, pic, ["--stereo", "--layout", "anaglyph", "--size", size], st)
    print("| scene | size | visible depth | interaxial | convergence (effective) "
          "| disparity, % of width | window violations | floating window L / R px "
          "| depth passes / render |")
    print("|---|---|---|---:|---:|---|---|---|---|")
    print("\n".join(rows_auto))
    print()
    print("| scene | `--convergence near`: interaxial | its disparity, % | its violations "
          "| `--interaxial 0.1` at `at`: disparity, % | its window violations | warned |")
    print("|---|---:|---|---:|---|---|---|")
    print("\n".join(rows_cmp))


if __name__ == "__main__":
    main()
