"""Settings objects: one check of every setting, and the estimators take them whole."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import simulated

from imucal import InputError, estimate_axis, estimate_position
from imucal.settings import AxisSettings, PositionSettings


def test_axis_settings_object_gives_the_keyword_result():
    rec, _ = simulated(3)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    s = AxisSettings(restarts=6, seed=4, sign="+x", time_offset=0)
    a = estimate_axis(g1, g2, rate=rec.rate, settings=s)
    b = estimate_axis(g1, g2, rate=rec.rate, **s.as_kwargs())
    assert np.array_equal(a.j1, b.j1) and np.array_equal(a.j2, b.j2)
    assert a.j1[0] > 0  # the pinned sign convention was used
    assert a.settings["restarts"] == 6 and a.settings["seed"] == 4


def test_position_settings_object_gives_the_keyword_result():
    rec, _ = simulated(3)
    shank, foot = rec.sensor("shank"), rec.sensor("foot")
    s = PositionSettings(restarts=4, seed=2, time_offset=0, max_iterations=20)
    args = (shank.gyr, shank.acc, foot.gyr, foot.acc)
    a = estimate_position(*args, rate=rec.rate, settings=s)
    b = estimate_position(*args, rate=rec.rate, **s.as_kwargs())
    assert np.array_equal(a.o1, b.o1) and np.array_equal(a.o2, b.o2)
    assert a.settings["max_iterations"] == 20


@pytest.mark.parametrize(("kwargs", "phrase"), [
    ({"sign": "bogus"}, "sign must be one of"),
    ({"restarts": 0}, "restarts must be at least 1"),
    # 1e20 restarts: numpy's "Maximum allowed dimension exceeded", exit 3 (fuzz audit)
    ({"restarts": 10**20}, "restarts must be at most 10000, got 100000000000000000000"),
    ({"subset": 1.5}, r"subset must be in \(0, 1\]"),
    ({"time_offset": "soon"}, "time offset must be auto or a number"),
    ({"start": 5.0, "end": 4.0}, "after its start"),
    ({"max_samples": 10}, "max_samples must be at least 100"),
])
def test_bad_settings_fail_before_any_data_is_used(kwargs, phrase):
    with pytest.raises(InputError, match=phrase):
        AxisSettings(**kwargs)
    # the estimator reports the same error for the same keyword, whatever the data
    with pytest.raises(InputError, match=phrase):
        estimate_axis(np.zeros((5, 3)), np.zeros((5, 3)), rate=100.0, **kwargs)


def test_settings_and_differing_keywords_together_are_refused():
    g = np.zeros((50, 3))
    with pytest.raises(InputError, match=r"not both \(restarts\)"):
        estimate_axis(g, g, rate=100.0, restarts=3, settings=AxisSettings(restarts=5))
    with pytest.raises(InputError, match="settings must be a PositionSettings"):
        estimate_position(g, g, g, g, rate=100.0, settings=AxisSettings())


def test_position_joint_is_checked():
    with pytest.raises(InputError, match="joint must be one of spheroidal, hinge"):
        PositionSettings(joint="ball")


def test_the_settings_module_is_reachable_after_a_plain_import():
    # `import imucal; imucal.settings.AxisSettings(...)` raised AttributeError until some
    # estimator had been used (a new-user trial); a fresh interpreter shows it
    import subprocess
    import sys

    code = ("import imucal; print(imucal.settings.AxisSettings(restarts=3).restarts, "
            "imucal.simulate.simulate.__name__)")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["3", "simulate"]
