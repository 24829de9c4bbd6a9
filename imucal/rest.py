"""Still periods, and what gravity says about a hinge axis while the leg rests.

At rest an accelerometer reads gravity alone (specific force, +9.81 m/s^2 upward). A
hinge axis is one physical line, so at every still instant it makes the same angle with
the vertical seen from either segment, whatever the posture (standing, sitting, lying)::

    angle(j1, a1) = angle(j2, a2)        while both sensors rest

with ``j1``, ``j2`` pointing the same physical way. Eq. (1) never uses gravity, so this
is an independent check of an estimated axis pair. On the shared real recording, 0-55 s,
the knees' estimated axes make 12 and 5 deg with the vertical while the person stands,
but 85 and 4 deg while they sit (thighs horizontal, shanks vertical): no single line does
that, so those axes are not the knee's flexion axis (docs/real-data.md).
"""

from __future__ import annotations

import numpy as np

from .preprocess import lowpass
from .sensor_checks import ACC_UNITS

#: Both sensors turn slower than this (after a 2 Hz low-pass) in a still period, rad/s.
STILL_RATE = 0.1
#: Shortest still period, s.
STILL_MIN_S = 1.0
#: At rest the accelerometer's magnitude is within this fraction of its median over the
#: still periods (gravity alone; a sensor that accelerates is not at rest).
GRAVITY_TOLERANCE = 0.05
#: Largest difference of the axis's angle to the vertical between the two sensors that
#: one physical axis can show, deg: sensor noise and soft tissue at rest move each
#: angle by a degree or two, and an axis within its few-degree uncertainty by as much.
MAX_MISMATCH_DEG = 20.0
#: 1 g, m/s^2 (standard gravity, the one value imucal uses for it), and how far local
#: gravity strays from it (9.78 at the equator to 9.83 at the poles, less with height):
#: what a resting accelerometer should read.
GRAVITY_M_S2 = ACC_UNITS["g"]
LOCAL_GRAVITY_SPREAD_M_S2 = 0.03


def norm_at_rest(gyr, acc, rate: float) -> float | None:
    """What one sensor's accelerometer reads at rest: ``gyr`` (N, 3) rad/s, ``acc`` (N, 3)
    m/s^2, ``rate`` Hz. An exact accelerometer reads 1 g there; an offset or scale error
    shows along gravity.

    Returns
    -------
    norm : float or None
        m/s^2: the median over the sensor's own still periods (:func:`still_periods` of
        ``gyr`` alone) of the magnitude of its mean specific force in each; None without
        a still period.
    """
    periods = still_periods([gyr], rate)
    if not periods:
        return None
    acc = np.asarray(acc, float)
    return float(np.median([np.linalg.norm(acc[a:b].mean(axis=0)) for a, b in periods]))


def still_periods(gyrs, rate: float, min_s: float = STILL_MIN_S) -> list[tuple[int, int]]:
    """Still periods: where every sensor in ``gyrs`` (each (N, 3), rad/s, sampled at
    ``rate`` Hz) turns slower than :data:`STILL_RATE` (after a low-pass at 2 Hz, or 0.4 x
    ``rate`` below 5 Hz, so noise does not break them) for at least ``min_s`` s.

    Returns
    -------
    periods : list of (int, int)
        Sample index runs ``[i0, i1)`` in time order; empty when there is none.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.rest import still_periods
    >>> gyr = np.zeros((500, 3)); gyr[200:300, 0] = 2.0  # rad/s, 100 Hz: still, turn, still
    >>> still_periods([gyr], 100.0)  # the low-pass widens the turn a little
    [(0, 186), (314, 500)]
    """
    moving = np.zeros(np.asarray(gyrs[0]).shape[0], dtype=bool)
    for g in gyrs:
        speed = np.linalg.norm(lowpass(np.asarray(g, float), rate, min(2.0, 0.4 * rate)),
                               axis=1)
        moving |= speed > STILL_RATE
    edges = np.diff(np.concatenate([[1], moving.astype(np.int8), [1]]))
    starts, stops = np.flatnonzero(edges == -1), np.flatnonzero(edges == 1)
    need = int(round(min_s * rate))
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True) if b - a >= need]


