"""Schematic of model ``axle4dof`` (the paper's Fig. 4, with this project's conventions).

:func:`plot_schematic` draws, in one axes: an oblique view of the trailing arm rotating
about the bushing centre O, the wheel with contact point C, the tread particle on its
lateral spring, the tire's vertical spring, the ISO axes X/Y/Z and the rotations
alpha/beta/gamma with their torsional springs; a top view with the running toe
``toe0 + alpha`` and the lateral direction d; a rear view with the running camber
``camber0 + beta``, the friction force F and the normal load N. Angles are exaggerated.

Write the documentation figure (docs/model_axle4dof.md) with::

    .venv/bin/python docs/figures/make_schematic.py docs/figures/axle4dof_schematic.png

This script is not part of the installed package; tests load it by its path.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from polywear.params import Axle, Operating

__all__ = ["plot_schematic"]

# drawn to the default geometry [m]: arm length L, pivot height H, rolling radius R_e
_ARM_LENGTH, _PIVOT_HEIGHT, _RADIUS = Axle().arm_length_m, Axle().pivot_height_m, Operating().rolling_radius_m
_OBLIQUE = 0.5 * np.array([math.cos(math.radians(30)), math.sin(math.radians(30))])


def _proj(x, y, z):
    """Oblique projection: X to the right, Z up, Y (inboard) receding up-right."""
    return np.array([x, z]) + y * _OBLIQUE


def _zigzag(a, b, turns=5, width=0.018):
    """Points of a spring symbol from a to b (2D)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = b - a
    normal = np.array([-axis[1], axis[0]]) / np.hypot(*axis)
    s = np.linspace(0.15, 0.85, 2 * turns + 1)
    offsets = width * np.array([0.0] + [(-1) ** i for i in range(1, 2 * turns)] + [0.0])
    pts = a + np.outer(s, axis) + np.outer(offsets, normal)
    return np.vstack([a, pts, b])


def _arrow(ax, start, end, label=None, color="k", offset=(0.0, 0.0), **text):
    art = [ax.annotate("", xy=end, xytext=start, arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.3})]
    if label:
        pos = np.asarray(end) + offset
        art.append(ax.text(*pos, label, color=color, ha="center", va="center", **text))
    return art


def _rotation_arc(ax, centre, radius, flatten, label, label_at, color):
    """An elliptic arc with an arrow head (a rotation about an axis seen obliquely)."""
    from matplotlib.patches import Arc

    arc = Arc(centre, 2 * radius, 2 * radius * flatten, theta1=200, theta2=500, color=color, lw=1.2)
    ax.add_patch(arc)
    tip = np.radians(500)
    head = centre + np.array([radius * np.cos(tip), radius * flatten * np.sin(tip)])
    back = centre + np.array([radius * np.cos(tip - 0.25), radius * flatten * np.sin(tip - 0.25)])
    return [arc, *_arrow(ax, back, head, color=color), ax.text(*label_at, label, color=color, fontsize=9)]


