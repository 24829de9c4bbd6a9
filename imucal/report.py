"""Estimator results -> the JSON documents the command line prints (schema: docs/json.md).

Pure functions: they build plain dicts (lists, floats, str, None; never NaN, which JSON
lacks) and serialise them deterministically, so the same input and seed give the same
bytes. Restarts are summarised (start, end, iterations, final costs); their per-iteration
cost traces, a third of a document's size, are written only with ``trace=True``.
"""

from __future__ import annotations

import json
import math

import numpy as np

from . import __version__
from .axis import AxisResult
from .position import PositionResult
from .quality import CAREFUL, GOOD

AXIS_CONVENTION = (
    "j1 is the unit hinge axis in the first sensor's frame, j2 the same physical axis in "
    "the second sensor's frame; j1 and j2 point the same physical way (decided from the "
    "data), overall sign chosen so that {sign}"
)


def _axis_convention(sign: str) -> str:
    rule = ("j1's largest component is positive" if sign == "auto"
            else f"j1's {sign[1]} component is {'positive' if sign[0] == '+' else 'negative'}")
    return AXIS_CONVENTION.format(sign=rule)
POSITION_CONVENTION = (
    "o1 and o2 are the vectors from the joint centre to the first and second sensor's "
    "origin, each in its own sensor's frame, in metres (Seel et al. 2012)"
)


def axis_report(result: AxisResult, *, input_info: dict, trace: bool = False) -> dict:
    """JSON document for an axis estimate; ``input_info`` describes the recording;
    ``trace`` adds every restart's cost per iteration (``--trace``).

    Returns
    -------
    dict
        The ``imucal axis`` document (docs/json.md), plain JSON values (:func:`clean`):
        ``j1``, ``j2`` (unit vectors in the first / second sensor's frame), ``time_offset``
        (s), ``gyr_bias`` (rad/s), ``quality`` (uncertainty and spread in deg, residual in
        rad/s), ``convergence``, ``restarts``, with ``input``, ``settings``,
        ``convention`` and ``units``.
    """
    quality = _quality_block(
        result, input_info, "deg", result.uncertainty_deg, result.spread_deg,
        {
            "sign": {
                "method": "combined tests (imucal.sign): joint-plane angles vs. j2.g2 - j1.g1, "
                          "integrated flexion within a knee's range, and (with acc) the joint "
                          "centre's acceleration along the axis",
                "evidence": result.sign_evidence,
                "tests": result.sign_tests,
                "convention": result.settings["sign_convention"],
                "j2_sign": result.settings["j2_sign"],
            },
            "gravity": result.gravity,
        },
    )
    doc = {
        "imucal_version": __version__,
        "command": "axis",
        "input": _input_block(input_info, result),
        "settings": result.settings,
        "convention": _axis_convention(result.settings["sign_convention"]),
        "units": {"j1": "unit vector", "j2": "unit vector", "rms_residual": "rad/s",
                  "smooth_residual": "rad/s", "cost": "rad/s (RMS residual)",
                  "uncertainty": "deg", "spread": "deg",
                  "time_offset": "s (positive: the second sensor's clock is late)",
                  "time_offset.sensitivity_per_ms": "deg per ms of offset",
                  "time_offset.unapplied_move": "deg",
                  "time_offset.moved_from_zero": "deg",
                  "time_offset.moved_from_own": "deg",
                  "gyr_bias": "rad/s"},
        "j1": result.j1,
        "j2": result.j2,
        "time_offset": result.time_offset,
        "gyr_bias": result.gyr_bias,
        "quality": quality,
        "convergence": _convergence_block(result, "agreement_deg"),
        "restarts": _restart_entries(result, "j1", "j2", trace),
    }
    return clean(doc)


def position_report(result: PositionResult, *, input_info: dict, trace: bool = False) -> dict:
    """JSON document for a joint-position estimate; ``trace`` as in :func:`axis_report`.

    Returns
    -------
    dict
        The ``imucal position`` document (docs/json.md), plain JSON values
        (:func:`clean`): ``joint``, ``o1``, ``o2`` (m, from the joint centre to each
        sensor, in its frame), ``time_offset`` (s), ``gyr_bias`` (rad/s), for a hinge
        ``axis_line``, ``quality`` (uncertainty and spread in mm, residual in m/s^2),
        ``convergence``, ``restarts``, with ``input``, ``settings``, ``convention`` and
        ``units``.
    """
    doc = {
        "imucal_version": __version__,
        "command": "position",
        "input": _input_block(input_info, result),
        "settings": result.settings,
        "convention": POSITION_CONVENTION,
        "units": {"o1": "m", "o2": "m", "rms_residual": "m/s^2",
                  "smooth_residual": "m/s^2", "cost": "m/s^2 (RMS residual)",
                  "uncertainty": "mm", "spread": "mm",
                  "time_offset": "s (positive: the second sensor's clock is late)",
                  "time_offset.sensitivity_per_ms": "mm per ms of offset",
                  "time_offset.unapplied_move": "mm",
                  "time_offset.moved_from_own": "mm",
                  "quality.weak_direction": "o1, o2 unit vectors; along_mm, across_mm mm",
                  "gyr_bias": "rad/s"},
        "joint": result.joint,
        "o1": result.o1,
        "o2": result.o2,
        "time_offset": result.time_offset,
        "gyr_bias": result.gyr_bias,
    }
    if result.line is not None:
        doc["axis_line"] = {
            "j1": result.line[:3],
            "j2": result.line[3:],
            "description": "every point o1 + lambda*j1, o2 + lambda*j2 fits the data; o1, o2 "
            "is the point of this line closest to both sensors (lambda = -(o1.j1 + o2.j2)/2)",
        }
    extra = {} if result.weak_direction is None else {"weak_direction": result.weak_direction}
    doc["quality"] = _quality_block(result, input_info, "mm", result.uncertainty_mm,
                                    result.spread_mm, extra)
    doc["convergence"] = _convergence_block(result, "agreement_mm")
    doc["restarts"] = _restart_entries(result, "o1", "o2", trace)
    return clean(doc)


