"""Convergence figures in the spirit of the paper's Fig. 4 and Fig. 5 (matplotlib, no display).

Figures are built on :class:`matplotlib.figure.Figure` directly, without pyplot, so no
GUI backend or global state is involved; this module is imported only when a plot is
asked for. :func:`save_figure` writes PNG, PDF or SVG; in the vector formats the bundles
of restart curves and sample clouds are embedded as images (hundreds of thousands of
vector segments would make files of megabytes that viewers draw slowly), axes and text
stay vector.

Every restart is drawn through all its stages, shaded and named in each per-iteration
panel: for the axis a coarse stage on a share of a few hundred samples (long recordings
only), then the fit on the restart's random data subset, then the refinement on all
samples, where the best restart is polished further. Costs are RMS residuals on the
samples a stage fits, so a curve steps where its restart changes stage; that step is
expected. Blue: restarts that reached the estimate; grey: the others; black: the best
restart, the estimate.

The restart-spread panel shows where the reported spread (``quality.*_spread_*``) comes
from: each restart's result on its data subset, relative to the estimate, in deg (axis)
or mm (position). Its Axes carries the gid :data:`SPREAD_GID`.

A header above the panels states what a reader must know before trusting any of them:
the verdict (in its colour; a result that is not identifiable in red), the reported
1-sigma, which the spread is not, the residual and how much the sensors moved, and the
warnings. Its Axes carries the gid :data:`HEADER_GID`.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib import ticker
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from .axis import AxisResult, joint_plane_projection
from .position import PositionResult, closest_point_on_axis
from .restarts import settled
from .vectors import joint_plane_rate

#: File name extensions --plot accepts, and matplotlib's name of each format.
FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}
#: Resolution of PNG figures, dots per inch (PDF and SVG are vector formats).
DPI = 110
_COMPONENT_COLOURS = ("tab:red", "tab:green", "tab:blue")
#: Sample-wise panels draw at most this many samples, evenly spread over all used ones
#: (more only blacken the cloud and slow vector formats down).
_MAX_POINTS = 3000
#: gid of the restart-spread panel's Axes (tests and callers find the panel by it).
SPREAD_GID = "restart-spread"
#: Restarts outside the spread panel's range are drawn at its edge when their values
#: exceed the spread-defining restarts' by this factor (one far-off local minimum would
#: otherwise squash the informative cloud into a line).
_CLIP_FACTOR = 3.0
_REACHED, _OTHER, _BEST = "tab:blue", "0.6", "k"
_STUCK = "tab:orange"
#: gid of the header's Axes (verdict, 1-sigma, residual, warnings).
HEADER_GID = "header"
#: Colour of each verdict in the header.
VERDICT_COLOURS = {"good": "tab:green", "use with care": "darkorange",
                   "not identifiable": "tab:red"}
#: Lines of reasons and warnings in the header at most (all of them are in the JSON).
_MAX_REASON_LINES = 12
#: Width of the axis and position figures, inches.
FIGURE_WIDTH_IN = 12
#: Height of one header line, inches.
_LINE_IN = 0.24
#: Sample-wise panels span at least this many rad/s: the rates of a still sensor, a few
#: hundredths of a rad/s of noise, would otherwise fill them like motion does.
_MIN_RATE_SPAN = 0.5


@dataclass(frozen=True)
class _Stage:
    """A span of the joined iteration axis (subset stage columns, then refinement)."""

    name: str
    start: float
    end: float
    colour: str


def axis_figure(result: AxisResult, sensors: str = "", document: dict | None = None
                ) -> Figure:
    """The axis estimate's convergence (Fig. 4 of the paper) and its data dependence.

    Header: the verdict, the reported 1-sigma (deg), the residual, the sensors' motion
    and the warnings. Panels: cost per iteration by stage (rad/s); j1, j2 components per
    iteration; each restart's subset fit as an angle from the estimate (deg); eq. (1) at
    the estimate; both sensors' rates in their joint planes (rad/s, drawn as points).
    ``sensors``: "first - second" for the title; ``document``: the run's JSON document
    (:func:`imucal.report.axis_report`), whose verdict and warnings (which count the
    loader's) and input (file, window on the recording's time axis) the figure then
    states, so that both say the same.

    Returns
    -------
    matplotlib.figure.Figure
        12 in wide, not attached to pyplot; write it with :func:`save_figure`.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, eq. 1 and Fig. 4.
    """
    lines = _header_lines(result, document, "j", result.uncertainty_deg, result.spread_deg,
                          "deg", _axis_motion(result))
    header = _LINE_IN * (len(lines) + 0.6)
    fig = Figure(figsize=(FIGURE_WIDTH_IN, 19 + header), layout="constrained")
    ax = _rows(fig, [["header"], ["cost"], ["j1", "j2"], ["spread", "fit"],
                     ["plane1", "plane2"]], [header, 4.0, 5.0, 5.0, 5.0])
    _header_panel(ax["header"], lines)
    best = _best_axis_restart(result)
    stages = _stages(result)
    path = _aligned_axis_path(result)
    _cost_panel(ax["cost"], result, "rad/s", stages, best, polished=True)
    _component_panel(ax["j1"], path[:, :, :3], result, result.j1, stages, best,
                     "j1 (first sensor's frame) per iteration", "component (unit vector)")
    _component_panel(ax["j2"], path[:, :, 3:], result, result.j2, stages, best,
                     "j2 (second sensor's frame) per iteration", "component (unit vector)")
    _axis_spread_panel(ax["spread"], result)
    _fit_panel(ax["fit"], result)
    for key, g, j, name in (("plane1", result.gyr1, result.j1, "First"),
                            ("plane2", result.gyr2, result.j2, "Second")):
        _plane_panel(ax[key], g, j, name, result)
    fig.suptitle(_title("Hinge axis estimation", sensors, document, result),
                 parse_math=False)
    return fig


def position_figure(result: PositionResult, sensors: str = "",
                    document: dict | None = None) -> Figure:
    """The joint-position estimate's convergence (Fig. 5 of the paper), in mm.

    Header: the verdict, the reported 1-sigma (mm), the residual, the sensors' motion and
    the warnings. Panels: cost per iteration by stage (m/s^2); o1, o2 components per
    iteration (mm); each restart's subset fit relative to the estimate, per component
    (mm). For a hinge every point is first moved along the axis to the point closest to
    both sensors, as the estimate is, and the cost panel marks the estimate's residual
    there. ``sensors`` and ``document`` as for :func:`axis_figure`
    (:func:`imucal.report.position_report`).

    Returns
    -------
    matplotlib.figure.Figure
        12 in wide, not attached to pyplot; write it with :func:`save_figure`.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, eq. 3 and Fig. 5.
    """
    lines = _header_lines(result, document, "o", result.uncertainty_mm, result.spread_mm,
                          "mm", _position_motion(result))
    header = _LINE_IN * (len(lines) + 0.6)
    fig = Figure(figsize=(FIGURE_WIDTH_IN, 14 + header), layout="constrained")
    ax = _rows(fig, [["header"], ["cost"], ["o1", "o2"], ["spread"]],
               [header, 4.3, 5.1, 4.6])
    _header_panel(ax["header"], lines)
    path = _joined(result.batch.path, result.refined.path)
    line = _line(result)
    if line is not None:
        path = closest_point_on_axis(path, line)
    best = _best_position_restart(result, line)
    stages = _stages(result)
    _cost_panel(ax["cost"], result, "m/s^2", stages, best,
                moved=result.rms_residual if line is not None else None)
    for key, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6))):
        which = "first" if key == "o1" else "second"
        _component_panel(ax[key], 1000 * path[:, :, sl], result,
                         1000 * getattr(result, key), stages, best,
                         f"{key} ({which} sensor's frame) per iteration", "component (mm)",
                         unit=" mm")
    _position_spread_panel(ax["spread"], result, line)
    fig.suptitle(_title(f"Joint position estimation ({result.joint})", sensors, document,
                        result), parse_math=False)
    return fig


def save_figure(fig: Figure, path, suffix: str | None = None) -> None:
    """Write ``fig`` to ``path`` in the format of ``suffix`` (default: ``path``'s), one of
    :data:`FORMATS`, PNG at :data:`DPI` dots per inch.

    The same figure gives the same bytes: no creation date in PDF and SVG, and SVG's
    element ids are hashed from a fixed salt instead of a random one.

    Raises
    ------
    ValueError
        The suffix is not one of :data:`FORMATS` (nothing is written).
    """
    import matplotlib

    suffix = (Path(path).suffix if suffix is None else suffix).lower()
    if suffix not in FORMATS:
        raise ValueError(f"unknown figure format '{suffix}'; use one of {', '.join(FORMATS)}")
    fmt = FORMATS[suffix]
    metadata = {"png": None, "pdf": {"CreationDate": None}, "svg": {"Date": None}}[fmt]
    with matplotlib.rc_context({"svg.hashsalt": "imucal"}):
        fig.savefig(path, format=fmt, dpi=DPI, metadata=metadata)


def _rows(fig: Figure, rows: list[list[str]], heights: list[float]) -> dict:
    """Axes by name, one subfigure per row: a legend beside one row's panel must not
    narrow the panels of the other rows (it would in a shared grid)."""
    axes = {}
    subs = fig.subfigures(len(rows), 1, height_ratios=heights)
    for sub, names in zip(subs, rows, strict=True):
        axes.update(zip(names, np.atleast_1d(sub.subplots(1, len(names))), strict=True))
    return axes


def _title(what: str, sensors: str, document: dict | None, result) -> str:
    """The estimate, then which recording, window, samples and seed it comes from (the
    document's where given: its window is on the recording's own time axis)."""
    first = f"{what}: {sensors}" if sensors else what
    info = (document or {}).get("input", {})
    start, end = info.get("window_s") or result.window
    samples = info.get("samples_used", result.samples_used)
    where = [f"window {start:g} to {end:g} s", f"{samples} samples used"]
    if info.get("path"):
        where.insert(0, Path(str(info["path"])).name)
    seed = result.settings.get("seed")
    if seed is not None:
        where.append(f"seed {seed}")
    # a long file or sensor name must not run off the figure (12 in at 12 pt)
    wrap = chars_per_line(FIGURE_WIDTH_IN, 12)  # a suptitle's 12 pt
    return "\n".join(textwrap.fill(line, wrap) for line in (first, ", ".join(where)))


def _header_lines(result, document: dict | None, v: str, sigma: dict, spread: dict,
                  unit: str, motion: str) -> list[tuple[str, str, str]]:
    """(text, colour, weight) per header line: verdict, 1-sigma against the spread,
    residual and motion, then the blocking reasons and warnings, each wrapped; whole
    warnings only, as many as ``_MAX_REASON_LINES`` hold. Verdict and warnings are the
    document's where given (they count the loader's warnings too)."""
    quality = (document or {}).get("quality", {})
    verdict = quality.get("verdict", result.verdict)
    colour = VERDICT_COLOURS.get(verdict, "k")
    head = {"good": "Verdict: good",
            "use with care": "Verdict: use with care (see the warnings below)",
            "not identifiable": "Verdict: NOT IDENTIFIABLE - the data cannot determine "
                                "this estimate; do not use these values"}.get(
        verdict, f"Verdict: {verdict}")
    v1, v2 = f"{v}1", f"{v}2"

    def pair(d):
        return f"{v1} {_num(d[v1], unit)}, {v2} {_num(d[v2], unit)}"

    wrap = chars_per_line(FIGURE_WIDTH_IN, 8.5)  # the header's 8.5 pt
    lines = [(head, colour, "bold")]
    for text in (f"Reported 1-sigma: {pair(sigma)}. The restarts' spread drawn below "
                 f"({pair(spread)}) is not the uncertainty: random halves of the samples "
                 "share every stretch of the recording.",
                 f"Relative residual {result.relative_residual:.1%}; {motion}"):
        lines += [(t, "k", "normal") for t in textwrap.wrap(text, wrap)]
    warnings = quality.get("warnings", result.blocking + result.warnings)
    blocking = len(result.blocking)
    reasons = [(f"not identifiable: {w}" if k < blocking else f"warning: {w}",
                "tab:red" if k < blocking else "darkorange")
               for k, w in enumerate(warnings)]
    shown, left = wrapped_whole([text for text, _ in reasons], wrap, _MAX_REASON_LINES)
    # (shown may be shorter than reasons: the ones left out are counted below)
    lines += [(t, c, "normal") for (_, c), texts in zip(reasons, shown, strict=False)
              for t in texts]
    if left:
        lines.append((f"... and {left} more (every reason and warning is in the JSON's "
                      "quality.warnings and the result's warnings)", "0.3", "normal"))
    return lines


def chars_per_line(width_in: float, points: float) -> int:
    """Characters of text ``points`` high that fit a line across ``width_in`` inches (an
    average character is about 0.6 of the font size wide, with a margin).

    Returns
    -------
    int
        ``int(0.9 * width_in * 72 / (0.6 * points))``.

    Examples
    --------
    >>> from imucal.plots import chars_per_line
    >>> chars_per_line(12, 12)
    108
    """
    return int(0.9 * width_in * 72 / (0.6 * points))


def wrapped_whole(texts: list[str], wrap: int, max_lines: int) -> tuple[list[list[str]], int]:
    """Each of ``texts`` wrapped to ``wrap`` characters (continuation lines indented),
    whole ones only (never cut in the middle of a sentence), as many as ``max_lines``
    hold with one line left to say how many more there are.

    Returns
    -------
    shown : list of list of str
        The wrapped lines of each text shown, the first ones of ``texts`` in order.
    left : int
        How many texts were left out (0: all shown).

    Examples
    --------
    >>> from imucal.plots import wrapped_whole
    >>> wrapped_whole(["short one", "a somewhat longer warning that wraps", "third"], 20, 4)
    ([['short one']], 2)
    """
    shown: list[list[str]] = []
    used = 0
    for k, text in enumerate(texts):
        lines = textwrap.wrap(text, wrap, subsequent_indent="    ")
        left = len(texts) - k
        if used + len(lines) > max_lines - (left > 1):
            return shown, left
        shown.append(lines)
        used += len(lines)
    return shown, 0


def _num(value, unit: str) -> str:
    """A number for the header as the JSON has it: null there, n/a here."""
    return f"{value:.3g} {unit}" if value is not None and np.isfinite(value) else "n/a"


def _header_panel(ax, lines: list[tuple[str, str, str]]) -> None:
    ax.set_axis_off()
    ax.set_gid(HEADER_GID)
    step = 1.0 / max(len(lines), 1)
    for k, (text, colour, weight) in enumerate(lines):
        ax.text(0.0, 1.0 - k * step, text, transform=ax.transAxes, va="top", ha="left",
                color=colour, fontweight=weight, fontsize=10 if k == 0 else 8.5,
                parse_math=False)  # a "$" in a file or sensor name is no formula


def _axis_motion(result: AxisResult) -> str:
    e = result.excitation
    plane = e.get("joint_plane_rate_rms_deg_s", [float("nan")] * 2)
    return (f"RMS flexion rate {e.get('flexion_rate_rms_deg_s', float('nan')):.3g} deg/s; "
            f"RMS joint-plane rates {plane[0]:.3g} and {plane[1]:.3g} deg/s (first, second "
            "sensor)")


def _position_motion(result: PositionResult) -> str:
    rates = result.excitation.get("rate_rms_deg_s", [float("nan")] * 2)
    return f"RMS angular rates {rates[0]:.3g} and {rates[1]:.3g} deg/s (first, second sensor)"


def _line(result: PositionResult) -> np.ndarray | None:
    line = getattr(result, "line", None)
    if line is None and result.joint == "hinge" and result.axis is not None:
        line = np.concatenate([result.axis.j1, result.axis.j2])
    return None if line is None else np.asarray(line, dtype=float)


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


def _axis_angles_deg(x: np.ndarray, result: AxisResult) -> np.ndarray:
    """(R, 2) sign-free angles of (j1, j2) rows of ``x`` from the estimate, deg."""
    out = np.empty((x.shape[0], 2))
    for k, (sl, ref) in enumerate(((slice(0, 3), result.j1), (slice(3, 6), result.j2))):
        v = x[:, sl] / np.linalg.norm(x[:, sl], axis=1, keepdims=True)
        out[:, k] = np.degrees(np.arccos(np.clip(np.abs(v @ ref), 0.0, 1.0)))
    return out


def _best_axis_restart(result: AxisResult) -> int:
    """Index of the restart the estimate came from (its refined value is the estimate)."""
    best = getattr(result, "best", None)
    if best is not None:
        return int(best)
    with np.errstate(invalid="ignore"):
        d = _axis_angles_deg(result.refined.x, result).sum(axis=1)
    return int(np.nanargmin(d)) if np.isfinite(d).any() else 0


def _best_position_restart(result: PositionResult, line) -> int:
    best = getattr(result, "best", None)
    if best is not None:
        return int(best)
    finals = result.refined.x if line is None else closest_point_on_axis(result.refined.x, line)
    d = np.linalg.norm(finals - np.concatenate([result.o1, result.o2]), axis=1)
    return int(np.nanargmin(d)) if np.isfinite(d).any() else 0


def _subset_and_refined(result) -> list[_Stage]:
    k1 = result.batch.cost.shape[1] - 1
    end = k1 + result.refined.cost.shape[1] - 1
    return [_Stage("subset: each restart on its random half of the samples", 0, k1, "white"),
            _Stage("refined on all samples", k1, end, "#dbe9f6")]


def _stages(result) -> list[_Stage]:
    """The solver's stages on the joined iteration axis (:mod:`imucal.multistart`, the
    same for both estimators)."""
    stages = _subset_and_refined(result)
    k1 = stages[0].end
    coarse = getattr(result, "coarse_iterations", None)
    if coarse is not None:
        c_end = float(np.max(coarse)) if np.size(coarse) else 0.0
    else:
        # Not in the result: the coarse stage runs when the used samples are at least
        # twice its sample count, for at most coarse_iterations steps; where within
        # that span each restart moves on is not recorded.
        s = result.settings
        ran = "coarse_samples" in s and result.samples_used >= 2 * s["coarse_samples"]
        c_end = min(s.get("coarse_iterations", 0), s["max_iterations"], k1) if ran else 0.0
    if c_end > 0:
        samples = result.settings.get("coarse_samples", "a few hundred")
        stages = [_Stage(f"coarse: at most {c_end:g} steps on a share of {samples} samples",
                         0, c_end, "#fde9c9"),
                  _Stage("subset: each restart on its random half of the samples", c_end, k1,
                         "white"),
                  stages[1]]
    return stages


def _shade(ax, stages: list[_Stage]) -> None:
    for st in stages:
        if st.colour != "white":
            ax.axvspan(st.start, st.end, color=st.colour, lw=0, zorder=0)
        if st.start > 0:
            ax.axvline(st.start, color="k", ls=":", lw=0.8, zorder=1)


def _filled(cost: np.ndarray) -> np.ndarray:
    """Carry each restart's last cost forward over the NaN padding after it stopped."""
    out = cost.copy()
    for col in range(1, out.shape[1]):
        gap = np.isnan(out[:, col])
        out[gap, col] = out[gap, col - 1]
    return out