def _oblique_view(ax):
    art = []
    L, H, R = _ARM_LENGTH, _PIVOT_HEIGHT, _RADIUS
    road = [_proj(x, y, -H - 0.06) for x, y in ((-0.95, -0.15), (0.35, -0.15), (0.35, 0.45), (-0.95, 0.45))]
    art.append(ax.fill(*np.array(road).T, color="0.92", zorder=0)[0])
    art.append(ax.text(*_proj(0.2, 0.45, -H - 0.06) + (0, -0.04), "road (drum)", fontsize=8, color="0.4"))
    art += _arrow(ax, _proj(0.25, -0.1, -H - 0.06), _proj(-0.05, -0.1, -H - 0.06), r"road $-V X$", "0.35", (0.0, -0.04))

    origin = _proj(0, 0, 0)
    for vec, name in (((0.32, 0, 0), "X (forward)"), ((0, 0.42, 0), "Y (inboard)"), ((0, 0, 0.3), "Z (up)")):
        art += _arrow(ax, origin, _proj(*vec), name, "tab:blue", (0.02, 0.035), fontsize=9)

    wheel_centre = _proj(-L, 0, -H + R)
    contact = _proj(-L, 0, -H)
    art.append(ax.plot(*np.array([origin, wheel_centre]).T, color="0.25", lw=6, solid_capstyle="round")[0])
    label = "trailing arm + carrier + wheel\n($J_1, J_2, J_3$ about O)"
    art.append(ax.text(*(0.5 * (origin + wheel_centre) + (0, 0.03)), label, ha="center", fontsize=8))
    from matplotlib.patches import Circle

    wheel = Circle(wheel_centre, R * 0.97, fill=False, lw=2.5, color="0.3")
    ax.add_patch(wheel)
    art.append(wheel)
    art.append(ax.plot(*origin, "o", ms=11, mfc="white", mec="k", mew=2, zorder=5)[0])
    art.append(ax.text(*(origin + (0.025, -0.05)), "O (bushing)", fontsize=9))
    art.append(ax.plot(*contact, "o", color="k", ms=5, zorder=5)[0])
    art.append(ax.text(*(contact + (-0.06, 0.02)), "C", fontsize=10, weight="bold"))
    art.append(ax.text(*_proj(-0.95, -0.15, -H - 0.2), r"$C = (-L, -b, -H)$ in body axes", fontsize=8))

    tread = _proj(-L, 0.25, -H)
    art.append(ax.plot(*np.array(_zigzag(contact, tread)).T, color="tab:green", lw=1.2)[0])
    art.append(ax.plot(*tread, "s", ms=10, color="tab:green", zorder=5)[0])
    art.append(ax.text(*(tread + (0.12, -0.02)), "tread $m$ (state $x$)\n$k,\\ c$ along body $y$", fontsize=8, color="tab:green"))
    art += _arrow(ax, tread, tread + 0.12 * _OBLIQUE / np.hypot(*_OBLIQUE), r"$F\,d$", "tab:red", (0.0, 0.035))
    ground = contact + (0, -0.07)
    art.append(ax.plot(*np.array(_zigzag(ground, contact, turns=3)).T, color="tab:purple", lw=1.2)[0])
    art.append(ax.text(*(ground + (0.03, -0.01)), "$k_z,\\ c_z$", fontsize=9, color="tab:purple"))
    art += _arrow(ax, contact + (-0.07, -0.09), contact + (-0.07, 0.0), "$N$", "tab:red", (-0.035, -0.02))

    art += _rotation_arc(ax, _proj(0, 0, 0.2), 0.05, 0.35, r"$\alpha$ toe: $k_\alpha, c_\alpha$", _proj(-0.3, 0, 0.22), "tab:orange")
    art += _rotation_arc(ax, _proj(0.2, 0, 0), 0.03, 2.2, r"$\beta$ camber: $k_\beta, c_\beta$", _proj(0.2, 0, 0) + (0.05, -0.09), "tab:orange")
    art += _rotation_arc(ax, _proj(0, 0.3, 0), 0.04, 1.2, r"$\gamma$ pitch: $k_\gamma, c_\gamma$", _proj(0, 0.3, 0) + (0.06, 0.02), "tab:orange")
    return art