def _uncertainty_method(centre: bool) -> str:
    """The reported 1-sigma's formula in words; an axis's has no accelerometer part (its
    text named acc_error^2, which no axis has: a new-user trial)."""
    return (
        "sqrt(max(curvature, time_blocks)^2 + cutoff_shift^2 + model^2 + gyr_bias^2 + "
        + ("acc_error^2 + " if centre else "") + "time_offset^2): curvature of the cost "
        "at the estimate ((J^T J)^-1 S (J^T J)^-1, Newey-West S), delete-one-block jackknife "
        "over 10 contiguous time blocks, the largest shift of the cut-off refits (axis: 10 "
        "and 20 Hz low-pass, or the cut-off halved and doubled; position: the cut-off x 0.75 "
        "and x 1.5), a model-error term (axis: a bound from the residual's smooth part; "
        "position: 3 x the move of a refit weighing each sample by (|r1| + |r2|)^2), a "
        "gyroscope-bias part (axis: the widening by a removed bias; position: the move when "
        "a constant bias of each gyroscope is fitted with it)"
        + (", for a joint centre an accelerometer part (its response to an offset and a "
           "scale error of each accelerometer, settings.acc_error_m_s2 at 1 g, that the "
           "motion cannot tell from a move of the centre)" if centre else "")
        + ", and with an automatic clock offset the estimate's move per ms of offset times "
        "the offset's 1-sigma (for the axis, with an applied offset, also its move from "
        "offset 0, capped at 3 x model; see uncertainty_components and docs/quality.md)")


UNCERTAINTY_METHOD = _uncertainty_method(centre=True)
AXIS_UNCERTAINTY_METHOD = _uncertainty_method(centre=False)
SPREAD_METHOD = (
    "RMS distance between the estimate and the results of the restarts that reached it, "
    "each fitted on a random half of the samples (leaving out subset fits stuck in a local "
    "minimum: RMS residual above 1.25 x the median)"
)


def _quality_block(result, info: dict, unit: str, uncertainty: dict, spread: dict,
                   extra: dict) -> dict:
    """The `quality` block both reports share (docs/quality.md).

    Warnings from loading (repaired gaps, doubtful units) count, too: data that needed
    repair are never "good".
    """
    loaded = [f"input: {w}" for w in info.get("load_warnings", [])]
    verdict = result.verdict
    if loaded and verdict == GOOD:
        verdict = CAREFUL
    first, second = uncertainty
    block = {
        "verdict": verdict,
        "warnings": result.blocking + result.warnings + loaded,
        "rms_residual": result.rms_residual,
        "relative_residual": result.relative_residual,
        "smooth_residual": result.smooth_residual,
        f"{first}_uncertainty_{unit}": uncertainty[first],
        f"{second}_uncertainty_{unit}": uncertainty[second],
        "uncertainty_method": AXIS_UNCERTAINTY_METHOD if first == "j1" else UNCERTAINTY_METHOD,
        "uncertainty_components": result.uncertainty_components,
        f"{first}_spread_{unit}": spread[first],
        f"{second}_spread_{unit}": spread[second],
        "spread_method": SPREAD_METHOD,
        "identifiability": {
            "singular_ratio": result.singular_ratio,
            "condition_number": 1 / result.singular_ratio if result.singular_ratio > 0 else None,
            "smallest_singular_value": result.singular_values[-1],
            "excitation": result.excitation,
        },
        "sensitivity": result.sensitivity,
    }
    block.update(extra)
    return block


def dumps(doc: dict) -> str:
    """Serialise a report: deterministic key order as built, two-space indent, newline.

    Lists of numbers (vectors, costs, time ranges' ends) stay on one line: one number per
    line made a document of a hundred restarts 5,000 lines long.

    Returns
    -------
    str
        The JSON text, ending in a newline.

    Raises
    ------
    ValueError
        ``doc`` holds NaN or Inf (JSON has neither; :func:`clean` turns them into None).

    Examples
    --------
    >>> from imucal.report import dumps
    >>> print(dumps({"j1": [1.0, 0.0, 0.0], "verdict": "good"}), end="")
    {
      "j1": [1.0, 0.0, 0.0],
      "verdict": "good"
    }
    """
    return _formatted(doc, 0) + "\n"


