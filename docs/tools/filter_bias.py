"""The joint-centre pre-filter's own bias (docs/method.md, "The joint-centre filter").

Noise-free simulated recordings (30 s, seeds 1-3), ankle centre (shank - foot,
spheroidal), clocks in sync (``time_offset=0``), error = the larger of |o1 - truth| and
|o2 - truth|, mm. Three pipelines:

- before (until 110d7d3): Butterworth order 2 at 10 Hz (at most 0.4 x rate), run forwards
  and backwards, and the 2-point central difference (``numpy.gradient``) for gdot;
- the new filter with the old difference: order 4 (8 after filtfilt) at the spectral
  cut-off, 2-point difference;
- now: order 4 at the spectral cut-off and the 8th-order central difference;
- no filter at all (``cutoff=0``) with the 8th-order difference: what is left without
  any filter (noise-free data need none).

Run from the repository root (about a minute):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python docs/tools/filter_bias.py
"""

from __future__ import annotations

import numpy as np

import imucal.position as position
from imucal import estimate_position
from imucal.preprocess import default_cutoff, derivative
from imucal.simulate import simulate

SEEDS = (1, 2, 3)
RATES = (40.0, 100.0, 400.0)
MOTIONS = ("gait", "protocol", "circling")


def gradient(x, rate):
    return np.gradient(x, 1.0 / rate, axis=0)


PIPELINES = {  # name: (filter order of one pass, gdot, cut-off: None = spectral)
    "before": (2, gradient, "old"),
    "new filter, 2-point difference": (4, gradient, None),
    "now": (4, derivative, None),
    "no filter, 8th-order difference": (4, derivative, 0.0),
}


def error_mm(motion, rate, seed, order, gdot, cutoff):
    rec, truth = simulate(seed=seed, rate=rate, duration=30.0, snr=None, motion=motion)
    a, b = rec.sensor("shank"), rec.sensor("foot")
    position.JOINT_FILTER_ORDER = order
    position.derivative = gdot
    c = default_cutoff(rate) if cutoff == "old" else cutoff
    p = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=rate, seed=1, joint="spheroidal",
                          cutoff=c, time_offset=0.0)
    return max(1000 * np.linalg.norm(p.o1 - truth["ankle"]["o1"]),
               1000 * np.linalg.norm(p.o2 - truth["ankle"]["o2"])), p.settings["cutoff_hz"]


def main() -> None:
    print("| motion | rate Hz | " + " | ".join(f"{k}: mm (max over seeds)" for k in PIPELINES)
          + " | spectral cut-off Hz |")
    print("|---|---|" + "---|" * (len(PIPELINES) + 1))
    for motion in MOTIONS:
        for rate in RATES:
            cells, cutoffs = [], set()
            for order, gdot, cutoff in PIPELINES.values():
                errs = []
                for seed in SEEDS:
                    e, c = error_mm(motion, rate, seed, order, gdot, cutoff)
                    errs.append(e)
                    if cutoff is None:
                        cutoffs.add(round(c, 1))
                cells.append(f"{max(errs):.1f}")
            print(f"| {motion} | {rate:g} | " + " | ".join(cells) + " | "
                  + ", ".join(f"{c:g}" for c in sorted(cutoffs)) + " |")


if __name__ == "__main__":
    main()
