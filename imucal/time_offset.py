"""Time offset between two sensors' clocks, found from the kinematic constraint itself.

Wireless sensors timestamp with their own clocks; even "synchronised" exports can be
tens of milliseconds apart. Eq. (1) and eq. (3) compare the two sensors at the same
instant, so an offset breaks them: 20 ms wrecks a joint centre and moves a knee axis by
degrees. Both constraints hold only at the right relative shift ``delta``::

    |g1(t) x j1| = |g2(t + delta) x j2|          (hinge)
    |a1(t) - Gamma_1(o1)| = |(a2 - Gamma_2(o2))(t + delta)|   (joint centre)

``delta`` > 0 means the second sensor's clock is late: its samples show the motion
``delta`` seconds after the first sensor's do, so its signal is read at ``t + delta``.
The cost over ``delta`` is smooth near its minimum: a coarse grid over +-``search``, then
one-sample steps around its lowest point find the basin, and a least-squares parabola
through candidates 2 ms apart, recentred until they straddle its vertex, gives the
minimum to a fraction of a sample (:func:`estimate_offset`; docs/method.md, "Clock
offsets between the two sensors").
The profile leaves out samples within the search of the recording's ends
(:func:`profile_samples`). The uncertainty is twice the delete-one-block jackknife over
contiguous time blocks, as for the estimates themselves
(:func:`imucal.quality.block_masks`; the factor is measured, see ``SIGMA_SCALE``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import make_interp_spline

from .errors import InputError, signed_ms
from .quality import block_masks, is_still, jackknife_sigma, refresh_uncertainty
from .settings import OFFSET_SEARCH_S

#: The profile refits use about this many of the samples and this many plain
#: Gauss-Newton steps from the first estimate; both estimators. An offset of tens of
#: milliseconds moves a joint centre far (hundreds of mm for 20 ms): with 2 steps the
#: refits near the right offset had not converged and the simulated ankle's offset came
#: out 0.5-0.9 ms early (40-200 Hz); from 4 steps on it does not move.
OFFSET_SAMPLES = 1500
OFFSET_STEPS = 5
#: A shift also lowers the residual a little where the model is wrong rather than the
#: clocks (soft tissue lags the bone; a knee is no perfect hinge): on the shared real
#: recording the knees' best shifts differ between 0-55 s and 55-100 s and between eq. (1)
#: and eq. (3), which no clock does, at cost ratios of at most 1.50 (the right knee's
#: centre, 55-100 s); on simulated soft tissue without an offset (1 deg / 2 mm and 2 deg /
#: 3 mm, 40-200 Hz, seeds 1-8) the knee axes' best shifts reach 1.57 (one seed; the next
#: 1.49). A real 20 ms offset on simulated circling, walking, gait and the protocol gives
#: 1.5-3 on the noisiest (circling at 40 Hz) and 2.6-90 otherwise. An offset is applied
#: only from this ratio on.
MIN_COST_RATIO = 1.6
#: A profile falling to the end of the search by at least this cost ratio makes the
#: result not identifiable (:func:`refused_at_edge`).
EDGE_REFUSAL_RATIO = 2.0
#: A best shift this large, clear of its 1-sigma but not applied, is reported as a warning.
SUSPICIOUS_S = 0.01
#: The coarse pass reads one of this many of the profile's samples; a second coarse
#: minimum within this share of the lowest is looked at on every sample too.
COARSE_THIN = 2
COARSE_TIE = 0.1
#: Grid step of the first pass over the search range, s (at least one sample). The
#: profile's dip can be narrow: on simulated gait with soft tissue, the foot's 20 ms was a
#: dip from 1.6 to 0.45 m/s^2 between -40 and 0 ms, which a 40 ms step (4 samples at
#: 100 Hz) stepped over to a shallow minimum at +49 ms (a new-user trial).
COARSE_STEP_S = 0.02
#: An estimated offset is applied when it exceeds both this fraction of a sample and
#: twice its own 1-sigma: a smaller one changes nothing the estimates could resolve.
MIN_APPLIED_SAMPLES = 0.25
#: The sub-sample pass of :func:`estimate_offset`: this many candidates this far apart,
#: s, around the one-sample grid's minimum (spanning +-4 ms: well inside the +-10 ms or
#: so over which the profile is a parabola).
FINE_POINTS = 5
FINE_STEP_S = 0.002
FINE_SPAN_S = FINE_STEP_S * (FINE_POINTS // 2)
#: At most this many sub-sample passes, each recentred on the last one's vertex.
FINE_PASSES = 4
#: A delay within this many samples of a whole number of them is read as that shift
#: (:func:`delayed`): the band-limited delay by whole samples is exactly a shift.
WHOLE_SAMPLE_TOLERANCE = 1e-9
#: The offset's reported 1-sigma is the delete-one-block jackknife's times this. The
#: jackknife leaves the refitted estimates at their all-sample values and has only 9
#: degrees of freedom: on 80 simulated 20 ms offsets (knee and ankle, 40-200 Hz, seeds
#: 1-8, docs/accuracy.md) the errors' RMS was 1.5 jackknife sigmas and the largest 4.3,
#: with no bias left (mean error -0.02 ms knee, +0.01 ms ankle); times 2, every error
#: is within 2.2 sigma.
SIGMA_SCALE = 2.0
#: The estimate's sensitivity to the offset: refits this far, s, either side of it.
SENSITIVITY_STEP_S = 0.002
#: An applied offset's choice enters the uncertainty as the estimate's move from offset
#: 0, capped at this many times the fit's model-error term (:func:`fit_with_offset`).
#: Simulated, clocks in sync, gait with soft tissue 1 deg / 2 mm (seeds 1-40): offsets
#: of -178 to +68 ms were applied in 8 fits at cost ratios 1.6-4.8 (as high as a real
#: 20 ms offset's), moving the axes 1-9 deg, and 2 ended "good" beyond 3 sigma; with the
#: move capped at 3 x model none did (1 at 2, 2 at 1), and with shank clocks 20 ms late
#: the share within 3 sigma rose from 0.93 to 0.97-1.00 (gait, 0.5-2 deg). Clean fits,
#: 20 ms late (circling, gait, protocol; 40 seeds each): model terms of at most 0.36 deg,
#: no verdict changes; without the cap, every clean circling fit lost its "good".
OFFSET_MODEL_CAP = 3.0
#: An offset found but not applied whose refit moves the estimate by more than this many
#: of its 1-sigma makes the result "use with care" (:func:`_unapplied_move_warning`).
UNAPPLIED_MOVE_SIGMAS = 3.0
#: An applied offset is followed (:func:`_follow`) at most this many times, while the
#: profile around the fit at it moves it by more than its 1-sigma and ``FOLLOW_STEP_S``.
MAX_FOLLOW = 3
FOLLOW_STEP_S = 0.002
#: How :func:`check_given`'s warning begins.
GIVEN_WARNING = "the clock offset given"


def refusal_reason(reason: str, warnings) -> str:
    """A refusal's ``reason`` for its one line, led by a contradicted given clock offset
    among the estimate's other ``warnings``: a wrong ``--time-offset`` spoils the fit, and
    the reason it causes (restarts disagree, a poor hinge fit: "a spheroidal joint such
    as the ankle?") blamed the joint, while the cause stood in a warning that ``-q``
    hides, then in a parenthesis at the line's end (5 s given where 5 ms were meant: a
    new-user trial).

    Returns
    -------
    str
        ``"<that warning>; with it, <reason>"``, or ``reason`` when no warning is about a
        given offset.
    """
    # (a hand-edited calibration file may hold anything there)
    given = next((w for w in warnings if isinstance(w, str) and w.startswith(GIVEN_WARNING)),
                 None)
    return f"{given}; with it, {reason}" if given else reason


#: An offset the axis's search (rates only) applied is doubted, with a warning that begins
#: ``DOUBT_WARNING``, where the axis's model term (the residual's smooth part, soft
#: tissue's mark) reaches this, deg. An honesty audit (6270 simulated fits): with soft
#: tissue, 955 of 1558 applied knee offsets were more than 5 ms off at a 1-sigma of
#: 0.2-6 ms, and 185 of 983 gait fits with clocks in sync applied 7-180 ms, 37 of them
#: `good` without a word; the term reached 0.5 deg in 1468 of the 1558 (910 of the 955),
#: and in 28 of 939 clean fits (real offsets, within 1 ms).
OFFSET_DOUBT_MODEL_DEG = 0.5
#: An applied offset's model share (:func:`model_sigma`) per unit of (smooth residual /
#: RMS derivative by the offset), the fraction of that bound the axis's model term also
#: takes (``imucal.axis.MODEL_FACTOR``). Re-run of 1400 simulated knees of an honesty
#: audit (circling, gait, protocol; soft tissue 0-2 deg; 40-200 Hz; biases 0 or 0.02
#: rad/s): the 581 applied knee offsets were 66 % within 3 x the jackknife's 1-sigma
#: (soft tissue 46 %, 6.4 ms off median at 1.4 ms) and 98 % with this share (soft
#: tissue 97 %, clean 100 %, the median 1-sigma of clean ones 0.37 -> 0.82 ms); 0.25
#: would have left soft tissue at 73 %. The 957 applied ankle offsets of the same
#: conditions: 63 -> 99 % (soft tissue 55 -> 99 %, clean 86 -> 98 %).
OFFSET_MODEL_FACTOR = 0.5
DOUBT_WARNING = "the clock offset applied"


@dataclass(frozen=True)
class Offset:
    """A time offset estimate.

    Attributes
    ----------
    delta_s : the second sensor's clock lateness, s (0 when not estimated).
    sigma_s : its 1-sigma (``SIGMA_SCALE`` times the delete-one-block jackknife), s.
    at_edge : the cost kept falling to the end of the search range (the lowest point of
        the one-sample grid is an end of the search) with a gain of at least
        ``MIN_COST_RATIO``: the offset may be larger than the search, so ``delta_s`` is
        not trusted (and not applied).
    search_s : the search range +-, s.
    cost_ratio : cost at zero offset over the cost at ``delta_s`` (1 = no gain).
    curvature : the profile's curvature there, (mean squared residual) per s^2: a
        parabola ``curvature x (delta - delta_s)^2`` through the candidates' mean costs
        (NaN where none was fitted); its square root is the RMS of the residual's
        derivative by the offset once the estimate is refitted.
    model_sigma_s : a model error's share of the offset's 1-sigma, s (0: none known;
        :func:`fit_with_offset`); ``reported_sigma_s`` adds it to ``sigma_s``, which
        alone decides whether the offset is applied.
    """

    delta_s: float
    sigma_s: float
    at_edge: bool
    search_s: float
    cost_ratio: float
    curvature: float = float("nan")
    model_sigma_s: float = 0.0

    @property
    def reported_sigma_s(self) -> float:
        """The 1-sigma reported, s: ``sigma_s`` and ``model_sigma_s`` in quadrature."""
        return float(np.hypot(self.sigma_s, self.model_sigma_s))

    def significant(self, rate: float) -> bool:
        """Whether the offset is worth applying at ``rate`` Hz.

        Returns
        -------
        significant : bool
            True when not ``at_edge``, larger than ``MIN_APPLIED_SAMPLES`` of a sample
            and than twice its 1-sigma, and aligning lowers the mean squared residual by
            at least ``MIN_COST_RATIO``.
        """
        size = abs(self.delta_s)
        return (not self.at_edge and size > MIN_APPLIED_SAMPLES / rate
                and size > 2 * self.sigma_s and self.cost_ratio >= MIN_COST_RATIO)

    def suspicious(self, rate: float) -> bool:
        """Whether the offset, found but not applied, is large and clear enough to mention.

        Returns
        -------
        suspicious : bool
            True when not :meth:`significant` at ``rate`` Hz, not ``at_edge``, aligning
            lowers the cost at all, and the offset is at least ``SUSPICIOUS_S`` and more
            than twice its 1-sigma.
        """
        size = abs(self.delta_s)
        return (not self.significant(rate) and not self.at_edge and self.cost_ratio > 1.0
                and size >= SUSPICIOUS_S and size > 2 * self.sigma_s)


def shifted(x: np.ndarray, rate: float, delta: float) -> np.ndarray:
    """``x`` (N, ...) sampled at ``rate`` Hz, read at t + ``delta`` s by a cubic spline
    (times beyond the ends are held at the ends).

    Returns
    -------
    x_shifted : ndarray
        (N, ...) float, in the unit of ``x``; ``x`` itself (not a copy) when ``delta`` is 0.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.time_offset import shifted
    >>> shifted(np.arange(5.0), 100.0, 0.01)  # one sample later; the end is held
    array([1., 2., 3., 4., 4.])
    """
    if delta == 0:
        return x
    n = x.shape[0]
    t = np.arange(n) / rate
    spline = make_interp_spline(t, x, k=3, axis=0)
    return spline(np.clip(t + delta, 0.0, t[-1]))


def estimate_offset(refit: Callable[..., tuple[np.ndarray, np.ndarray]],
                    rate: float, search: float = OFFSET_SEARCH_S) -> Offset:
    """Minimise the profile cost: for candidate offsets over +-``search`` s,
    ``refit(deltas, every=1)`` (D,) refits the estimate with the second sensor read at
    t + delta, for every delta at once, and returns the (D, M) residuals (the same M
    samples, in time order, for every delta; with ``every`` only every so many of them)
    and the (D, k) refitted states.

    Refitting matters: at a fixed estimate the cost barely sees the offset, because the
    first fit, made with the wrong alignment, has already absorbed most of it (simulated
    circling, shank 20 ms late: the axis moves 3.9 deg and a fixed-axis search finds
    1.3 ms).

    Three stages: a coarse grid (``COARSE_STEP_S``, on every ``COARSE_THIN``-th sample),
    one-sample steps around its lowest point, and a
    least-squares parabola through ``FINE_POINTS`` candidates ``FINE_STEP_S`` apart
    around the one-sample minimum, recentred on its vertex until the candidates straddle
    it. The last stage matters at low rates: the profile is a parabola only within about
    +-10 ms of its minimum, so a parabola through one-sample neighbours 25 ms apart
    (40 Hz) landed 3-6 ms off (the simulated ankle, foot 20 ms late).

    Returns
    -------
    offset : Offset
        The minimum ``delta_s`` (s, > 0: the second sensor's clock late), its 1-sigma
        ``sigma_s`` (s, ``SIGMA_SCALE`` times the delete-one-block jackknife's),
        ``at_edge``, ``search_s`` (``search``) and ``cost_ratio`` (cost at 0 over the
        lowest mean squared residual found). With fewer than 20 samples or non-finite
        residuals on the one-sample grid: 0 s, sigma infinite, cost ratio 1. Where the
        one-sample grid's lowest point is an end of that grid: that point, no sub-sample
        pass; where a sub-sample pass gives non-finite residuals: the one-sample grid's
        three-point parabola vertex.
    """

    def residuals(deltas):
        return refit(deltas)[0]

    # a rate from printed time stamps (99.99999999994884 Hz for 100 Hz) must not lose
    # the search's last sample: it then read 190 ms '(+-0 ms)' where HDF5 read the end
    steps = max(1, int(np.floor(search * rate + 1e-6)))
    # coarse grid first, then one-sample steps around its lowest point: the profile is
    # smooth, and each point costs a refit. The coarse grid only finds the basin, on every
    # COARSE_THIN-th sample (its 20 ms steps cost twice the 40 ms steps' refits otherwise);
    # the one-sample grid, 0 (the cost ratio's) and all that follows read every sample.
    step = max(1, int(round(COARSE_STEP_S * rate)))
    half = np.unique(np.concatenate([np.arange(0, steps + 1, step), [steps]]))
    coarse = np.unique(np.concatenate([-half, half]))  # symmetric, with 0 and both ends
    # (where the coarse grid is the one-sample grid, at 40 Hz, it is read in full: a thinned
    # look at a periodic circling's profile picked the wrong one of two close dips)
    thin = COARSE_THIN if step > 1 else 1
    rough = np.square(refit(coarse / rate, every=thin)[0])
    if rough.shape[-1] == 0:  # no sample away from the ends (numpy warned of empty means)
        return Offset(0.0, float("inf"), False, float(search), 1.0)
    costs = dict(zip(coarse.tolist(), rough, strict=True)) if thin == 1 else {}
    grids = [np.arange(max(-steps, low - step), min(steps, low + step) + 1)
             for low in _coarse_basins(rough.mean(axis=1), coarse, thin)]
    todo = np.array([k for k in np.unique(np.concatenate([*grids, [0]])).tolist()
                     if k not in costs])
    if todo.size:
        costs.update(zip(todo.tolist(), np.square(residuals(todo / rate)), strict=True))
    # the one-sample grid whose lowest point is lowest on every sample
    fine = min(grids, key=lambda g: min(costs[int(k)].mean() for k in g))
    if costs[0].shape[0] < 20:  # too few samples away from the ends to compare shifts
        return Offset(0.0, float("inf"), False, float(search), 1.0)
    table = np.stack([costs[int(k)] for k in fine])  # (D, M) on the one-sample grid
    if not np.isfinite(table).all():
        return Offset(0.0, float("inf"), False, float(search), 1.0)
    whole = table.mean(axis=1)
    zero = costs[0].mean()  # 0 is on the coarse grid
    ratio = float(zero / max(whole.min(), 1e-300))
    # the profile falling to the end of the search (on the one-sample grid: a coarse
    # point at the end may have a lower neighbour inside) is evidence of a larger offset
    # only where it gains as much as an offset that would be applied: the real knees'
    # model errors fall to the end at 1.16-1.28 (1.67 in one calibrate window, 10-30 s)
    at_edge = bool(fine[np.argmin(whole)] in (-steps, steps) and ratio >= MIN_COST_RATIO)
    rough, edge = _parabola_minimum(whole, fine / rate)
    if at_edge or edge:
        return Offset(rough, _block_sigma(table, fine / rate, rough), bool(at_edge),
                      float(search), ratio, _curvature(whole, fine / rate))
    # the sub-sample pass, recentred on its own vertex until the candidates straddle it
    # the candidates stay inside the search (at 1000 Hz the one-sample grid spans only
    # the sub-sample pass's own width)
    lo, hi = -search + FINE_SPAN_S, search - FINE_SPAN_S
    lo, hi = min(lo, rough), max(hi, rough)  # a search narrower than the sub-sample span
    best, near_table, near = float(np.clip(rough, lo, hi)), table, fine / rate
    for _ in range(FINE_PASSES):
        centre = best
        near = centre + FINE_STEP_S * (np.arange(FINE_POINTS) - FINE_POINTS // 2)
        near_table = np.square(residuals(near))
        if not np.isfinite(near_table).all():
            return Offset(rough, _block_sigma(table, fine / rate, rough), False,
                          float(search), ratio, _curvature(whole, fine / rate))
        best = float(np.clip(_parabola_vertices(near_table.mean(axis=1)[:, None], near)[0],
                             lo, hi))
        if abs(best - centre) <= FINE_STEP_S:
            break
    ratio = max(ratio, float(zero / max(near_table.mean(axis=1).min(), 1e-300)))
    return Offset(best, _block_sigma(near_table, near, best), False, float(search), ratio,
                  _curvature(near_table.mean(axis=1), near))


def _coarse_basins(rough: np.ndarray, coarse: np.ndarray, thin: int) -> list[int]:
    """The coarse candidates (samples) whose one-sample grids are read in full: the lowest
    of the mean costs ``rough``, and where they were read on every ``thin``-th sample
    only, also the next lowest local minimum within ``COARSE_TIE`` of it (a flat profile
    has near ties that thinning can swap: the real left knee's centre, 55-100 s, read
    -77.7 ms at a cost ratio of 1.39 where the full samples' lowest was -37.9 at 1.46)."""
    order = np.argsort(rough)
    picks = [int(coarse[order[0]])]
    if thin == 1:
        return picks
    local_min = np.r_[True, rough[1:] <= rough[:-1]] & np.r_[rough[:-1] <= rough[1:], True]
    for i in order[1:]:
        if rough[i] > rough[order[0]] * (1 + COARSE_TIE):
            break
        if local_min[i] and abs(int(coarse[i]) - picks[0]) > 1:
            picks.append(int(coarse[i]))
            break
    return picks


def _block_sigma(table: np.ndarray, deltas: np.ndarray, best: float) -> float:
    """1-sigma, s, of the parabola vertex of the (D, M) cost ``table`` over the
    candidates ``deltas``: ``SIGMA_SCALE`` times the delete-one-block jackknife's."""
    masks = block_masks(table.shape[1])
    parts = (table @ masks.T) / masks.sum(axis=1)  # (D, K): mean square, one block out
    left_out = np.clip(_parabola_vertices(parts, deltas), deltas[0], deltas[-1])
    return SIGMA_SCALE * jackknife_sigma(left_out - best)


def _parabolas(cost: np.ndarray, deltas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(``deltas`` less their mean, (3, ...) coefficients a, b, c): least-squares
    parabolas ``a x^2 + b x + c`` through ``cost`` (D,) or each of its columns (D, K)."""
    x = deltas - deltas.mean()
    return x, np.linalg.lstsq(np.stack([x**2, x, np.ones_like(x)], axis=1), cost,
                              rcond=None)[0]


def _curvature(cost: np.ndarray, deltas: np.ndarray) -> float:
    """Leading coefficient of the least-squares parabola through ``cost`` (D,) over
    ``deltas`` (D,), per s^2; NaN where it does not curve upwards."""
    a = _parabolas(cost, deltas)[1][0]
    return float(a) if a > 0 else float("nan")


def _parabola_vertices(cost: np.ndarray, deltas: np.ndarray) -> np.ndarray:
    """(K,) vertices of least-squares parabolas through each column of ``cost`` (D, K)
    over ``deltas`` (D,); the lowest candidate where a column does not curve upwards."""
    x, (a, b, _) = _parabolas(cost, deltas)
    lowest = x[np.argmin(cost, axis=0)]
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(a > 0, -b / (2 * a), lowest)
    return vertex + deltas.mean()


def delayed(x: np.ndarray, rate: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``(index, deltas) -> (D, M, ...)``: ``x`` (N, ...) sampled at ``rate`` Hz, read at
    the samples ``index`` (M,) t + each of ``deltas`` (D,) s later, by a band-limited
    (Fourier) delay of the evenly extended signal (times beyond the ends read its mirror
    image).

    Band-limited, not a cubic spline, because the delay must not change the noise: a
    spline between samples averages neighbouring samples and so lowers white noise's
    variance by about a quarter half-way between them, which pulls the profile's minimum
    towards half-samples (the knee at 40 and 60 Hz, unfiltered rates: -0.3 and +0.4 ms
    on every seed, 2-7 times the jackknife sigma). The Fourier delay is all-pass: white
    noise keeps its variance at every delay.

    A delay by a whole number of samples (the coarse and one-sample grids: most
    candidates) is exactly a circular shift of the extended signal and is read as one;
    only fractional delays are transformed (the whole recording, once per delay).

    Returns
    -------
    read : callable
        ``read(index, deltas)``: ``index`` (M,) int sample indices, ``deltas`` (D,) s;
        gives (D, M, ...) float64 in the unit of ``x``.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.time_offset import delayed
    >>> read = delayed(np.arange(6.0), 100.0)
    >>> read(np.array([0, 4, 5]), np.array([0.0, 0.01, 0.02]))  # the end reads its mirror
    array([[0., 4., 5.],
           [1., 5., 5.],
           [2., 5., 4.]])
    """
    n = x.shape[0]
    transformed = []  # the extension's spectrum and frequencies, Hz, on the first
    # fractional delay (the extension itself is never stored: 2 N samples of a long one)

    def read(index: np.ndarray, deltas: np.ndarray) -> np.ndarray:
        deltas = np.atleast_1d(np.asarray(deltas, dtype=np.float64))
        steps = np.rint(deltas * rate)
        whole = np.abs(deltas * rate - steps) < WHOLE_SAMPLE_TOLERANCE
        out = np.empty((deltas.size, index.size) + x.shape[1:])
        at = (index[None, :] + steps[whole, None].astype(np.intp)) % (2 * n)
        out[whole] = x[np.where(at < n, at, 2 * n - 1 - at)]  # the second half mirrors x
        for k in np.flatnonzero(~whole):
            if not transformed:
                freq = np.fft.rfftfreq(2 * n, d=1.0 / rate)
                transformed.extend([np.fft.rfft(np.concatenate([x, x[::-1]], axis=0), axis=0),
                                    freq.reshape((-1,) + (1,) * (x.ndim - 1))])
            spectrum, freq = transformed
            out[k] = np.fft.irfft(spectrum * np.exp(2j * np.pi * freq * deltas[k]), n=2 * n,
                                  axis=0)[index]
        return out
    return read


def profile_samples(sample_index: np.ndarray, n: int, rate: float,
                    search: float) -> np.ndarray:
    """The samples an offset profile compares: of the fit's samples ``sample_index``
    (into a recording of ``n`` samples at ``rate`` Hz), those farther than the search
    range ``search`` s (plus the sub-sample pass's span and a sample) from either end,
    thinned to about ``OFFSET_SAMPLES``.

    Near an end the second sensor read at t + delta is no recorded motion (the delay
    wraps or holds the ends there), and when eq. (1) barely separates the offset from a
    turn of the axis a few such samples decide the minimum: noise-free circling at 1000
    Hz, shank 13 ms late, found 9.6 ms from 1500 samples of which 3 lay within the search
    of the end, 13.02 ms without them; at 100 Hz with noise a 20 ms offset read 14.7 ms
    and was not applied, leaving a 4.5 deg axis error called good.

    Returns
    -------
    index : ndarray
        Sample indices into the recording, a subset of ``sample_index`` in its order:
        every k-th of those at least ceil((``search`` + ``FINE_SPAN_S``) x ``rate``) + 1
        samples from either end, k = max(1, their number // ``OFFSET_SAMPLES``).
    """
    margin = int(np.ceil((search + FINE_SPAN_S) * rate)) + 1
    inside = sample_index[(sample_index >= margin) & (sample_index < n - margin)]
    return inside[::max(1, inside.size // OFFSET_SAMPLES)]


def fit_with_offset(fit, profile, rate: float, search: float, moved, unit: str,
                    limit: float, state=None, unapplied: bool = False):
    """The "auto" clock offset around any estimator.

    ``fit(seconds)`` runs the estimator with the second sensor read at
    t + seconds; ``profile(result)`` returns the ``refit(deltas)`` function of
    :func:`estimate_offset` around a result (the estimate refitted at each candidate
    offset, from that result). Fits again with the offset where it is significant
    (:meth:`Offset.significant`) and records it in the result's ``time_offset``,
    ``settings`` and ``warnings``.

    The offset's uncertainty then goes into the estimate's: ``moved(result, a, b)``
    gives each vector's distance ({name: deg or mm}) between two refitted states (6,),
    here the refits at the offset used +- ``SENSITIVITY_STEP_S``; that over the step is
    the estimate's sensitivity to the offset, and times the offset's 1-sigma it is the
    ``time_offset`` entry of ``uncertainty_components``, added in quadrature to the
    reported 1-sigma (``uncertainty_<unit>``); a total above ``limit`` raises the
    estimator's "uncertain" warning.

    An applied offset is also a choice: a model error (soft tissue moving the sensor on
    its segment in step with the stride) lowers the cost of a shift as a late clock does,
    by as much, and the two cannot be told apart from the residual. Where ``state`` is
    given (the axis) and the fit has a model-error term (its ``model`` component), the
    estimate's move from the fit at offset 0 (``state(result)`` (6,) of each), capped at
    ``OFFSET_MODEL_CAP`` times that term, joins the ``time_offset`` entry in quadrature
    and is reported as ``time_offset.moved_from_zero``; on clean data the term is a
    fraction of a degree, so a real offset's estimate keeps its verdict.

    An offset found but not applied adds nothing, unless its refit would move the estimate
    by more than ``UNAPPLIED_MOVE_SIGMAS`` of its 1-sigma: then that move is the
    ``time_offset`` entry (``time_offset.unapplied_move``), with the warning that says so.
    With ``unapplied`` (the axis), that move joins the 1-sigma without the warning too,
    capped at ``OFFSET_MODEL_CAP`` times the model term as an applied offset's choice is:
    the estimate rests on the clocks being in sync, and where a model error flattens the
    profile it cannot confirm that. Simulated circling with soft tissue 0.5-2 deg, shank
    20-45 ms late: the profile found 8.5 +- 6.3 ms at a gain of 1.02, nothing was applied,
    and the axes were 5-7 deg off at a 1-sigma of 1.4-1.6 deg, `good`; an honesty audit's
    873 soft-tissue circling axes were 91.2 % within 3 sigma (9 `good` beyond), 99.7 %
    with the move (none); clean circling 98.3 -> 100 % (the 1-sigma's median the same).

    The offset's own 1-sigma is the profile's sampling error, which a model error does
    not show in: :func:`model_sigma` joins it in the reported ``sigma_s`` and is reported
    as ``time_offset.model_sigma_s``, for an offset applied or not (one not applied is
    still the data's reading of the clock; the knee angles' spread reads its sampling
    part, :func:`imucal.angles.unapplied_offset_spread`). Which
    offset is applied, and the estimate's ``time_offset`` entry, rest on the sampling
    error as before (the axis's model bound and its move from offset 0 already carry a
    model error's share).

    ``unit`` is "deg" (axis) or "mm" (joint centre); ``limit`` is in that unit.

    Returns
    -------
    result : AxisResult or PositionResult
        What ``fit`` returns: the fit at the offset applied (0 s when none is), with
        ``time_offset`` (:func:`offset_report`, plus ``found_by``, ``sensitivity_per_ms``
        in ``unit`` per ms, and ``moved_from_zero`` / ``unapplied_move`` where they
        apply), ``settings["time_offset"]`` "auto", the offset's warnings and blocking
        reason, and ``uncertainty_components["time_offset"]`` in the reported 1-sigma.

    Raises
    ------
    InputError
        ``search`` spans less than one sample at ``rate`` Hz (:func:`check_search`).
    """
    check_search(search, rate)
    first = fit(0.0)
    still = is_still(first.blocking)
    if still:  # no motion, no shift to compare: not searched (a standing trial's ankle
        # "applied" +191.5 ms, an independent review)
        found = Offset(0.0, float("inf"), False, search, 1.0)
    else:
        found = estimate_offset(profile(first), rate, search)
    applied = found.significant(rate)
    result, start, how = first, found, "profile"
    if applied:
        found, result = _follow(fit, profile, rate, search, found)
        how = "profile" if found is start else "followed"
    elif found.suspicious(rate) and not at_search_end(found, rate):
        applied, found, result = _trial(fit, profile, rate, search, first, found)
        how = "trial" if applied else "profile"
    # applied or not, the number reported is the data's best reading of the clock, and a
    # model error moves it alike
    reported = replace(found, model_sigma_s=model_sigma(result, found))
    result.time_offset = {**offset_report(reported, rate), "found_by": how}
    if still:
        result.time_offset["not_estimated"] = "no motion"
    result.settings["time_offset"] = "auto"
    result.warnings.extend(offset_warnings(reported, rate))
    if refused_at_edge(found):
        result.blocking.append(offset_edge_reason(found))
    used = found.delta_s if applied else 0.0
    states = profile(result)(used + SENSITIVITY_STEP_S * np.array([-1.0, 1.0]))[1]
    per_s = {k: v / (2 * SENSITIVITY_STEP_S)
             for k, v in moved(result, states[0], states[1]).items()}
    result.time_offset["sensitivity_per_ms"] = {k: v / 1000 for k, v in per_s.items()}
    # not applied, the estimate is made as with --time-offset 0 (clocks in sync), and the
    # profile's sigma there mostly measures a model error's preferred shift (the real
    # recording's knees: 3-16 ms, which would add 1-15 deg); the sensitivity is reported
    sigma = found.sigma_s if applied and np.isfinite(found.sigma_s) else 0.0
    part = {k: v * sigma for k, v in per_s.items()}
    model = result.uncertainty_components.get("model")
    if applied and model is not None and state is not None:
        shift = moved(result, state(first), state(result))
        result.time_offset["moved_from_zero"] = shift
        part = {k: float(np.hypot(v, min(shift[k], OFFSET_MODEL_CAP * model[k])))
                for k, v in part.items()}
        result.warnings.extend(_doubt_warning(found, model))
    move = {k: v * abs(found.delta_s) for k, v in per_s.items()}
    warning = [] if applied else _unapplied_move_warning(result, found, rate, move, unit)
    if warning:
        # the warned move joins the 1-sigma: the estimate rests on the clocks being in
        # sync, and a 5 ms shank left circling axes 0.8-1.3 deg off at 5.7-13.5 x a
        # 1-sigma that did not carry it (an honesty audit)
        result.time_offset["unapplied_move"] = move
        part = {k: float(np.hypot(v, move[k])) for k, v in part.items()}
    elif (unapplied and not applied and model is not None and np.isfinite(found.sigma_s)
          and not at_search_end(found, rate)):
        # unwarned, as far as a model error could have hidden the offset (capped as an
        # applied offset's choice is): noise alone puts a clean 10 s circling's minimum
        # a few ms off, where the axis at 0 is right
        result.time_offset["unapplied_move"] = move
        part = {k: float(np.hypot(v, min(move[k], OFFSET_MODEL_CAP * model[k])))
                for k, v in part.items()}
    _widen(result, part, unit, limit)
    result.warnings.extend(warning)
    return result


def sampling_sigma(block: dict) -> float:
    """The sampling part of a ``time_offset`` block's 1-sigma, s: ``sigma_s`` without its
    ``model_sigma_s`` (:func:`model_sigma`), or ``sampling_sigma_s`` where a disagreement
    widened it (:func:`note_disagreement`); 0 without a finite ``sigma_s``.

    Returns
    -------
    float
        The jackknife's 1-sigma, s.
    """
    if "sampling_sigma_s" in block:
        return float(block["sampling_sigma_s"])
    sigma = block.get("sigma_s")
    if sigma is None or not np.isfinite(sigma):
        return 0.0
    return float(np.sqrt(max(sigma**2 - block.get("model_sigma_s", 0.0) ** 2, 0.0)))


def model_sigma(result, found: Offset) -> float:
    """A model error's share of an offset's 1-sigma, s: ``OFFSET_MODEL_FACTOR``
    times the fit's smooth residual (``result.smooth_residual``,
    :func:`imucal.quality.smooth_residual_rms`) over the RMS of the residual's
    derivative by the offset once the estimate is refitted (the square root of the
    profile's curvature, ``found.curvature``): by Cauchy-Schwarz the largest shift of the
    profile's minimum a residual of that size could cause, as the axis's model term is
    the largest turn of the axes. Soft tissue moving the sensors in step with the stride
    lowers the cost of a shift as a late clock does, alike in every time block, and the
    jackknife does not show it.

    A fit at another offset than the one found (not applied, or given) keeps the
    misalignment in its smooth residual, so the share is wide there: a clean protocol with
    the shank 20 ms late, checked at a given 0, read 19.8 ms with a share of 9.9 ms where
    the offset applied has 0.7 ms. Taking the profile's drop to its minimum off the smooth
    residual narrowed that to 0.4 ms, but also took off what soft tissue mimics: on gait
    a reading 19 ms off kept a 1-sigma of 1.2 ms. Not done.

    Returns
    -------
    float
        The share, s (0 where the fit has no smooth residual or the profile no
        curvature).
    """
    smooth = getattr(result, "smooth_residual", 0.0)
    if not (smooth > 0 and np.isfinite(found.curvature) and np.isfinite(found.sigma_s)):
        return 0.0
    return float(OFFSET_MODEL_FACTOR * smooth / np.sqrt(found.curvature))


def _doubt_warning(found: Offset, model: dict) -> list[str]:
    """The warning on an offset the axis's search applied where its model term
    (``model``, deg per vector) reaches ``OFFSET_DOUBT_MODEL_DEG``: soft tissue lowers
    the cost of a shift as a late clock does, so the rates alone cannot vouch for it
    (its 1-sigma carries that, :func:`model_sigma`; whether it is applied does
    not)."""
    worst = max(model.values())
    if not worst >= OFFSET_DOUBT_MODEL_DEG:
        return []
    return [f"{DOUBT_WARNING} ({signed_ms(found.delta_s, 1)} ms) rests on the rates alone, "
            f"and their residual has a smooth part (model term {worst:.1f} deg: soft tissue?) "
            "that can fake or shift one: check the sensors' synchronisation, or use imucal "
            "calibrate (the knee centre's specific forces check it) or --time-offset"]


def confirm(result, by: str) -> str | None:
    """Withdraw ``result``'s :func:`_doubt_warning`: the other estimate of the same two
    sensors (``by``, e.g. "knee centre"), through its own constraint, applied the same
    offset (``time_offset.confirmed_by``).

    Returns
    -------
    str or None
        The warning removed (a joint centre estimated on this axis carries a copy), None
        if it had none.
    """
    dropped = _pop_warning(result, DOUBT_WARNING)
    if dropped is not None:
        result.time_offset["confirmed_by"] = by
    return dropped


def agree(first: dict, second: dict) -> None:
    """Two searches of one clock through different constraints (a knee's axis: rates; its
    centre: specific forces) that applied the same offset (within ``FOLLOW_STEP_S``):
    each ``time_offset`` block's model share capped by their agreement
    (:func:`_cap_model_share`).

    Returns
    -------
    None
        The blocks changed in place.
    """
    blocks = (first, second)
    if not all(b.get("mode") == "auto" and b.get("applied") for b in blocks):
        return
    gap = abs(float(first["time_offset_s"]) - float(second["time_offset_s"]))
    if gap > FOLLOW_STEP_S:
        return
    for block, other in ((first, second), (second, first)):
        jackknife = sampling_sigma(block)  # (before the share it subtracts changes)
        _cap_model_share(block, gap, float(other["time_offset_s"]))
        if "model_capped_by" in block:
            block["sigma_s"] = float(np.hypot(jackknife, block["model_sigma_s"]))


def _cap_model_share(block: dict, gap: float, other_s: float) -> None:
    """Cap ``block``'s ``model_sigma_s`` (:func:`model_sigma`) at the distance ``gap``, s,
    between its offset and another search's of the same clock through another constraint
    (``other_s``, s), or ``FOLLOW_STEP_S`` where that is larger; ``model_capped_by``
    records ``other_s``. The share is a worst case (every smooth residual aligned with the
    offset's derivative), and two constraints that agree would have to be moved alike:
    simulated knees whose centre confirmed the axis's offset were within 1.3 ms of the
    truth at shares of 12-14 ms, and the knee angles' bands twice as wide as their errors
    needed (an independent review)."""
    cap = max(gap, FOLLOW_STEP_S)
    if block.get("model_sigma_s", 0.0) > cap:
        block.update({"model_sigma_s": cap, "model_capped_by": other_s})


def _unapplied_move_warning(result, found: Offset, rate: float, moves: dict,
                            unit: str) -> list[str]:
    """The warning when the offset the profile prefers, not applied, would move the
    estimate by more than ``UNAPPLIED_MOVE_SIGMAS`` of its 1-sigma (its caller then adds
    that move to the 1-sigma, ``time_offset.unapplied_move``).

    Not applied, the offset's own sigma adds nothing to the 1-sigma (a model error's
    preferred shift would otherwise cost the real recording's knees degrees they do not
    lose), so a small real offset the thresholds let through left a confident wrong answer:
    simulated circling and protocol, shank 5-10 ms late, 4-20 s at 40-200 Hz, found but
    below ``MIN_COST_RATIO``: axes 1-2.3 deg off at a 1-sigma of 0.07-0.3 deg, `good`
    (66 of 300 runs beyond 3 sigma, an independent audit). The move is the sensitivity
    times the offset found, if that is clear of twice its 1-sigma; an offset on the
    search's end has no size to use (it gets its own warning)."""
    # (clear of twice its 1-sigma: in sync, noise puts the minimum a few ms off, and the
    # 10 s circling of seed 5 would have moved by 3.3 sigma for -1.5 +- 2.4 ms)
    if (at_search_end(found, rate) or not found.cost_ratio > 1.0
            or not abs(found.delta_s) > 2 * found.sigma_s):
        return []
    total = getattr(result, f"uncertainty_{unit}")
    # (a 1-sigma of 0 with no move is no warning)
    ratios = {k: moves[k] / total[k] if total[k] > 0 else (np.inf if moves[k] > 0 else 0.0)
              for k in moves}
    worst = max(ratios, key=ratios.get)
    if not ratios[worst] > UNAPPLIED_MOVE_SIGMAS:
        return []
    return [f"with the second sensor read {_read_at(found.delta_s, '.1f')}, where the "
            f"residual is lowest (by a factor {found.cost_ratio:.2f}, too little to apply "
            f"it), {worst} would move by {moves[worst]:.2g} {unit}, {ratios[worst]:.1f} times "
            "its 1-sigma without it (the reported 1-sigma includes it): the estimate rests "
            "on the clocks being in sync. Check the synchronisation, or pass the offset with "
            "--time-offset"]


def _read_at(delta_s: float, spec: str) -> str:
    """"20 ms later" / "37 ms earlier" for a shift of the second sensor, s (it read
    "-37 ms later")."""
    return f"{format(1000 * abs(delta_s), spec)} ms {'earlier' if delta_s < 0 else 'later'}"


def _follow(fit, profile, rate: float, search: float, found: Offset):
    """(offset, fit at it): the fit at ``found``, then the profile made around that fit,
    while it moves the offset and the fit there lowers the residual (``MAX_FOLLOW``
    times at most).

    The first profile is made around the fit at offset 0, which a large offset spoils: its
    refits stay near that fit's estimate, so the profile's minimum falls short (simulated
    circling and protocol, shank 50-150 ms late: 26-112 ms found, the axis 4-15 deg off
    at `use with care`, up to 2.1 sigma). Made around the fit at the offset found, it
    moves on to the true one."""
    result = fit(found.delta_s)
    for _ in range(MAX_FOLLOW):
        again = estimate_offset(profile(result), rate, search)
        if (not again.significant(rate)
                or abs(again.delta_s - found.delta_s) <= max(FOLLOW_STEP_S, again.sigma_s)):
            break
        candidate = fit(again.delta_s)
        if not candidate.rms_residual < result.rms_residual:
            break
        found, result = again, candidate
    return found, result


def _trial(fit, profile, rate: float, search: float, first, found: Offset):
    """(applied, offset, fit) for an offset found but not applied, yet one that gets a
    warning (:meth:`Offset.suspicious`: at least ``SUSPICIOUS_S`` and clear of its
    1-sigma; a trial costs two whole fits and a profile, 0.1-0.25 s on the shared real
    recording, where model errors prefer shifts of 4-37 ms: from 5 ms 7 of 12 reference
    estimates ran one, from 10 ms 3, none applied): the fit at 0 may have spoiled its
    profile, as for an applied one (:func:`_follow`). The profile is made again around the
    fit at the offset found; where that makes it significant, it is followed, and applied
    only if the whole fits gain ``MIN_COST_RATIO`` over the fit at 0 too (a model error's
    preferred shift does not). Simulated circling, shank 50 ms late: 18.4 ms found at a profile
    gain of 1.48, the axis 12 deg off; the fit at 50 ms gains 1.87."""
    trial = fit(found.delta_s)
    again = estimate_offset(profile(trial), rate, search)
    if not again.significant(rate):
        return False, found, first
    moved, result = _follow(fit, profile, rate, search, again)
    gain = (first.rms_residual / result.rms_residual) ** 2 if result.rms_residual > 0 else 0.0
    if not gain >= MIN_COST_RATIO:
        return False, found, first
    return True, moved, result


def check_search(search: float, rate: float) -> None:
    """Check that the search range ``search`` (+- s) spans at least one sample at ``rate``
    Hz: a shorter one has no candidate besides 0 (it used to be widened to one sample
    silently, and reported as given).

    Raises
    ------
    InputError
        ``search`` x ``rate`` is below 1.
    """
    if search * rate < 1 - 1e-9:  # (1 / rate) * rate may round below 1
        raise InputError(f"the time-offset search +-{search:g} s is shorter than one sample "
                         f"at {rate:g} Hz ({1 / rate:g} s): widen it or pass the offset")


def _widen(result, part: dict, unit: str, limit: float) -> None:
    """Add ``part`` ({name: deg or mm}) to ``result``'s uncertainty as its "time_offset"
    component, with the "uncertain" warning when the new total exceeds ``limit``."""
    result.uncertainty_components["time_offset"] = {k: float(v) for k, v in part.items()}
    refresh_uncertainty(result, unit, limit)


def given_search(search: float, given: float, rate: float) -> float:
    """The range, +- s, that checks a given offset: ``search``, widened to reach the
    offset given (the profile's candidates are absolute offsets).

    Returns
    -------
    float
        ``max(search, |given| + 2 / rate)``, s.
    """
    return max(search, abs(given) + 2.0 / rate)


def check_given(result, profile, rate: float, search: float, given: float) -> None:
    """Check a given clock offset against the data: the profile around ``result`` (fitted
    with the second sensor read at t + ``given`` s; ``profile`` as for
    :func:`fit_with_offset`) over +-``search`` s, :func:`given_search`'s (the profile built
    for that range, which reaches the offset given). Where
    it finds another offset by the rule that applies one in "auto"
    (:meth:`Offset.significant`, here of the difference to ``given`` and of the cost at
    ``given`` over the cost at the minimum), or the cost falls to the search's end by the
    ratio an applied offset needs (the offset may lie beyond it), ``result`` gets a
    warning ("use with care"); the block records what was found either way. The offset
    found is the profile's first minimum, not followed as "auto" follows it: on circling
    with the shank 50 ms late it read 26-28 ms in 4 of 6 runs (an independent review), so
    the warning's number says where, not how far.

    A given offset was taken as exact: a shank 20 ms late calibrated with
    ``--time-offset 0`` gave simulated walks' knee angles 3.5-4.4 deg RMS off, 64-92 % of
    the samples within 3 sigma, "fits" and no word (a new-user trial, 21 of 24 runs).

    Returns
    -------
    None
        ``result.time_offset`` gains ``estimated_s``, ``sigma_s`` (with a model error's
        share, ``model_sigma_s``, :func:`model_sigma`), ``cost_ratio`` (cost at
        ``given`` over the cost at ``estimated_s``), ``search_s``, ``at_edge`` and
        ``contradicted``; ``result.warnings`` the warning when contradicted.
    """
    check_search(search, rate)
    refit = profile(result)
    found = estimate_offset(refit, rate, search)
    checked = bool(np.isfinite(found.sigma_s))
    ratio = found.cost_ratio
    if given and checked:
        at_zero, at_given = np.square(refit(np.array([0.0, given]))[0]).mean(axis=1)
        ratio = float(ratio * at_given / max(at_zero, 1e-300))
    versus = Offset(found.delta_s - given, found.sigma_s, found.at_edge, search, ratio)
    elsewhere = versus.significant(rate)
    edge = checked and found.at_edge and ratio >= MIN_COST_RATIO
    contradicted = (elsewhere or edge) if checked else None
    # the reading carries a model error's share as an automatic one does; whether it
    # contradicts the offset given rests on the jackknife, as applying one does
    share = model_sigma(result, found) if checked and not at_search_end(found, rate) else 0.0
    reported = replace(found, model_sigma_s=share)
    result.time_offset.update({
        "estimated_s": found.delta_s if checked else None,
        "sigma_s": reported.reported_sigma_s if checked else None,
        **({"model_sigma_s": share} if share > 0 else {}),
        "cost_ratio": ratio if checked else None, "search_s": float(search),
        "at_edge": found.at_edge, "contradicted": contradicted})
    if contradicted:
        lag = found.delta_s
        where = (f"beyond {'+' if lag > 0 else '-'}{1000 * search:.0f} ms (the search's end)"
                 if edge and not elsewhere else
                 f"{abs(1000 * lag):.1f} +- {1000 * reported.reported_sigma_s:.1f} ms "
                 f"{'late' if lag >= 0 else 'early'}")
        result.warnings.append(
            f"{GIVEN_WARNING} ({signed_ms(given, 1)} ms) is not the data's: they put the "
            f"second sensor's clock {where}, and reading it so lowers the residual "
            f"{ratio:.2f}x; check the sensors' synchronisation, or use --time-offset auto "
            "(a given offset is otherwise taken as exact)")


def offset_report(found: Offset, rate: float) -> dict:
    """The ``time_offset`` block of a result estimated with "auto".

    Returns
    -------
    block : dict
        JSON-ready: ``mode`` "auto", ``time_offset_s`` (s, the offset applied: ``found``'s
        when :meth:`Offset.significant` at ``rate`` Hz, else 0.0), ``estimated_s`` (s),
        ``sigma_s`` (s; None for a minimum on the search's end that is not applied;
        with ``found``'s model share, then also ``model_sigma_s``, s), ``applied``,
        ``cost_ratio``, ``search_s`` (s) and ``at_edge``.
    """
    applied = found.significant(rate)
    # a minimum on the search's end that is not applied is a bound, not an estimate: it
    # has no 1-sigma (the sub-sample pass can apply one within half a sample of the end)
    sigma = None if not applied and at_search_end(found, rate) else found.reported_sigma_s
    # (a bound has no 1-sigma to have a share of)
    share = ({"model_sigma_s": found.model_sigma_s}
             if found.model_sigma_s > 0 and sigma is not None else {})
    return {"mode": "auto", "time_offset_s": found.delta_s if applied else 0.0,
            "estimated_s": found.delta_s, "sigma_s": sigma, **share, "applied": applied,
            "cost_ratio": found.cost_ratio, "search_s": found.search_s,
            "at_edge": found.at_edge}


def at_search_end(found: Offset, rate: float) -> bool:
    """Whether the profile's minimum lies on an end of the search (within half a sample):
    the offset is then at least that large, its size and 1-sigma unknown.

    Returns
    -------
    at_end : bool
        abs(``delta_s``) >= ``search_s`` - 0.5 / ``rate`` (``rate`` in Hz).
    """
    return abs(found.delta_s) >= found.search_s - 0.5 / rate


def offset_warnings(found: Offset, rate: float) -> list[str]:
    """What to say about an automatic offset that was not applied (one clearly beyond the
    search is no warning but a reason the result is not identifiable,
    :func:`refused_at_edge`).

    Returns
    -------
    warnings : list of str
        At most one: no search at all (:func:`not_searched`), the profile falling to the
        search's end (:func:`offset_edge_reason`), an offset that lowers the cost by
        ``MIN_COST_RATIO`` but is too uncertain to apply, or a :meth:`Offset.suspicious`
        one; empty for an applied or refused offset, or where aligning lowers the cost
        not at all.
    """
    if refused_at_edge(found) or found.significant(rate):
        return []
    if not_searched(found):
        # (an --offset-search of half a 20 s recording left a shank 30 ms late unsearched:
        # an axis 3.9 deg off at a 1-sigma of 1.0, good, and no word: a fuzz review)
        return [f"the clock offset was not searched: too few samples lie more than the "
                f"search's +-{1000 * found.search_s:.0f} ms from the window's ends (or their "
                "residuals were not finite); the estimate assumes synchronised clocks. Give "
                "the offset with --time-offset if they are not, or search a shorter range "
                "(--offset-search)"]
    if not found.cost_ratio > 1.0:
        # aligning gains nothing: no motion leaves a residual of 0 at every offset, and the
        # warning said "lowers it only by a factor 0.00" (a new-user review)
        return []
    if found.at_edge:
        return [offset_edge_reason(found, refused=False)]
    where = (f"at least {_read_at(found.delta_s, '.0f')} (the end of the search)"
             if at_search_end(found, rate)
             else f"{_read_at(found.delta_s, '.0f')} (+-{1000 * found.reported_sigma_s:.0f} ms)")
    if found.cost_ratio >= MIN_COST_RATIO and abs(found.delta_s) > MIN_APPLIED_SAMPLES / rate:
        return [f"the residual is lowest with the second sensor read {where}, lower by a "
                f"factor {found.cost_ratio:.2f}, but the offset is not determined well "
                "enough to apply: the estimate assumes synchronised clocks. Check the "
                "synchronisation, or pass the offset with --time-offset"]
    if found.suspicious(rate):
        return [f"the residual is lowest with the second sensor read {where}, but that "
                f"lowers it only by a factor {found.cost_ratio:.2f}: a clock offset or a "
                "model error (soft tissue, not a hinge); not applied. Check the "
                "synchronisation, or pass the offset with --time-offset"]
    return []


def not_searched(found: Offset) -> bool:
    """Whether :func:`estimate_offset` could not compare shifts (too few samples away from
    the ends, or residuals not finite): its 0 s is no reading of the clocks.

    Returns
    -------
    bool
        True for the offset it returns then (0 s, 1-sigma infinite, not at the edge).
    """
    return not np.isfinite(found.sigma_s) and found.delta_s == 0.0 and not found.at_edge


def refused_at_edge(found: Offset) -> bool:
    """Whether the profile falls to the end of the search so steeply that the result is
    not identifiable: the estimate assumes synchronised clocks while the data say they
    are off by more than was searched (simulated shank clocks 220-400 ms late: ankle
    centres 0.5-1.1 m off and knee signs wrong under a usable verdict, at cost ratios
    3.5-5.4; circling with the shank 300 ms late and +-0.1 s searched: 2.04). A profile
    falling to the end by less is a warning only: on the shared real recording,
    synchronised, a right knee's profile reached 1.67 there (calibrate, 10-30 s).

    Returns
    -------
    refused : bool
        ``found.at_edge`` and a cost ratio of at least ``EDGE_REFUSAL_RATIO``.
    """
    return found.at_edge and found.cost_ratio >= EDGE_REFUSAL_RATIO


def offset_edge_reason(found: Offset, refused: bool = True) -> str:
    """Why a result whose clock offset may lie beyond the search range is not identifiable
    (``refused``), or the warning when the profile falls there less steeply.

    Returns
    -------
    reason : str
        The search range (s), the cost ratio at its edge and what to do (align the
        recordings, ``--offset-search``, ``--time-offset``).
    """
    consequence = ("an estimate that assumes synchronised clocks would be wrong" if refused
                   else "none was applied, and the estimate assumes synchronised clocks")
    return (f"the clock offset between the sensors may exceed the +-{found.search_s:g} s "
            f"searched (the constraint's cost kept falling to the edge, {found.cost_ratio:.1f}"
            f" times lower there than in sync): {consequence}; align the recordings first, "
            "widen the search (--offset-search, Python offset_search) or pass the offset "
            "with --time-offset")


def _parabola_minimum(cost: np.ndarray, deltas: np.ndarray) -> tuple[float, bool]:
    """Sub-sample minimum of ``cost`` over the grid ``deltas``; True when the lowest point
    is at an end of the grid (the minimum may lie beyond it)."""
    k = int(np.argmin(cost))
    if k == 0 or k == cost.size - 1:
        return float(deltas[k]), True
    c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
    curvature = c0 - 2 * c1 + c2
    step = deltas[1] - deltas[0]
    shift = 0.5 * (c0 - c2) / curvature if curvature > 0 else 0.0
    return float(deltas[k] + np.clip(shift, -0.5, 0.5) * step), False


# ----------------------------------------------------------------- one offset per joint


def disagree(first: dict, second: dict) -> bool:
    """Whether two "auto" searches of the same two sensors (``time_offset`` blocks, e.g.
    a knee's axis and centre) applied different offsets: more than ``FOLLOW_STEP_S``
    apart (an offset not applied counts as exactly 0), with neither search ended at its
    edge (that one is refused or warned already).

    Not "beyond their combined 1-sigma": a joint has one clock. With that rule a knee kept
    two (simulated protocol with soft tissue and a gyroscope bias, shank 20 ms late: the
    axis's 32.0 +- 7.2 ms against the centre's 21.7 +- 0.6 ms, 4 of 8 further mountings
    alike), and the angles read the shank at the axis's: 2.1 deg RMS off where the
    centre's gave 0.1 deg (a new-user trial). Whether they differ beyond their sampling
    errors decides only the warning (:func:`note_disagreement`).

    Returns
    -------
    bool
        True when the two applied offsets differ by more than that.
    """
    blocks = (first, second)
    if any(b.get("mode") != "auto" or b.get("at_edge") for b in blocks):
        return False
    gap = abs(float(first["time_offset_s"]) - float(second["time_offset_s"]))
    return gap > FOLLOW_STEP_S


def choose(deltas: np.ndarray, *refits) -> int:
    """Index of the candidate offset (``deltas`` (D,), s) both constraints fit best:
    each ``refit`` (:func:`estimate_offset`'s, around its own estimate) gives its mean
    squared residual at every candidate, and the lowest sum of their logarithms wins
    (the product of the two cost ratios between candidates; for Gaussian residuals and
    equal sample counts, the joint profile likelihood: both profiles read at most
    ``OFFSET_SAMPLES``). A sharp profile thereby outweighs a flat one: on simulated gait with
    soft tissue the centre's (eq. 3) gains 7-110x between the candidates, the axis's
    (eq. 1) 0.8-4.3x (imucal.calibration).

    Returns
    -------
    int
        The winning candidate's index.
    """
    score = sum(np.log(np.maximum(np.square(refit(deltas)[0]).mean(axis=1), 1e-300))
                for refit in refits)
    return int(np.argmin(score))


def adopt(result, own, profile, rate: float, source: dict, found_by: str, moved,
          unit: str, limit: float, state=None, versus: dict | None = None,
          warn: bool = True):
    """``result``, an estimator's fit with the offset another search of the same two
    sensors applied (``source``, that search's ``time_offset`` block, chosen by
    :func:`choose`), made an "auto" result: the block is ``source``'s with ``found_by``
    (which estimate found it) and ``own`` (this estimator's own search: ``own``'s block's
    offset, estimate, 1-sigma and cost ratio; none where ``own`` is None: the search that
    found it was this estimator's, on another fit); the given-offset check of ``result``,
    whose profile is this estimator's own, is replaced by that, and its warning dropped.

    Two searches of one clock that disagree say that a model error (soft tissue, a gyro
    bias) moves at least one of them, and not which: their difference ``disagreement_s``
    (this estimator's own estimate against the offset adopted) enters the offset's 1-sigma
    as half of it (or the adopted search's model share ``model_sigma_s``, capped at the
    difference, where larger), in quadrature with the other search's jackknife part
    (``sampling_sigma_s``), and
    where they differ beyond their sampling errors a warning says so
    (:func:`note_disagreement`). An independent review's 173 knees that changed (gait, protocol,
    circling; 40-200 Hz; soft tissue 0.5-2 deg; shanks 0-50 ms late): the adopted offset
    was within half the difference of the truth in all but 10, all circling; the centre's
    own 1-sigma, 0.2-1 ms, had left the angles of circling calibrations 53-68 % within 3
    sigma. The offset's 1-sigma enters the estimate's as in :func:`fit_with_offset`
    (sensitivity times 1-sigma); with ``state`` (the axis) as the sensitivity times the
    other search's own 1-sigma, and the move from the estimator's own choice
    (``moved_from_own``) or its own fit's move from offset 0 (its ``moved_from_zero``),
    the larger, capped as ``moved_from_zero`` is.
    ``profile``, ``moved``, ``unit``, ``limit``: as for :func:`fit_with_offset`.
    ``versus``: without ``own``, the other search's block to weigh the disagreement
    against (the knee centre refitted at its own offset on an axis that took it);
    ``warn`` False leaves the warning to the other estimate.

    Returns
    -------
    result
        ``result``, changed in place.
    """
    _pop_warning(result, GIVEN_WARNING)  # (the given path's check: its disagreement is ``own``)
    delta = float(source["time_offset_s"])
    sampling = sampling_sigma(source)
    result.time_offset = {
        **{k: source.get(k) for k in ("mode", "time_offset_s", "estimated_s", "sigma_s",
                                       "applied", "cost_ratio", "search_s", "at_edge")},
        **({"model_sigma_s": source["model_sigma_s"]} if "model_sigma_s" in source else {}),
        "found_by": found_by}
    if own is not None:
        mine = own.time_offset
        result.time_offset["own"] = {k: mine[k] for k in (
            "time_offset_s", "estimated_s", "sigma_s", "model_sigma_s", "cost_ratio",
            "found_by") if k in mine}
        versus = mine
    if versus is not None:
        note_disagreement(result, found_by, versus, "its own" if own is not None
                          else "the other estimate's search", warn=warn)
    result.settings["time_offset"] = "auto"
    states = profile(result)(delta + SENSITIVITY_STEP_S * np.array([-1.0, 1.0]))[1]
    per_s = {k: v / (2 * SENSITIVITY_STEP_S)
             for k, v in moved(result, states[0], states[1]).items()}
    result.time_offset["sensitivity_per_ms"] = {k: v / 1000 for k, v in per_s.items()}
    # as in fit_with_offset, an offset not applied adds only its disagreement
    applied = sampling if source.get("applied") else 0.0
    # the estimate carries the sampling part and the disagreement, as fit_with_offset
    # carries the sampling part (a model share is the offset's, reported in sigma_s)
    joint = float(np.hypot(sampling_sigma(result.time_offset),
                           result.time_offset.get("disagreement_s", 0.0) / 2))
    model = result.uncertainty_components.get("model")
    if model is not None and state is not None and own is not None:
        part = {k: v * applied for k, v in per_s.items()}
        shift = moved(result, state(own), state(result))
        result.time_offset["moved_from_own"] = shift
        # an applied offset is a choice the residual cannot make under soft tissue
        # (fit_with_offset): the own fit's move from offset 0 stays in, or the adopted axis
        # lost it (simulated protocol, 2 deg / 3 mm, shank 50 ms late: 52.2 -> 49.1 ms
        # adopted, 1-sigma 5.05 -> 1.60 deg at an error of 7.3 deg)
        zero = own.time_offset.get("moved_from_zero") or {}
        part = {k: float(np.hypot(v, min(max(shift[k], zero.get(k, 0.0)),
                                          OFFSET_MODEL_CAP * model[k])))
                for k, v in part.items()}
    else:
        part = {k: v * (joint if versus is not None else applied) for k, v in per_s.items()}
    _widen(result, part, unit, limit)
    return result


def note_disagreement(result, used_by: str, other: dict, other_by: str, *,
                      warn: bool = True, unit: str | None = None,
                      limit: float | None = None) -> None:
    """Put two searches' disagreement about one clock into ``result``'s offset: its
    ``time_offset`` block (the offset used, found by ``used_by``'s search) gets
    ``disagreement_s``, how far the ``other`` search (a ``time_offset`` block, named
    ``other_by``) put it (its estimate where it has a 1-sigma, else what it applied),
    ``sampling_sigma_s`` (the block's own sampling part, :func:`sampling_sigma`) and
    ``sigma_s``: that with half the disagreement or the block's ``model_sigma_s`` (capped
    at the disagreement, :func:`_cap_model_share`), the larger, in quadrature (both
    measure a model error's move); where they differ by more
    than ``FOLLOW_STEP_S`` and twice their combined sampling 1-sigma, a warning says so
    (unless ``warn`` is False). Two searches of one
    clock that disagree say that a model error moves at least one of them, and not which
    (:func:`adopt`). With ``unit`` and ``limit`` (as for :func:`fit_with_offset`), the
    estimate's ``time_offset`` uncertainty component, already made, also takes the
    sensitivity (``sensitivity_per_ms``) times half the disagreement, in quadrature.

    Returns
    -------
    None
        ``result.time_offset`` and ``result.warnings`` changed in place.
    """
    block = result.time_offset
    used = float(block["time_offset_s"])
    sampling = sampling_sigma(block)
    at = float(other["estimated_s"] if other.get("sigma_s") is not None
               else other["time_offset_s"])
    theirs = sampling_sigma(other)
    gap = abs(at - used)
    _cap_model_share(block, gap, at)
    # the disagreement measures a model error that the model share bounds: the larger
    # counts, not both
    joint = float(np.hypot(sampling, max(gap / 2, block.get("model_sigma_s", 0.0))))
    block.update({"sigma_s": joint, "sampling_sigma_s": sampling, "disagreement_s": gap})
    per_ms = block.get("sensitivity_per_ms")
    part = result.uncertainty_components.get("time_offset")
    if unit is not None and isinstance(per_ms, dict) and isinstance(part, dict):
        _widen(result, {k: float(np.hypot(part.get(k, 0.0), 1000 * per_ms[k] * gap / 2))
                        for k in per_ms}, unit, limit)
    if warn and gap > max(FOLLOW_STEP_S, 2 * float(np.hypot(sampling, theirs))):
        result.warnings.append(
            f"the clock offset of the second sensor is {signed_ms(used, 1)} ms by the "
            f"{used_by}'s search (used for both of the joint's estimates: the two constraints "
            f"fit it better), but {signed_ms(at, 1)} ms by {other_by}: a model error (soft "
            f"tissue, a gyroscope bias) moves at least one of them, so half the difference "
            f"is in the offset's 1-sigma ({1000 * joint:.1f} ms)")


def withdraw(result, by: str) -> str | None:
    """Withdraw the contradiction :func:`check_given` reported for ``result`` (its
    ``time_offset.contradicted`` and warning), overruled by the other estimate of the
    same two sensors (``by``, e.g. "knee centre"), whose constraint together with this
    one's fits the offset given better than this check's estimate
    (:func:`choose`).

    Returns
    -------
    str or None
        The warning removed from ``result.warnings`` (a joint centre estimated on this
        axis carries a copy), None if it had none; ``result.time_offset`` gets
        ``contradicted`` False and ``overruled_by`` ``by``.
    """
    result.time_offset.update({"contradicted": False, "overruled_by": by})
    return _pop_warning(result, GIVEN_WARNING)


def _pop_warning(result, prefix: str) -> str | None:
    """Remove the last of ``result``'s warnings that begins with ``prefix`` (one of
    :func:`check_given`'s or :func:`_doubt_warning`'s; each adds at most one), if any,
    and return it."""
    for i in range(len(result.warnings) - 1, -1, -1):
        if result.warnings[i].startswith(prefix):
            return result.warnings.pop(i)
    return None
