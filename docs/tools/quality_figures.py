"""Draw the figures of docs/quality.md from simulated good and bad cases.

Run from the repository root:  .venv/bin/python docs/tools/quality_figures.py
Writes docs/figures/quality_*.png (deterministic seeds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from imucal import estimate_axis, estimate_position
from imucal.simulate import simulate

OUT = Path(__file__).resolve().parents[1] / "figures"


def _cases():
    good, _ = simulate(seed=1, rate=100, duration=20, snr=100, motion="circling")
    rigid, _ = simulate(seed=1, rate=100, duration=20, snr=100, motion="rigid-knee")
    return {
        "good knee": (good, "thigh", "shank"),
        "rigid knee": (rigid, "thigh", "shank"),
        "ankle fitted as a hinge": (good, "shank", "foot"),
    }


def restarts_figure(results) -> Figure:
    """Where each restart ended (refined on all samples): angle from the estimate against
    its RMS residual relative to the best. One point = one answer."""
    fig = Figure(figsize=(9, 3.2), layout="constrained")
    for ax, (name, r) in zip(fig.subplots(1, len(results)), results.items(), strict=True):
        rms = np.sqrt(r.refined.final_cost)
        x = r.refined.x
        cos = np.minimum(np.abs(x[:, :3] @ r.j1), np.abs(x[:, 3:] @ r.j2))
        ax.plot(np.degrees(np.arccos(np.clip(cos, 0, 1))), rms / rms.min(), "o", alpha=0.4,
                color="tab:green" if r.verdict == "good" else "tab:red")
        ax.set_title(f"{name}\nverdict: {r.verdict}", fontsize=9)
        ax.set_xlabel("angle from the estimate, deg")
        ax.set_ylabel("RMS residual / best")
        ax.set_xlim(-5, 95)
        ax.set_ylim(0.995, max(1.1, 1.02 * float(np.max(rms / rms.min()))))
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.text(0.97, 0.95, f"{r.convergence_fraction:.0%} reached the estimate\n"
                f"relative residual {r.relative_residual:.2f}\n"
                f"flexion rate {r.excitation['flexion_rate_rms_deg_s']:.0f} deg/s",
                transform=ax.transAxes, va="top", ha="right", fontsize=8)
    return fig


def uncertainty_figure() -> Figure:
    """True error against the reported 1-sigma over random cases, and sigma vs duration."""
    rng = np.random.default_rng(7)
    errs, sigmas = [], []
    for i in range(40):
        snr = float(np.exp(rng.uniform(np.log(30), np.log(300))))
        rate = float(rng.choice([40, 100, 200]))
        rec, truth = simulate(seed=900 + i, rate=rate, duration=10, snr=snr)
        r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rate,
                          seed=1, restarts=10)
        err = np.degrees(np.arccos(min(1.0, abs(r.j1 @ truth["knee"]["j1"]))))
        errs.append(err)
        sigmas.append(r.uncertainty_deg["j1"])
    durations = [5, 10, 20, 30]
    by_length, sampling = [], []
    for d in durations:
        rec, _ = simulate(seed=3, rate=100, duration=d, snr=50)
        sh, ft = rec.sensor("shank"), rec.sensor("foot")
        p = estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=100, seed=1, restarts=10)
        by_length.append(p.uncertainty_mm["o1"])
        c = p.uncertainty_components
        sampling.append(max(c["curvature"]["o1"], c["time_blocks"]["o1"]))
    fig = Figure(figsize=(9, 3.4), layout="constrained")
    a, b = fig.subplots(1, 2)
    a.loglog(sigmas, errs, ".")
    lim = np.array([min(sigmas) / 2, max(sigmas) * 4])
    a.plot(lim, lim, "k-", lw=0.8, label="error = 1 sigma")
    a.plot(lim, 3 * lim, "k--", lw=0.8, label="error = 3 sigma")
    a.set_xlabel("reported j1 1-sigma, deg")
    a.set_ylabel("true j1 error, deg")
    a.set_title("axis: 40 simulated knees, SNR 30-300, 40-200 Hz", fontsize=9)
    a.legend(fontsize=8)
    b.plot(durations, by_length, "o-", label="reported 1-sigma")
    # the cut-off shift and the model term do not average out with more samples
    b.plot(durations, sampling, "s--", label="its sampling part (curvature, time blocks)")
    b.set_xlabel("recording length, s")
    b.set_ylabel("ankle o1 1-sigma, mm")
    b.set_ylim(bottom=0)
    b.set_title("position: the sampling error shrinks with data", fontsize=9)
    b.legend(fontsize=8)
    return fig


def main() -> None:
    OUT.mkdir(exist_ok=True)
    results = {
        name: estimate_axis(rec.sensor(a).gyr, rec.sensor(b).gyr, rate=rec.rate, seed=1)
        for name, (rec, a, b) in _cases().items()
    }
    restarts_figure(results).savefig(OUT / "quality_restarts.png", dpi=100)
    uncertainty_figure().savefig(OUT / "quality_uncertainty.png", dpi=100)
    print(f"wrote {OUT}/quality_restarts.png, quality_uncertainty.png")


if __name__ == "__main__":
    main()