def gravity_check(gyr1, acc1, gyr2, acc2, j1, j2, rate: float, *,
                  window: slice | None = None, origin: float = 0.0) -> dict:
    """Compare the axis's angle to the vertical in both sensors over every still period.

    Parameters
    ----------
    gyr1, acc1, gyr2, acc2
        (N, 3) rates (rad/s) and specific forces (m/s^2) of the two sensors.
    j1, j2
        (3,) unit axis in each sensor's frame, pointing the same physical way.
    rate
        Sample rate, Hz.
    window
        Only still periods inside this slice of samples count (None: all).
    origin
        Time of the first sample given, s on the recording's time axis (the periods'
        times are on that axis).

    Returns
    -------
    check : dict
        ``periods``: one entry per still period whose two accelerometer magnitudes are
        within :data:`GRAVITY_TOLERANCE` of their medians (``start_s``, ``end_s``, s;
        ``angle1_deg``, ``angle2_deg``: the axis's angle to the upward vertical in each
        sensor, deg; and ``mismatch_deg``, their difference); ``max_mismatch_deg`` (None
        without still periods), ``consistent`` (None without still periods, else whether
        every mismatch is within :data:`MAX_MISMATCH_DEG`) and ``max_allowed_deg``
        (:data:`MAX_MISMATCH_DEG`).
    """
    g1, a1, g2, a2 = (np.asarray(x, float) for x in (gyr1, acc1, gyr2, acc2))
    if window is not None:
        g1, a1, g2, a2 = g1[window], a1[window], g2[window], a2[window]
    t0 = origin + (0.0 if window is None or window.start is None else window.start / rate)
    periods = still_periods((g1, g2), rate)
    rows = []
    for i0, i1 in periods:
        m1, m2 = a1[i0:i1].mean(axis=0), a2[i0:i1].mean(axis=0)
        n1, n2 = np.linalg.norm(m1), np.linalg.norm(m2)
        if min(n1, n2) <= 0 or not np.isfinite(n1 * n2):
            continue
        c1 = float(np.clip(m1 @ j1 / n1, -1.0, 1.0))
        c2 = float(np.clip(m2 @ j2 / n2, -1.0, 1.0))
        e1, e2 = np.degrees(np.arccos(c1)), np.degrees(np.arccos(c2))
        rows.append({"start_s": t0 + i0 / rate, "end_s": t0 + i1 / rate,
                     "angle1_deg": float(e1), "angle2_deg": float(e2),
                     "mismatch_deg": float(abs(e1 - e2)), "gravity": (n1, n2)})
    if rows:
        # a sensor that accelerates steadily is not at rest: keep the periods whose
        # magnitudes are gravity's
        ref = np.median([r["gravity"] for r in rows], axis=0)
        rows = [r for r in rows
                if np.all(np.abs(np.array(r["gravity"]) / ref - 1) <= GRAVITY_TOLERANCE)]
    for r in rows:
        del r["gravity"]
    worst = max((r["mismatch_deg"] for r in rows), default=None)
    return {"periods": rows, "max_mismatch_deg": worst,
            "consistent": None if worst is None else bool(worst <= MAX_MISMATCH_DEG),
            "max_allowed_deg": MAX_MISMATCH_DEG}


#: s: a window without a still period of its own is checked against those this close to
#: it (:func:`gravity_check_near`); farther away the sensors may have been re-strapped.
NEAR_REST_S = 60.0


def gravity_check_near(gyr1, acc1, gyr2, acc2, j1, j2, rate: float, *, window: slice,
                       origin: float = 0.0) -> dict:
    """:func:`gravity_check` over the still periods of ``window`` (a slice of the samples
    given) or, where it has none, over those within :data:`NEAR_REST_S` of it (the same
    mounting assumed): 16 of 20 walking windows of 10-20 s of the real recording gave knee
    axes `use with care` that its rests outside them put 40-89 deg beyond the limit (a
    real-data audit).

    Returns
    -------
    check : dict
        :func:`gravity_check`'s, with ``scope``: ``"window"``, ``"around the window"`` or
        None (no still period in either).
    """
    args = (gyr1, acc1, gyr2, acc2, j1, j2, rate)
    check = gravity_check(*args, window=window, origin=origin)
    if check["periods"]:
        return {**check, "scope": "window"}
    near = int(round(NEAR_REST_S * rate))
    start = 0 if window.start is None else window.start
    stop = len(gyr1) if window.stop is None else window.stop
    around = slice(max(0, start - near), min(len(gyr1), stop + near))
    nearby = gravity_check(*args, window=around, origin=origin)
    return {**nearby, "scope": "around the window" if nearby["periods"] else None}


def gravity_warning(check: dict, what: str = "the axis") -> str | None:
    """The reason for a failed :func:`gravity_check` ``check``, with its evidence (it
    refuses the axis, :func:`imucal.estimate_axis`; a warning where another reason refuses
    it first). ``what`` names the axis in the text.

    Returns
    -------
    reason : str or None
        The worst still period's times (s) and the axis's angles to the vertical in both
        sensors (deg); None if the check passed or could not be made (``consistent`` not
        False).
    """
    if check["consistent"] is not False:
        return None
    worst = max(check["periods"], key=lambda r: r["mismatch_deg"])
    # (a window without a rest of its own is checked against the recording's rests)
    outside = (" (outside the window, which has no rest of its own: unless the sensors "
               "were re-strapped or set down there, which cutting the recording or --force "
               "gets past)" if check.get("scope") == "around the window" else "")
    return (f"{what} is not one physical line: while the sensors rest at "
            f"{worst['start_s']:.0f}-{worst['end_s']:.0f} s{outside} it makes "
            f"{worst['angle1_deg']:.0f} deg with the vertical in the first sensor but "
            f"{worst['angle2_deg']:.0f} deg in the second (one hinge axis makes the same "
            f"angle in both, within {check['max_allowed_deg']:g} deg): the axes are not "
            "the joint's, or the recording holds too little motion about it")
