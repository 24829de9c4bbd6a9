"""Convergence figures in the spirit of the paper's Fig. 4 and Fig. 5 (matplotlib, no display).

Figures are built on :class:`matplotlib.figure.Figure` directly, without pyplot, so no
GUI backend or global state is involved; this module is imported only when a plot is
asked for.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .axis import AxisResult, joint_plane_projection
from .position import PositionResult

_COMPONENT_COLOURS = ("tab:red", "tab:green", "tab:blue")


def axis_figure(result: AxisResult, title: str = "") -> Figure:
    """Cost per iteration, j1 and j2 components per iteration, and the joint-plane traces.

    Each restart's path is drawn with the sign that matches the estimate (eq. 1 cannot
    see signs), so restarts that reached the estimate visibly converge onto it.
    """
    fig = Figure(figsize=(11, 8), layout="constrained")
    axes = fig.subplots(2, 2)
    path = _aligned_axis_path(result)
    _cost_panel(axes[0, 0], result, "RMS residual (rad/s)")
    _component_panel(axes[0, 1], path[:, :, :3], result.j1, result.reached, "j1 (first sensor)")
    _component_panel(axes[1, 0], path[:, :, 3:], result.j2, result.reached, "j2 (second sensor)")
    _plane_panel(axes[1, 1], result)
    fig.suptitle(title or "Hinge axis estimation")
    return fig


def position_figure(result: PositionResult, title: str = "") -> Figure:
    """Cost per iteration and the o1, o2 components per iteration (Fig. 5 of the paper)."""
    fig = Figure(figsize=(11, 8), layout="constrained")
    axes = fig.subplots(2, 2)
    _cost_panel(axes[0, 0], result, "RMS residual (m/s^2)")
    path = result.batch.path
    _component_panel(axes[0, 1], path[:, :, :3], result.o1, result.reached, "o1 (m)")
    _component_panel(axes[1, 0], path[:, :, 3:], result.o2, result.reached, "o2 (m)")
    ax = axes[1, 1]
    final = result.batch.x
    ax.scatter(final[~result.reached, 0], final[~result.reached, 1], s=12, c="0.6",
               label="did not reach the estimate")
    ax.scatter(final[result.reached, 0], final[result.reached, 1], s=12, c="tab:blue",
               label="reached the estimate")
    ax.plot(result.o1[0], result.o1[1], "k+", ms=14, mew=2, label="estimate")
    ax.set(xlabel="o1 x (m)", ylabel="o1 y (m)", title="Final o1 of every restart (x-y)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    fig.suptitle(title or f"Joint position estimation ({result.joint})")
    return fig


def _aligned_axis_path(result: AxisResult) -> np.ndarray:
    path = result.batch.path.copy()
    final = result.batch.x
    for sl, ref in ((slice(0, 3), result.j1), (slice(3, 6), result.j2)):
        sign = np.where(final[:, sl] @ ref < 0, -1.0, 1.0)
        path[:, :, sl] *= sign[None, :, None]
    return path


def _cost_panel(ax, result, ylabel: str) -> None:
    cost = np.sqrt(result.batch.cost)  # mean squared -> RMS
    its = np.arange(cost.shape[1])
    for reached in (False, True):
        rows = cost[result.reached == reached]
        colour = "tab:blue" if reached else "0.6"
        for row in rows:
            ax.plot(its, row, color=colour, lw=0.7, alpha=0.6)
    ax.set_yscale("log")
    n = len(result.reached)
    ax.set(xlabel="Gauss-Newton iteration", ylabel=ylabel,
           title=f"Cost of {n} restarts ({int(result.reached.sum())} reached the estimate, blue)")


def _component_panel(ax, path, final, reached, label: str) -> None:
    its = np.arange(path.shape[0])
    for c, colour in enumerate(_COMPONENT_COLOURS):
        ax.plot(its, path[:, reached, c], color=colour, lw=0.6, alpha=0.4)
        ax.plot(its, path[:, ~reached, c], color="0.7", lw=0.5, alpha=0.4)
        ax.axhline(final[c], color=colour, ls="--", lw=1.5, label=f"{'xyz'[c]} = {final[c]:.3f}")
    ax.set(xlabel="Gauss-Newton iteration", ylabel="component", title=f"{label} per iteration")
    ax.legend(fontsize=8, loc="upper right")


def _plane_panel(ax, result: AxisResult) -> None:
    p1 = joint_plane_projection(result.gyr1, result.j1)
    p2 = joint_plane_projection(result.gyr2, result.j2)
    ax.plot(p1[:, 0], p1[:, 1], lw=0.7, label="g1 projected (first sensor)")
    ax.plot(p2[:, 0], p2[:, 1], lw=0.7, label="g2 projected (second sensor)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="rad/s", ylabel="rad/s",
           title="Angular rates in the joint planes (eq. 6, Fig. 4)")
    ax.legend(fontsize=8)
