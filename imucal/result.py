"""What every estimate reports besides its own parameters: one result base.

The axis (:class:`imucal.axis.AxisResult`) and the joint position
(:class:`imucal.position.PositionResult`) add their parameters, uncertainties and
spreads in their own units to these fields.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .equality import ByValue
from .gauss_newton import BatchResult
from .quality import Verdict

if TYPE_CHECKING:
    from .multistart import Multistart
    from .preprocess import Prepared


@dataclass(kw_only=True, eq=False)
class EstimateResult(ByValue, Verdict):
    """Fields every estimator's result has.

    Attributes
    ----------
    rms_residual : RMS of the constraint's residual e(t) over all used samples at the
        estimate, in the residual's units (rad/s for the axis, m/s^2 for the position).
    relative_residual : ``rms_residual`` over the RMS of what the residual compares,
        dimensionless (0 = the model fits exactly).
    smooth_residual : RMS of the residual's smooth part over every moving sample (below
        8 Hz, less the white noise's share there,
        :func:`imucal.quality.smooth_residual_rms`), in the residual's units: what soft
        tissue and a joint that is no perfect hinge or ball leave; the axis's model term
        and the clock offset's (``time_offset.model_sigma_s``) are made of it. For a
        position, whose signals are low-passed below that band, the noise's share
        stays in (no octave above the band measures it).
    singular_ratio : smallest / largest singular value of the Jacobian at the estimate
        (near 0: some direction of the parameters is not determined by the data).
    singular_values : singular values of that Jacobian over sqrt(samples).
    uncertainty_components : the parts of the 1-sigma uncertainty, each per vector in the
        result's units: "curvature" (the cost's curvature, robust to correlated
        residuals, :func:`imucal.quality.robust_covariance`), "time_blocks"
        (delete-one-block jackknife over contiguous time blocks,
        :func:`imucal.quality.block_masks`), "cutoff_shift" (the largest shift of the
        cut-off refits), "model" (systematic model errors: for the axis a bias bound
        from the smooth part of the residual, :func:`imucal.quality.smooth_residual_rms`,
        over the Jacobian's smallest singular value; for a position 3 x the move of a
        refit weighing the samples by (|r1| + |r2|)^2, ``position.MODEL_MOVE_FACTOR``),
        "gyr_bias" (axis: the widening by a removed gyroscope bias; position: the move
        of the centre when gyroscope biases are fitted with it,
        :func:`imucal.gyr_bias.joint_centre_with_bias`), for a position "acc_error"
        (the centre's response to the accelerometers' offset and scale errors of
        ``settings.acc_error_m_s2``, not fitted) and, with the automatic clock offset
        only, "time_offset" (the estimate's move per unit of offset times the offset's
        1-sigma, :func:`imucal.time_offset.fit_with_offset`).
    excitation : how much the joint moved over the samples used (per estimator).
    sensitivity : cut-offs of the two refits from the estimate, "cutoffs_hz", and how far
        each vector moved (":math:`v`\\_shift_deg" or "..._shift_mm", and the maximum).
    convergence_fraction : fraction of restarts that reached the estimate: whose final
        value, refined on all samples, lies within the agreement distance of it. The
        estimate is the refined result with the lowest cost.
    competing_agreement : the same fraction among restarts whose RMS residual is within
        1.25 x the best (clearly worse local minima do not count).
    equal_minima : restarts that ended elsewhere at an RMS residual within
        :data:`imucal.restarts.EQUAL_RMS_FACTOR` of the best: "count", the largest
        distance to the estimate ("max_distance_deg" or "max_distance_mm") and the largest
        "max_rms_ratio" (a second answer outside the reported 1-sigma blocks the
        estimate).
    reached : (R,) which restarts reached the estimate.
    batch : the restarts on their subsets (initial states ``batch.path[0]``, costs,
        iterations), the coarse stage's steps first (:mod:`imucal.multistart`).
    refined : each restart's result refined on all samples; the estimate is the one with
        the lowest cost, polished in double precision.
    settings : every setting used, including the seed.
    samples_used : samples after window, subsampling and informative-sample selection.
    window : (start, end) in seconds from the first sample.
    time_ranges : (K, 2) stretches the selection used, s from the first sample.
    sample_index : (M,) index of each sample used in the recording passed in.
    warnings : plain-language reasons to use the estimate with care; empty when fine.
    blocking : reasons the data cannot identify the estimate at all (``verdict`` "not
        identifiable"; the command line exits 1).
    time_offset : the second sensor's clock lateness: "time_offset_s" applied (s),
        "mode" ("auto" or "given"), and with "auto" the estimate "estimated_s", its
        "sigma_s", "applied", "cost_ratio" (cost at 0 over cost at the estimate),
        "search_s", "at_edge" (:class:`imucal.time_offset.Offset`), "found_by"
        ("profile", "followed" or "trial": how the offset was reached; in a calibration
        also "knee centre" or "axis", the other estimate of the joint, with "own": this
        estimate's own search, "disagreement_s" and "sampling_sigma_s", and "sigma_s"
        widened by half that disagreement or the model share, the larger) and
        "sensitivity_per_ms" (per vector, deg or mm per ms of offset); where they apply
        also "moved_from_zero", "moved_from_own",
        "unapplied_move", "with_biases" (the axis: the offset found with gyroscope biases
        refitted), "model_sigma_s" (a model error's share of "sigma_s", s, applied or not, also
        in the check of a given offset;
        "model_capped_by" where a calibration's other search of the knee confirmed it)
        and "confirmed_by" (the axis in a calibration: the knee centre applied
        the same offset); with "given", the check of the offset
        given: "estimated_s", "sigma_s", "cost_ratio" (cost at the offset given over the
        cost at "estimated_s"), "search_s", "at_edge" and "contradicted" (in a
        calibration also "overruled_by": the other estimate of the knee, whose check
        withdrew this one's contradiction) (docs/json.md).
    """

    rms_residual: float
    relative_residual: float
    smooth_residual: float
    singular_ratio: float
    singular_values: np.ndarray
    uncertainty_components: dict
    excitation: dict
    sensitivity: dict
    convergence_fraction: float
    competing_agreement: float
    equal_minima: dict
    reached: np.ndarray
    batch: BatchResult
    refined: BatchResult
    settings: dict
    samples_used: int
    window: tuple[float, float]
    time_ranges: np.ndarray
    sample_index: np.ndarray
    warnings: list[str] = field(default_factory=list)
    blocking: list[str] = field(default_factory=list)
    time_offset: dict = field(default_factory=dict)

    @property
    def iterations(self) -> np.ndarray:
        """(R,) iterations of each restart on its subset (coarse stage included)."""
        return self.batch.iterations


def shared_fields(p: Prepared, fit: Multistart, q: dict, *, unit: str, settings: dict,
                  time_offset: float, warnings: list[str], blocking: list[str]) -> dict:
    """The :class:`EstimateResult` fields of an estimate made by the shared stages:
    ``p`` the prepared data, ``fit`` the multistart, ``q`` the estimator's quality
    block (keys "rms", "smooth", "relative", "singular_ratio", "singular_values", "components",
    "excitation", "sensitivity", "fraction", "agreement", "minima"), ``unit`` of the
    equal minima's distance ("deg" or "mm") and ``time_offset`` the offset applied, s.

    Returns
    -------
    fields : dict
        Keyword arguments for the result class: every :class:`EstimateResult` field, with
        ``equal_minima`` as {"count", "max_distance_<unit>", "max_rms_ratio"} and
        ``time_offset`` as {"mode": "given", "time_offset_s"} (with the automatic
        offset, later replaced by :func:`imucal.time_offset.offset_report`'s block).
    """
    count, apart, ratio = q["minima"]
    return {
        "rms_residual": q["rms"],
        "relative_residual": q["relative"],
        "smooth_residual": q["smooth"],
        "singular_ratio": q["singular_ratio"],
        "singular_values": q["singular_values"],
        "uncertainty_components": q["components"],
        "excitation": q["excitation"],
        "sensitivity": q["sensitivity"],
        "convergence_fraction": q["fraction"],
        "competing_agreement": q["agreement"],
        "equal_minima": {"count": count, f"max_distance_{unit}": apart,
                         "max_rms_ratio": ratio},
        "reached": fit.reached,
        "batch": fit.batch,
        "refined": fit.refined,
        "settings": settings,
        "samples_used": p.samples,
        "window": p.span_s,
        "time_ranges": p.time_ranges,
        "sample_index": p.sample_index,
        "warnings": warnings,
        "blocking": blocking,
        "time_offset": {"mode": "given", "time_offset_s": time_offset},
    }
