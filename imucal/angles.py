"""Knee flexion over time from a calibration (Seel, Raisch, Schauer 2014, Sensors 14:6891).

The angle of a hinge is the gyro angle (the integrated rate about the axis, exact up to a
constant and drifting with a gyro bias) fused with the acc angle (the joint centre's
acceleration seen in both joint planes: noisy, no drift); :mod:`imucal.fusion` computes
both and their fusion. This module turns that into flexion, checks that the calibration
still fits the recording, and holds the results.

The flexion angle is ``sign * (theta - zero)`` in degrees: the sign makes flexion positive,
the zero is an anatomical convention (docs/angles.md). The calibration and its file are in
:mod:`imucal.calibration`; :func:`joint_angles` applies one to a recording.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from .equality import ByValue
from .errors import InputError, NotIdentifiableError, number_text, signed_ms
from .formats import HDF5_SUFFIXES
from .fusion import SMOOTHING_S, check_smoothing, fuse, hinge_signals, plane_basis
from .rest import (
    STILL_MIN_S,
    STILL_RATE,
    gravity_check,
    gravity_check_near,
    gravity_warning,
    still_periods,
)
from .settings import check_time_offset, is_bool
from .time_offset import sampling_sigma, shifted
from .timing import reported_rate
from .vectors import joint_plane_rate

if TYPE_CHECKING:
    from .calibration import Calibration

#: Sign decisions with |evidence| below this (see :func:`sign_evidence`) are weak.
SIGN_EVIDENCE_MIN = 0.15
#: Fewest samples an angle is computed over: the acc angle needs the rates' derivative
#: (a 9-sample stencil). Over 2 samples a simulated walk read up to 75 deg off, at 3
#: sigma and more in 50 of 51 windows, with "fits"; over 10 samples at most 1 deg.
MIN_SAMPLES = 10
#: A recording's own sign evidence (used when the calibration trial's was weak) counts
#: only over at least this long, s: two slow strides (``GAIT_STRIDE_S``). Over part of a
#: stride the skew says where in the stride the window lies: with the circling sample
#: calibration, 0.3-0.5 s windows of a walk took the wrong direction unwarned in 93 of 259
#: windows (about 70 deg off), windows of 0.75 s and more in none of 619.
SIGN_MIN_S = 4.0
#: ... and only where the angle spans (5th to 95th percentile) at least this, deg: the
#: skew of a knee that hardly moves is the skew of noise. Simulated still recordings
#: (0.05 deg of spread) gave evidence of -0.19 and -0.48 and read 55 deg of flexion
#: for a knee bent 10 deg, with no warning; walking spans 50-70 deg.
SIGN_MIN_SPAN_DEG = 10.0
#: s: a window too short to decide the direction is given the samples this close to it.
SIGN_AROUND_S = 60.0
#: Samples turning slower than this (rad/s, RMS of both sensors' angular rates) are left
#: out of the hinge residual: at rest it would be noise over noise.
MOVING_RATE = 0.5
#: The "still fits" check: a recording's hinge residual and acc-gyro disagreement may
#: exceed the calibration trial's by this factor plus the floors below before the
#: calibration is said not to fit (docs/angles.md#does-the-calibration-still-fit).
FIT_FACTOR = 2.0
#: Simulated 40 s walks of a 30 s protocol calibration's mounting (39-40 seeds each): with
#: 0.03 the residual refused 2 and 3 walks with soft tissue of 2 deg / 3 mm and 4 deg /
#: 6 mm (13 and 8 with the old residual and 0.1; rigid: none), and passed 8 / 1 / 0 with
#: the shank re-strapped by 5 / 10 / 20 deg (10 / 2 / 0 before).
FIT_FLOOR_RESIDUAL = 0.03
FIT_FLOOR_DEG = 2.0
#: On the calibration trial, an RMS disagreement of the acc and gyro angles above this
#: (deg) means the acc angle cannot be trusted to correct drift (simulated: 0.3-2 deg).
ACC_AGREEMENT_DEG = 10.0
#: The disagreement limit never exceeds what a trustworthy calibration trial allows: a
#: trial that itself disagreed by 79 deg (real knees with wrong axes) would otherwise
#: accept anything, even another recording's sensors (knee angles of -278 deg).
FIT_MAX_DEG = FIT_FACTOR * ACC_AGREEMENT_DEG + FIT_FLOOR_DEG
#: Flexion a knee (or elbow) can reach from its extended zero, deg. Where the zero is an
#: extended posture (see ``_one_joint``), more than ``IMPLAUSIBLE_SHARE`` of the samples
#: outside it means the zero or the axes do not carry over to this recording.
PLAUSIBLE_FLEXION_DEG = (-30.0, 180.0)
IMPLAUSIBLE_SHARE = 0.01
#: Where the zero is an extended still posture of the calibration trial, a recording whose
#: 1st percentile of flexion lies beyond this many deg of extension is warned: a sensor
#: turned about the knee axis since the calibration shifts every angle by the turn, which
#: no fit check sees (eq. 1 and the rest check are blind to it: a shank turned 20 deg
#: "fit" in 95 % of simulated walks, every angle 20 deg off at a 1-sigma of 0.1-0.4),
#: and so does a zero taken from a pause with the leg in the air (18-28 deg low). An
#: independent audit: with the calibration's stand 10 deg more flexed than the walks'
#: extension, 62 % false alarms at 10 deg, 2 % at 12.5, none at 15; turns of 20 deg
#: towards extension all caught, turns towards flexion never (a crouch gait looks alike).
HYPEREXTENDED_DEG = 15.0
#: A calibration trial whose flexion (1st to 99th percentile) spans more than this, deg,
#: measured no hinge of the body: its knee is "not identifiable" (docs/angles.md).
PLAUSIBLE_SPAN_DEG = PLAUSIBLE_FLEXION_DEG[1] - PLAUSIBLE_FLEXION_DEG[0]
#: Walking: at least this many flexion peaks of this prominence (deg), spaced by strides
#: of 0.6-2 s that vary by at most GAIT_MAX_CV.
GAIT_MIN_CYCLES = 4
GAIT_PROMINENCE_DEG = 20.0
GAIT_STRIDE_S = (0.6, 2.0)
GAIT_MAX_CV = 0.25

FLEXION_COLUMN = "{joint}_flexion_deg"
SIGMA_COLUMN = "{joint}_flexion_sigma_deg"


# ----------------------------------------------------------------------------- conventions


def sign_evidence(angle: np.ndarray) -> float:
    """Skew of the angle's spread, in [-1, 1]: ``((p95 - p50) - (p50 - p5)) / (p95 - p5)``.

    A knee spends most of its time near extension and makes excursions into flexion, so
    with flexion positive this is positive (walking about +0.5, standing with leg motions
    near +1); a symmetric motion (pure circling) gives about 0: weak evidence.

    Returns
    -------
    float
        The skew in [-1, 1]; 0 when the angle does not vary.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.angles import sign_evidence
    >>> knee = np.r_[np.zeros(80), np.linspace(0, 60, 20)]   # deg: mostly extended
    >>> sign_evidence(knee), sign_evidence(-knee)
    (1.0, -1.0)
    >>> round(abs(sign_evidence(np.sin(np.linspace(0, 8 * np.pi, 2000)))), 2)  # symmetric
    0.0
    """
    p5, p50, p95 = np.percentile(angle, [5, 50, 95])
    span = p95 - p5
    return 0.0 if span <= 0 else float(((p95 - p50) - (p50 - p5)) / span)


def moving_part(raw: np.ndarray, rate: float, gyrs) -> np.ndarray:
    """The angle ``raw`` without its still periods (:func:`imucal.rest.still_periods` of
    the sensors' rates ``gyrs``, rad/s, at ``rate`` Hz), for :func:`sign_evidence`: a
    rest lumps one posture into the percentiles, and a 4 s rest with the knee flexed made
    a circling trial's evidence (about 0 without it) +0.30, the wrong way in 9 of 17
    simulated trials; walks then read as mirror images of the knee, "fits" (an
    independent audit). All of ``raw`` when nothing moves.

    Returns
    -------
    numpy.ndarray
        The samples of ``raw`` outside still periods, in time order.
    """
    periods = still_periods(gyrs, rate)
    if not periods:
        return raw
    moving = np.ones(raw.shape[0], dtype=bool)
    for a, b in periods:
        moving[a:b] = False
    return raw[moving] if moving.any() else raw


def hinge_residual(g1, g2, j1, j2) -> float:
    """Relative hinge residual: RMS of ``|g1 x j1| - |g2 x j2|`` (the rates across the
    axis, which a rigid hinge with the right axes makes equal) over the RMS angular rate
    ``sqrt((|g1|^2 + |g2|^2) / 2)``, on the samples where that rate exceeds
    :data:`MOVING_RATE`; NaN if it never does.

    Relative to the rates, not to the rates across the axis: those vanish when a knee
    flexes cleanly about its axis (in simulated walking they stayed below 0.5 rad/s while
    the knee flexed at 6 rad/s), which left the residual to a handful of samples, or none
    (a re-strapped thigh then went unnoticed), and made a walk's residual several times
    its protocol calibration trial's (soft tissue 2 deg / 3 mm: 13 of 40 walks refused).
    Simulated: 0.005-0.015 with a rigid hinge, 0.03-0.23 with soft tissue.

    Parameters
    ----------
    g1, g2 : (N, 3) angular rates, rad/s, in the first / second sensor's frame.
    j1, j2 : (3,) the hinge axis in those frames (any length; normalised here).

    Returns
    -------
    float
        The relative residual (dimensionless), NaN when no sample moves.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", eq. (1).
    """
    g1, g2 = np.asarray(g1, float), np.asarray(g2, float)
    j1, j2 = (np.asarray(j, float) / np.linalg.norm(j) for j in (j1, j2))
    p1, p2 = joint_plane_rate(g1, j1), joint_plane_rate(g2, j2)
    speed2 = 0.5 * (np.sum(g1 * g1, axis=1) + np.sum(g2 * g2, axis=1))
    use = speed2 > MOVING_RATE**2
    if not use.any():
        return float("nan")
    return float(np.sqrt(np.mean((p1 - p2)[use] ** 2) / np.mean(speed2[use])))


def detect_gait(flexion_deg: np.ndarray, rate: float) -> dict | None:
    """Walking, if the flexion has at least :data:`GAIT_MIN_CYCLES` swing peaks (prominence
    :data:`GAIT_PROMINENCE_DEG`) at regular stride intervals: ``{"peaks": sample indices
    of peak swing flexion, "stride_s": median stride, "cv": variation}``; else None.
    Cycles run from one swing peak to the next. Any regular flexion qualifies: circling
    the leg as well as walking.

    Returns
    -------
    dict or None
        ``peaks`` (int array of sample indices), ``stride_s`` (s), ``cv`` (the strides'
        coefficient of variation), or None when the flexion does not repeat regularly.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.angles import detect_gait
    >>> t = np.arange(1000) / 100.0                                   # s, 100 Hz
    >>> gait = detect_gait(30 - 30 * np.cos(2 * np.pi * t / 1.1), 100.0)
    >>> len(gait["peaks"]), gait["stride_s"]
    (9, 1.1)
    """
    from scipy.signal import find_peaks

    peaks, _ = find_peaks(flexion_deg, prominence=GAIT_PROMINENCE_DEG,
                          distance=max(1, int(GAIT_STRIDE_S[0] * rate)))
    if peaks.size < GAIT_MIN_CYCLES + 1:
        return None
    strides = np.diff(peaks) / rate
    regular = (strides >= GAIT_STRIDE_S[0]) & (strides <= GAIT_STRIDE_S[1])
    # the longest run of regular strides is the walk
    edges = np.diff(np.concatenate([[0], regular.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return None
    k = int(np.argmax(stops - starts))
    run = strides[starts[k]:stops[k]]
    if run.size < GAIT_MIN_CYCLES or np.std(run) / np.mean(run) > GAIT_MAX_CV:
        return None
    return {"peaks": peaks[starts[k]:stops[k] + 1], "stride_s": float(np.median(run)),
            "cv": float(np.std(run) / np.mean(run))}


# ----------------------------------------------------------------------------- calibration


def _offset_number(jc, key: str, doc=None) -> float | None:
    """``key`` of the ``time_offset`` block of ``doc`` (default: the calibration's axis),
    if a finite number."""
    doc = jc.axis if doc is None else doc
    offset = doc.get("time_offset") if isinstance(doc, dict) else None
    value = offset.get(key) if isinstance(offset, dict) else None
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    return float(value) if ok else None


def clock_offset_sigma(jc) -> float:
    """The 1-sigma, s, of the clock offset :func:`clock_offset` returns (0 when none was
    applied, or when it was given, which is taken as exact).

    Returns
    -------
    float
        The offset's 1-sigma, s.
    """
    block = jc.axis.get("time_offset") if isinstance(jc.axis, dict) else None
    applied = isinstance(block, dict) and block.get("applied")
    sigma = _offset_number(jc, "sigma_s")
    return sigma if applied and sigma is not None and clock_offset(jc) else 0.0


def unapplied_clock_offset(jc) -> float:
    """The clock offset, s, the calibration's axis found where its residual was lowest but
    did not apply (too little gain to tell it from soft tissue), when clear of twice its
    1-sigma and inside the search; or, with an offset given, how far from it the data put
    the clocks where they contradict it (:func:`imucal.time_offset.check_given`); else 0.
    The angles read the sensors at the offset applied, so such an offset, if real, makes
    them lag: a calibration that found a 30 ms shank 16 ms late and left it gave a
    simulated walk 12 deg of error at a 1-sigma of 2 deg, "fits" (an honesty audit).

    Returns
    -------
    float
        The offset found and not applied (beyond the one given), s (positive: the second
        sensor later), or 0.
    """
    found, sigma = _unapplied_search(jc)
    return found if abs(found) > 2 * sigma else 0.0


def unapplied_offset_spread(jc) -> float:
    """How far, s (root mean square), the clocks may differ where the calibration's axis
    searched for an offset and applied none: ``sqrt(estimated_s^2 + sigma_s^2)``, or
    where its data contradicted the offset given, with ``estimated_s`` less that offset;
    0 when an offset was applied (the angles then carry :func:`clock_offset_sigma`), or
    given and not contradicted, or when the search ended at its edge. The angles read
    such sensors as in sync; a 10 ms shank found at 14 +- 8 ms (not clear of twice its
    1-sigma, so no warning) left a simulated walk 1.8 deg RMS off at a median 1-sigma of
    0.8 deg, 80 % of the samples within 3 sigma (an honesty audit).

    Returns
    -------
    float
        The spread, s (root mean square, >= 0).
    """
    return math.hypot(*_unapplied_search(jc))


def _unapplied_search(jc) -> tuple[float, float]:
    """(estimated_s, the sampling part of sigma_s) of the calibration axis's clock-offset
    search where it ran (mode auto), applied nothing and did not end at its edge
    (the model share, ``model_sigma_s``, measures how far soft tissue may have moved the
    reading, which ``estimated_s`` carries already where the clocks are in sync: with it,
    67 simulated knees calibrated with nothing applied got angle bands 1.6 x as wide, at
    most 7 x, for no gain in coverage); (estimated_s minus the offset given, sigma_s)
    where the check of the axis or of the knee centre contradicted a given offset (the
    one with the larger cost ratio: with soft tissue on gait the centre's caught a 20 ms
    shank the axis's missed, an independent review); else (0, 0)."""
    block = jc.axis.get("time_offset") if isinstance(jc.axis, dict) else None
    if not isinstance(block, dict):
        return 0.0, 0.0
    if block.get("mode") == "given":
        return _contradicted_given(jc)
    if block.get("mode") != "auto" or block.get("applied") or block.get("at_edge"):
        return 0.0, 0.0
    found, sigma = _offset_number(jc, "estimated_s"), _offset_number(jc, "sigma_s")
    if found is None or sigma is None:
        return 0.0, 0.0
    return found - clock_offset(jc), _sampling_part(jc, jc.axis, sigma)


def _contradicted_given(jc) -> tuple[float, float]:
    """(estimated_s minus the offset given, the sampling part of sigma_s) of the
    contradicted check (axis or knee centre) with the larger cost ratio, else (0, 0)."""
    found = []
    for doc in (jc.axis, jc.position):
        block = doc.get("time_offset") if isinstance(doc, dict) else None
        if not isinstance(block, dict) or block.get("contradicted") is not True:
            continue
        values = [_offset_number(jc, k, doc) for k in ("estimated_s", "sigma_s",
                                                        "time_offset_s", "cost_ratio")]
        if None not in values:
            found.append(values + [doc])
    if not found:
        return 0.0, 0.0
    estimated, sigma, given, _, doc = max(found, key=lambda v: v[3])
    return estimated - given, _sampling_part(jc, doc, sigma)  # as an unapplied one


def _sampling_part(jc, doc, sigma: float) -> float:
    """``sigma`` (the ``sigma_s`` of ``doc``'s ``time_offset`` block, s) without its model
    share (``model_sigma_s``), but with half a disagreement with the knee's other search
    (``disagreement_s``, :func:`imucal.time_offset.note_disagreement`) where one widened
    it: a knee whose axis applied nothing and won over its centre's offset keeps that in
    its angles' spread (4.9 ms, not 0.4 ms, on gait with the shank 10 ms late, a
    review)."""
    numbers = {k: _offset_number(jc, k, doc)  # (checked: a calibration file is text)
               for k in ("model_sigma_s", "sampling_sigma_s")}
    sampling = sampling_sigma({"sigma_s": sigma,
                               **{k: v for k, v in numbers.items() if v is not None}})
    gap = _offset_number(jc, "disagreement_s", doc) or 0.0
    return math.hypot(sampling, gap / 2)


def clock_offset(jc) -> float:
    """The clock offset, s, the calibration's axis estimate applied between the hinge's
    sensors (positive: the second sensor's clock is late; docs/json.md), else 0.

    Returns
    -------
    float
        The applied offset, s.
    """
    value = _offset_number(jc, "time_offset_s")
    return 0.0 if value is None else value


#: ``time_offset`` of the blocks :func:`_given_clock` puts in a joint's calibration.
GIVEN_FOR_RECORDING = "given for this recording"


def check_trial_offset(value) -> float | None:
    """A recording's own clock offset for :func:`joint_angles` checked: None, or a finite
    number of seconds within +-10 s (also as a string).

    Returns
    -------
    float or None
        The offset, s, or None (the calibration's).

    Raises
    ------
    InputError
        "auto" (the angles have no search of their own: under soft tissue a walk's rates
        put the clocks 6-26 ms from the truth with the calibration's axes, on imucal's
        simulator) or anything :func:`imucal.settings.check_time_offset` refuses.
    """
    if value is None:
        return None
    try:
        checked = check_time_offset(value)
    except InputError:
        checked = None
    if checked == "auto":
        raise InputError("time offset of the angles must be a number of seconds, got "
                         "'auto': not searched here, as soft tissue on a walk mimics offsets "
                         "of 6-26 ms; find it with imucal calibrate on this recording, or "
                         "give it from the sensors' synchronisation")
    if checked is None:
        raise InputError("time offset of the angles must be a finite number of seconds "
                         f"within +-10 s, got {value!r}")
    return checked


def _given_clock(jc, offset: float | None):
    """``jc`` with its calibration's clock offset replaced by ``offset`` (s, taken as
    exact: mode "given", no check to contradict it, ``clock_offset_source`` "given for
    this recording"), or ``jc`` itself for None."""
    if offset is None:
        return jc
    block = {"mode": "given", "time_offset_s": float(offset),
             "source": GIVEN_FOR_RECORDING}
    return replace(jc, axis={**jc.axis, "time_offset": block},
                   position=None if jc.position is None else {**jc.position,
                                                              "time_offset": block})


def clock_offset_source(jc) -> str:
    """Where the clock offset the angles read comes from.

    Returns
    -------
    str
        "calibration", or ``GIVEN_FOR_RECORDING`` (:func:`_given_clock`).
    """
    block = jc.axis.get("time_offset") if isinstance(jc.axis, dict) else None
    given = isinstance(block, dict) and block.get("source") == GIVEN_FOR_RECORDING
    return GIVEN_FOR_RECORDING if given else "calibration"


def _offset_words(jc) -> str:
    """How messages name the offset read: "the calibration's" or "the given"."""
    return "the calibration's" if clock_offset_source(jc) == "calibration" else "the given"


def _fused(rec, jc, smoothing_s: float, context=None):
    """(first sensor, second sensor aligned, signals, fusion, beyond). The second sensor is read
    at t + the calibration's clock offset: the gyro angle subtracts the two sensors'
    rates sample by sample, so a 20 ms offset left 3-8 deg of error in simulated walking
    that the band did not cover (the offset is assumed to persist from the calibration
    trial, as a fixed latency does; the fit check compares the aligned signals).

    ``context``: ``rec``'s sensors with the samples around it (``Recording.select`` with
    ``context=True``): the shift reads them there, instead of holding the window's last
    sample (5 s of a walk, 50 ms late: the last samples 2.8 deg off at 5 sigma).

    ``beyond`` (N,): how far, s, each sample's read of the second sensor lies beyond the
    samples there are (0 inside): the shift holds the last sample there, so those angles
    are extrapolated (with a 100 ms offset the last 0.1 s of a recording came out 14-22
    deg off at 20-42 sigma, an independent audit)."""
    s1, s2 = rec.sensor(jc.sensors[0]), rec.sensor(jc.sensors[1])
    delta = clock_offset(jc)
    beyond = np.zeros(rec.n_samples)
    if delta:
        source = s2 if context is None else context.sensor(jc.sensors[1])
        i0, i1 = (0, rec.n_samples) if context is None else context.window
        s2 = replace(s2, gyr=shifted(source.gyr, rec.rate, delta)[i0:i1],
                     acc=shifted(source.acc, rec.rate, delta)[i0:i1])
        read = np.arange(i0, i1) / rec.rate + delta
        last = (source.gyr.shape[0] - 1) / rec.rate
        beyond = np.maximum(np.maximum(read - last, -read), 0.0)
    sig = hinge_signals(s1.gyr, s1.acc, s2.gyr, s2.acc, rate=rec.rate, j1=jc.j1, j2=jc.j2,
                        o1=jc.o1, o2=jc.o2)
    if beyond.any():
        # their acc angle is made of the held sample too: with full weight the drift
        # correction followed it back over the last 5-8 s (protocol, 100 ms late: -5 deg
        # over the last 2 s, 87 % of the samples within 3 sigma, "good")
        sig = replace(sig, weight=np.where(beyond > 0, 0.0, sig.weight))
    return s1, s2, sig, fuse(sig, rec.rate, smoothing_s), beyond


def _zero(raw_deg: np.ndarray, sign: int, rec, gyrs) -> tuple[float, str, float | None]:
    """(raw angle of zero flexion, how it was found, time s or None): the most extended
    still period (>= STILL_MIN_S) if any, else the 1st percentile of flexion."""
    periods = still_periods(gyrs, rec.rate)
    if periods:
        means = np.array([raw_deg[a:b].mean() for a, b in periods])
        k = int(np.argmin(sign * means))
        a, b = periods[k]
        return (float(means[k]), "most extended still period (>= "
                f"{STILL_MIN_S:g} s, both sensors below {STILL_RATE:g} rad/s)",
                float(rec.time[a]))
    return (float(sign * np.percentile(sign * raw_deg, 1.0)),
            "no still period: the 1st percentile of flexion (the most extended posture of "
            "the calibration trial, not necessarily a straight knee)",
            None)


def reference_statistics(rec, jc, *, smoothing_s: float = SMOOTHING_S,
                         context=None) -> dict:
    """The ``angle`` block of a hinge in the calibration file (docs/json.md): flexion sign
    and zero decided on the calibration trial ``rec`` (``context``: its sensors with the
    samples around it, see ``_fused``), and the statistics the "still fits" check
    compares other recordings with.

    Returns
    -------
    dict
        ``flexion_sign`` (+1 / -1), ``sign_evidence``, ``zero_deg`` / ``zero_method`` /
        ``zero_time_s`` (raw angle, deg, of 0 flexion, how and when it was found),
        ``reference_x1`` / ``reference_x2`` (the joint-plane reference directions in the
        first / second sensor frame), ``smoothing_s`` (s), ``hinge_residual``,
        ``acc_gyro_disagreement_deg``, ``flexion_range_deg`` (1st and 99th percentile),
        ``sigma_median_deg``, ``gravity_mismatch_deg``, ``gravity_consistent`` and
        ``warnings`` (list of str).

    References
    ----------
    Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for gait analysis",
    Sensors 14(4):6891-6909: the gyroscope angle with its accelerometer-based drift correction.
    """
    s1, s2, sig, fus, _ = _fused(rec, jc, smoothing_s, context)
    raw = np.degrees(fus.theta)
    evidence = sign_evidence(moving_part(raw, rec.rate, (s1.gyr, s2.gyr)))
    sign = 1 if evidence >= 0 else -1
    zero, method, zero_t = _zero(raw, sign, rec, (s1.gyr, s2.gyr))
    flex = sign * (raw - zero)
    # one hinge axis makes the same angle with the vertical in both sensors whenever
    # they rest, whatever the posture (imucal.rest): eq. (1) never sees gravity, so this
    # is an independent test of the axes the angles rest on
    gravity = gravity_check(s1.gyr, s1.acc, s2.gyr, s2.acc, jc.j1, jc.j2, rec.rate,
                            origin=float(rec.time[0]))
    warned = gravity_warning(gravity, f"{jc.name}: the axis")
    warnings = [] if warned is None else [warned]
    if math.degrees(fus.disagreement) > ACC_AGREEMENT_DEG:
        warnings.append(
            f"{jc.name}: on the calibration trial the accelerometer-based angle differs "
            f"from the gyro-based angle by {math.degrees(fus.disagreement):.0f} deg RMS "
            f"(more than {ACC_AGREEMENT_DEG:g} deg): the drift correction is unreliable; "
            "the joint is far from a hinge with these axes, or the axes are wrong")
    flexion_range = [float(np.percentile(flex, 1)), float(np.percentile(flex, 99))]
    failing = own_check_failure(jc.name, math.degrees(fus.disagreement), gravity["consistent"])
    implausible = implausible_range(jc.name, flexion_range)
    for reason in (failing, implausible):  # last: the reasons calibrate gives for the joint
        if reason:
            warnings.append(reason)
    x1, _ = plane_basis(jc.j1)
    x2, _ = plane_basis(jc.j2)
    return {
        "flexion_sign": sign,
        "sign_evidence": evidence,
        "zero_deg": zero,
        "zero_method": method,
        "zero_time_s": zero_t,
        "zero_trial": None,
        "reference_x1": x1.tolist(),
        "reference_x2": x2.tolist(),
        "smoothing_s": smoothing_s,
        "hinge_residual": hinge_residual(s1.gyr, s2.gyr, jc.j1, jc.j2),
        "acc_gyro_disagreement_deg": math.degrees(fus.disagreement),
        "flexion_range_deg": flexion_range,
        "sigma_median_deg": float(np.degrees(np.median(fus.sigma))),
        "gravity_mismatch_deg": gravity["max_mismatch_deg"],
        "gravity_consistent": gravity["consistent"],
        "warnings": warnings,
    }


def own_check_failure(name: str, disagreement_deg: float, gravity_consistent) -> str | None:
    """Why no recording can pass the fit check with this calibration: its own trial fails
    the parts of it that do not depend on the trial's own numbers (a disagreement above
    ``FIT_MAX_DEG``, axes the gravity check rejects), else None. Such a knee was "use
    with care" in ``calibrate`` and then refused on the very trial it came from.

    Returns
    -------
    str or None
        One sentence naming ``name`` and the failing parts, or None.
    """
    fails = ([f"acc-gyro disagreement {disagreement_deg:.0f} deg > {FIT_MAX_DEG:g} deg"]
             if disagreement_deg > FIT_MAX_DEG else [])
    if gravity_consistent is False:
        fails.append("the gravity check")
    if not fails:
        return None
    return (f"{name}: no recording can pass the fit check with this calibration: its own "
            f"trial fails it ({', '.join(fails)})")


def implausible_range(name: str, flexion_range) -> str | None:
    """Why a calibration trial's flexion range ``[p1, p99]`` (deg) is no hinge of the body's
    (it spans more than ``PLAUSIBLE_SPAN_DEG``), else None. The real knees of the shared
    recording, with axes the gravity check rejects, spanned -25 to 278 deg.

    Returns
    -------
    str or None
        One sentence naming ``name`` and the range, or None when it is plausible.
    """
    low, high = flexion_range
    if not high - low > PLAUSIBLE_SPAN_DEG:
        return None
    return (f"{name}: on the calibration trial the flexion spans {low:.0f} to {high:.0f} deg "
            f"(1st to 99th percentile), more than the {PLAUSIBLE_SPAN_DEG:g} deg a hinge of "
            "the body can move through: the axes or the drift correction are wrong, and no "
            "angle measured with this calibration can be trusted")


# ----------------------------------------------------------------------------- apply


@dataclass(eq=False)
class JointAngle(ByValue):
    """Flexion of one hinge over the recording.

    Attributes
    ----------
    name, sensors : the joint and its (thigh, shank) sensors in this recording.
    flexion_deg, sigma_deg : (N,) flexion (positive = flexion, 0 as ``zero`` says) and its
        1-sigma (deg).
    gyro_only_deg : (N,) pure integration of the rates with the same sign, equal to
        ``flexion_deg`` at the first sample (what the fusion corrects).
    sign, sign_source : +1 / -1 applied to the calibration's raw angle (the right-handed
        rotation of the second segment about j), and why: "calibration" (its trial
        decided), "recording" (this window decided), "recording around the window" (the
        window could not, its recording's other samples did), "user" (pinned) or
        "calibration guess" (none decided: the calibration's guess, with a warning).
    sign_evidence : this recording's evidence (:func:`sign_evidence`).
    zero : {"method", "raw_deg", "time_s", "time_in"}: what 0 deg is.
    check : the "still fits" evidence (docs/angles.md): hinge residual and acc-gyro
        disagreement here and on the calibration trial, their limits, ``fits``.
    gait : None, or {"peaks" (sample indices of peak swing flexion), "stride_s", "cv"}.
    warnings : the calibration's angle warnings and this recording's (sign, fit).
    """

    name: str
    sensors: tuple[str, str]
    flexion_deg: np.ndarray
    sigma_deg: np.ndarray
    gyro_only_deg: np.ndarray
    sign: int
    sign_source: str
    sign_evidence: float
    zero: dict
    check: dict
    gait: dict | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def fits(self) -> bool:
        """Whether the "still fits" check passed (``check["fits"]``, docs/angles.md)."""
        return bool(self.check["fits"])


@dataclass(eq=False)
class JointAngles(ByValue):
    """Result of :func:`joint_angles`; ``fits`` is False when any joint's check failed (the
    command line exits 1 then).

    Attributes
    ----------
    time : (N,) sample times, s on the recording's time axis.
    joints : joint name -> :class:`JointAngle`, one per usable hinge of the calibration.
    source : the recording's path.
    calibration : the calibration's file (or, made in memory, its trial's path).
    rate : sample rate, Hz.
    reference : the ``reference`` argument (what 0 deg means).
    warnings : hinges of the calibration that have no angle (their estimate failed) and
        the recording's notes about the sensors used (repairs, units).
    """

    time: np.ndarray
    joints: dict[str, JointAngle]
    source: str
    calibration: str
    rate: float
    reference: object = None
    warnings: list[str] = field(default_factory=list)

    @property
    def fits(self) -> bool:
        """Whether every joint passed its "still fits" check."""
        return all(j.fits for j in self.joints.values())

    def problems(self) -> list[str]:
        """Why these angles are not to be trusted, one phrase per joint that does not fit
        (``joint 'knee': not identifiable in the calibration`` / ``joint 'knee': the
        calibration does not fit``); empty when every joint fits. The command line
        refuses to write the angles when there is one, unless ``--force``.

        Returns
        -------
        list of str
            One phrase per joint that does not fit.

        Examples
        --------
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"), seed=1,
        ...                        restarts=20, joints=["knee=hinge:thigh,shank"])
        >>> angles = imucal.joint_angles(imucal.load_recording("sample_data/walking.h5"), cal)
        >>> angles.problems()
        []
        """
        problems = []
        for j in self.joints.values():
            if not j.fits:
                verdict = j.check["calibration_verdict"]
                problems.append(f"joint '{j.name}': " + (
                    f"{verdict} in the calibration" if verdict == "not identifiable"
                    else "the calibration does not fit"))
        return problems

    def to_frame(self):
        """The angles as a table.

        Returns
        -------
        pandas.DataFrame
            One row per sample: ``time`` (s), and per joint ``<joint>_flexion_deg`` and
            ``<joint>_flexion_sigma_deg`` (deg).

        Examples
        --------
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"), seed=1,
        ...                        restarts=20, joints=["knee=hinge:thigh,shank"])
        >>> angles = imucal.joint_angles(imucal.load_recording("sample_data/walking.h5"), cal)
        >>> table = angles.to_frame()
        >>> list(table.columns), len(table)
        (['time', 'knee_flexion_deg', 'knee_flexion_sigma_deg'], 3000)
        """
        import pandas as pd

        cols = {"time": self.time}
        for name, j in self.joints.items():
            cols[FLEXION_COLUMN.format(joint=name)] = j.flexion_deg
            cols[SIGMA_COLUMN.format(joint=name)] = j.sigma_deg
        return pd.DataFrame(cols)

    def to_document(self) -> dict:
        """JSON-ready summary (no per-sample data: those are in :meth:`write`'s table).

        Returns
        -------
        dict
            ``imucal_version``, ``command`` (``"angles"``), ``input``, ``calibration``,
            ``reference``, ``fits``, ``convention``, ``joints`` (per joint: sign, zero,
            range, 1-sigma, check, gait, warnings; docs/angles.md#output) and
            ``warnings``.

        Examples
        --------
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"), seed=1,
        ...                        restarts=20, joints=["knee=hinge:thigh,shank"])
        >>> angles = imucal.joint_angles(imucal.load_recording("sample_data/walking.h5"), cal)
        >>> doc = angles.to_document()
        >>> doc["fits"], doc["joints"]["knee"]["column"]
        (True, 'knee_flexion_deg')
        """
        from . import __version__
        from .report import clean

        joints = {}
        for name, j in self.joints.items():
            f = j.flexion_deg
            joints[name] = {
                "sensors": list(j.sensors),
                "column": FLEXION_COLUMN.format(joint=name),
                "fits": j.fits,
                "flexion_sign": j.sign,
                "sign_source": j.sign_source,
                "sign_evidence": j.sign_evidence,
                "zero": j.zero,
                "range_deg": [float(f.min()), float(f.max())],
                "percentiles_deg": dict(zip(("p1", "p50", "p99"),
                                            np.percentile(f, [1, 50, 99]).tolist(),
                                            strict=True)),
                "sigma_deg": {"median": float(np.median(j.sigma_deg)),
                              "max": float(np.max(j.sigma_deg))},
                "gyro_only_end_difference_deg": float(j.gyro_only_deg[-1] - f[-1]),
                "check": j.check,
                "gait": None if j.gait is None else {
                    "strides": int(len(j.gait["peaks"]) - 1),
                    "stride_s": j.gait["stride_s"], "stride_cv": j.gait["cv"],
                    "from_s": float(self.time[j.gait["peaks"][0]]),
                    "to_s": float(self.time[j.gait["peaks"][-1]])},
                "warnings": j.warnings,
            }
        return clean({
            "imucal_version": __version__,
            "command": "angles",
            "input": {"path": self.source, "sample_rate_hz": reported_rate(self.rate),
                      "window_s": [float(self.time[0]), float(self.time[-1]) + 1 / self.rate],
                      "samples": int(self.time.shape[0])},
            "calibration": self.calibration,
            "reference": self.reference,
            "fits": self.fits,
            "convention": "flexion in degrees, positive = flexion; 0 as each joint's 'zero' "
                          "says; sigma = 1-sigma per sample (docs/angles.md)",
            "joints": joints,
            "warnings": self.warnings,
        })

    def _column_attrs(self) -> dict[str, dict]:
        """Per column of the table, the HDF5 attributes that say what it holds: ``units``
        and ``description``; a joint's columns also ``joint``, ``sensors`` and (flexion)
        ``frame``, the rotation it measures."""
        attrs = {"time": {"units": "s", "description": "sample times on the recording's "
                          "time axis"}}
        for name, j in self.joints.items():
            first, second = j.sensors
            about = {"joint": name, "sensors": [first, second]}
            attrs[FLEXION_COLUMN.format(joint=name)] = {
                **about, "units": "deg",
                "description": f"flexion of joint '{name}', positive = flexion; 0: "
                               f"{j.zero['method']} (docs/angles.md)",
                "frame": f"rotation of sensor '{second}' relative to sensor '{first}' about "
                         f"the calibration's hinge axis (j1 in the '{first}' sensor frame, "
                         f"j2 in the '{second}' sensor frame); flexion is the "
                         f"{'right' if j.sign > 0 else 'left'}-handed rotation about it"}
            attrs[SIGMA_COLUMN.format(joint=name)] = {
                **about, "units": "deg",
                "description": f"1-sigma of {FLEXION_COLUMN.format(joint=name)} per sample"}
        return attrs

    def write(self, path) -> None:
        """The table to ``.csv`` (one row per sample) or ``.h5`` (one dataset per column
        with its ``units``, ``description`` and, for a joint, ``joint``, ``sensors`` and
        ``frame`` attributes; the summary document as the root attribute ``imucal``),
        atomically.

        Raises
        ------
        InputError
            the suffix is neither ``.csv`` nor ``.h5``/``.hdf5``, or the file cannot be
            written.

        Examples
        --------
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"), seed=1,
        ...                        restarts=20, joints=["knee=hinge:thigh,shank"])
        >>> angles = imucal.joint_angles(imucal.load_recording("sample_data/walking.h5"), cal)
        >>> import tempfile, pathlib, pandas as pd
        >>> with tempfile.TemporaryDirectory() as tmp:
        ...     angles.write(pathlib.Path(tmp) / "knee.csv")
        ...     pd.read_csv(pathlib.Path(tmp) / "knee.csv").shape
        (3000, 3)
        """
        from .atomic import as_path, write_atomic, write_hdf5_atomic
        from .report import dumps

        path = as_path(path, "an output file name")
        suffix = path.suffix.lower()
        frame = self.to_frame()
        if suffix == ".csv":
            write_atomic(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))
        elif suffix in HDF5_SUFFIXES:
            attrs = self._column_attrs()

            def fill(f):
                # creation order (track_order): a reader lists the columns as the CSV has
                for col in frame.columns:
                    f.create_dataset(col, data=frame[col].to_numpy()).attrs.update(attrs[col])
                f.attrs["imucal"] = dumps(self.to_document())

            write_hdf5_atomic(path, fill)
        else:
            raise InputError(f"{path}: unknown table format '{path.suffix or path.name}'; "
                             "angles are written as .csv or .h5")


def _check_sign(flexion_sign) -> int | None:
    if is_bool(flexion_sign):  # (True == 1 read as "+")
        raise InputError(f"flexion sign must be auto, + or -, got {flexion_sign!r}")
    if flexion_sign in ("auto", None):
        return None
    if flexion_sign in ("+", "-", 1, -1):
        return 1 if flexion_sign in ("+", 1) else -1
    raise InputError(f"flexion sign must be auto, + or -, got {flexion_sign!r}")


def _check_reference(reference) -> float | str | None:
    """None, ``"standing"`` or a time in s as a float, else InputError."""
    if reference is None or reference == "standing":
        return reference
    try:
        if is_bool(reference):
            raise TypeError  # (True read as 1 s)
        t_ref = float(reference)
    except (TypeError, ValueError):
        raise InputError(f"reference must be None, 'standing' or a time in s, got "
                         f"{reference!r}") from None
    if not math.isfinite(t_ref):
        raise InputError(f"reference must be None, 'standing' or a time in s, got {t_ref!r}")
    return t_ref


def joint_angles(recording, calibration: Calibration | None = None, *, settings=None,
                 reference=None, flexion_sign="auto", start: float | None = None,
                 end: float | None = None, smoothing_s: float | None = None,
                 time_offset: float | None = None) -> JointAngles:
    """Flexion of every usable hinge of ``calibration`` over ``recording`` (module docstring).

    Parameters
    ----------
    recording
        The trial to measure (:class:`imucal.Recording`), with the calibration's sensors
        (found by name as :meth:`imucal.Recording.resolve` does).
    calibration
        A :class:`imucal.calibration.Calibration` (:func:`imucal.calibration.calibrate` or
        :func:`imucal.calibration.load_calibration`); None: the file of ``settings``.
    settings
        A :class:`imucal.settings.AnglesSettings` holding ``reference``,
        ``flexion_sign``, ``smoothing_s`` and ``time_offset`` instead of the keywords (not
        both), and the calibration file read when ``calibration`` is None (its
        ``tables`` are the runner's: not used here).
    reference
        What 0 deg means. None: the calibration's zero (its trial's most extended still
        period, else its most extended posture), so every trial of one mounting shares it;
        ``"standing"``: the most extended still period of this recording; a number: the
        angle at that time (s on the recording's time axis) is 0.
    flexion_sign
        ``"auto"``: decided on the calibration trial (knees spend most time near extension
        and make excursions into flexion, :func:`sign_evidence`), or on this recording
        when the calibration trial was ambiguous; ``"+"`` / ``"-"``: flexion is the
        right-handed rotation of the second segment relative to the first about the
        calibration's ``j1``/``j2`` (``+``) or the opposite (``-``).
    start, end
        Window, s on the recording's time axis.
    smoothing_s
        Fusion kernel, s (default: the calibration's).
    time_offset
        Clock offset of every hinge's second sensor in this recording, s (positive: its
        clock is late), taken as exact; None (the default): the calibration's, as the
        offset of a fixed latency persists from trial to trial. For sensors whose clocks
        are synchronised anew for each recording (``check["clock_offset_source"]`` is then
        "given for this recording").

    Returns
    -------
    JointAngles
        ``time`` (s) and, per hinge, the flexion and its 1-sigma (deg), the pure gyro
        integration, the sign and zero used, the "still fits" check and the gait cycles;
        ``to_frame()`` / ``write(path)`` give the table (``time``,
        ``<joint>_flexion_deg``, ``<joint>_flexion_sigma_deg``).

    Raises
    ------
    InputError
        ``recording`` or ``calibration`` is not a Recording / Calibration, the
        calibration has no usable hinge, a sensor it needs is missing or two of its
        sensors find one sensor of the recording, the window holds fewer than
        ``MIN_SAMPLES`` samples, ``reference`` lies outside the window, ``time_offset``
        puts the second sensors' reads wholly outside the recording, or ``reference`` /
        ``flexion_sign`` / ``time_offset`` / ``smoothing_s`` are invalid. A calibration
        that does not fit gives ``fits=False`` and a warning with the evidence, never
        silently wrong angles.
    NotIdentifiableError
        A joint centre's acceleration that never lies in the joint plane: no
        accelerometer angle corrects the gyroscopes' drift (docs/errors.md, exit 1).

    References
    ----------
    Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for gait analysis",
    Sensors 14:6891 (gyroscope angle, accelerometer angle, their fusion).

    Examples
    --------
    >>> import imucal
    >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
    ...                        restarts=20, seed=1)
    >>> walk = imucal.joint_angles(imucal.load_recording("sample_data/walking.h5"), cal)
    >>> walk.fits, list(walk.to_frame().columns)
    (True, ['time', 'knee_flexion_deg', 'knee_flexion_sigma_deg'])
    """
    from .calibration import Calibration, load_calibration
    from .recording import check_recording
    from .settings import AnglesSettings, resolve

    check_recording(recording)
    if settings is not None:
        # one settings object for the angles as for the estimators (an independent review)
        s = resolve(AnglesSettings, settings, reference=reference, flexion_sign=flexion_sign,
                    smoothing_s=smoothing_s, time_offset=time_offset)
        reference, flexion_sign = s.reference, s.flexion_sign
        smoothing_s, time_offset = s.smoothing_s, s.time_offset
        if calibration is None:
            calibration = load_calibration(s.calibration)
    if not isinstance(calibration, Calibration):
        hint = (" (load it first: imucal.load_calibration(path))"
                if isinstance(calibration, str | os.PathLike) else "")
        raise InputError(f"expected a Calibration, got {type(calibration).__name__}{hint}")
    pinned = _check_sign(flexion_sign)
    reference = _check_reference(reference)
    time_offset = check_trial_offset(time_offset)
    if smoothing_s is not None:
        smoothing_s = check_smoothing(smoothing_s)
    hinges = [j for j in calibration.hinges if j.usable and j.angle]
    if not hinges:
        raise InputError(f"{calibration.file or calibration.source}: the calibration has no "
                         "usable hinge joint (knee); nothing to measure")
    names = []
    found: dict[str, str] = {}  # sensor in this recording -> the calibration's name for it
    for jc in hinges:
        for s in jc.sensors:
            try:
                names.append(recording.resolve(s))
            except InputError as err:
                raise InputError(f"{err}; the calibration's joint '{jc.name}' needs sensor "
                                 f"'{s}'") from None
            # "left_thigh" and "right_thigh" both find a one-leg file's "thigh": both
            # knees would be read from one leg (-278 deg on the simulated walk)
            if found.setdefault(names[-1], s) != s:
                raise InputError(
                    f"{recording.source}: the calibration's sensors '{found[names[-1]]}' and "
                    f"'{s}' both find sensor '{names[-1]}' here: not the sensors it "
                    "calibrated (one leg of a two-leg calibration?); name them with --map")
    rec = recording.select(names, start, end)
    around = recording.select(names, start, end, context=True)
    if rec.n_samples < MIN_SAMPLES:
        raise InputError(f"{recording.source}: the window holds {rec.n_samples} samples; "
                         f"angles need at least {MIN_SAMPLES} (the derivative of the rates "
                         "spans 9)")
    if reference not in (None, "standing") and not rec.time[0] <= reference <= rec.time[-1]:
        raise InputError(f"{recording.source}: reference time {reference:g} s is outside the "
                         f"window measured ({rec.time[0]:g} to {rec.time[-1]:g} s)")
    if time_offset is not None and (rec.time[0] + time_offset > around.time[-1]
                                    or rec.time[-1] + time_offset < around.time[0]):
        # every read of the shank would lie beyond its samples: the fusion then found no
        # usable sample and blamed the accelerometers (a new-user trial)
        raise InputError(f"{recording.source}: time offset {time_offset:+g} s reads the "
                         f"second sensors at {rec.time[0] + time_offset:g} to "
                         f"{rec.time[-1] + time_offset:g} s, wholly outside the "
                         f"{around.time[0]:g} to {around.time[-1]:g} s recorded; give the "
                         "offset in seconds (0.015 for 15 ms)")
    joints = {}
    for jc in hinges:
        local = _given_clock(replace(jc, sensors=tuple(recording.resolve(s)
                                                       for s in jc.sensors)), time_offset)
        joints[jc.name] = _one_joint(rec, local, reference=reference, pinned=pinned,
                                     smoothing_s=smoothing_s or jc.angle["smoothing_s"],
                                     context=around)
    skipped = [f"joint '{j.name}' has no angle: its calibration {j.verdict} ("
               f"{j.reason() if j.warnings else 'no vectors'})"
               for j in calibration.hinges if all(j is not h for h in hinges)]
    return JointAngles(time=rec.time.copy(), joints=joints, source=recording.source,
                       calibration=calibration.file or calibration.source, rate=rec.rate,
                       reference=reference,
                       warnings=skipped + list(rec.warnings))


def _one_joint(rec, jc, *, reference, pinned, smoothing_s, context) -> JointAngle:
    """One hinge's flexion over ``rec`` (``reference`` checked by :func:`_check_reference`,
    ``pinned`` by :func:`_check_sign`): the fused angle, its direction and zero, the fit
    check, and its 1-sigma with what the calibration's clock offset adds."""
    ref = jc.angle
    try:
        s1, s2, sig, fus, beyond = _fused(rec, jc, smoothing_s, context)
    except NotIdentifiableError as err:
        raise NotIdentifiableError(f"{rec.source}: joint '{jc.name}': {err}; nothing "
                                   "written") from None
    raw = _on_calibration_turn(np.degrees(fus.theta), ref)
    moving = moving_part(raw, rec.rate, (s1.gyr, s2.gyr))
    evidence = sign_evidence(moving)

    def around() -> np.ndarray | None:
        """The raw angle over the samples within SIGN_AROUND_S of the window, where there
        are more (not the whole recording: a 1 s window of a 1 h walk took 15 s), without
        its still periods."""
        if context is None or context.n_samples <= rec.n_samples:
            return None
        near = context.select(list(context.sensors),
                              max(rec.time[0] - SIGN_AROUND_S, context.time[0]),
                              min(rec.time[-1] + SIGN_AROUND_S, context.time[-1]))
        try:
            n1, n2, _, wide, _ = _fused(near, jc, smoothing_s)
        except NotIdentifiableError:
            return None
        return moving_part(_on_calibration_turn(np.degrees(wide.theta), ref), near.rate,
                           (n1.gyr, n2.gyr))

    sign, source, warnings = _choose_sign(jc, moving, evidence, pinned, rec.rate, around)
    zero, more = _choose_zero(jc, raw, sign, reference, rec, (s1.gyr, s2.gyr))
    flex = sign * (raw - zero["raw_deg"])
    gyro_only = sign * np.degrees(sig.theta_gyro - sig.theta_gyro[0]) + flex[0]
    warnings = [f"calibration: {w}" for w in ref.get("warnings", [])] + warnings + more
    # the range a knee reaches is only known from an extended zero, with flexion positive:
    # not from a user's time, a pinned sign, a zero chosen for the other direction, or a
    # calibration trial without a still period (its zero is its 1st percentile, 19 deg
    # low on the sample circling: a trial that never straightens reads stance at -40)
    # (a standing trial's zero is one posture under either direction: zero_from_standing;
    # left out, a sitting "stand" read a walk -86 to -24 deg, "fits", a review)
    extended = (source != "user" and (reference == "standing" or (
        reference is None and ref["zero_time_s"] is not None
        and (sign == int(ref["flexion_sign"]) or bool(ref.get("zero_trial"))))))
    check = _fit_check(jc, ref, s1, s2, fus, rec, flex, extended, context)
    if not check["fits"]:
        warnings.append(check["message"])
    elif extended and reference is None:  # (a reference given is this recording's zero)
        warnings += _hyperextended(jc, flex)
    sigma, lagged = _sigma_with_clock(jc, fus, s2)
    if lagged:
        warnings.append(lagged)
    sigma, extrapolated = _extrapolated(jc, sigma, flex, beyond, rec.rate)
    if extrapolated:
        warnings.append(extrapolated)
    return JointAngle(jc.name, jc.sensors, flex, sigma, gyro_only, sign,
                      source, evidence, zero, check, detect_gait(flex, rec.rate), warnings)


def _choose_sign(jc, raw: np.ndarray, evidence: float, pinned: int | None, rate: float,
                 around=None) -> tuple[int, str, list[str]]:
    """(flexion sign, its ``sign_source``, warnings): pinned, the calibration trial's clear
    decision, this recording's window's (when it counts: :func:`_sign_doubt`), the
    recording's around the window (``around()``: its raw angle there, or None), else the
    calibration's guess with a warning."""
    ref = jc.angle
    if pinned is not None:
        return pinned, "user", _pinned_flexion_doubt(jc, pinned, raw, evidence, rate)
    doubt = _sign_doubt(raw, evidence, rate)
    if abs(ref["sign_evidence"]) >= SIGN_EVIDENCE_MIN:
        return int(ref["flexion_sign"]), "calibration", _contradicted_sign(
            jc, evidence, doubt)
    if doubt is None:
        return (1 if evidence >= 0 else -1), "recording", []
    # A window too short to decide (a stride's part says where in the stride it lies) is
    # one of the recording's: its samples around the window decide for it. With the demo's
    # circling calibration, 8 of 16 walking windows of 1 s read inverted, "fits" (a
    # new-user trial), as the calibration's guess was the wrong one.
    wide = None if around is None else around()
    if wide is not None:
        wide_evidence = sign_evidence(wide)
        if _sign_doubt(wide, wide_evidence, rate) is None:
            return (1 if wide_evidence >= 0 else -1), "recording around the window", []
    # Neither decides. The calibration's guess keeps its zero (chosen under that guess)
    # and gives every recording of a study the same direction, where the recordings' own
    # coin flips would not.
    return int(ref["flexion_sign"]), "calibration guess", [
        f"{jc.name}: the flexion direction is ambiguous in the calibration trial (evidence "
        f"{ref['sign_evidence']:+.2f}) and here ({doubt}); the calibration's guess is kept: "
        "pin it (flexion_sign '+' or '-') if the angles look inverted"]


def _hyperextended(jc, flex: np.ndarray) -> list[str]:
    """The warning for angles that read far beyond the calibration's extended zero
    (:data:`HYPEREXTENDED_DEG`), where the fit check passed."""
    p1 = float(np.percentile(flex, 1))
    if p1 >= -HYPEREXTENDED_DEG:
        return []
    return [f"{jc.name}: the knee reads down to {p1:.0f} deg (1st percentile), more than "
            f"{HYPEREXTENDED_DEG:g} deg beyond the calibration's straight knee: a sensor "
            "turned on its segment (about the knee axis) since the calibration shifts every "
            "angle by the turn, unseen by the fit check; or the calibration's zero was no "
            "straight stand; give a reference ('standing' or a time) where this recording "
            "has a known posture"]


def _contradicted_sign(jc, evidence: float, doubt: str | None) -> list[str]:
    """The warning for a calibration trial's clear flexion direction that this
    recording's clear evidence contradicts. The trial's is kept (a recording of sitting
    with leg extensions skews the other way as rightly as a walk skews its way), but one
    of them misleads: a trial whose rests or motion skewed it wrongly read walks as
    mirror images of the knee, with no word (an independent audit)."""
    ref = jc.angle
    if doubt is not None or (1 if evidence >= 0 else -1) == int(ref["flexion_sign"]):
        return []
    return [f"{jc.name}: the calibration trial's flexion direction (evidence "
            f"{ref['sign_evidence']:+.2f}) is the opposite of this recording's (evidence "
            f"{evidence:+.2f}); the trial's is kept: the angles may be inverted (flexion "
            "read as extension) unless this motion flexes more than it extends (sitting); "
            "pin it (flexion_sign '+' or '-') once you know which"]


def _pinned_flexion_doubt(jc, pinned: int, raw: np.ndarray, evidence: float,
                       rate: float) -> list[str]:
    """The warning for a pinned flexion sign that the calibration trial's or this
    recording's clear evidence contradicts (as a pinned j2 sign gets one): pinned the
    wrong way, the demo's walk read a mirror image of its knee, 0.3-62.5 deg, that
    "fits", with no word (a new-user trial)."""
    ref = jc.angle
    if abs(ref["sign_evidence"]) >= SIGN_EVIDENCE_MIN and int(ref["flexion_sign"]) != pinned:
        where = f"the calibration trial's (evidence {ref['sign_evidence']:+.2f})"
    elif _sign_doubt(raw, evidence, rate) is None and (1 if evidence >= 0 else -1) != pinned:
        where = f"this recording's (evidence {evidence:+.2f})"
    else:
        return []
    return [f"{jc.name}: the pinned flexion sign ({pinned:+d}) contradicts {where}: the "
            "angles may be inverted (flexion read as extension); check how the sensors sit"]


def _choose_zero(jc, raw: np.ndarray, sign: int, reference, rec,
                 gyrs) -> tuple[dict, list[str]]:
    """(the ``zero`` block: method, raw_deg, time_s, time_in; warnings) for ``reference``
    None (the calibration's zero), ``"standing"`` (this recording's most extended still
    period) or a time, s, inside the window (checked before: :func:`_check_reference`)."""
    ref = jc.angle
    if reference == "standing":
        if not still_periods(gyrs, rec.rate):
            raise InputError(f"{rec.source}: no still period of at least {STILL_MIN_S:g} s for "
                             "the zero (reference 'standing'); give a time instead")
        z, method, t = _zero(raw, sign, rec, gyrs)
        return {"method": method, "raw_deg": z, "time_s": t, "time_in": "this recording"}, []
    if reference is not None:
        i = int(np.argmin(np.abs(rec.time - reference)))
        half = max(1, int(0.1 * rec.rate))
        return {"method": "user time (mean over +-0.1 s)",
                "raw_deg": float(raw[max(0, i - half):i + half + 1].mean()),
                "time_s": reference, "time_in": "this recording"}, []
    zero = {"method": "calibration: " + ref["zero_method"], "raw_deg": ref["zero_deg"],
            "time_s": ref["zero_time_s"],
            "time_in": (f"standing trial {ref['zero_trial']}" if ref.get("zero_trial")
                        else "calibration trial")}
    # a percentile zero is no straight knee: said where a pipeline reads it (the method's
    # words alone left walks 5.7-7.1 deg low at a 1-sigma of 1 deg, "fits", no warning: a
    # new-user trial)
    level = [] if ref["zero_time_s"] is not None else [
        f"{jc.name}: 0 deg is the calibration trial's most extended posture (it has no still "
        "period), not a straight knee: every angle is low by the knee's flexion there (5-7 "
        "deg in simulated walking protocols), which the 1-sigma does not include; for "
        "absolute angles (peak flexion) give a reference ('standing' or a time), or calibrate "
        "with a moment of still standing or with a standing trial (--standing)"]
    if sign == int(ref["flexion_sign"]) or abs(ref["sign_evidence"]) >= SIGN_EVIDENCE_MIN \
            or ref.get("zero_trial"):
        # (a sign pinned against a clear calibration just negates it; a standing trial's
        # zero is the same posture under either direction: zero_from_standing)
        return zero, level
    # The calibration trial's zero is its most extended posture under the sign it guessed
    # (its evidence was weak), which is the most flexed one under this sign.
    if ref["zero_time_s"] is None:  # the 1st percentile: take the other end
        zero["raw_deg"] = ref["zero_deg"] + int(ref["flexion_sign"]) * ref["flexion_range_deg"][1]
        zero["method"] += " (with the flexion direction used here)"
        return zero, level
    return zero, [f"{jc.name}: the calibration's zero (its most extended still period) was "
                  "chosen for the opposite flexion direction; give a reference ('standing' "
                  "or a time) for a meaningful zero"]


def _sigma_with_clock(jc, fus, s2) -> tuple[np.ndarray, str | None]:
    """(per-sample 1-sigma, deg, of the fused angle with the calibration's clock offset
    carried; a warning when that offset was found but not applied)."""
    # reading the second sensor dt later than it should turns the gyro angle by about its
    # own rate about j2 times dt: the offset's 1-sigma, a fraction of a ms, is 0.1-0.3
    # deg at walking rates, as much as the fusion's own band (simulated gait, 100 ms
    # late: 8 % of the samples beyond 3 sigma without it)
    rate2 = np.degrees(np.abs(s2.gyr @ jc.j2))
    lag = unapplied_clock_offset(jc)  # (within the spread: only for the warning)
    sigma = np.hypot(np.hypot(np.degrees(fus.sigma), rate2 * clock_offset_sigma(jc)),
                     rate2 * unapplied_offset_spread(jc))
    if not lag:
        return sigma, None
    given = jc.axis["time_offset"].get("mode") == "given"
    read = jc.axis["time_offset"].get("sigma_s")
    # (with the reading's 1-sigma: "found 10 ms early" where the calibration said +-24 ms,
    # the truth 0: a new-user trial)
    within = (f" (1-sigma {1000 * read:.0f} ms)" if isinstance(read, int | float)
              and math.isfinite(read) else "")
    found = (f"the calibration's data put the second sensor's clock {abs(1000 * lag):.0f} ms"
             f"{within} {'later' if lag > 0 else 'earlier'} than the offset it was given"
             if given else
             f"the calibration read the second sensor's clock {abs(1000 * lag):.0f} ms"
             f"{within} {'late' if lag > 0 else 'early'} but did not apply it (too little "
             "gain to tell it from soft tissue)")
    return sigma, (
        f"{jc.name}: {found}; if the clocks differ by that, the angles "
        f"{'lag' if lag > 0 else 'lead'} by up to "
        f"{float(np.max(rate2, initial=0.0)) * abs(lag):.1f} deg "
        "where the knee turns fastest, which their 1-sigma carries. Calibrate with "
        + ("--time-offset auto" if given else "--time-offset SECONDS if the offset is known"))


def _sign_doubt(raw: np.ndarray, evidence: float, rate: float) -> str | None:
    """Why this recording's own sign evidence decides nothing, or None when it decides:
    too weak, too short (:data:`SIGN_MIN_S`), or an angle that hardly moves
    (:data:`SIGN_MIN_SPAN_DEG`)."""
    seconds = raw.shape[0] / rate
    if seconds < SIGN_MIN_S:
        # (``raw`` is the moving part, :func:`moving_part`: its seconds are of motion)
        return (f"evidence {evidence:+.2f} over {seconds:.2g} s of motion, less than the "
                f"{SIGN_MIN_S:g} s it needs")
    p5, p95 = np.percentile(raw, [5, 95])
    if p95 - p5 < SIGN_MIN_SPAN_DEG:
        return (f"evidence {evidence:+.2f} over an angle spanning {p95 - p5:.2g} deg, less "
                f"than the {SIGN_MIN_SPAN_DEG:g} deg it needs")
    if abs(evidence) < SIGN_EVIDENCE_MIN:
        return f"evidence {evidence:+.2f}"
    return None


def _extrapolated(jc, sigma_deg: np.ndarray, flex: np.ndarray, beyond: np.ndarray,
                  rate: float) -> tuple[np.ndarray, str | None]:
    """(1-sigma, deg, warning or None): where the clock offset reads the second sensor
    beyond its samples (``beyond``, s, from :func:`_fused`), the angle is extrapolated
    with that sensor's last rate; the 1-sigma there grows as an RMS flexion rate over
    that time would turn the angle."""
    past = beyond > 0
    if not past.any():
        return sigma_deg, None
    moving = np.gradient(flex[~past]) * rate if (~past).sum() > 1 else np.zeros(1)
    rate_rms = float(np.sqrt(np.mean(moving**2)))  # deg/s
    count, end = int(past.sum()), "last" if past[-1] else "first"
    return (np.hypot(sigma_deg, rate_rms * beyond),
            f"{jc.name}: the {end} {count} samples (up to {1000 * beyond.max():.0f} ms) read "
            f"{jc.sensors[1]} beyond its recording ({_offset_words(jc)} clock offset of "
            f"{signed_ms(clock_offset(jc), 0)} ms): extrapolated, their 1-sigma grows with the "
            f"RMS flexion rate ({rate_rms:.0f} deg/s) to {rate_rms * beyond.max():.1f} deg")


def _on_calibration_turn(raw: np.ndarray, ref: dict) -> np.ndarray:
    """``raw`` (deg) moved by the whole turns that bring its median nearest the middle of
    the calibration trial's range. The accelerometer fixes the angle only up to whole
    turns, and each recording's fusion takes the turn of its own first usable sample: a
    knee whose range straddles that turn's edge read 360 deg off on some windows (7 of 80
    simulated mountings) while its check said it fits. A knee's range is far narrower than
    a turn, so the nearest turn is the calibration trial's."""
    low, high = ref["flexion_range_deg"]
    middle = ref["zero_deg"] + int(ref["flexion_sign"]) * (low + high) / 2
    turns = np.round((middle - np.median(raw)) / 360.0)
    return raw + 360.0 * turns if np.isfinite(turns) else raw


def _beyond(value: float, limit: float, decimals: int, unit: str = "") -> str:
    """``"value > limit"`` with as many more decimals as tell the two apart: a refusal
    that reads "0.102 > 0.102" looks like a bug."""
    for more in range(6):
        a, b = number_text(value, decimals + more), number_text(limit, decimals + more)
        if a != b:
            break
    return f"{a}{unit} > {b}{unit}"


def _gravity(jc, s1, s2, rec, context) -> dict:
    """The gravity check of the calibration's axes over this window's still periods, or,
    where it has none, over the recording's within NEAR_REST_S of it (as the axis
    estimate does, :func:`imucal.rest.gravity_check_near`)."""
    if context is None or context.n_samples <= rec.n_samples:
        check = gravity_check(s1.gyr, s1.acc, s2.gyr, s2.acc, jc.j1, jc.j2, rec.rate,
                              origin=float(rec.time[0]))
        return {**check, "scope": "window" if check["periods"] else None}
    c1, c2 = context.sensor(jc.sensors[0]), context.sensor(jc.sensors[1])
    return gravity_check_near(c1.gyr, c1.acc, c2.gyr, c2.acc, jc.j1, jc.j2, rec.rate,
                              window=slice(*context.window), origin=float(context.time[0]))


def _pinned_sign_doubt(jc) -> str:
    """The first suspect of a misfit where the calibration pinned a relative sign its own
    data contradicted (its axis's warning), else "": such a knee fits no trial, and the
    message named only re-strapping, swapping or another subject (a new-user trial: a
    --j2-sign pin contradicted 663:1)."""
    from .axis import PINNED_SIGN_WARNING

    pinned = next((w for w in jc.warnings if PINNED_SIGN_WARNING in w), None)
    if pinned is None:
        return ""
    return ("the calibration's pinned j2 sign, which its own data contradicted, is the "
            "likelier cause (calibrate again without --j2-sign); else ")


def _fit_check(jc, ref, s1, s2, fus, rec, flex: np.ndarray, extended: bool,
               context=None) -> dict:
    """Does the calibration still fit this recording ``rec``? (docs/angles.md) ``flex``:
    the flexion, deg; ``extended``: its zero is an extended posture and flexion positive,
    so its range can be judged (else only its span, see ``_one_joint``); ``context``:
    ``rec``'s sensors with the samples around it, whose still periods near the window
    check the axes when it has none of its own."""
    res = hinge_residual(s1.gyr, s2.gyr, jc.j1, jc.j2)
    dis = math.degrees(fus.disagreement)
    # A calibration trial that never moved has no residual (NaN, null in its file): no
    # reference, so no evidence either way.
    ref_res, ref_dis = (math.nan if ref[k] is None else float(ref[k])
                        for k in ("hinge_residual", "acc_gyro_disagreement_deg"))
    res_lim = FIT_FACTOR * ref_res + FIT_FLOOR_RESIDUAL
    dis_lim = min(FIT_FACTOR * ref_dis + FIT_FLOOR_DEG, FIT_MAX_DEG)
    bad = []
    if res > res_lim:  # NaN (never moved, here or there) is no evidence against
        bad.append(f"hinge residual {_beyond(res, res_lim, 3)} (calibration trial "
                   f"{number_text(ref_res, 3)})")
    gravity = _gravity(jc, s1, s2, rec, context)
    if gravity["consistent"] is False:
        worst = gravity["max_mismatch_deg"]
        where = (" (outside the window, which has no rest of its own)"
                 if gravity["scope"] == "around the window" else "")
        bad.append(f"at rest{where} the axis makes angles with the vertical that differ by "
                   f"{worst:.0f} deg between the sensors (one hinge axis: within "
                   f"{gravity['max_allowed_deg']:g} deg)")
    if dis > dis_lim:
        bad.append(f"acc- vs gyro-angle disagreement {_beyond(dis, dis_lim, 2, ' deg')} "
                   f"(calibration trial {number_text(ref_dis, 2)} deg)")
    low, high = PLAUSIBLE_FLEXION_DEG
    outside = float(np.mean((flex < low) | (flex > high))) if extended else 0.0
    p1, p99 = np.percentile(flex, [1, 99])
    if outside > IMPLAUSIBLE_SHARE:
        bad.append(f"the flexion spans {np.min(flex):.0f} to {np.max(flex):.0f} deg, outside "
                   f"the {low:g} to {high:g} deg a hinge of the body reaches from its "
                   f"extended zero on {outside:.0%} of the samples")
    elif p99 - p1 > PLAUSIBLE_SPAN_DEG:  # whatever the zero: no knee moves that far
        bad.append(f"the flexion spans {p1:.0f} to {p99:.0f} deg (1st to 99th percentile), "
                   f"more than the {PLAUSIBLE_SPAN_DEG:g} deg a hinge of the body moves "
                   "through")
    unidentified = jc.verdict == "not identifiable"
    out = {"fits": not bad and not unidentified, "calibration_verdict": jc.verdict,
           "clock_offset_s": clock_offset(jc),
           "clock_offset_source": clock_offset_source(jc),
           "hinge_residual": res, "hinge_residual_limit": res_lim,
           "calibration_hinge_residual": ref["hinge_residual"],
           "acc_gyro_disagreement_deg": dis, "acc_gyro_disagreement_limit_deg": dis_lim,
           "calibration_acc_gyro_disagreement_deg": ref["acc_gyro_disagreement_deg"],
           "gravity_mismatch_deg": gravity["max_mismatch_deg"],
           "gravity_scope": gravity["scope"],
           "implausible_flexion_share": outside,
           "tolerance": f"{FIT_FACTOR:g} x the calibration trial's value + "
                        f"{FIT_FLOOR_RESIDUAL:g} (residual) / {FIT_FLOOR_DEG:g} deg (at most "
                        f"{FIT_MAX_DEG:g} deg)"}
    if bad:
        # a clock offset that changed between trials reads as a misfit too (a shank 10 ms
        # later than in the calibration trial: disagreement 5 deg over a 2.9 deg limit),
        # and nothing had named it (a new-user trial)
        mounting = "sensors re-strapped, swapped or another subject"
        clocks = (f"the two sensors' clocks offset otherwise than {_offset_words(jc)} "
                  f"{signed_ms(out['clock_offset_s'], 0)} ms")
        # the likelier first: a hinge residual beyond its limit says the axes are not this
        # joint's; within it, a clock shift or another motion spoils only the acc angle (a
        # re-strapped subject and a 5 ms shift got one list: a new-user trial)
        first, second = (mounting, clocks) if res > res_lim else (clocks, mounting)
        out["message"] = (f"{jc.name}: the calibration does not fit this recording ("
                          + "; ".join(bad) + "): " + _pinned_sign_doubt(jc)
                          + f"{first}, {second}, or a motion far from the calibration "
                          "trial's (a trial of small steady motions, such as circling, "
                          "leaves a walk little room)? "
                          + ("give this recording's (--time-offset SECONDS) or calibrate "
                             if out["clock_offset_source"] == "calibration" else
                             "check the offset given (--time-offset), or calibrate ")
                          + "again; these angles are not trustworthy")
    if unidentified:  # first: whatever else is wrong, the axes were never found
        out["message"] = (f"{jc.name}: the calibration could not identify this joint ("
                          f"{jc.reason()}): these angles are not trustworthy; calibrate again on "
                          "a trial that moves it more"
                          + ("" if not bad else "; " + out["message"]))
    return out
