"""Write docs/real-data.md: imucal on the shared real recording, next to qmt's estimator.

Run from the repository root with ../shared beside it (qmt is a dev dependency), with one
BLAS thread as the command line runs (a few minutes):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python docs/tools/real_data_table.py

Every estimate is called as the command line calls it: the axis gets both sensors'
accelerometers (``acc1``, ``acc2``), which add the accelerometer test of the relative sign
(the fit itself uses only the rates).
"""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

import numpy as np
import qmt

from imucal import estimate_axis, estimate_position, load_recording

ROOT = Path(__file__).resolve().parents[2]
#: The heading of the section docs/tools/angles_figure.py writes, kept on a rewrite.
ANGLES_SECTION = "## Knee flexion"
DATA = ROOT.parent / "shared" / "data" / "walk_and_leg_motions_100hz.h5"
SEED = 1
WINDOWS = ((0.0, 55.0), (55.0, 100.0))
#: Hinge fits: the knees, and the ankles to show what the report says about a joint that
#: is not a hinge.
AXES = {"knee": ("thigh", "shank"), "ankle": ("shank", "foot")}
#: Joint-centre fits: (name, model, first sensor, second sensor) per side.
POSITIONS = (("knee", "hinge", "{side}_thigh", "{side}_shank"),
             ("ankle", "spheroidal", "{side}_shank", "{side}_foot"),
             ("hip", "spheroidal", "pelvis", "{side}_thigh"))
#: Two halves of independent data each: split-half consistency.
SPLITS = (((0.0, 27.5), (27.5, 55.0)), ((55.0, 77.5), (77.5, 100.0)),
          ((0.0, 50.0), (50.0, 100.0)))
#: The data README's rough lateral (flexion) axis of each segment in its sensor's frame,
#: tuned by eye to about 15 deg. Both sensors' x axes point laterally, so the two
#: references point the same physical way: with the right relative sign j1 and j2 are
#: both near them or both near their negatives.
ROUGH_LATERAL = {
    "left_thigh": [0.961, -0.067, -0.270],
    "left_shank": [0.996, -0.061, -0.062],
    "right_thigh": [0.947, -0.007, -0.322],
    "right_shank": [0.996, -0.062, -0.061],
}
#: The first words of each warning (imucal/axis.py, position.py, preprocess.py,
#: quality.py), enough to recognise it in a table. Keep in sync with the warning texts:
#: an unknown warning shows as its first 30 characters.
SHORT = {
    "the sensors barely rotate": "no motion",
    "the joint barely bent while": "wobble, not flexion",
    "the joint barely bent": "rigid",
    "the joint barely moved": "rigid",
    "the data leave one direction": "undetermined",
    "restarts disagree (": "no hinge",
    "restarts disagree:": "restarts",
    "two different axes fit equally well": "two minima",
    "two joint positions fit equally well": "two minima",
    "the angle about this axis, integrated": "span > 170 deg",
    "the estimate puts the joint": "implausible",
    "the hinge model fits poorly": "poor fit",
    "the hinge joint model fits poorly": "poor fit",
    "the spheroidal joint model fits poorly": "poor fit",
    "the data barely decide whether": "sign undecided",
    "more than a warmed-up gyroscope's": "large bias asked",
    "the joint position's 1-sigma is": "1-sigma beyond 500 mm",
    "the sign tests disagree": "sign tests disagree",
    "the pinned j2 sign contradicts": "pin contradicted",
    "motion stays": "line",
    "directions of the point across": "across-axis weak",
    "the residual is lowest with the second sensor": "offset not applied",
    "with the second sensor read": "offset would move it",
    "the clock offset between the sensors may exceed": "offset at edge",
    "the axis is not one physical line": "gravity mismatch",
    "the axis's 1-sigma is": "1-sigma beyond 90 deg",
    "the first sensor reads": "acc off at rest",
    "the second sensor reads": "acc off at rest",
}
#: "the estimate is uncertain: ..., mostly because WHY": which component dominates.
UNCERTAIN = {
    "the data barely constrain it": "uncertain (curvature)",
    "fits on different stretches": "uncertain (time blocks)",
    "it moves with the low-pass cut-off": "uncertain (cut-off)",
    "the residuals are systematic": "uncertain (model)",
    "a different weighting of the samples": "uncertain (model)",
    "a gyroscope bias was estimated": "uncertain (gyro bias)",
    "moves when gyroscope biases are fitted": "uncertain (gyro bias)",
    "accelerometer offset or scale": "uncertain (accelerometer)",
    "it moves with the clock offset": "uncertain (clock offset)",
}
#: (estimate, side, window, time_offset block) of every fit in the tables, filled as
#: they run.
OFFSETS = []