def _formatted(value, level: int) -> str:
    if isinstance(value, list) and not any(isinstance(v, (dict, list, str)) for v in value):
        return json.dumps(value, allow_nan=False)
    if isinstance(value, (dict, list)):
        if not value:
            return json.dumps(value)
        pad = "  " * (level + 1)
        if isinstance(value, dict):
            items = [f"{pad}{json.dumps(k)}: {_formatted(v, level + 1)}"
                     for k, v in value.items()]
            brackets = "{}"
        else:
            items = [pad + _formatted(v, level + 1) for v in value]
            brackets = "[]"
        return brackets[0] + "\n" + ",\n".join(items) + "\n" + "  " * level + brackets[1]
    return json.dumps(value, allow_nan=False)


def clean(value):
    """Recursively turn numpy values into plain Python; NaN and Inf become None.

    Returns
    -------
    object
        ``value`` with dicts (keys as str), lists, tuples and arrays as lists, numpy
        booleans, integers and floats as ``bool``, ``int``, ``float``; anything else
        unchanged.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.report import clean
    >>> clean({"a": np.float64("nan"), "b": np.arange(2), "c": (np.bool_(True), 1.5)})
    {'a': None, 'b': [0, 1], 'c': [True, 1.5]}
    """
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return [clean(v) for v in value.tolist()]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    return value


#: Significant digits of the numbers in ``restarts``: the restarts are computed in single
#: precision (axis) and stop far from machine precision (1e-3 rad, 1e-5 m), so more digits
#: would be noise; the estimate itself keeps full precision.
RESTART_DIGITS = 7


def _restart_entries(result, first: str, second: str, trace: bool = False) -> list[dict]:
    """One JSON entry per restart; ``first``/``second`` name the two state vectors.

    Costs are RMS residuals: ``final_cost`` on the restart's subset (as ``final``),
    ``refined_cost`` on all samples; ``trace`` adds each stage's cost per iteration.
    """
    batch, refined = result.batch, result.refined

    def pair(x):
        return {first: _rounded(x[:3]), second: _rounded(x[3:])}

    entries = []
    for r in range(batch.x.shape[0]):
        entry = {
            "initial": pair(batch.path[0, r]),
            "final": pair(batch.x[r]),
            "refined": pair(refined.x[r]),
            "iterations": int(batch.iterations[r]),
            "converged": bool(batch.converged[r]),
            "reached_estimate": bool(result.reached[r]),
            "final_cost": _rounded(_rms(batch.cost[r, batch.iterations[r]])),
            "refined_cost": _rounded(_rms(refined.cost[r, refined.iterations[r]])),
        }
        if trace:
            entry["cost_trace"] = _cost_trace(batch.cost[r])
            entry["refined_cost_trace"] = _cost_trace(refined.cost[r])
        entries.append(entry)
    return entries


def _rms(mean_square):
    return np.sqrt(mean_square) if np.isfinite(mean_square) and mean_square >= 0 else np.nan


def _rounded(values):
    """``values`` (a number or an array) to ``RESTART_DIGITS`` significant digits."""
    a = np.asarray(values, dtype=float)
    out = [float(f"{v:.{RESTART_DIGITS}g}") if np.isfinite(v) else None for v in a.ravel()]
    return out[0] if a.ndim == 0 else out


def _cost_trace(cost_row: np.ndarray) -> list:
    """RMS residual per iteration (start first), without the NaN padding."""
    return _rounded(np.sqrt(cost_row[np.isfinite(cost_row)]))


def _input_block(info: dict, result) -> dict:
    out = dict(info)
    out.pop("load_warnings", None)
    t0 = out.pop("time_origin", 0.0)
    out["samples_used"] = result.samples_used
    # to the nanosecond: a window of a 40 Hz time column read [5.000000000000032,
    # 20.000000000000245] (samples over a measured rate; a new-user trial)
    out["window_s"] = [round(t0 + result.window[0], 9), round(t0 + result.window[1], 9)]
    out["time_ranges_s"] = np.round(t0 + np.asarray(result.time_ranges), 9)
    return out


def _convergence_block(result, tol_key: str) -> dict:
    it = result.batch.iterations
    return {
        "fraction": result.convergence_fraction,
        "competing_agreement": result.competing_agreement,
        tol_key: result.settings[tol_key],
        "iterations_median": float(np.median(it)),
        "iterations_max": int(it.max()),
        "converged_within_limit": float(np.mean(result.batch.converged)),
        # restarts dropped because their cost or normal equations overflowed (extreme
        # data); they never become the estimate
        "degenerate_restarts": int(np.sum(result.batch.degenerate | result.refined.degenerate)),
        "equal_minima": result.equal_minima,
    }