def _cost_panel(ax, result, unit: str, stages: list[_Stage], best: int,
                polished: bool = False, moved: float | None = None) -> None:
    """``moved``: the estimate's RMS residual after the best restart's point was moved
    along the hinge axis (joint centres of hinges), marked at the last iteration: on a
    joint that is not an exact hinge that move raises the cost."""
    subset = _filled(result.batch.cost)
    refined = _filled(result.refined.cost)
    with np.errstate(invalid="ignore"):
        cost = np.sqrt(np.concatenate([subset, refined[:, 1:]], axis=1))  # mean square -> RMS
    its = np.arange(cost.shape[1])
    _shade(ax, stages)
    reached = np.asarray(result.reached, dtype=bool)
    # the few restarts that did not reach the estimate go on top: where they end at the
    # estimate's cost, a competing minimum, they must not hide behind the blue ones
    for mask, colour in ((reached, _REACHED), (~reached, _OTHER)):
        if mask.any():
            ax.plot(its, cost[mask].T, color=colour, lw=0.7, alpha=0.5, rasterized=True)
    ax.plot(its, cost[best], color=_BEST, lw=1.5)
    if moved is not None:
        ax.plot([its[-1]], [moved], marker="D", ms=7, color="tab:red", ls="none", zorder=6)
    finite = cost[np.isfinite(cost) & (cost > 0)]
    if moved is not None and np.isfinite(moved) and moved > 0:
        finite = np.append(finite, moved)
    if finite.size and finite.max() > 10 * finite.min():
        ax.set_yscale("log")
        _plain_log_ticks(ax.yaxis)
    else:  # within a decade a log axis would carry one or two labels
        ax.yaxis.get_major_formatter().set_useOffset(False)
    _iteration_axis(ax)
    n = len(reached)
    ax.set(ylabel=f"RMS residual ({unit})",
           title=f"Cost of {n} restart{'s' if n != 1 else ''} per iteration "
                 f"({int(reached.sum())} reached the estimate)")
    n_reached = int(reached.sum())
    handles = [
        Line2D([], [], color=_REACHED, lw=1.2, label=f"reached the estimate ({n_reached})"),
        Line2D([], [], color=_OTHER, lw=1.2, label=f"did not reach it ({n - n_reached})"),
        Line2D([], [], color=_BEST, lw=1.5,
               label=("best restart" if moved is not None else "best restart = the estimate")
                     + ("\n(polished further on all samples)" if polished else "")),
    ]
    if moved is not None:
        handles.append(Line2D([], [], marker="D", ms=6, color="tab:red", ls="none",
                              label="the estimate, moved along the axis\n"
                                    f"(RMS residual {moved:.3g} {unit})"))
    handles += [Patch(facecolor=st.colour, edgecolor="0.5", lw=0.5, label=st.name)
                for st in stages]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              title_fontsize=8, alignment="left",
              title="Each stage fits other samples, so\na curve steps where its restart\n"
                    "moves on: expected, not a failure")


