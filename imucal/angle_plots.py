"""Figure of :func:`imucal.joint_angles`: flexion over time with its band, and a cycle
view when the flexion repeats regularly, as in walking (docs/angles.md)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from .errors import InputError

FORMATS = (".png", ".pdf", ".svg")
#: Points per gait cycle in the cycle view (0-100 %).
CYCLE_POINTS = 101


def gait_cycles(flexion_deg: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Flexion resampled over each cycle (a gait cycle when walking), from one flexion peak
    to the next (0-100 %), vectorised over cycles.

    Parameters
    ----------
    flexion_deg
        (N,) flexion, deg.
    peaks
        Sample indices of the flexion peaks (peak swing flexion when walking),
        increasing; one cycle fewer than peaks.

    Returns
    -------
    (cycles, CYCLE_POINTS) float64
        Flexion, deg, linearly interpolated at :data:`CYCLE_POINTS` evenly spaced points
        of each cycle.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.angle_plots import gait_cycles
    >>> cycles = gait_cycles(np.arange(30.0), [0, 10, 20])
    >>> cycles.shape, cycles[:, [0, 50, 100]].tolist()
    ((2, 101), [[0.0, 5.0, 10.0], [10.0, 15.0, 20.0]])
    """
    peaks = np.asarray(peaks)
    a, b = peaks[:-1], peaks[1:]
    frac = np.linspace(0.0, 1.0, CYCLE_POINTS)
    pos = a[:, None] + frac[None, :] * (b - a)[:, None]
    return np.interp(pos, np.arange(flexion_deg.shape[0]), flexion_deg)


def zero_label(zero: dict) -> str:
    """What 0 deg is, short enough for a title: the method's first clause (its details in
    parentheses stay in the JSON) and where the zero was taken, e.g. "calibration: most
    extended still period from 3.2 s (calibration trial)": a still period's zero is its
    mean, so the period is named by its start ("at" read as the instant of the zero).
    (Cut at a fixed length, the title read "... the 1st percentile of flexion )".)

    Returns
    -------
    str
        The text of ``zero["method"]`` before its first " (", plus " at T s (WHERE)"
        (" from T s" for a still period) when ``zero["time_s"]`` is given (s, in
        ``zero["time_in"]``).

    Examples
    --------
    >>> from imucal.angle_plots import zero_label
    >>> zero_label({"method": "most extended still period (gyro below 0.1 rad/s)",
    ...             "time_s": 3.21, "time_in": "calibration trial"})
    'most extended still period from 3.2 s (calibration trial)'
    """
    label = zero["method"].split(" (")[0]
    if zero.get("time_s") is not None:
        when = "from" if label.endswith("still period") else "at"
        label += f" {when} {zero['time_s']:.1f} s ({zero['time_in']})"
    return label


def angles_figure(result, *, truth: dict | None = None, gyro_only: bool = True):
    """The figure of a :class:`imucal.angles.JointAngles` (a matplotlib ``Figure``, no
    pyplot): per joint, flexion over time with the 2-sigma band (deg; and pure gyro
    integration for comparison, ``gyro_only``); beside it the mean +- SD over the
    cycles when the flexion repeats regularly (walking, or circling the leg). Above each
    joint: what + and 0 mean, whether the joint still fits its calibration (red when
    not, and then no cycle average), the calibration's verdict when it is not
    identifiable, and the joint's warnings.
    ``truth``: joint -> (N,) true flexion, deg (simulations).

    Returns
    -------
    matplotlib.figure.Figure
        One row per joint (flexion in deg against time in s, and the cycle view when the
        flexion repeats regularly), 12 in wide with the cycle view, else 9 in.
    """
    from matplotlib.figure import Figure

    from .plots import chars_per_line

    joints = list(result.joints.values())
    walking = any(j.gait is not None for j in joints)
    width = 12 if walking else 9
    heads = [_joint_header(j, chars_per_line(width, 9)) for j in joints]
    top = _figure_header(result, chars_per_line(width, 10))
    heights = [2.6 + _LINE_IN * len(lines) for lines, _ in heads]
    fig = Figure(figsize=(width, sum(heights) + _LINE_IN * (len(top) + 1)),
                 layout="constrained")
    # (parse_math off: a "$" in a file or joint name is no formula)
    fig.suptitle("\n".join(top), fontsize=10, parse_math=False)
    subs = np.atleast_1d(fig.subfigures(len(joints), 1, height_ratios=heights))
    t = result.time
    for sub, j, (lines, colour) in zip(subs, joints, heads, strict=True):
        row = np.atleast_1d(sub.subplots(
            1, 2 if walking else 1, gridspec_kw={"width_ratios": [3, 1]} if walking else None))
        sub.suptitle("\n".join(lines), x=0.01, ha="left", fontsize=9, color=colour,
                     parse_math=False)
        ax = row[0]
        if gyro_only:
            ax.plot(t, j.gyro_only_deg, color="0.6", lw=0.8, label="gyro integration only")
        ax.fill_between(t, j.flexion_deg - 2 * j.sigma_deg, j.flexion_deg + 2 * j.sigma_deg,
                        color="C0", alpha=0.25, lw=0, label="2-sigma band")
        ax.plot(t, j.flexion_deg, color="C0", lw=0.9, label="fused (imucal)")
        if truth and j.name in truth:
            ax.plot(t, truth[j.name], color="k", lw=0.7, ls="--", label="truth")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("flexion (deg)")
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
        if walking:
            _cycle_panel(row[1], j)
    return fig


