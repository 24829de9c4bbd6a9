"""Figure of :func:`imucal.joint_angles`: flexion over time with its band, and a gait-cycle
view when the recording is walking (docs/angles.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputError

FORMATS = (".png", ".pdf", ".svg")
#: Points per gait cycle in the cycle view (0-100 %).
CYCLE_POINTS = 101


def gait_cycles(flexion_deg: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """(cycles, CYCLE_POINTS) flexion resampled over each cycle from one peak of swing
    flexion to the next (0-100 %), vectorised over cycles."""
    peaks = np.asarray(peaks)
    a, b = peaks[:-1], peaks[1:]
    frac = np.linspace(0.0, 1.0, CYCLE_POINTS)
    pos = a[:, None] + frac[None, :] * (b - a)[:, None]
    return np.interp(pos, np.arange(flexion_deg.shape[0]), flexion_deg)


def zero_label(zero: dict) -> str:
    """What 0 deg is, short enough for a title: the method's first clause (its details in
    parentheses stay in the JSON) and where the zero was taken, e.g. "calibration: most
    extended still period at 3.2 s (calibration trial)". (Cut at a fixed length, the
    title read "... the 1st percentile of flexion )".)"""
    label = zero["method"].split(" (")[0]
    if zero.get("time_s") is not None:
        label += f" at {zero['time_s']:.1f} s ({zero['time_in']})"
    return label


def plot_angles(result, path: str | Path, *, truth: dict | None = None,
                gyro_only: bool = True) -> None:
    """Write the figure of a :class:`imucal.angles.JointAngles` to ``path`` (PNG, PDF or SVG
    by extension): per joint, flexion over time with the 2-sigma band (and pure gyro
    integration for comparison, ``gyro_only``); beside it the mean +- SD over gait cycles
    when walking was found. ``truth``: joint -> (N,) true flexion (simulations)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .atomic import write_atomic

    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise InputError(f"{path}: unknown figure format '{path.suffix or path.name}'; "
                         f"use {', '.join(FORMATS)}")
    joints = list(result.joints.values())
    walking = any(j.gait is not None for j in joints)
    fig, axes = plt.subplots(len(joints), 2 if walking else 1, squeeze=False,
                             figsize=(12 if walking else 9, 3.2 * len(joints)),
                             gridspec_kw={"width_ratios": [3, 1]} if walking else None)
    t = result.time
    for row, j in zip(axes, joints, strict=True):
        ax = row[0]
        if gyro_only:
            ax.plot(t, j.gyro_only_deg, color="0.6", lw=0.8, label="gyro integration only")
        ax.fill_between(t, j.flexion_deg - 2 * j.sigma_deg, j.flexion_deg + 2 * j.sigma_deg,
                        color="C0", alpha=0.25, lw=0, label="2-sigma band")
        ax.plot(t, j.flexion_deg, color="C0", lw=0.9, label="fused (imucal)")
        if truth and j.name in truth:
            ax.plot(t, truth[j.name], color="k", lw=0.7, ls="--", label="truth")
        status = "fits" if j.fits else "DOES NOT FIT the calibration"
        ax.set_title(f"{j.name}: flexion (+ = flexion, 0 = {zero_label(j.zero)}); {status}",
                     fontsize=9)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("flexion (deg)")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
        if walking:
            cyc = row[1]
            if j.gait is None:
                cyc.set_axis_off()
                continue
            cycles = gait_cycles(j.flexion_deg, j.gait["peaks"])
            x = np.linspace(0, 100, CYCLE_POINTS)
            mean, sd = cycles.mean(axis=0), cycles.std(axis=0)
            cyc.fill_between(x, mean - sd, mean + sd, color="C1", alpha=0.3, lw=0)
            cyc.plot(x, mean, color="C1")
            cyc.set_title(f"{len(cycles)} gait cycles, stride {j.gait['stride_s']:.2f} s "
                          "(mean +- SD)", fontsize=9)
            cyc.set_xlabel("% of cycle (from peak swing flexion)")
            cyc.grid(alpha=0.3)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
