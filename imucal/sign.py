"""Which way j2 points relative to j1: the hinge axes' relative sign (docs/method.md).

Eq. (1) cannot see the signs of ``j1`` and ``j2``. Only with both pointing the same
physical way is ``j2.g2 - j1.g1`` the flexion rate; with one flipped, integrating it
gives the flexion plus twice the first segment's rotation about the axis. Three tests
decide, each from different evidence, because no single one holds on every motion:

``plane``
    Integration-free (Sec. III-C; docs/method.md, "Relative sign"): the angle between the two
    joint-plane projections of the rates changes at the flexion rate only with the
    right sign. Decisive on clean simulated motion; on real gait soft tissue and
    non-hinge motion blur it (evidence 1.0-1.2 on the shared recording).
``range``
    The flexion angle, integrated from ``j2.g2 - j1.g1`` over blocks of
    ``RANGE_BLOCK_S`` with a linear trend (gyroscope bias) removed, must stay within
    what a knee can do. With the wrong sign the thigh's rotation about the axis enters
    twice (on the shared recording 190-210 deg of "flexion" against 60-70 deg). Only a
    hypothesis that leaves the plausible range is evidence; when both stay within it
    (a squat, where thigh and shank counter-rotate, can make the wrong sign look
    smaller) the test abstains.
``acc``
    With accelerometers: the joint centre's acceleration ``a_i - Gamma_gi(o_i)`` is one
    vector, and a hinge rotation keeps its component along the axis, so
    ``j1.(a1 - Gamma_g1(o1)) = j2.(a2 - Gamma_g2(o2))`` at every instant with the right
    sign. The condition is linear in (o1, o2), so each hypothesis is one linear least
    squares; the evidence is the ratio of their RMS residuals. Weak when the axis stays
    horizontal without sideways acceleration (then both fit).

Each test gives a sign for ``j2`` and an evidence ratio (wrong hypothesis' error over
the right one's, >= 1; 1 = no information). They are combined by adding signed log
evidences: tests that abstain add nothing, and a test that clearly contradicts the
others is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .preprocess import derivative, lowpass

#: Evidence ratios are capped here (a perfect fit would divide by zero).
MAX_EVIDENCE = 1e6
#: A knee flexes through at most about 160 deg (hyperextension to deep flexion); a
#: relative angle spanning more within one block is not a knee's.
MAX_KNEE_SPAN_DEG = 170.0
#: Blocks of this length bound the drift of a slowly changing gyroscope bias (a constant
#: bias is removed with each block's linear trend), s.
RANGE_BLOCK_S = 60.0
#: The acc test uses at most this many samples (evenly spaced): six unknowns.
ACC_MAX_SAMPLES = 20000
#: One test contradicts the decision when its own evidence for the other sign exceeds
#: this ratio.
CONTRADICTION_EVIDENCE = 1.5


@dataclass(frozen=True)
class SignTest:
    """One test's verdict: ``sign`` to apply to j2 (+1 or -1), ``evidence`` >= 1 (ratio
    of the wrong hypothesis' error to the right one's; 1 = no information), and
    ``detail`` with the numbers behind it."""

    sign: float
    evidence: float
    detail: dict

    def report(self, applied: float) -> dict:
        """This test as reported in a result's ``sign_tests``, for the sign finally
        ``applied`` to j2 (+1 or -1).

        Returns
        -------
        report : dict
            JSON-ready: ``evidence`` (ratio >= 1), ``favours_reported`` (whether this
            test's evidence is above 1 for the sign applied) and each ``detail`` entry;
            a pair (values for +j2, -j2 of the tested axes) becomes
            ``<name>_reported`` / ``<name>_flipped`` for the reported j2.
        """
        out = {"evidence": self.evidence,
               "favours_reported": bool(self.evidence > 1.0 and self.sign == applied)}
        for name, value in self.detail.items():
            if isinstance(value, tuple):
                first, second = value if applied > 0 else value[::-1]
                out[f"{name}_reported"], out[f"{name}_flipped"] = first, second
            else:
                out[name] = value
        return out


@dataclass(frozen=True)
class SignDecision:
    """Combined decision: ``sign`` for j2, the combined ``evidence`` ratio (the product
    of the tests' evidence for the chosen sign over the evidence against it), each
    test's :class:`SignTest` and the names of tests that contradict the decision."""

    sign: float
    evidence: float
    tests: dict
    contradicting: list


def decide_relative_sign(gyr1, gyr2, j1, j2, rate, acc1=None, acc2=None, *,
                         cutoff: float, window: slice) -> SignDecision:
    """Run the sign tests on the low-passed (``cutoff`` Hz) signals inside ``window``.

    ``gyr*`` rad/s, ``acc*`` m/s^2 (N, 3), full recording sampled at ``rate`` Hz (the
    filter runs on the whole signal, then the window is cut); ``j1``, ``j2`` unit (3,),
    each in its sensor's frame.

    Returns
    -------
    decision : SignDecision
        :func:`combine` of the ``plane`` and ``range`` tests and, with both ``acc1`` and
        ``acc2``, the ``acc`` test: the sign to apply to ``j2`` and its evidence.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA,
    Sec. II-A (eq. 1 is blind to the axes' signs) and III-C (the alignment check from
    the joint-plane projections).
    """
    signals = [gyr1, gyr2] + ([acc1, acc2] if acc1 is not None and acc2 is not None else [])
    # one filter call for all channels (each is filtered on its own): the call's fixed
    # cost (the filter's initial conditions) is that of filtering several channels
    f1, f2, *acc = np.split(lowpass(np.concatenate(signals, axis=1), rate, cutoff),
                            len(signals), axis=1)
    tests = {
        "plane": plane_test(f1[window], f2[window], j1, j2, rate),
        "range": range_test(f1[window], f2[window], j1, j2, rate),
    }
    if acc:
        parts = [(f[window], derivative(f, rate)[window], a[window])
                 for f, a in ((f1, acc[0]), (f2, acc[1]))]
        tests["acc"] = acc_test(*parts[0], *parts[1], j1, j2)
    return combine(tests)


def combine(tests: dict) -> SignDecision:
    """Add the tests' signed log evidences; see the module docstring.

    Returns
    -------
    decision : SignDecision
        ``sign`` +1.0 where the sum is >= 0, else -1.0; ``evidence`` exp(|sum|), at most
        ``MAX_EVIDENCE``; ``tests`` as given; ``contradicting``, the names of tests for
        the other sign with evidence >= ``CONTRADICTION_EVIDENCE``.
    """
    score = sum(t.sign * np.log(t.evidence) for t in tests.values())
    sign = 1.0 if score >= 0 else -1.0
    contradicting = [name for name, t in tests.items()
                     if t.sign != sign and t.evidence >= CONTRADICTION_EVIDENCE]
    evidence = float(min(np.exp(abs(score)), MAX_EVIDENCE))
    return SignDecision(sign=sign, evidence=evidence, tests=tests, contradicting=contradicting)


def plane_test(gyr1, gyr2, j1, j2, rate) -> SignTest:
    """The integration-free test: project both rates into their joint planes and follow
    each projection's angle alpha_i in a basis (u_i, j_i x u_i) of its plane. With aligned
    axes d/dt (alpha1 - alpha2) = j2.g2 - j1.g1 at every sample; with one axis flipped one
    trace is mirrored. Errors are weighted by the projections' lengths (the angle of a
    short projection is noise).

    ``gyr1``, ``gyr2`` (N, 3) rad/s at ``rate`` Hz; ``j1``, ``j2`` unit (3,).

    Returns
    -------
    test : SignTest
        The sign with the smaller weighted angle error, evidence the ratio of the two
        errors (1, sign +1, when both are 0: no motion); ``detail["weighted_error_rad"]``
        (for +j2, -j2).

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA,
    Sec. III-C, eq. (6) and Fig. 4 (with misaligned axes one trace is mirrored).
    """
    dt = 1.0 / rate
    a1, len1 = _plane_angle(gyr1, j1)
    # flipping j flips the plane's second basis vector (perpendicular(-j) = perpendicular(j)):
    # the angle changes sign, the length stays
    angle2, len2 = _plane_angle(gyr2, j2)
    errors = []
    for s in (1.0, -1.0):
        a2 = s * angle2
        rel = np.diff(a1 - a2)
        rel = (rel + np.pi) % (2 * np.pi) - np.pi
        thetadot = gyr2 @ (s * j2) - gyr1 @ j1
        predicted = 0.5 * (thetadot[1:] + thetadot[:-1]) * dt
        mismatch = np.abs((rel - predicted + np.pi) % (2 * np.pi) - np.pi)
        w = np.minimum(len1, len2)
        w = 0.5 * (w[1:] + w[:-1])
        errors.append(float(np.sum(w * mismatch)))
    return _verdict(errors, {"weighted_error_rad": tuple(errors)})


def range_test(gyr1, gyr2, j1, j2, rate) -> SignTest:
    """The integrated relative angle must stay within a knee's range (module docstring).

    ``gyr1``, ``gyr2`` (N, 3) rad/s at ``rate`` Hz; ``j1``, ``j2`` unit (3,).

    Returns
    -------
    test : SignTest
        Evidence 1 (sign +1) unless exactly one hypothesis spans more than
        ``MAX_KNEE_SPAN_DEG`` within a block; then the sign that stays within it, with
        the ratio of the spans (wrong over right) as evidence. ``detail``: ``span_deg``
        (for +j2, -j2, deg) and ``max_knee_span_deg``.
    """
    spans = [_largest_span_deg(gyr2 @ (s * j2) - gyr1 @ j1, rate) for s in (1.0, -1.0)]
    detail = {"span_deg": tuple(spans), "max_knee_span_deg": MAX_KNEE_SPAN_DEG}
    out = [s > MAX_KNEE_SPAN_DEG for s in spans]
    if out[0] == out[1]:  # both plausible, or both not: no information
        return SignTest(1.0, 1.0, detail)
    right = 1 if out[0] else 0
    evidence = min(spans[1 - right] / max(spans[right], 1e-9), MAX_EVIDENCE)
    return SignTest((1.0, -1.0)[right], float(max(evidence, 1.0)), detail)


def acc_test(g1, gdot1, a1, g2, gdot2, a2, j1, j2) -> SignTest:
    """The joint centre's acceleration along the axis is the same in both frames.

    ``g*`` (N, 3) rad/s, ``gdot*`` (N, 3) rad/s^2 and ``a*`` (N, 3) m/s^2 of each sensor;
    ``j1``, ``j2`` unit (3,). At most ``ACC_MAX_SAMPLES`` evenly spaced samples are used.

    Returns
    -------
    test : SignTest
        The sign whose linear least-squares fit of (o1, o2) leaves the smaller RMS
        residual, evidence the ratio of the two; ``detail["rms_residual_m_s2"]`` (for
        +j2, -j2). Evidence 1, sign +1, when both residuals are 0 or the fit fails
        (residuals None then).

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA,
    Sec. II-B, eq. (3) (Gamma_g, the joint centre's acceleration).
    """
    n = g1.shape[0]
    pick = np.linspace(0, n - 1, min(n, ACC_MAX_SAMPLES)).astype(int)
    rows1 = _axis_row(g1[pick], gdot1[pick], j1)
    rows2 = _axis_row(g2[pick], gdot2[pick], j2)
    # j1.a1 - s j2.a2 = j1^T Gamma1 o1 - s j2^T Gamma2 o2, linear in (o1, o2); the sign s
    # of the second block of columns leaves their span, so the residual, alike: both
    # signs are one least-squares problem with two right-hand sides
    y1, y2 = a1[pick] @ j1, a2[pick] @ j2
    ys = np.stack([y1 - s * y2 for s in (1.0, -1.0)], axis=1)
    design = np.concatenate([rows1, rows2], axis=1)
    try:
        o, *_ = np.linalg.lstsq(design, ys, rcond=None)
        e = ys - design @ o
        errors = [float(v) for v in np.sqrt(np.mean(e * e, axis=0))]
    except np.linalg.LinAlgError:
        errors = [float("nan")] * 2
    if not np.isfinite(errors).all():
        return SignTest(1.0, 1.0, {"rms_residual_m_s2": (None, None)})
    return _verdict(errors, {"rms_residual_m_s2": tuple(errors)})


def _axis_row(g, gdot, j):
    """(N, 3) rows j^T Gamma_g with Gamma_g = [g]x^2 + [gdot]x, so j.Gamma_g(o) = row . o."""
    # j.(g x (g x o)) = (g.j)(g.o) - |g|^2 (j.o) and j.(gdot x o) = (j x gdot).o
    gj = g @ j
    gg = np.sum(g * g, axis=1)
    return gj[:, None] * g - gg[:, None] * j[None, :] + np.cross(j[None, :], gdot)


def _largest_span_deg(thetadot, rate) -> float:
    """Largest span (max - min) of the integrated ``thetadot`` (rad/s, low-passed: an
    integral of impact spikes stays small) over blocks of ``RANGE_BLOCK_S`` with a linear
    trend removed from each, deg."""
    n = thetadot.shape[0]
    theta = np.cumsum(thetadot) / rate
    # equal blocks of about RANGE_BLOCK_S (at most a few hundred on a long recording)
    count = max(1, int(round(n / (RANGE_BLOCK_S * rate))))
    spans = []
    for part in np.array_split(theta, count):
        if part.size > 2:  # remove the least-squares line (closed form)
            t = np.arange(part.size) - (part.size - 1) / 2
            part = part - part.mean() - t * (t @ part) / (t @ t)
        spans.append(float(np.degrees(np.ptp(part))))
    return max(spans)


def _verdict(errors, detail) -> SignTest:
    right = int(np.argmin(errors))
    wrong = errors[1 - right]
    if wrong <= 0:  # nothing to compare: no motion
        return SignTest(1.0, 1.0, detail)
    evidence = min(wrong / max(errors[right], 1e-300), MAX_EVIDENCE)
    return SignTest((1.0, -1.0)[right], float(evidence), detail)


def _plane_angle(g: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = perpendicular(j)
    w = np.cross(j, u)
    x, y = g @ u, g @ w
    return np.arctan2(y, x), np.hypot(x, y)


def perpendicular(j: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each unit ``j`` (..., 3), smooth away from axes:
    Gram-Schmidt of the coordinate axis least aligned with ``j``.

    Returns
    -------
    u : ndarray
        (..., 3) float64, unit, perpendicular to ``j``; the same for ``j`` and ``-j``.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.sign import perpendicular
    >>> perpendicular(np.array([0.0, 0.0, 1.0]))
    array([1., 0., 0.])
    >>> perpendicular(np.array([[0.6, 0.8, 0.0], [1.0, 0.0, 0.0]]))
    array([[0., 0., 1.],
           [0., 1., 0.]])
    """
    j = np.asarray(j, dtype=np.float64)
    helper = (np.abs(j).argmin(axis=-1)[..., None] == np.arange(3)).astype(np.float64)
    u = helper - np.sum(helper * j, axis=-1, keepdims=True) * j
    return u / np.sqrt(np.sum(u * u, axis=-1, keepdims=True))