def _component_panel(ax, path, result, final, stages, best, title, ylabel,
                     unit: str = "") -> None:
    its = np.arange(path.shape[0])
    reached = np.asarray(result.reached, dtype=bool)
    _shade(ax, stages)
    for c, colour in enumerate(_COMPONENT_COLOURS):
        if (~reached).any():
            ax.plot(its, path[:, ~reached, c], color="0.7", lw=0.5, alpha=0.4, rasterized=True)
        ax.plot(its, path[:, reached, c], color=colour, lw=0.6, alpha=0.4, rasterized=True)
        ax.axhline(final[c], color=colour, ls="--", lw=1.2,
                   label=f"{'xyz'[c]} = {final[c]:.3g}{unit}")
    ax.plot(its, path[:, best], color=_BEST, lw=0.8)
    ax.yaxis.get_major_formatter().set_useOffset(False)
    _iteration_axis(ax)
    ax.set(ylabel=ylabel, title=title)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=8,
              title="estimate (dashed)", title_fontsize=8)


def _iteration_axis(ax) -> None:
    ax.xaxis.set_major_locator(ticker.MaxNLocator(nbins=8, integer=True))
    ax.set_xlabel("iteration")
    ax.margins(x=0.01)


def _plain_log_ticks(axis) -> None:
    """Log axis ticks at 1, 2, 5 x 10^k labelled as plain numbers (no 2x10^0)."""
    axis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(ticker.NullFormatter())


