"""Figures and numbers of docs/angles.md and docs/real-data.md (knee flexion, issue 13).

Run from the repository root:  PYTHONPATH=. python docs/tools/angles_figure.py
Writes docs/figures/angles_simulated.png and (when ../shared/data exists)
docs/figures/angles_real.png, and prints the numbers the docs quote.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from imucal.angle_plots import plot_angles
from imucal.angles import joint_angles
from imucal.calibration import calibrate
from imucal.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
FIGURES = ROOT / "docs" / "figures"
REAL = ROOT.parent / "shared" / "data" / "walk_and_leg_motions_100hz.h5"
NOISE = {"gyr_noise": 0.01, "acc_noise": 0.05}


def stats(flexion, truth) -> tuple[float, float, float]:
    """RMSE after removing the constant offset, drift (last 10 s minus first 10 s of the
    error), and the offset itself, deg."""
    err = np.asarray(flexion) - np.asarray(truth)
    offset = float(err.mean())
    err = err - offset
    return float(np.sqrt(np.mean(err**2))), float(err[-1000:].mean() - err[:1000].mean()), offset


def simulated(tissue: float, mounting: int = 11, figure: bool = False) -> None:
    extra = {"soft_tissue_deg": tissue, "soft_tissue_mm": 2 * tissue} if tissue else {}
    cal, _ = simulate(seed=1, mounting_seed=mounting, motion="protocol", duration=30.0,
                      **NOISE, **extra)
    walk, truth = simulate(seed=2, mounting_seed=mounting, motion="gait", duration=120.0,
                           gyr_bias=0.02, **NOISE, **extra)
    calibration = calibrate(cal, restarts=20, seed=1, joints=["knee=hinge:thigh,shank"])
    result = joint_angles(walk, calibration)
    knee = result.joints["knee"]
    fused = stats(knee.flexion_deg, truth["knee_flexion_deg"])
    gyro = stats(knee.gyro_only_deg, truth["knee_flexion_deg"])
    err = knee.flexion_deg - np.asarray(truth["knee_flexion_deg"]) - fused[2]
    cover = float(np.mean(np.abs(err) <= 2 * knee.sigma_deg))
    print(f"mounting {mounting}, soft tissue {tissue:g} deg / {2 * tissue:g} mm: fused RMSE "
          f"{fused[0]:.2f} deg, drift {fused[1]:+.2f} deg, offset {fused[2]:+.2f} deg; "
          f"gyro only RMSE {gyro[0]:.1f} deg, drift {gyro[1]:+.1f} deg; sigma median "
          f"{np.median(knee.sigma_deg):.2f} deg, |error| <= 2 sigma in {cover:.1%}; "
          f"fits {result.fits}; check {knee.check['hinge_residual']:.3f} / "
          f"{knee.check['acc_gyro_disagreement_deg']:.2f} deg (calibration "
          f"{knee.check['calibration_hinge_residual']:.3f} / "
          f"{knee.check['calibration_acc_gyro_disagreement_deg']:.2f} deg)")
    if figure:
        plot_angles(result, FIGURES / "angles_simulated.png",
                    truth={"knee": np.asarray(truth["knee_flexion_deg"])})
    # another mounting with this calibration: the check
    other, _ = simulate(seed=2, mounting_seed=mounting + 1, motion="gait", duration=120.0,
                        gyr_bias=0.02, **NOISE, **extra)
    o = joint_angles(other, calibration).joints["knee"]
    print(f"  another mounting: fits {o.fits}, hinge residual {o.check['hinge_residual']:.3f}"
          f" (limit {o.check['hinge_residual_limit']:.3f}), disagreement "
          f"{o.check['acc_gyro_disagreement_deg']:.1f} deg (limit "
          f"{o.check['acc_gyro_disagreement_limit_deg']:.1f})")


def real() -> None:
    from imucal import load_recording
    from imucal.angles import still_periods

    rec = load_recording(REAL)
    calibration = calibrate(rec, restarts=20, seed=1, end=55.0,
                            joints=["left_knee=hinge:left_thigh,left_shank",
                                    "right_knee=hinge:right_thigh,right_shank"])
    result = joint_angles(rec, calibration, end=55.0)
    for name, j in result.joints.items():
        ref = calibration.joints[name].angle
        s1, s2 = (rec.select([n], None, 55.0).sensors[n].gyr for n in j.sensors)
        periods = still_periods((s1, s2), rec.rate)
        means = ", ".join(f"{rec.time[a]:.1f}-{rec.time[b - 1]:.1f} s: "
                          f"{j.flexion_deg[a:b].mean():.0f}" for a, b in periods)
        gyro = ", ".join(f"{j.gyro_only_deg[a:b].mean():.0f}" for a, b in periods)
        print(f"real {name}: verdict {calibration.joints[name].verdict}, gravity mismatch "
              f"{ref['gravity_mismatch_deg']:.0f} deg, acc-gyro disagreement "
              f"{ref['acc_gyro_disagreement_deg']:.0f} deg, hinge residual "
              f"{ref['hinge_residual']:.2f}; range {j.flexion_deg.min():.0f} to "
              f"{j.flexion_deg.max():.0f} deg; still periods (fused) {means}; "
              f"(gyro only) {gyro}")
    plot_angles(result, FIGURES / "angles_real.png")


if __name__ == "__main__":
    simulated(0.0, figure=True)
    simulated(1.0)
    if REAL.exists():
        real()