def qmt_axis(rec, first, second, window, settings):
    sl = slice(int(window[0] * rec.rate), int(window[1] * rec.rate))
    a, b = rec.sensor(first), rec.sensor(second)
    with contextlib.redirect_stdout(io.StringIO()):
        j1, j2 = qmt.jointAxisEstHingeOlsson(a.acc[sl], b.acc[sl], a.gyr[sl], b.gyr[sl],
                                             estSettings=settings)[:2]
    return np.ravel(j1), np.ravel(j2)


def angle(a, b) -> float:
    """Sign-free angle between axes, deg."""
    return float(np.degrees(np.arccos(min(1.0, abs(a @ b) / np.linalg.norm(b)))))


def signed_angles(r, s1, s2) -> str:
    """Signed angles of j1, j2 to the README's lateral references, deg: the references'
    common sign is the one that makes j1 agree, so j2 near 180 means a wrong relative
    sign. "-" where the README gives no reference."""
    if s1 not in ROUGH_LATERAL or s2 not in ROUGH_LATERAL:
        return "-"
    ref1, ref2 = (np.asarray(ROUGH_LATERAL[s]) / np.linalg.norm(ROUGH_LATERAL[s])
                  for s in (s1, s2))
    k = 1.0 if r.j1 @ ref1 >= 0 else -1.0
    a1, a2 = (float(np.degrees(np.arccos(np.clip(k * j @ ref, -1, 1))))
              for j, ref in ((r.j1, ref1), (r.j2, ref2)))
    return f"{a1:.0f} / {a2:.0f}"


def evidence(test: dict) -> str:
    """One sign test's evidence ratio: "-" when it abstains (1), "against" when it favours
    the other relative sign than the one reported."""
    if test["evidence"] <= 1.0:
        return "-"
    return f"{test['evidence']:.2f}" + ("" if test["favours_reported"] else " against")


def short(warnings) -> str:
    out = []
    for w in warnings:
        prefix = "axis: " if w.startswith("axis: ") else ""
        w = w.removeprefix("axis: ")
        if w.startswith("the estimate is uncertain"):
            name = next(v for k, v in UNCERTAIN.items() if k in w)
        elif "'s angular rate exceeds" in w:
            name = "units (deg/s?)"
        elif "'s specific force has a median" in w:
            name = "units (g?)"
        else:
            name = next((v for k, v in SHORT.items() if k in w), w[:30])
        out.append(prefix + name)
    return ", ".join(out) or "-"


def pair(values: dict, fmt: str) -> str:
    return " / ".join(format(v, fmt) for v in values.values())


def fit_axis(rec, s1, s2, window):
    a, b = rec.sensor(s1), rec.sensor(s2)
    return estimate_axis(a.gyr, b.gyr, rate=rec.rate, seed=SEED, start=window[0],
                         end=window[1], acc1=a.acc, acc2=b.acc)


def fit_position(rec, model, s1, s2, window):
    a, b = rec.sensor(s1), rec.sensor(s2)
    return estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=rec.rate, seed=SEED,
                             joint=model, start=window[0], end=window[1])