def _axis_spread_panel(ax, result: AxisResult) -> None:
    """Each restart's subset fit: its angle from the estimate, deg, per axis."""
    angles = _axis_angles_deg(result.batch.x, result)
    spread = getattr(result, "spread_deg", {}) or {}
    _strip(ax, ["j1", "j2"], angles, result, "angle from the estimate (deg)", " deg",
           signed=False,
           rms={0: spread.get("j1"), 1: spread.get("j2")}, rms_groups={0: [0], 1: [1]})
    ax.set_title("Each restart's fit on its data subset: angle from the estimate\n"
                 "(the spread is the RMS of the blue points)")


def _position_spread_panel(ax, result: PositionResult, line) -> None:
    """Each restart's subset fit minus the estimate, per component, mm."""
    x = result.batch.x if line is None else closest_point_on_axis(result.batch.x, line)
    d = 1000 * (x - np.concatenate([result.o1, result.o2]))
    spread = getattr(result, "spread_mm", {}) or {}
    names = [f"{v} {c}" for v in ("o1", "o2") for c in "xyz"]
    _strip(ax, names, d, result, "subset fit - estimate (mm)", " mm", signed=True,
           rms={1: spread.get("o1"), 4: spread.get("o2")},
           rms_groups={1: [0, 1, 2], 4: [3, 4, 5]})
    hinge = " (moved along the axis to the point closest to both sensors)" if line is not None \
        else ""
    ax.set_title(f"Each restart's fit on its data subset{hinge}, relative to the estimate\n"
                 "(the spread is the RMS distance of the blue points)")


