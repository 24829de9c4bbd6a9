"""Write docs/accuracy.md: imucal on its own simulator under lab-realistic conditions
(issue 11), next to qmt's gyroscope-only estimator for the knee axis.

Run from the repository root (qmt is a dev dependency), with one BLAS thread per
process as the command line runs (a few minutes on two cores):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python docs/tools/accuracy_table.py [--jobs N]

Every estimate is called as the command line calls it (default settings, seed 1 for the
restarts, ``time_offset="auto"``; the axis gets both accelerometers for the sign test).
The knee axis is fitted to thigh - shank, the ankle centre (spheroidal) to shank - foot.
Seeds, rates and conditions are fixed, so the page is reproducible.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from imucal import estimate_axis, estimate_position
from imucal.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
DURATION = 30.0
NOISE = {"gyr_noise": 0.01, "acc_noise": 0.05}
TABLE_SEEDS = (1, 2, 3, 4, 5)
TABLE_RATE = 100.0
COVERAGE_SEEDS = tuple(range(1, 9))
COVERAGE_RATES = (40.0, 60.0, 100.0, 150.0, 200.0)
#: (key, label, simulate options, rate of the table row or None for TABLE_RATE,
#:  knee-axis target, ankle-centre target). "late" simulates twice: for the knee the
#: shank (second sensor) is 20 ms late, for the ankle the foot.
CONDITIONS = (
    ("protocol40", "`protocol` at 40 Hz, gyro noise 0.01 rad/s, acc noise 0.05 m/s^2",
     {"motion": "protocol"}, 40.0, "< 0.25 deg", "< 5 mm"),
    ("protocol100", "`protocol` at 100 Hz, same noise", {"motion": "protocol"}, None,
     "< 0.25 deg", "< 3 mm"),
    ("gait100", "`gait` at 100 Hz, same noise", {"motion": "gait"}, None, "< 0.25 deg",
     "honest: weak direction reported, error < 3 sigma"),
    ("late", "`protocol` 100 Hz, second sensor 20 ms late, same noise",
     {"motion": "protocol", "late": 0.02}, None, "< 0.5 deg, offset within 3 ms",
     "< 10 mm, offset within 3 ms"),
    ("late40", "`protocol` 40 Hz, second sensor 20 ms late, same noise",
     {"motion": "protocol", "late": 0.02}, 40.0, "< 0.5 deg, offset within 3 ms",
     "< 10 mm, offset within 3 ms"),
    ("bias", "`protocol` 100 Hz, gyro bias 0.02 rad/s, same noise",
     {"motion": "protocol", "gyr_bias": 0.02}, None, "< 0.5 deg", "< 10 mm"),
    ("soft1", "`protocol` 100 Hz, soft tissue 1 deg / 2 mm, same noise",
     {"motion": "protocol", "soft_tissue_deg": 1.0, "soft_tissue_mm": 2.0}, None,
     "no internal error; error < 3 sigma or refused", "same"),
    ("soft2", "`protocol` 100 Hz, soft tissue 2 deg / 3 mm, same noise",
     {"motion": "protocol", "soft_tissue_deg": 2.0, "soft_tissue_mm": 3.0}, None,
     "no internal error; error < 3 sigma or refused", "same"),
)
REFUSED = "not identifiable"
#: The coverage run: each distinct condition at every rate (protocol40 and protocol100
#: differ only in rate).
COVERAGE = {"protocol100": "`protocol`, noise", "gait100": "`gait`, noise",
            "late": "`protocol`, second sensor 20 ms late",
            "bias": "`protocol`, gyro bias 0.02 rad/s",
            "soft1": "`protocol`, soft tissue 1 deg / 2 mm",
            "soft2": "`protocol`, soft tissue 2 deg / 3 mm"}


def axis_error_deg(j1, j2, t1, t2) -> float:
    """The larger of the two angles to the truth, one common sign flip allowed (a wrong
    relative sign counts as ~180 deg; tests/conftest.py)."""
    s = 1.0 if np.dot(j1, t1) >= 0 else -1.0
    return float(max(np.degrees(np.arccos(np.clip(s * np.dot(j, t), -1, 1)))
                     for j, t in ((j1, t1), (j2, t2))))


def sign_free_deg(j, t) -> float:
    return float(np.degrees(np.arccos(min(1.0, abs(np.dot(j, t)) / np.linalg.norm(j)))))


def qmt_axis(a, b, rate):
    """qmt's gyroscope-only estimator (wa=0, wg=1: the residual of eq. 1), one start, as
    in docs/tools/real_data_table.py."""
    import qmt

    with contextlib.redirect_stdout(io.StringIO()):
        j1, j2 = qmt.jointAxisEstHingeOlsson(a.acc, b.acc, a.gyr, b.gyr,
                                             estSettings={"wa": 0.0, "wg": 1.0})[:2]
    return np.ravel(j1), np.ravel(j2)


def warning_names(warnings) -> list[str]:
    names = []
    for w in warnings:
        w = w.removeprefix("axis: ")
        if w.startswith("the estimate is uncertain"):
            names.append("uncertain")
        elif "only known along a line" in w or "motion stays close to one axis" in w:
            names.append("line")
        elif w.startswith("the residual is lowest with the second sensor"):
            names.append("offset not applied")
        elif "may exceed" in w:
            names.append("offset at edge")
        elif w.startswith("restarts disagree"):
            names.append("restarts")
        elif "not one physical line" in w:
            names.append("gravity mismatch")
        elif "fits poorly" in w:
            names.append("poor fit")
        elif "more than a warmed-up gyroscope's" in w:
            names.append("large bias asked")
        elif w.startswith("the data barely decide whether"):
            names.append("sign undecided")
        else:
            names.append(w[:30])
    return names


def run_case(case):
    """One (condition, seed, rate): knee axis and ankle centre, with qmt when asked."""
    key, options, seed, rate, with_qmt = case
    options = dict(options)
    late = options.pop("late", 0.0)
    out = {"key": key, "seed": seed, "rate": rate}
    for joint, first, second in (("knee", "thigh", "shank"), ("ankle", "shank", "foot")):
        clock = {second: late} if late else None
        rec, truth = simulate(seed=seed, rate=rate, duration=DURATION, clock_offset=clock,
                              **NOISE, **options)
        a, b = rec.sensor(first), rec.sensor(second)
        true_offset = truth["time_offset_s"][joint]
        try:
            if joint == "knee":
                r = estimate_axis(a.gyr, b.gyr, rate=rate, seed=1, acc1=a.acc, acc2=b.acc)
                t1, t2 = truth["knee"]["j1"], truth["knee"]["j2"]
                error = axis_error_deg(r.j1, r.j2, t1, t2)
                sigma = r.uncertainty_deg
                # per vector: error over that vector's own sigma
                s = 1.0 if np.dot(r.j1, t1) >= 0 else -1.0
                per = [np.degrees(np.arccos(np.clip(s * np.dot(j, t), -1, 1))) / sigma[k]
                       for k, j, t in (("j1", r.j1, t1), ("j2", r.j2, t2))]
                ratio = float(max(per))
                if with_qmt:
                    q1, q2 = qmt_axis(a, b, rate)
                    out["qmt_deg"] = max(sign_free_deg(q1, t1), sign_free_deg(q2, t2))
            else:
                r = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=rate, seed=1,
                                      joint="spheroidal")
                t1, t2 = (np.asarray(truth["ankle"][k]) for k in ("o1", "o2"))
                d = {"o1": 1000 * np.linalg.norm(r.o1 - t1),
                     "o2": 1000 * np.linalg.norm(r.o2 - t2)}
                error = float(max(d.values()))
                sigma = r.uncertainty_mm
                ratio = float(max(d[k] / sigma[k] for k in d))
        except Exception as exc:  # an internal error is a result of the benchmark too
            out[joint] = {"error": float("nan"), "sigma": float("nan"), "ratio": float("nan"),
                          "verdict": f"internal error: {type(exc).__name__}",
                          "warnings": [], "offset": None, "true_offset": true_offset}
            continue
        off = r.time_offset
        out[joint] = {
            "error": error, "sigma": float(max(sigma.values())), "ratio": ratio,
            "verdict": r.verdict, "warnings": warning_names(r.warnings + r.blocking),
            "offset": (off["estimated_s"], off["sigma_s"], off["applied"], off["cost_ratio"]),
            "true_offset": true_offset,
        }
    return out


def spread(values, fmt) -> str:
    """worst / median"""
    v = np.asarray(values, float)
    return f"{format(np.nanmax(v), fmt)} / {format(np.nanmedian(v), fmt)}"


def span(values, fmt) -> str:
    v = np.asarray(values, float)
    lo, hi = format(np.nanmin(v), fmt), format(np.nanmax(v), fmt)
    return lo if lo == hi else f"{lo} to {hi}" if "+" in fmt else f"{lo}-{hi}"


def verdicts(items) -> str:
    names = {"good": "good", "use with care": "care", REFUSED: "refused"}
    counts = {}
    for it in items:
        v = names.get(it["verdict"], it["verdict"])
        counts[v] = counts.get(v, 0) + 1
    return ", ".join(f"{k} {n}" for k, n in counts.items())


def warnings_seen(items) -> str:
    seen = sorted({w for it in items for w in it["warnings"]})
    return ", ".join(seen) or "-"


def offsets(items) -> str:
    """Applied offsets (ms, how many of the seeds) and, if any, the largest estimate not
    applied."""
    applied = [1000 * it["offset"][0] for it in items if it["offset"] and it["offset"][2]]
    rest = [it["offset"] for it in items if it["offset"] and not it["offset"][2]]
    parts = []
    if applied:
        err = [abs(1000 * (it["offset"][0] - it["true_offset"])) for it in items
               if it["offset"] and it["offset"][2]]
        parts.append(f"applied {len(applied)}: {span(applied, '+.1f')} ms "
                     f"(true {1000 * items[0]['true_offset']:+.0f}, off by <= "
                     f"{max(err):.1f} ms)")
    if rest:
        big = max(rest, key=lambda o: abs(o[0]))
        parts.append(f"not applied {len(rest)} (largest {1000 * big[0]:+.1f} ms, "
                     f"ratio {big[3]:.2f})")
    return "; ".join(parts) or "-"


def offset_count(items) -> str:
    """Applied offsets: how many, and how many of them within 3 ms of the truth."""
    applied = [it for it in items if it["offset"] and it["offset"][2]]
    good = sum(abs(it["offset"][0] - it["true_offset"]) <= 0.003 for it in applied)
    return f"{len(applied)} ({good} within 3 ms)"


def covered(item) -> bool:
    return item["verdict"] == REFUSED or (np.isfinite(item["ratio"]) and item["ratio"] < 3)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    jobs = parser.parse_args().jobs
    table_cases = [(key, opts, seed, rate or TABLE_RATE, True)
                   for key, _, opts, rate, _, _ in CONDITIONS for seed in TABLE_SEEDS]
    cover_cases = [(key, opts, seed, rate, False)
                   for key, _, opts, _, _, _ in CONDITIONS if key in COVERAGE
                   for rate in COVERAGE_RATES for seed in COVERAGE_SEEDS]
    with Pool(jobs) as pool:
        table = pool.map(run_case, table_cases, chunksize=1)
        cover = pool.map(run_case, cover_cases, chunksize=1)

    axis_rows, ankle_rows = [], []
    for key, label, _, _, target_axis, target_ankle in CONDITIONS:
        got = [r for r in table if r["key"] == key]
        knee, ankle = [r["knee"] for r in got], [r["ankle"] for r in got]
        axis_rows.append(
            f"| {label} | {target_axis} | {spread([k['error'] for k in knee], '.2f')} | "
            f"{span([k['sigma'] for k in knee], '.2f')} | "
            f"{spread([k['ratio'] for k in knee], '.1f')} | {verdicts(knee)} | "
            f"{warnings_seen(knee)} | {offsets(knee)} | "
            f"{spread([r['qmt_deg'] for r in got], '.2f')} |")
        ankle_rows.append(
            f"| {label} | {target_ankle} | {spread([k['error'] for k in ankle], '.1f')} | "
            f"{span([k['sigma'] for k in ankle], '.1f')} | "
            f"{spread([k['ratio'] for k in ankle], '.1f')} | {verdicts(ankle)} | "
            f"{warnings_seen(ankle)} | {offsets(ankle)} |")

    cover_rows, totals = [], {"knee": [0, 0], "ankle": [0, 0]}
    for key, label in COVERAGE.items():
        got = [r for r in cover if r["key"] == key]
        cells = []
        for joint in ("knee", "ankle"):
            items = [r[joint] for r in got]
            ok = sum(covered(it) for it in items)
            refused = sum(it["verdict"] == REFUSED for it in items)
            crashed = sum(it["verdict"].startswith("internal") for it in items)
            totals[joint][0] += ok
            totals[joint][1] += len(items)
            worst = max(items, key=lambda it: it["ratio"] if np.isfinite(it["ratio"]) else -1)
            misses = [f"{int(r['rate'])} Hz s{r['seed']} {r[joint]['ratio']:.1f} sigma "
                      f"({r[joint]['verdict']})" for r in got if not covered(r[joint])]
            cells.append(f"{ok}/{len(items)} ({refused} refused"
                         + (f", {crashed} internal errors" if crashed else "")
                         + f"); worst {worst['ratio']:.1f} sigma"
                         + (f"; misses: {', '.join(misses[:6])}"
                            + (" ..." if len(misses) > 6 else "") if misses else ""))
        cells.append(" / ".join(offset_count([r[j] for r in got]) for j in ("knee", "ankle")))
        cover_rows.append(f"| {label} | "
                          + " | ".join(cells) + " |")
    share = {j: totals[j][0] / totals[j][1] for j in totals}
    both = (totals["knee"][0] + totals["ankle"][0]) / (totals["knee"][1] + totals["ankle"][1])
    cover_rows.append(
        f"| **all** | {totals['knee'][0]}/{totals['knee'][1]} = {share['knee']:.1%} | "
        f"{totals['ankle'][0]}/{totals['ankle'][1]} = {share['ankle']:.1%} | |")
    without_bias = [r for r in cover if r["key"] != "bias"]
    ok_nb = sum(covered(r[j]) for r in without_bias for j in ("knee", "ankle"))

    page = (HEADER.format(seeds=f"{TABLE_SEEDS[0]}-{TABLE_SEEDS[-1]}", rate=TABLE_RATE)
            + "\n".join(AXIS_HEAD + axis_rows) + "\n" + ANKLE_TEXT
            + "\n".join(ANKLE_HEAD + ankle_rows) + "\n"
            + COVER_TEXT.format(seeds=f"{COVERAGE_SEEDS[0]}-{COVERAGE_SEEDS[-1]}",
                                rates=", ".join(f"{r:g}" for r in COVERAGE_RATES),
                                n=len(cover) * 2)
            + "\n".join(COVER_HEAD + cover_rows) + "\n\n"
            + f"Both estimates together: {both:.1%} covered (target >= 95 %); without the "
              f"gyro-bias rows {ok_nb / (2 * len(without_bias)):.1%}.\n"
            # the knees' one clock offset was measured by calibrate sweeps, not here
            + FOOTER.replace("{knee_clock}", KNEE_CLOCK.read_text()))
    (ROOT / "docs" / "accuracy.md").write_text(page)
    print(page)


HEADER = """# Accuracy under lab-realistic conditions