def axis_rows(rec):
    est, qual = [], []
    for joint, (seg1, seg2) in AXES.items():
        for side in ("left", "right"):
            s1, s2 = f"{side}_{seg1}", f"{side}_{seg2}"
            for window in WINDOWS:
                r = fit_axis(rec, s1, s2, window)
                OFFSETS.append((f"{joint} axis", side, window, r.time_offset))
                g1, g2 = qmt_axis(rec, s1, s2, window, {"wa": 0.0, "wg": 1.0})
                d1, d2 = qmt_axis(rec, s1, s2, window, None)
                t = r.sign_tests
                row = f"| {joint} | {side} | {window[0]:g}-{window[1]:g} | "
                est.append(
                    row + f"{angle(r.j1, g1):.2f} / {angle(r.j2, g2):.2f} | "
                    f"{angle(r.j1, d1):.2f} / {angle(r.j2, d2):.2f} | "
                    f"{signed_angles(r, s1, s2)} | {r.sign_evidence:.2f} | "
                    f"{evidence(t['plane'])} | {evidence(t['range'])} | "
                    f"{t['range']['span_deg_reported']:.0f} / "
                    f"{t['range']['span_deg_flipped']:.0f} | {evidence(t['acc'])} |"
                )
                c = r.uncertainty_components
                qual.append(
                    row + f"{r.relative_residual:.2f} | {pair(r.uncertainty_deg, '.1f')} | "
                    f"{pair(c['curvature'], '.1f')} | {pair(c['time_blocks'], '.1f')} | "
                    f"{pair(c['cutoff_shift'], '.1f')} | {pair(c['model'], '.1f')} | "
                    f"{pair(r.spread_deg, '.1f')} | "
                    f"{r.verdict} | {short(r.blocking + r.warnings)} |"
                )
    return est, qual


def position_rows(rec):
    rows = []
    for joint, model, first, second in POSITIONS:
        for side in ("left", "right"):
            s1, s2 = first.format(side=side), second.format(side=side)
            for window in WINDOWS:
                p = fit_position(rec, model, s1, s2, window)
                OFFSETS.append((f"{joint} ({model})", side, window, p.time_offset))
                c = p.uncertainty_components
                eq = p.equal_minima
                minima = (f"{eq['count']} at {eq['max_distance_mm']:.0f} mm"
                          if eq["count"] else "-")
                rows.append(
                    f"| {joint} ({model}) | {s1}, {s2} | {window[0]:g}-{window[1]:g} | "
                    f"{np.round(1000 * p.o1).astype(int).tolist()} | "
                    f"{np.round(1000 * p.o2).astype(int).tolist()} | "
                    f"{p.relative_residual:.2f} | {pair(p.uncertainty_mm, '.0f')} | "
                    f"{pair(c['curvature'], '.0f')} | {pair(c['time_blocks'], '.0f')} | "
                    f"{pair(c['cutoff_shift'], '.0f')} | {pair(c['model'], '.0f')} | "
                    f"{pair(p.spread_mm, '.0f')} | "
                    f"{minima} | {p.verdict} | {short(p.blocking + p.warnings)} |"
                )
    return rows


def offset_rows():
    """The automatic clock offset of every fit above: the second sensor's lateness."""
    rows = []
    for name, side, window, off in OFFSETS:
        rows.append(
            f"| {name} | {side} | {window[0]:g}-{window[1]:g} | "
            f"{1000 * off['estimated_s']:+.1f} | "
            f"{'-' if off['sigma_s'] is None else format(1000 * off['sigma_s'], '.1f')} | "
            f"{off['cost_ratio']:.2f} | {'yes' if off['applied'] else 'no'}"
            + (" (at edge)" if off["at_edge"] else "") + " |"
        )
    return rows


def split_rows(rec):
    """Distance between the two halves' estimates over their combined 1-sigma
    (sqrt(sigma_a^2 + sigma_b^2)): the halves are independent data, so a reported sigma
    that is honest keeps this below about 3."""
    cases = [("knee axis", lambda side, w: fit_axis(rec, f"{side}_thigh", f"{side}_shank", w),
              ("j1", "j2"), "deg")]
    for joint, model, first, second in POSITIONS:
        cases.append((f"{joint} ({model})",
                      lambda side, w, m=model, f=first, s=second:
                      fit_position(rec, m, f.format(side=side), s.format(side=side), w),
                      ("o1", "o2"), "mm"))
    rows, worst = [], 0.0
    for name, fit, keys, unit in cases:
        for side in ("left", "right"):
            for halves in SPLITS:
                a, b = (fit(side, w) for w in halves)
                cells = []
                for k in keys:
                    if unit == "deg":
                        d = angle(getattr(a, k), getattr(b, k))
                        sa, sb = a.uncertainty_deg[k], b.uncertainty_deg[k]
                    else:
                        d = 1000 * float(np.linalg.norm(getattr(a, k) - getattr(b, k)))
                        sa, sb = a.uncertainty_mm[k], b.uncertainty_mm[k]
                    cells.append((d, float(np.hypot(sa, sb))))
                refused = [h for h, r in zip("AB", (a, b), strict=True)
                           if r.verdict == "not identifiable"]
                ratio = max(d / s for d, s in cells)
                if not refused:
                    worst = max(worst, ratio)
                rows.append(
                    f"| {name} | {side} | {halves[0][0]:g}-{halves[0][1]:g} / "
                    f"{halves[1][0]:g}-{halves[1][1]:g} | "
                    + " | ".join(f"{d:.1f} / {s:.1f}" for d, s in cells)
                    + f" {unit} | {ratio:.1f} | "
                    + (f"refused: {', '.join(refused)}" if refused else "both")
                    + f" | {a.verdict} / {b.verdict} |"
                )
    return rows, worst


