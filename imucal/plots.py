"""Convergence figures in the spirit of the paper's Fig. 4 and Fig. 5 (matplotlib, no display).

Figures are built on :class:`matplotlib.figure.Figure` directly, without pyplot, so no
GUI backend or global state is involved; this module is imported only when a plot is
asked for.

Every restart is drawn through both of its phases: the fit on its random data
subset, then the refinement on all samples (right of the dotted line), so the curves
end on the reported estimate when the restart reached it. Blue: restarts that reached
the estimate; grey: the others.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .axis import AxisResult, joint_plane_projection
from .position import PositionResult, closest_point_on_axis

_COMPONENT_COLOURS = ("tab:red", "tab:green", "tab:blue")
_LEGEND_NOTE = "\n(curves of restarts that did not reach the estimate are grey)"
#: At most this many samples are drawn in the sample-wise panels (readability).
_MAX_POINTS = 1500


def axis_figure(result: AxisResult, sensors: str = "") -> Figure:
    """Cost and j1, j2 per iteration; eq. (1) check; joint-plane traces (Fig. 4)."""
    fig = Figure(figsize=(11, 12), layout="constrained")
    axes = fig.subplots(3, 2)
    path = _aligned_axis_path(result)
    _cost_panel(axes[0, 0], result, "RMS residual (rad/s)")
    _fit_panel(axes[0, 1], result)
    _component_panel(axes[1, 0], path[:, :, :3], result, result.j1, "j1 (first sensor)")
    _component_panel(axes[1, 1], path[:, :, 3:], result, result.j2, "j2 (second sensor)")
    for ax, g, j, name in ((axes[2, 0], result.gyr1, result.j1, "first"),
                           (axes[2, 1], result.gyr2, result.j2, "second")):
        _plane_panel(ax, g, j, name)
    fig.suptitle(_title("Hinge axis estimation", sensors))
    return fig


def position_figure(result: PositionResult, sensors: str = "") -> Figure:
    """Cost and o1, o2 per iteration (Fig. 5 of the paper) and every restart's final o1."""
    fig = Figure(figsize=(11, 8), layout="constrained")
    axes = fig.subplots(2, 2)
    path = _joined(result.batch.path, result.refined.path)
    line = None
    if result.joint == "hinge" and result.axis is not None:
        # compare like with like: the estimate is the point of the axis closest to both
        # sensors, so the paths are drawn moved to that point, too
        line = np.concatenate([result.axis.j1, result.axis.j2])
        path = closest_point_on_axis(path, line)
    _cost_panel(axes[0, 0], result, "RMS residual (m/s^2)")
    _component_panel(axes[0, 1], path[:, :, :3], result, result.o1, "o1 (m)")
    _component_panel(axes[1, 0], path[:, :, 3:], result, result.o2, "o2 (m)")
    ax = axes[1, 1]
    final = path[-1]
    ax.scatter(final[~result.reached, 0], final[~result.reached, 1], s=12, c="0.6",
               label="did not reach the estimate")
    ax.scatter(final[result.reached, 0], final[result.reached, 1], s=12, c="tab:blue",
               label="reached the estimate")
    ax.plot(result.o1[0], result.o1[1], "k+", ms=14, mew=2, label="estimate")
    ax.set(xlabel="o1 x (m)", ylabel="o1 y (m)",
           title="Final o1 of every restart, refined on all samples (x-y)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8, loc="best")
    fig.suptitle(_title(f"Joint position estimation ({result.joint})", sensors))
    return fig


def _title(what: str, sensors: str) -> str:
    return f"{what}: {sensors}{_LEGEND_NOTE}" if sensors else what + _LEGEND_NOTE


def _joined(subset: np.ndarray, refined: np.ndarray) -> np.ndarray:
    """Subset iterations followed by the refinement iterations, along axis 0."""
    return np.concatenate([subset, refined[1:]], axis=0)


def _aligned_axis_path(result: AxisResult) -> np.ndarray:
    """Both phases of every restart, each axis drawn with the sign matching the estimate."""
    path = _joined(result.batch.path, result.refined.path)
    for sl, ref in ((slice(0, 3), result.j1), (slice(3, 6), result.j2)):
        sign = np.where(path[-1, :, sl] @ ref < 0, -1.0, 1.0)
        path[:, :, sl] *= sign[None, :, None]
    return path


def _filled(cost: np.ndarray) -> np.ndarray:
    """Carry each restart's last cost forward over the NaN padding after it stopped."""
    out = cost.copy()
    for col in range(1, out.shape[1]):
        gap = np.isnan(out[:, col])
        out[gap, col] = out[gap, col - 1]
    return out


def _cost_panel(ax, result, ylabel: str) -> None:
    subset = _filled(result.batch.cost)
    refined = _filled(result.refined.cost)
    cost = np.sqrt(np.concatenate([subset, refined[:, 1:]], axis=1))  # mean squared -> RMS
    its = np.arange(cost.shape[1])
    for reached in (False, True):
        colour = "tab:blue" if reached else "0.6"
        for row in cost[result.reached == reached]:
            ax.plot(its, row, color=colour, lw=0.7, alpha=0.6)
    _phase_line(ax, subset.shape[1] - 1)
    ax.set_yscale("log")
    n = len(result.reached)
    ax.set(xlabel="iteration", ylabel=ylabel,
           title=f"Cost of {n} restarts ({int(result.reached.sum())} reached the estimate)")


def _component_panel(ax, path, result, final, label: str) -> None:
    its = np.arange(path.shape[0])
    reached = result.reached
    for c, colour in enumerate(_COMPONENT_COLOURS):
        ax.plot(its, path[:, ~reached, c], color="0.7", lw=0.5, alpha=0.4)
        ax.plot(its, path[:, reached, c], color=colour, lw=0.6, alpha=0.4)
        ax.axhline(final[c], color=colour, ls="--", lw=1.5, label=f"{'xyz'[c]} = {final[c]:.3f}")
    _phase_line(ax, result.batch.path.shape[0] - 1)
    ax.set(xlabel="iteration", ylabel="component",
           title=f"{label} per iteration")
    ax.legend(fontsize=8, loc="best", framealpha=0.8)


def _phase_line(ax, at: int) -> None:
    ax.axvline(at, color="k", ls=":", lw=1)
    ax.annotate(" refined on all samples", (at, 1), xycoords=("data", "axes fraction"),
                va="top", fontsize=8)


def _fit_panel(ax, result: AxisResult) -> None:
    """Eq. (1): the projections' lengths should agree sample by sample."""
    n1 = np.linalg.norm(np.cross(result.gyr1, result.j1), axis=1)
    n2 = np.linalg.norm(np.cross(result.gyr2, result.j2), axis=1)
    step = max(1, n1.size // _MAX_POINTS)
    ax.scatter(n1[::step], n2[::step], s=4, alpha=0.5)
    top = float(max(n1.max(), n2.max(), 1e-9))
    ax.plot([0, top], [0, top], "k--", lw=1, label="perfect hinge")
    ax.set(xlabel="|g1 x j1| (rad/s)", ylabel="|g2 x j2| (rad/s)",
           title=f"Eq. (1) at the estimate (relative residual {result.relative_residual:.1%})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8, loc="upper left")


def _plane_panel(ax, g: np.ndarray, j: np.ndarray, name: str) -> None:
    p = joint_plane_projection(g[:_MAX_POINTS], j)
    ax.plot(p[:, 0], p[:, 1], lw=0.7)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="rad/s", ylabel="rad/s",
           title=f"{name.capitalize()} sensor's rate in its joint plane (eq. 6, Fig. 4)")
