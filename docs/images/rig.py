"""Draws docs/images/rig.png: the stereo rig from above, and the twin method's
two passes over a row of samples.  Run from the project root:

    python3 docs/images/rig.py
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, Rectangle

RED, BLUE, GREY = "#c0392b", "#1f77b4", "#555555"

fig, (ax, bx) = plt.subplots(1, 2, figsize=(10.5, 5.0))

# (a) The rig seen from above.
ax.set_title("(a) the rig, seen from above", fontsize=11)
left, right, screen = (-0.5, 0.0), (0.5, 0.0), 5.0
for x, c in ((left[0], RED), (right[0], BLUE)):
    ax.plot([x, x], [0, 8.5], "--", color=c, lw=1)
ax.plot([-2.5, 3.5], [screen, screen], color=GREY, lw=2)
ax.text(0.3, screen + 0.15, "zero parallax (screen) at C = f·b/D", fontsize=8)
far, near = (1.2, 8.0), (1.5, 3.0)
for p in (far, near):
    for e, c in ((left, RED), (right, BLUE)):
        ax.plot([e[0], p[0]], [e[1], p[1]], color=c, lw=0.8)
    ax.plot(*p, "ks", ms=5)
ax.text(far[0] + 0.1, far[1] - 0.1, "far point:\nZ > C, x_R − x_L > 0", fontsize=8)
ax.text(near[0] + 0.1, near[1] - 0.1, "near point:\nZ < C, x_R − x_L < 0", fontsize=8)
ax.text(0.62, 3.9, "parallel\nlens axes\n(view_dir)", fontsize=8)
ax.add_patch(FancyArrowPatch((-0.5, 0.8), (0.5, 0.8), arrowstyle="<->", mutation_scale=10))
ax.text(-0.05, 0.95, "b", fontsize=10)
ax.plot(*left, "o", color=RED, ms=8)
ax.plot(*right, "o", color=BLUE, ms=8)
ax.plot(0, 0, "ko", ms=4)
ax.text(0, -0.55, "eye\n(NFF from)", fontsize=7, ha="center")
ax.text(-0.6, -0.55, "left view\noffset −b/2", fontsize=8, color=RED, ha="right")
ax.text(0.6, -0.55, "right view\noffset +b/2", fontsize=8, color=BLUE)
ax.add_patch(FancyArrowPatch((-2.5, -1.3), (1.5, -1.3), arrowstyle="->", mutation_scale=12))
ax.text(1.6, -1.45, "right axis =\nnormalize(cross(view_dir, up))", fontsize=8)
ax.set_xlim(-2.6, 4.2)
ax.set_ylim(-1.9, 9)
ax.axis("off")

# (b) The twin method's two passes over one row of samples.
bx.set_title("(b) the twin method, one row of samples", fontsize=11)
n = 14
shift_l, shift_r = 2, -2


def row(y, color, label, highlight=()):
    for i in range(n):
        face = color if i in highlight else "white"
        bx.add_patch(Rectangle((i, y), 1, 0.7, fc=face, ec=color, lw=0.8, alpha=0.9))
    bx.text(-0.4, y + 0.35, label, fontsize=8, color=color, ha="right", va="center")


# Pass 1: sample x of each view, one packet; the lanes look along their own columns.
x = 6
bx.text(-3.3, 7.6, "pass 1, eye rays:", fontsize=9, weight="bold")
row(6.4, RED, "left samples", highlight=(x,))
row(5.2, BLUE, "right samples", highlight=(x,))
bx.text(n + 0.3, 6.75, f"column x + shift_L", fontsize=8, color=RED, va="center")
bx.text(n + 0.3, 5.55, f"column x + shift_R", fontsize=8, color=BLUE, va="center")
bx.text(-3.3, 4.5, "one packet per sample x: one descent returns the\n"
        "nearest hit of both views' rays (they cross at the screen)", fontsize=8)

# Pass 2: a left sample's hit projected into the right view picks its partner.
i, k = 4, 7
bx.text(-3.3, 3.2, "pass 2, shading:", fontsize=9, weight="bold")
row(2.0, RED, "left samples", highlight=(i,))
row(0.8, BLUE, "right samples", highlight=(k,))
bx.add_patch(FancyArrowPatch((i + 0.5, 2.0), (k + 0.5, 1.5), arrowstyle="->",
                             mutation_scale=10, color=GREY))
bx.text(-3.3, -0.5, "the left hit, projected into the right view, picks the sample\n"
        "that sees the same point; the two are shaded as one packet\n"
        "(shadow, reflected, refracted rays: each its own view's)", fontsize=8)
bx.set_xlim(-3.5, n + 4.5)
bx.set_ylim(-1.3, 8.2)
bx.axis("off")

fig.tight_layout()
fig.savefig("docs/images/rig.png", dpi=110)
