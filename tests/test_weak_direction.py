"""Walking alone leaves an ankle centre known only along a line: the result says which."""

import numpy as np
import pytest

from imucal import estimate_position
from imucal.report import position_report
from imucal.simulate import simulate


@pytest.fixture(scope="module")
def gait_ankle():
    rec, truth = simulate(seed=3, rate=100, duration=30, motion="gait", gyr_noise=0.01,
                          acc_noise=0.05)
    sh, ft = rec.sensor("shank"), rec.sensor("foot")
    return truth, estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=100, seed=1,
                                    restarts=20)


def test_the_weak_direction_is_reported_and_covers_the_error(gait_ankle):
    truth, r = gait_ankle
    d = r.weak_direction
    assert d["line"] is True
    assert np.linalg.norm(d["o1"]) == pytest.approx(1.0)
    assert np.linalg.norm(d["o2"]) == pytest.approx(1.0)
    assert d["along_mm"] > 1.5 * d["across_mm"]
    # together the two make the reported total
    total = np.hypot(*r.uncertainty_mm.values())
    assert np.hypot(d["along_mm"], d["across_mm"]) == pytest.approx(total, rel=1e-6)
    err = 1000 * np.concatenate([r.o1 - truth["o1"], r.o2 - truth["o2"]])
    v = np.concatenate([d["o1"], d["o2"]])
    v /= np.linalg.norm(v)
    along = abs(err @ v)
    across = np.sqrt(max(err @ err - along**2, 0.0))
    assert along < 3 * d["along_mm"] and across < 3 * d["across_mm"]
    assert any("only known along a line" in w and "mm along o1 direction" in w
               for w in r.warnings)
    doc = position_report(r, input_info={"path": "x.h5", "sensors": ["shank", "foot"]})
    assert doc["quality"]["weak_direction"]["line"] is True


def test_a_hinge_has_its_line_instead(gait_ankle):
    rec, _ = simulate(seed=3, rate=100, duration=10, motion="circling")
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_position(th.gyr, th.acc, sh.gyr, sh.acc, rate=100, seed=1, restarts=10,
                          joint="hinge")
    assert r.weak_direction is None and r.line is not None