def _top_view(ax, centre):
    """Top view: X right, Y up; running toe psi = toe0 + alpha (toe-in positive)."""
    art = [ax.text(*(centre + (-0.3, 0.22)), "top view (right rear wheel)", fontsize=9, weight="bold")]
    psi = math.radians(14.0)
    heading = np.array([math.cos(psi), math.sin(psi)])
    lateral = np.array([-math.sin(psi), math.cos(psi)])
    corners = [centre + sx * 0.17 * heading + sy * 0.035 * lateral for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    art.append(ax.fill(*np.array(corners).T, color="0.6", alpha=0.6)[0])
    art.append(ax.plot(*np.array([centre - (0.25, 0), centre + (0.25, 0)]).T, "k--", lw=0.8)[0])
    art.append(ax.text(*(centre + (0.27, 0.0)), "X", fontsize=9, va="center"))
    art += _arrow(ax, centre + (-0.33, -0.1), centre + (-0.33, 0.02), "Y (inboard)", "tab:blue", (0.0, 0.03), fontsize=8)
    art += _arrow(ax, centre, centre + 0.24 * heading, "heading", "0.3", (0.0, 0.035), fontsize=8)
    art += _arrow(ax, centre, centre + 0.15 * lateral, r"$d$", "tab:red", (-0.02, 0.03))
    from matplotlib.patches import Arc

    arc = Arc(centre, 0.3, 0.3, theta1=0, theta2=14, color="tab:orange", lw=1.2)
    ax.add_patch(arc)
    art.append(arc)
    art.append(ax.text(*(centre + (0.02, -0.06)), r"$\psi = toe_0 + \alpha$ (toe-in $+$)", fontsize=8, color="tab:orange"))
    formula = r"$v_r = V\sin\psi - v_{tread}\cdot d - \varepsilon V \sin\varphi$"
    art.append(ax.text(*(centre + (-0.3, -0.14)), formula, fontsize=8))
    return art


def _rear_view(ax, centre):
    """Rear view (looking forward): Y to the left, Z up; camber phi = camber0 + beta."""
    art = [ax.text(*(centre + (-0.3, 0.22)), "rear view (looking forward)", fontsize=9, weight="bold")]
    phi = math.radians(12.0)
    up = np.array([math.sin(phi), math.cos(phi)])  # top tilts to the right = outboard (-Y)
    side = np.array([math.cos(phi), -math.sin(phi)])
    base = centre + (0.0, -0.2)
    corners = [base + sx * 0.05 * side + sz * 0.36 * up for sx, sz in ((-1, 0), (1, 0), (1, 1), (-1, 1))]
    art.append(ax.fill(*np.array(corners).T, color="0.6", alpha=0.6)[0])
    art.append(ax.plot(*np.array([base, base + (0, 0.38)]).T, "k--", lw=0.8)[0])
    art.append(ax.plot(*np.array([base + (-0.3, 0), base + (0.3, 0)]).T, color="0.3", lw=2)[0])
    from matplotlib.patches import Arc

    arc = Arc(base, 0.56, 0.56, theta1=90 - 12, theta2=90, color="tab:orange", lw=1.2)
    ax.add_patch(arc)
    art.append(arc)
    label = r"$\varphi = camber_0 + \beta$" + "\n(top outward $+$)"
    art.append(ax.text(*(base + (0.1, 0.24)), label, fontsize=8, color="tab:orange"))
    art += _arrow(ax, base + (0.24, 0.04), base + (0.1, 0.04), "", "tab:red")
    art.append(ax.text(*(base + (0.12, 0.07)), "$F$ (along $d$)", fontsize=8, color="tab:red"))
    art += _arrow(ax, base + (0.0, -0.11), base + (0.0, -0.01), "", "tab:red")
    art.append(ax.text(*(base + (0.02, -0.1)), "$N$", fontsize=9, color="tab:red"))
    art.append(ax.text(*(base + (-0.3, -0.05)), "Y (inboard)", fontsize=8))
    art.append(ax.text(*(base + (0.17, -0.05)), "outboard", fontsize=8))
    return art


def plot_schematic(ax=None):
    """Draw the axle4dof schematic into ``ax`` (a new figure if None); returns the artists."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(12, 6))
    art = _oblique_view(ax)
    art += _top_view(ax, np.array([1.05, 0.3]))
    art += _rear_view(ax, np.array([1.05, -0.25]))
    ax.set_aspect("equal")
    ax.set_xlim(-1.0, 1.4)
    ax.set_ylim(-0.62, 0.58)
    ax.axis("off")
    return art


def _main(path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12, 6))
    plot_schematic(ax)
    fig.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    _main(sys.argv[1] if len(sys.argv) > 1 else "axle4dof_schematic.png")