def plot_angles(result, path: str | Path, *, truth: dict | None = None,
                gyro_only: bool = True) -> None:
    """Write :func:`angles_figure` to ``path`` (PNG, PDF or SVG by extension; the same
    figure gives the same bytes, :func:`imucal.plots.save_figure`), atomically.

    Raises
    ------
    InputError
        As :func:`staged_angles_figure`: an unknown suffix, or the file cannot be written.
    """
    with staged_angles_figure(result, path, truth=truth, gyro_only=gyro_only):
        pass


def staged_angles_figure(result, path: str | Path, *, truth: dict | None = None,
                         gyro_only: bool = True):
    """:func:`plot_angles` as a block (:func:`imucal.atomic.staged`): the figure is in place
    only when the block ends without an exception, so that a run whose table then fails
    to be written leaves no figure of it.

    Returns
    -------
    context manager
        The figure is drawn on the call; entering writes it to a temporary file beside
        ``path`` (a device or pipe: to ``path`` itself), a clean exit puts it at
        ``path``, an exception in the block removes it.

    Raises
    ------
    InputError
        ``path``'s suffix is not a figure format matplotlib writes, or the figure cannot be
        written.
    """
    from .atomic import staged
    from .plots import save_figure

    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise InputError(f"{path}: unknown figure format '{path.suffix or path.name}'; "
                         f"use {', '.join(FORMATS)}")
    fig = angles_figure(result, truth=truth, gyro_only=gyro_only)
    return staged(path, lambda tmp: save_figure(fig, tmp, path.suffix))


#: Height of one title line above a joint's panels, inches.
_LINE_IN = 0.2
#: Warning lines shown above a joint at most (whole warnings only; all of them are in the
#: joint's ``warnings`` and on the command line's stderr).
_MAX_WARNING_LINES = 10


def _figure_header(result, wrap: int) -> list[str]:
    """Which recording, window and calibration, and the recording's own warnings."""
    from pathlib import Path

    lines = textwrap.wrap(f"Flexion: {Path(str(result.source)).name}, t = "
                          f"{result.time[0]:g} to {result.time[-1]:g} s, calibration "
                          f"{Path(str(result.calibration)).name}", wrap)
    for w in result.warnings:
        lines += textwrap.wrap(f"warning: {w}", wrap, subsequent_indent="    ")
    return lines


def _joint_header(j, wrap: int) -> tuple[list[str], str]:
    """Title lines above one joint and their colour: red when the joint does not fit
    its calibration, orange with warnings or a calibration to use with care, black
    otherwise."""
    lines = [f"{j.name}: flexion in deg; + = flexion; 0 = {zero_label(j.zero)}"]
    verdict = j.check.get("calibration_verdict")
    if not j.fits:
        status = "DOES NOT FIT the calibration"
        if verdict == "not identifiable":
            status += " (the calibration itself is not identifiable for this joint)"
        lines.append(status + ": do not read these angles as the knee's")
    elif verdict not in (None, "good"):
        lines.append(f"fits its calibration (calibration verdict: {verdict})")
    else:
        lines.append("fits its calibration")
    wrapped = [text for line in lines for text in textwrap.wrap(line, wrap)]
    from .plots import wrapped_whole

    # this recording's warnings (sign, zero, fit) before those copied from the calibration
    ordered = sorted(j.warnings, key=lambda w: w.startswith("calibration:"))
    shown, left = wrapped_whole([f"warning: {w}" for w in ordered], wrap, _MAX_WARNING_LINES)
    warned = [t for texts in shown for t in texts]
    if left:
        warned.append(f"... and {left} more warning(s) (the joint's warnings; stderr of "
                      "imucal angles)")
    careful = j.warnings or verdict not in (None, "good")
    colour = "tab:red" if not j.fits else ("darkorange" if careful else "k")
    return wrapped + warned, colour


def _cycle_panel(cyc, j) -> None:
    if j.gait is None:
        cyc.set_axis_off()
        return
    cyc.set_xlabel("% of cycle (from peak flexion)")
    cyc.set_ylabel("flexion (deg)")
    cyc.grid(alpha=0.3)
    if not j.fits:  # an average would make angles that are not the knee's look regular
        cyc.set_title("cycles: not averaged\n(the joint does not fit)", fontsize=9,
                      color="tab:red")
        cyc.set_xticks([])
        cyc.set_yticks([])
        return
    cycles = gait_cycles(j.flexion_deg, j.gait["peaks"])
    x = np.linspace(0, 100, CYCLE_POINTS)
    mean, sd = cycles.mean(axis=0), cycles.std(axis=0)
    cyc.fill_between(x, mean - sd, mean + sd, color="C1", alpha=0.3, lw=0)
    cyc.plot(x, mean, color="C1")
    cyc.set_title(f"{len(cycles)} cycles of {j.gait['stride_s']:.2f} s\n"
                  "(mean +- SD)", fontsize=9)