def main() -> None:
    if not DATA.exists():
        sys.exit(f"{DATA} not found: this page needs ../shared/data")
    rec = load_recording(DATA)
    est, qual = axis_rows(rec)
    pos = position_rows(rec)
    offs = offset_rows()
    split, worst = split_rows(rec)
    page = (HEADER + "\n".join(AXIS_EST_HEAD + est) + "\n" + AXIS_QUAL_TEXT
            + "\n".join(AXIS_QUAL_HEAD + qual) + "\n" + POS_TEXT + "\n".join(POS_HEAD + pos)
            + "\n" + OFFSET_TEXT + "\n".join(OFFSET_HEAD + offs)
            + "\n" + SPLIT_TEXT + "\n".join(SPLIT_HEAD + split) + "\n\n"
            + f"Worst ratio where neither half is refused: {worst:.1f}.\n" + FOOTER)
    target = ROOT / "docs" / "real-data.md"
    # the knee-flexion section comes from docs/tools/angles_figure.py: keep it
    old = target.read_text() if target.exists() else ""
    kept = old[old.index(ANGLES_SECTION):] if ANGLES_SECTION in old else ""
    target.write_text(page.rstrip("\n") + "\n\n" + kept if kept else page)
    print(page)


HEADER = """# imucal on the shared real recording

Generated by `docs/tools/real_data_table.py` (seed 1, default settings, accelerometers
passed to the axis as the command line does) from
`../shared/data/walk_and_leg_motions_100hz.h5` (100 Hz, one person; 0-55 s standing with
short bursts of leg motion, 55-100 s vigorous gait-like motion with large impacts). There
is no optical ground truth. The references are `qmt.jointAxisEstHingeOlsson` (Olsson et
al. 2020), one start per call ("gyro" is its gyroscope-only variant, `wa=0, wg=1`, the
same residual as imucal's; "default" adds its accelerometer residual), and the data
README's rough lateral axes of thigh and shank, tuned by eye to about 15 deg.

## Hinge axis (`imucal axis`): estimate and relative sign

Angles in degrees. "vs qmt" angles are sign-free (qmt's signs are arbitrary). "vs README
lateral" is signed: both sensors' x axes point laterally, so the reference's sign is the
one that makes j1 agree, and j2 must then agree too; j2 near 180 deg would be the wrong
relative sign (the README gives no reference for the foot, hence "-" for the ankles).
Sign evidence is the combined ratio (wrong over right hypothesis' error, >= 1) and per
test (docs/method.md, "Relative sign"): "-" = the test abstains, "against" = it favours
the other relative sign than the one reported. Range spans: the flexion angle integrated
from j2.g2 - j1.g1 (largest span within 60 s, deg) with the reported / the flipped j2.
The ankle rows fit a hinge to a joint that is not one: they show what the quality
report says about that.

"""
AXIS_EST_HEAD = [
    "| joint | side | window s | vs qmt gyro j1 / j2 | vs qmt default j1 / j2 | "
    "vs README lateral j1 / j2 (signed) | sign evidence | plane | range | "
    "range span deg reported / flipped | acc |",
    "|---|---|---|---|---|---|---|---|---|---|---|",
]
AXIS_QUAL_TEXT = """
## Hinge axis: uncertainty and verdict

The 1-sigma (deg) is sqrt(max(curvature, time blocks)^2 + cut-off shift^2 + model^2 +
gyro bias^2 + clock offset^2) (docs/quality.md); its first four components follow, then
the spread over restarts on random half subsets (not part of the sigma). The gyro-bias
part is 0 on every row (no bias removed); the clock-offset part (the axes' move per ms of
offset times the offset's 1-sigma) is what the listed components leave of the sigma: most
of the right ankle's 165.1 / 89.5 deg in 55-100 s is that part, 160.0 / 77.7 deg (`imucal
axis walk_and_leg_motions_100hz.h5 --sensors right_shank,right_foot --start 55 --end 100
--seed 1 --force`, `quality.uncertainty_components.time_offset`). Cut-off shift: the
largest move when the fit is repeated with a 10 or 20 Hz low-pass. Model: half the turn
of the axes that the residual below 8 Hz (beyond the white noise's share) could explain
in the motion's weakest direction, a bound for model errors every time block shares.

"""
AXIS_QUAL_HEAD = [
    "| joint | side | window s | relative residual | sigma j1 / j2 | curvature j1 / j2 | "
    "time blocks j1 / j2 | cut-off shift j1 / j2 | model j1 / j2 | spread j1 / j2 | verdict | "
    "warnings |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|",
]
POS_TEXT = """
## Joint position (`imucal position`)

Knee: `--joint hinge` (the point of the axis closest to both sensors; the axis is
estimated from the same window, and its warnings are prefixed "axis:"); ankle and hip:
spheroidal. o1, o2 in mm (from the joint centre to each sensor, own frame); sigma, its
components, and spread in mm (the low-pass cut-off comes from the recording's spectrum,
`settings.cutoff_hz`; cut-off shift: refits at 0.75 and 1.5 x that cut-off; model:
3 x the move of a refit that weighs the samples by (|r1| + |r2|)^2). Equal
minima: restarts that ended elsewhere at an RMS residual within 1.05 x the best, and the
farthest one's distance. qmt has no joint-position estimator to compare with.

"""
POS_HEAD = [
    "| joint (model) | sensors | window s | o1 mm | o2 mm | relative residual | "
    "sigma o1 / o2 | curvature o1 / o2 | time blocks o1 / o2 | cut-off shift o1 / o2 | "
    "model o1 / o2 | spread o1 / o2 | equal minima | verdict | warnings |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
]
OFFSET_TEXT = """
## Clock offsets between the sensors

Every fit above runs with `--time-offset auto` (the default): after a first fit the
constraint's residual is profiled over relative shifts of the second sensor within
+-0.2 s, the estimate refitted at each
([method.md](method.md#clock-offsets-between-the-two-sensors)). Estimated: the second
sensor's lateness that minimises the residual, ms (positive: its clock late); sigma: its
1-sigma (twice the block jackknife, with a model error's share from the residual's smooth
part in quadrature: `model_sigma_s`), ms, "-" where the minimum lies on the end of the
search (+-200 ms: a bound, not an estimate); cost ratio: mean squared residual at zero shift
over that at the estimate (1 = no gain). Applied only when it is larger than a
quarter sample and twice its jackknife sigma, and the cost ratio is at least 1.6. None
of these is a clock (below): with the share, the readings are 0.04-3.8 sigma from 0 (the
jackknife alone put them up to 29 sigma away).

"""
OFFSET_HEAD = [
    "| estimate | side | window s | estimated ms | sigma ms | cost ratio | applied |",
    "|---|---|---|---|---|---|---|",
]
SPLIT_TEXT = """
## Split halves: does the reported 1-sigma cover independent data?

Each estimate fitted separately on two halves of a window. The halves are independent
data, so if the reported 1-sigma is honest the distance between the two estimates is
within about 3 combined sigma, sqrt(sigma_A^2 + sigma_B^2). Per vector: distance /
combined sigma (deg for the axis, sign-free; mm for positions); ratio: the larger of the
two vectors' distance over combined sigma. A half the tool refuses ("not identifiable")
makes no claim, so its ratio does not count.

"""
SPLIT_HEAD = [
    "| estimate | side | halves s | j1 or o1: distance / combined sigma | "
    "j2 or o2: distance / combined sigma | ratio | halves answered | verdicts A / B |",
    "|---|---|---|---|---|---|---|---|",
]
FOOTER = """
## Reading the tables

- **Same minimum as qmt.** The knees in 0-55 s agree with qmt's gyro-only estimator to
  within 0.03 deg (the test suite requires 3 deg: `tests/test_real_data.py`): both
  minimise the same residual and land in the same minimum. qmt's default, which adds an
  accelerometer residual, moves the axes by up to 3.4 deg. In 55-100 s the two still
  agree within 0.6-3.7 deg: what imucal refuses there is the data, not its solver.
- **Relative sign.** In 0-55 s both knees' j1 and j2 lie within 4-22 deg of the data
  README's "lateral" axes with the same sign (until issue 10 j2 was 165-176 deg from
  them); those reference axes lie along the sensors' x axes, which the accelerometers
  show to be the segments' long axes (next point), so the axes themselves are refused.
  The decision rests on the range test (the integrated flexion spans 49 and 65 deg with
  the reported j2, 189 and 177 deg with the flipped one, which no knee does) and the
  accelerometer test (ratio 2.1); the integration-free plane test cannot tell on this
  gait (1.01-1.11, slightly for the other sign, below the 1.5 at which a test counts as
  contradicting). Combined evidence 7.1 (left) and 5.6 (right): no sign warning.
- **Not one physical line at rest (gravity mismatch).** The accelerometers say the
  knees' 0-55 s axes are not the knees' flexion axes: while the person sits (12-40 s:
  thighs horizontal, shanks vertical) the axis makes 83-85 deg with the vertical in the
  thigh sensors but 5-8 deg in the shank sensors, while in the standing periods both are
  within 5-21 deg of it. One hinge axis makes the same angle with the vertical from both
  segments in any posture, so every 0-55 s knee axis is refused for it (`not
  identifiable`, `quality.gravity`, [method.md](method.md#the-gravity-check-at-rest)).
  Until this was a refusal they were `use with care` with a 1-sigma of 19-40 deg, while
  an axis along a segment's long axis is 60-90 deg from the knee's: the 1-sigma did not
  cover the error. The data README's "lateral" reference, about the sensors' x axes, is
  then the segments' long axis, and agreeing with it says little. The knee-flexion
  section below follows this up.
- **The vigorous part is not a hinge.** In 55-100 s the flexion angle about the fitted
  axis spans more than 170 deg within 60 s with either relative sign (207 / 266 deg left,
  192 / 308 deg right), so both knees are refused (`not identifiable`), and j2 lies 64 and
  86 deg from the lateral reference, as the data README describes. The relative residual
  alone would not show it: 0.41-0.43 there against 0.37-0.39 in 0-55 s, all below the
  0.5 at which imucal warns of a poor fit (real knees leave 0.35-0.45).
- **Uncertainty.** The knee axes in 0-55 s (refused, above) have a 1-sigma of 18.8-40.4
  deg. Most of it is the model term (18-25 deg): the real knees' residual is large
  (0.37-0.39 of the signal) and mostly smooth, the signature of soft tissue and of a
  knee that is no perfect hinge, which no time block escapes. The cut-off shift
  (2.9-30.0 deg) is the largest part for the right knee's j2; curvature (2.4-5.2 deg)
  and time blocks (4.8-10.5 deg) are smaller. The warnings name the largest part
  ("uncertain (model)" left, "uncertain (cut-off)" right). The ankles fitted as a hinge
  get 24.8-40.6 deg of model term: they excite their weakest direction less than the
  knees do. For the joint centres the two largest parts are the cut-off shift (refits at
  0.75 and 1.5 x the cut-off; 12-96 mm) and the model term (1-156 mm; the largest part
  of five of the twelve, the left hip in 55-100 s at its poor fit most of all), against
  2-22 mm of curvature and 2-30 mm of time blocks. The answered centres have a 1-sigma
  of 26-186 mm (25-99 mm before the joint centre's model term) and every one warns that
  it is uncertain. The split halves agree well within these sigmas; a model error that
  both halves share (soft tissue, a joint that is no ball) cannot show there, and that
  is what the model term is for.
- **Ankles fitted as a hinge.** They leave 0.26-0.38 of the signal, below the real knees,
  and their restarts agree (this ankle moves mostly in one plane). The left ankle in
  55-100 s, which came out `good` (1-sigma 3.6 / 4.9 deg) before the model term, then `use
  with care` (its smooth residual adds 40.6 deg, for a 1-sigma of 40.8 / 40.9 deg), is
  refused now only because the window has no rest and the recording's rests of 0-55 s show
  its axes are no one line. Without a rest anywhere no check tells a real ankle from a
  hinge: choose the joint model from anatomy. The right ankle in 55-100 s is the one row
  whose relative sign the data barely decide (1.31; plane and acc lean the other way).
- **Joint centres.** They moved with the new joint-centre filter (a flat fourth-order
  low-pass at a cut-off from the spectrum instead of a second-order one at 10 Hz, and an
  8th-order difference for `gdot`; [method.md](method.md#the-joint-centre-filter)): the
  knees and ankles by 15-35 mm, within their sigmas. The knee centres (`--joint hinge`,
  0-55 s) lie 80-92 mm from each sensor, with 1-sigma 66-68 mm; they inherit the axis'
  refusal in both windows (0-55 s: the gravity check). The ankle centres lie 147-180 mm
  from the shank sensor and 95-109 mm from the foot sensor in both windows, with 1-sigma
  31-92 mm. The hip (pelvis - thigh) fits the spheroidal model with a relative residual
  of 0.09-0.25 (the left hip in 55-100 s at the 0.25 where imucal warns of a poor fit);
  in 55-100 s the right hip has a second centre 241 mm away within 1.05 x the best RMS
  residual, reached by 61 restarts: refused. The left hip in 55-100 s shows no such
  second minimum with this seed and is answered with a 1-sigma of 186 mm.
- **Clock offsets.** No fit applied one: every cost ratio is 1.00-1.51, below the 1.6 at
  which imucal aligns the sensors. What the profiles prefer is not a clock. The left knee
  axis' residual keeps falling to the end of the +-0.2 s search (+200 ms, at a cost
  ratio of only 1.16 and 1.28, so no "beyond the search" warning); the right knee axis'
  is lowest at a shank lateness of -37 ms (+-74) in 0-55 s but -14 ms in 55-100 s; the
  same sensor pairs' joint centres (eq. 3, `--joint hinge`) prefer -9 ms in 0-55 s and
  -38 to -40 ms in 55-100 s. One pair of clocks has one offset (a drift of 30 ms within a
  minute would be 0.05 %, far beyond any crystal), whatever the constraint: shifts that
  differ between windows and between eq. (1) and eq. (3), and that lower the mean
  squared residual by a factor of only 1.06-1.51, are model errors (soft tissue lagging
  the bone, a knee that is not a hinge) that a shift partly mimics. This is why an
  offset must improve the fit by 1.6 x to be applied; the larger ones (at least 10 ms,
  clear of twice their sigma) appear as the warning "offset not applied", and those
  whose refit would move the estimate by more than 3 of its 1-sigma as "offset would
  move it". The right knee
  centre in 55-100 s comes closest (1.51). The ankle centres' and hips' best shifts are
  -19 to +8 ms at 1.00-1.19 (the right ankle fitted as a hinge in 55-100 s: -113 ms at
  1.46). On simulated data a real 20 ms offset gives cost ratios of 1.5-3 (circling at
  40 Hz) to 90 and is found within 0.2 ms at 40-200 Hz ([accuracy.md](accuracy.md)).
- **Split halves.** Wherever neither half is refused, the halves agree within 1.4
  combined sigma (worst: the left hip, 0-50 / 50-100 s, whose o1 moves 276 mm between the
  halves against a combined sigma of 202 mm; 2.1 and 129 mm before the joint centre's
  model term). Before issue 10, with the curvature alone,
  the same splits disagreed by up to 15.3 combined sigma (left knee), 13.4 (right
  knee), 14.5 and 13.6 (left and right hip):
  [quality.md](quality.md#how-the-uncertainty-is-computed-and-why). No knee axis half
  is answered: the halves in 0-55 s fail the gravity check (the right knee's two, both
  `use with care` before, agreed within 0.3 combined sigma on the segments' long axes:
  halves that share a wrong axis agree), and every half that contains most of 55-100 s
  spans more than a knee can. A refused half makes no
  claim, so the right hip's 2.5 (55-77.5 / 77.5-100 s) and 2.5 (0-50 / 50-100 s) do not
  count.

See [quality.md](quality.md) for what every field means.
"""

if __name__ == "__main__":
    main()