Generated by `docs/tools/accuracy_table.py` on imucal's own simulator
([simulator.md](simulator.md)), for the benchmark of issue 11: 30 s per recording, seeds
{seeds}, {rate:g} Hz unless stated, white noise of 0.01 rad/s (gyroscope) and 0.05 m/s^2
(accelerometer) per component and sample. Every estimate runs as the command line runs it:
default settings, `--time-offset auto`, 100 restarts (seed 1), accelerometers passed to
the axis for the sign test. Knee axis: thigh - shank; ankle centre: shank - foot,
spheroidal. "Late" simulates each joint separately with its second sensor's clock 20 ms
late (knee: `clock_offset={{"shank": 0.02}}`, ankle: `{{"foot": 0.02}}`), so the true
offset is +20 ms for both. The simulated accelerometers have no offset or scale error,
while the ankle centres' 1-sigma carries the default `--acc-error` of 0.05 m/s^2
([quality.md](quality.md#how-the-uncertainty-is-computed-and-why)): that part, 6-13 mm
on the protocol, is most of their sigma here, and their error / sigma is small.

Errors are worst / median over the seeds. Knee axis: the larger of the j1 and j2 angles
to the truth, with one common sign flip allowed (a wrong relative sign counts as about
180 deg; as in `tests/conftest.py`). Ankle centre: the larger of the |o1 - truth| and
|o2 - truth| distances. "Sigma" is the larger of the two reported 1-sigmas (range over
the seeds); "error / sigma" is each vector's error over its own reported 1-sigma, the
larger of the two, worst / median. Verdicts: good / care (`use with care`) / refused
(`not identifiable`). Offsets: the automatic clock offset (`time_offset`): how many
seeds applied one, its values and distance from the truth; for the rest the largest
estimate that was not applied and its cost ratio. qmt: `qmt.jointAxisEstHingeOlsson`
with `wa=0, wg=1` (its gyroscope-only residual, the same as imucal's), one start, on the
same samples, angles sign-free (qmt's signs are arbitrary); qmt has no clock-offset
estimate.

## Knee axis

"""
AXIS_HEAD = [
    "| condition | target | error deg worst / median | sigma deg | error / sigma "
    "worst / median | verdicts | warnings | clock offset | qmt gyro error deg worst / "
    "median |",
    "|---|---|---|---|---|---|---|---|---|",
]
ANKLE_TEXT = """
## Ankle centre

"""
ANKLE_HEAD = [
    "| condition | target | error mm worst / median | sigma mm | error / sigma "
    "worst / median | verdicts | warnings | clock offset |",
    "|---|---|---|---|---|---|---|---|",
]
COVER_TEXT = """
## Coverage: is the true error within 3 reported sigma?

Every condition above (gait for the gait row, protocol otherwise) at {rates} Hz,
seeds {seeds}: {n} estimates. An estimate counts as covered when its true error is below
3 x its reported 1-sigma (each vector against its own) or it is refused (`not
identifiable`, which makes no claim). Target: >= 95 %. The last column counts the fits
that applied an automatic clock offset, and how many of those lay within 3 ms of the
true offset (0 except in the "late" row).

"""
COVER_HEAD = [
    "| condition | knee axis covered | ankle centre covered | offsets applied, knee / ankle |",
    "|---|---|---|---|",
]

#: The calibrate sweep's section (measured outside this script), kept as written.
KNEE_CLOCK = ROOT / "docs" / "tools" / "accuracy_knee_clock.md"
FOOTER = """
## Against the targets

The numbers below are those of the tables above (written with this script; rerun it after
a change to the estimators and check them).

**Met.** The knee axis is within its target in every row: 0.05 deg worst on the protocol
at 40 Hz, 0.04 at 100 Hz, 0.02 on gait, 0.04 deg (100 Hz) and 0.06 deg (40 Hz) with the
second sensor 20 ms late, whose offset is found within 0.2 ms (100 Hz and 40 Hz)
and applied, and 0.06 deg worst (0.03 median) with a gyro bias of 0.02 rad/s, where
qmt's gyroscope-only estimator, fitting the same residual without the bias, is 0.89 deg
off (0.53 median): imucal fits constant gyroscope biases with the axis and removes them
when they clearly lower the residual with a size a gyroscope can have
([method.md](method.md#gyroscope-bias)); the joint fit's widening of the 1-sigma keeps
those errors within 1.1 sigma (1.7 in the coverage run). The ankle centre: 1.2 mm worst
on the protocol at 40 Hz (target 5), 1.6 mm at 100 Hz (target 3), 1.3 mm (100 Hz) and
1.0 mm (40 Hz) with the foot 20 ms late (target 10; offsets within 0.1 ms), 3.1 mm with
gyro bias (target 10). On gait alone every seed warns that the ankle centre is only known
along a line, the verdict is `use with care`, the error (4.8 mm worst) stays within 1.0
sigma, and the line is reported: `quality.weak_direction` gives its direction in both
sensor frames and the 1-sigma along it and across it (`tests/test_weak_direction.py`).
Soft tissue gives no internal error, and every error of the table is within 3 sigma (knee
axis 1.1 and 1.5 sigma worst, ankle 0.8 and 1.2). Coverage over 40-200 Hz and seeds 1-8:
all 480 estimates within 3 sigma or refused (knee axis 2.3 sigma worst, measured before
the large-bias move below, which only widens; target 95 %). Under soft tissue the
residual often asks for gyroscope biases larger than a warmed-up gyroscope's ("large
bias asked"): not removed, the axis's move without them is in its 1-sigma (the 2 deg /
3 mm knees' worst went from 2.3 to 1.6 sigma).
This protocol motion is where the knee's model term is most generous: on gait with soft
tissue a review found 4 of 40 knees (1 deg / 2 mm) beyond 3 sigma, one of them `good`
(seed 21, 4.2 sigma), and ankle centres from circling with soft tissue 3-5 of 20 `good`
beyond 3 sigma ([method.md](method.md#the-model-error-term-of-the-axis-1-sigma)).

**Clock offsets.** With the second sensor 20 ms late, all 80 offsets of the coverage run
(knee and ankle, 40-200 Hz) are applied within 3 ms of the truth; in the table within
0.2 ms. At 40 Hz the ankle's offset used to land 3-6 ms off (centre 17-36 mm off, two
seeds `good` at 4.0 and 3.3 sigma): a parabola through one-sample neighbours 25 ms apart
misjudges a profile that is a parabola only within about 10 ms of its minimum, and two
Gauss-Newton steps did not bring the refitted centre to its minimum. A sub-sample pass
(5 candidates 2 ms apart), five steps and a band-limited delay (a cubic spline lowers the
noise between samples, which pulled the knee's offset towards half-samples by 0.3-0.4 ms)
remove that ([method.md](method.md#clock-offsets-between-the-two-sensors)). The
offset's uncertainty now also counts in the estimate's: an applied offset's 1-sigma times
the estimate's move per ms of offset (4-18 mm/ms for these ankle centres, 0.01-0.1 deg/ms
for these knees, 0.16-0.28 on circling) is `uncertainty_components.time_offset`. No fit
without a simulated offset applies one: under soft tissue the knee axes' profile is now
low-passed (white noise diluted the gain of a real offset, not that of a soft-tissue
lag), and an offset needs a cost ratio of 1.6 (the largest best shift of the soft-tissue
rows, +19.6 ms, gains only 1.18; before, 9 of the 80 soft-tissue knee fits of the
coverage run applied +10 to +21 ms). That holds for this protocol motion, not for gait:
on simulated gait with soft tissue and clocks in sync (seeds 1-40, 100 Hz) an offset was
applied in 3, 8 and 11 of 40 knee fits at 0.5 deg / 1 mm, 1 deg / 2 mm and 2 deg / 3 mm
(-178 to +113 ms, cost ratios 1.6-4.8, as high as a real 20 ms offset's on gait): soft
tissue lags the bone in step with every stride, which is what a clock offset looks like,
and the axes moved by 1-9 deg. An applied offset therefore also adds the axes' move from
offset 0, capped at 3 x the model term, to the 1-sigma (`time_offset.moved_from_zero`;
[quality.md](quality.md#how-the-uncertainty-is-computed-and-why)). In that sweep (20 s,
gyroscope noise 0.01 rad/s) 0.97, 0.93 and 0.93 of the axes were within 3 sigma before,
with 1, 2 and 1 beyond it `good`; now 0.97, 1.00 and 0.95, with 1, 0 and 1 (the two left
have a model term too small for their soft tissue, with or without the offset). With the
shank's clock 20 ms late the share rose from 0.93 to 1.00, 0.97 and 0.97. Clean fits with
that offset (circling, gait, protocol, 40 seeds each) all stay `good`: their model term
is at most 0.36 deg and the added part at most 1.2 deg (circling; protocol 0.3, gait
0.4). The protocol rows above went from 1-sigma 0.05-0.09 to 0.05-0.27 deg at 100 Hz
and 0.08-0.17 to 0.17-0.53 deg at 40 Hz.

{knee_clock}**Missed.**
- **Soft tissue is not accurate, only honest.** Knee axis errors up to 2.2 deg (median
  1.4) at 1 deg / 2 mm and up to 11.6 deg (median 4.5) at 2 deg / 3 mm, ankle centres up
  to 50 mm (median 22) and 95 mm (median 38): within 3 sigma in this table, but not in
  every case of the coverage run (2 knee axes at 3.6 and 3.0 sigma, 2 deg / 3 mm, 40 and
  60 Hz, seed 5, both `use with care`: a knee axis whose 1-sigma exceeds 2 deg is never
  `good`). At 1 deg / 2 mm 3 of 5 are still `good` (errors within 1.5 sigma). qmt's
  errors are the same or larger (one start: 17.7 deg worst at 1 deg / 2 mm).

**qmt.** With the clocks in sync and no bias, qmt's gyroscope-only estimator finds the
same axes as imucal (the same residual; the error columns agree to 0.01 deg) except where
its single start ends in a local minimum (gait: 14.75 deg on one seed; soft tissue 1 deg /
2 mm: 17.7 deg). With a 20 ms offset it is up to 2.1 deg off (median 1.2), as it has no
offset estimate: imucal's 0.04 deg (100 Hz) and 0.06 deg (40 Hz) worst there are what the
offset search buys; with gyroscope bias it is 0.89 deg off, imucal 0.06 deg.
"""

if __name__ == "__main__":
    main()