def _strip(ax, names, values, result, ylabel, unit, *, signed, rms, rms_groups) -> None:
    """One column of points per name: ``values`` (R, len(names)), one row per restart.

    Blue: restarts that reached the estimate and whose subset fit settled (these make
    the spread); orange: reached, but the subset fit stuck in a local minimum (left out
    of the spread); grey: did not reach the estimate. Points far beyond the blue ones
    are drawn at the panel's edge as triangles.
    """
    ax.set_gid(SPREAD_GID)
    reached = np.asarray(result.reached, dtype=bool)
    keep = settled(result.batch.final_cost, reached)
    stuck = reached & ~keep
    r = values.shape[0]
    # deterministic jitter so that restarts with equal values stay visible side by side
    jitter = ((np.arange(r) * 0.6180339887) % 1.0 - 0.5) * 0.5
    finite = np.isfinite(values)
    core = np.abs(values[keep][finite[keep]])
    everything = np.abs(values[finite])
    top = float(core.max()) if core.size else (float(everything.max()) if everything.size
                                               else 1.0)
    top = max(top, 1e-6)
    allmax = float(everything.max()) if everything.size else top
    lim = 1.15 * (allmax if allmax <= _CLIP_FACTOR * top else top)
    clipped = finite & (np.abs(values) > lim)
    ax.axhline(0, color="k", lw=0.8)
    for mask, colour, label, z in ((~reached, _OTHER, "did not reach the estimate", 2),
                                   (stuck, _STUCK, "reached, but the subset fit was stuck "
                                    "in a local minimum (left out)", 3),
                                   (keep, _REACHED, "reached; in the spread", 4)):
        cols = [(k, mask & finite[:, k] & ~clipped[:, k]) for k in range(len(names))]
        xs = np.concatenate([k + jitter[m] for k, m in cols])
        ys = np.concatenate([values[m, k] for k, m in cols])
        ax.scatter(xs, ys, s=14, c=colour, lw=0, alpha=0.8, zorder=z,
                   label=f"{label} ({int(mask.sum())})", gid=f"spread-{colour}")
    if clipped.any():
        rows, cols = np.nonzero(clipped)
        up = values[rows, cols] > 0
        for sel, marker, edge in ((up, "^", 0.97), (~up, "v", -0.97)):
            if sel.any():
                ax.scatter(cols[sel] + jitter[rows[sel]], np.full(sel.sum(), edge * lim),
                           marker=marker, s=22, facecolors="none", edgecolors="0.3", lw=0.8,
                           zorder=5, label=f"{int(sel.sum())} values beyond the panel, drawn "
                           f"at its edge (up to {np.abs(values[rows[sel], cols[sel]]).max():.3g}"
                           f"{unit})")
    for centre, value in rms.items():
        if value is None or not np.isfinite(value):
            continue
        for k in rms_groups[centre]:
            # a signed column is one component of a 3-D distance: its dashes are that
            # component's RMS (the 3-D RMS drawn on each column looked like a band about
            # sqrt(3) too wide)
            level = value if not signed else float(np.sqrt(np.mean(values[keep, k] ** 2)))
            if np.isfinite(level):
                ax.hlines([level] + ([-level] if signed else []), k - 0.4, k + 0.4,
                          colors=_REACHED, lw=1, linestyles="--", zorder=1)
    ax.set_xticks(range(len(names)), names)
    ax.set_xlim(-0.6, len(names) - 0.4)
    ax.set_ylim(-lim if signed else 0.0, lim * 1.12)
    ax.yaxis.get_major_formatter().set_useOffset(False)
    ax.set_ylabel(ylabel)
    values_text = ", ".join(f"{names[c].split()[0]} {v:.3g}{unit}" for c, v in rms.items()
                            if v is not None and np.isfinite(v))
    ax.plot([], [], color=_REACHED, ls="--", lw=1,
            label=(f"spread = RMS distance of the blue points (3-D): {values_text};\n"
                   "dashes: each component's RMS" if signed else
                   f"spread = RMS angle of the blue points: {values_text}"))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2 if signed else 1,
              fontsize=8)


def _fit_panel(ax, result: AxisResult) -> None:
    """Eq. (1): the projections' lengths should agree sample by sample."""
    n1 = joint_plane_rate(result.gyr1, result.j1)
    n2 = joint_plane_rate(result.gyr2, result.j2)
    step = max(1, -(-n1.size // _MAX_POINTS))
    ax.scatter(n1[::step], n2[::step], s=_marker_size(n1[::step].size), alpha=0.4, lw=0,
               rasterized=True, label="samples used")
    top = max(float(max(n1.max(), n2.max())), _MIN_RATE_SPAN)
    ax.plot([0, top], [0, top], "k--", lw=1, label="perfect hinge")
    ax.set(xlabel="|g1 x j1|, first sensor's joint-plane rate (rad/s)",
           ylabel="|g2 x j2|, second sensor's (rad/s)",
           title=f"Eq. (1) at the estimate (relative residual {result.relative_residual:.1%})")
    ax.set_xlim(0, 1.05 * top)
    ax.set_ylim(0, 1.05 * top)
    ax.set_aspect("equal", adjustable="box")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=8)


def _marker_size(n: int) -> float:
    """Marker area, points^2: small for thousands of samples, visible for tens."""
    return float(np.clip(3000.0 / max(n, 1), 3.0, 20.0))


def _plane_panel(ax, g: np.ndarray, j: np.ndarray, name: str, result) -> None:
    """The rates in the joint plane as points: the samples used are a selection of time
    ranges (and thinned within them), so a line would join samples far apart in time."""
    step = max(1, -(-g.shape[0] // _MAX_POINTS))
    p = joint_plane_projection(g[::step], j)
    ax.scatter(p[:, 0], p[:, 1], s=_marker_size(p.shape[0]), alpha=0.35, lw=0,
               rasterized=True)
    half = max(float(np.abs(p).max()) if p.size else 0.0, _MIN_RATE_SPAN / 2)
    ax.set_xlim(-1.05 * half, 1.05 * half)
    ax.set_ylim(-1.05 * half, 1.05 * half)
    ax.set_aspect("equal", adjustable="box")
    ranges = np.asarray(getattr(result, "time_ranges", np.empty((0, 2)))).reshape(-1, 2)
    ax.set(xlabel="rate along the first in-plane direction (rad/s)",
           ylabel="along the second (rad/s)",
           title=f"{name} sensor's rate in its joint plane (eq. 6, Fig. 4)\n"
                 f"{p.shape[0]} samples from {len(ranges)} time range"
                 f"{'s' if len(ranges) != 1 else ''}, drawn as points")
