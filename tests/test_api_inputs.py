"""The Python API from a notebook: numpy scalars are numbers, and every wrong input is an
InputError naming the problem (a fuzz of the public functions found TypeErrors,
AttributeErrors and numpy's ValueErrors from deep inside, settings that came back as
joints marked `failed`, units silently ignored and one sensor silently replacing
another)."""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

import imucal
from imucal import InputError
from imucal.settings import AxisSettings

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5"


@pytest.fixture(scope="module")
def rec():
    return imucal.load_recording(SAMPLE)


@pytest.fixture(scope="module")
def pair(rec):
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    return th.gyr[:800], th.acc[:800], sh.gyr[:800], sh.acc[:800]


@pytest.fixture(scope="module")
def cal(rec):
    return imucal.calibrate(rec, restarts=5, seed=1)


def test_numpy_scalars_are_numbers(pair):
    g1, _, g2, _ = pair
    plain = imucal.estimate_axis(g1, g2, rate=100.0, restarts=5, seed=3, subset=0.5,
                                 time_offset=0.0)
    numpy = imucal.estimate_axis(g1, g2, rate=np.float32(100), restarts=np.int64(5),
                                 seed=np.uint64(3), subset=np.float32(0.5),
                                 time_offset=np.float64(0.0))
    np.testing.assert_array_equal(numpy.j1, plain.j1)
    assert numpy.verdict == plain.verdict
    assert type(numpy.settings["restarts"]) is int and type(numpy.settings["seed"]) is int
    # Decimal is not a numbers.Real: "rate must be a positive number, got Decimal('100')"
    exact = imucal.estimate_axis(g1, g2, rate=Decimal("100"), restarts=Decimal(5),
                                 seed=Decimal(3), subset=Decimal("0.5"), time_offset=Decimal(0))
    np.testing.assert_array_equal(exact.j1, plain.j1)
    # exactly, not through a float (10**30 became 1000000000000000019884624838656)
    assert AxisSettings(seed=Decimal("1e30")).seed == 10**30
    with pytest.raises(InputError, match="seed must be a whole number"):
        AxisSettings(seed=Decimal("3.0000000000000000001"))


@pytest.mark.parametrize("kwargs, message", [
    ({"restarts": float("nan")}, "restarts must be a whole number"),
    ({"restarts": float("inf")}, "restarts must be a whole number"),
    ({"seed": True}, "seed must be a whole number"),
    ({"time_offset": None}, "time offset must be auto or a finite number"),
    ({"rate": None}, "sample rate must be a positive number"),
    ({"rate": "abc"}, "sample rate must be a positive number"),
    ({"rate": np.array([100.0])}, "sample rate must be a positive number"),
    ({"rate": Decimal("NaN")}, "sample rate must be a positive number"),
    ({"sign": np.array("+x")}, "sign must be one of"),
])
def test_settings_of_the_wrong_type(pair, kwargs, message):
    g1, _, g2, _ = pair
    with pytest.raises(InputError, match=message):
        imucal.estimate_axis(g1, g2, **{"rate": 100.0, **kwargs})


@pytest.mark.parametrize("first, message", [
    ("abc", "must be real numbers, got text"),
    ({"x": 1}, "must be real numbers, got values that are not numbers"),
    ([[1.0, 2.0, 3.0], [1.0, 2.0]] * 400, "is not an .N, 3. array of numbers"),
    (None, r"has shape \(\), expected \(N, 3\)"),
])
def test_data_that_are_not_arrays_of_numbers(pair, first, message):
    _, _, g2, _ = pair
    with pytest.raises(InputError, match=message):
        imucal.estimate_axis(first, g2, rate=100.0)


def test_complex_data_are_refused_not_cut_to_their_real_part(pair):
    g1, _, g2, _ = pair
    with pytest.raises(InputError, match="got complex numbers"):
        imucal.estimate_axis(g1 + 1j, g2, rate=100.0)


def test_a_corrupt_reading_is_named_by_its_sample(pair):
    # 1e20 rad/s overflowed the single-precision restarts: "no restart produced a finite
    # result"
    g1, a1, g2, a2 = pair
    bad = g1.copy()
    bad[100] = 1e20
    with pytest.raises(InputError, match=r"beyond any body-worn sensor's range \(70 "
                                         r"rad/s\), the first 1e\+20 at sample 100"):
        imucal.estimate_axis(bad, g2, rate=100.0)
    acc = a2.copy()
    acc[7, 2] = -1e9
    with pytest.raises(InputError, match=r"second sensor's acc: 1 reading\(s\) beyond any "
                                         r"body-worn sensor's range \(3924 m/s\^2\), the first "
                                         r"1e\+09 at sample 7"):
        imucal.estimate_position(g1, a1, g2, acc, rate=100.0)
    # a spike within what a unit mistake gives (1e3 rad/s): it made a good axis "not
    # identifiable", blamed on the data
    bad[100] = [1e3, -20.0, 3.0]
    with pytest.raises(InputError, match=r"1 reading\(s\) beyond any body-worn sensor's "
                                         r"range \(70 rad/s\), the first 1000 at sample 100"):
        imucal.estimate_axis(bad, g2, rate=100.0)
    imucal.estimate_axis(g1 * 1000.0, g2, rate=100.0, restarts=3)  # (mrad/s: no spike)


def test_too_few_samples_for_a_joint_position(pair):
    g1, a1, g2, a2 = pair
    with pytest.raises(InputError, match="only 1 sample given; the joint position needs at "
                                         "least 30"):
        imucal.estimate_position(g1[:1], a1[:1], g2[:1], a2[:1], rate=100.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"joint": "hinge", "axis": (np.ones(2), np.ones(2))}, "two real 3-vectors"),
    ({"joint": "hinge", "axis": "x"}, "two real 3-vectors"),
    ({"joint": "hinge", "axis": np.ones((3, 3))}, "two real 3-vectors"),
    ({"joint": "hinge", "axis": np.zeros((2, 3))}, "finite non-zero"),
    ({"joint": "hinge", "axis": ([0, 0, np.nan], [0, 0, 1])}, "finite non-zero"),
    ({"axis": ([0, 0, 1], [0, 0, 1])}, "only for joint='hinge'"),
])
def test_a_given_axis_is_checked(pair, kwargs, message):
    g1, a1, g2, a2 = pair
    with pytest.raises(InputError, match=message):
        imucal.estimate_position(g1, a1, g2, a2, rate=100.0, **kwargs)


@pytest.mark.parametrize("kwargs, message", [
    ({"restarts": 0}, "restarts must be at least 1"),
    ({"seed": -1}, "seed must be at least 0"),
    ({"acc_error": -1.0}, r"acc_error must be in \[0, 5\]"),
    ({"time_offset": "x"}, "time offset must be auto or a number"),
    ({"restarts": 10**400}, "restarts must be at most 10000"),
    ({"start": 5.0, "end": 2.0}, "window end 2 s must be after its start 5 s"),
    ({"start": 1000.0}, "window start 1000 s lies outside the recording"),
    ({"smoothing_s": "abc"}, "smoothing_s must be a number of seconds"),
])
def test_calibrate_refuses_invalid_settings(rec, kwargs, message):
    # they came back as a Calibration with every joint `failed`
    with pytest.raises(InputError, match=message):
        imucal.calibrate(rec, **kwargs)


def test_objects_of_the_wrong_kind(rec, cal):
    with pytest.raises(InputError, match=r"expected a Recording, got str \(load it first"):
        imucal.calibrate(str(SAMPLE))
    with pytest.raises(InputError, match="expected a Calibration, got NoneType"):
        imucal.joint_angles(rec, None)
    with pytest.raises(InputError, match=r"expected a Calibration, got str \(load it first"):
        imucal.joint_angles(rec, "cal.json")
    with pytest.raises(InputError, match="expected a Recording, got str"):
        imucal.joint_angles(str(SAMPLE), cal)
    with pytest.raises(InputError, match="smoothing_s must be a number of seconds"):
        imucal.joint_angles(rec, cal, smoothing_s=[1])


def test_make_recording_refuses_what_it_would_ignore(rec):
    th = rec.sensor("thigh")
    data = {"thigh": {"gyr": np.degrees(th.gyr), "acc": th.acc}}
    with pytest.raises(InputError, match="units given for sensor 'Thigh', which is not"):
        imucal.make_recording(data, rate=100.0, units={"Thigh": {"gyr": "deg/s"}})
    with pytest.raises(InputError, match="unknown kind 'gyro'"):
        imucal.make_recording(data, rate=100.0, units={"thigh": {"gyro": "deg/s"}})
    with pytest.raises(InputError, match="units must be a mapping"):
        imucal.make_recording(data, rate=100.0, units="deg/s")
    with pytest.raises(InputError, match="sensor 'thigh' is given twice"):
        imucal.make_recording({**data, b"thigh": data["thigh"]}, rate=100.0)
    with pytest.raises(InputError, match="sensors must be a mapping"):
        imucal.make_recording([th.gyr, th.acc], rate=100.0)
    # True/False read as 1 and 0, where the estimators refuse them (fuzz audit)
    with pytest.raises(InputError, match="sensor 'thigh' gyr holds True/False values"):
        imucal.make_recording({"thigh": {"gyr": th.gyr > 0, "acc": th.acc}}, rate=100.0)
    with pytest.raises(InputError, match="'time' holds True/False values; expected seconds"):
        imucal.make_recording({"thigh": {"gyr": th.gyr[:2], "acc": th.acc[:2]}},
                              time=np.array([False, True]))
    right = imucal.make_recording(data, rate=100.0, units={"thigh": {"gyr": "deg/s"}})
    np.testing.assert_allclose(right.sensor("thigh").gyr, th.gyr)


def test_select_and_paths_of_the_wrong_kind(rec, cal, tmp_path):
    with pytest.raises(InputError, match="window start must be a finite number of seconds, "
                                         "got '1'"):
        rec.select(["thigh"], "1")
    with pytest.raises(InputError, match="no sensor named"):
        rec.select([])
    assert list(rec.select("thigh").sensors) == ["thigh"]
    with pytest.raises(InputError, match="expected a recording's file name"):
        imucal.load_recording(None)
    assert imucal.load_recording(bytes(SAMPLE)).n_samples == rec.n_samples
    # a str with a trailing '/' was refused, its bytes loaded the file (Path drops the '/')
    for name in (f"{SAMPLE}/", f"{SAMPLE}/".encode()):
        with pytest.raises(InputError, match="is a file, not a folder"):
            imucal.load_recording(name)
    with pytest.raises(InputError, match="expected a calibration file name"):
        imucal.load_calibration(None)
    with pytest.raises(InputError, match="expected an output file name"):
        cal.write(None)
    angles = imucal.joint_angles(rec, cal)
    with pytest.raises(InputError, match="expected an output file name"):
        angles.write(None)
    assert list(tmp_path.iterdir()) == []


def test_values_that_python_reads_as_true_are_not_settings(pair, rec, cal):
    # bool("no") is True (the selection stayed on); True == 1 read as flexion "+" and as
    # a reference time of 1 s
    g1, _, g2, _ = pair
    with pytest.raises(InputError, match="select must be True or False, got 'no'"):
        imucal.estimate_axis(g1, g2, rate=100.0, select="no")
    with pytest.raises(InputError, match="flexion sign must be auto, . or -, got True"):
        imucal.joint_angles(rec, cal, flexion_sign=True)
    with pytest.raises(InputError, match="reference must be None, 'standing' or a time"):
        imucal.joint_angles(rec, cal, reference=True)
    assert imucal.estimate_axis(g1, g2, rate=100.0, restarts=3, seed=1,
                                select=np.bool_(False)).settings["select"] is False


def test_a_recording_keeps_its_own_time_axis(rec):
    th = rec.sensor("thigh")
    time = np.arange(th.gyr.shape[0]) / 100.0
    made = imucal.make_recording({"thigh": {"gyr": th.gyr, "acc": th.acc}}, time=time)
    time += 50.0  # the caller's array, changed later
    assert made.time[0] == 0.0


def test_a_signal_in_another_unit_has_no_corrupt_readings(real_recording, pair):
    # the fast moments of quiet stretches in deg/s or mg (80 "rad/s", heel strikes of
    # 4-7 g as "m/s^2") were refused as corrupt packets; they stand at most 3.4 / 3.9
    # times above their neighbours
    from imucal.sensor_checks import corrupt_readings

    for name in real_recording.sensors:
        s = real_recording.sensor(name)
        assert not corrupt_readings(np.degrees(s.gyr), "gyr").any()
        assert not corrupt_readings(s.acc * 1000 / 9.81, "acc").any()
    th, sh = real_recording.sensor("right_thigh"), real_recording.sensor("right_shank")
    out = imucal.estimate_axis(np.degrees(th.gyr[2000:4000]), np.degrees(sh.gyr[2000:4000]),
                               rate=100.0, restarts=5, seed=1)
    assert any("deg/s" in w for w in out.warnings)
    # a burst of five corrupt readings is one still
    g1, _, g2, _ = pair
    bad = g1.copy()
    bad[500:505, 0] = 1e3
    with pytest.raises(InputError, match=r"5 reading\(s\) beyond any body-worn sensor's range"):
        imucal.estimate_axis(bad, g2, rate=100.0)


def test_numbers_in_other_containers(pair, rec, cal):
    # 0-d arrays (np.load gives them), pandas' nullable Float64 columns, huge integers
    import pandas as pd

    g1, _, g2, _ = pair
    plain = imucal.estimate_axis(g1, g2, rate=100.0, restarts=3, seed=1, time_offset=0.0)
    other = imucal.estimate_axis(pd.DataFrame(g1).astype("Float64"), g2,
                                 rate=np.array(100.0), restarts=np.array(3), seed=1,
                                 time_offset=np.array(0.0))
    np.testing.assert_array_equal(other.j1, plain.j1)
    assert rec.select(["thigh"], np.array(1.5)).time[0] == 1.5
    with pytest.raises(InputError, match="seed must be"):
        imucal.estimate_axis(g1, g2, rate=100.0, seed=float(10**300) * 1e10)
    with pytest.raises(InputError, match="window start must be a finite number"):
        rec.select(["thigh"], 10**400)
    # calibrate said "start must be a finite number" where every other entry names the
    # window and its unit
    for window in ({"start": float("nan")}, {"end": "1"}):
        name = next(iter(window))
        with pytest.raises(InputError, match=f"window {name} must be a finite number of "
                                             "seconds"):
            imucal.calibrate(rec, restarts=3, seed=1, **window)
    # numbers as 0-d arrays pass the checks, and the file records them as numbers (its
    # JSON stopped at them)
    cal0 = imucal.calibrate(rec, restarts=np.array(3), seed=np.array(1), start=np.array(0.0),
                            offset_search=np.array(0.4), acc_error=np.array(0.05))
    import json

    settings = json.loads(json.dumps(cal0.to_document()))["settings"]
    assert settings["restarts"] == 3 and settings["offset_search_s"] == 0.4
    assert settings["acc_error_m_s2"] == 0.05 and settings["start"] == 0.0
    # a search range with a given offset is the range its check looks over
    checked = imucal.estimate_axis(g1, g2, rate=100.0, time_offset=0,
                                   offset_search=np.array(0.05))
    assert checked.time_offset["search_s"] == 0.05
    with pytest.raises(InputError, match="sample rate must be a positive number"):
        imucal.estimate_axis(g1, g2, rate=10**400)
    with pytest.raises(InputError, match="flexion sign must be auto"):
        imucal.joint_angles(rec, cal, flexion_sign=np.True_)
    with pytest.raises(InputError, match="reference must be None"):
        imucal.joint_angles(rec, cal, reference=np.array(True))


def test_names_axes_and_maps_in_other_forms(pair, rec, tmp_path):
    g1, a1, g2, a2 = pair
    for names in (None, 3):
        with pytest.raises(InputError, match="sensor names must be a name or a list"):
            rec.select(names)
    assert list(rec.select(b"thigh").sensors) == ["thigh"]
    assert list(rec.select(np.array("thigh")).sensors) == ["thigh"]
    one = imucal.calibrate(rec, joints="knee=hinge:thigh,shank", restarts=3, seed=1)
    assert list(one.joints) == ["knee"]
    # 1e200 overflowed the norm: the hinge line's j1 became 0, silently
    big = imucal.estimate_position(g1, a1, g2, a2, rate=100.0, joint="hinge", restarts=3,
                                   seed=1, axis=(1e200 * np.array([0.0, 0.0, 1.0]),
                                                 np.array([0.0, 0.0, 2.0])))
    unit = imucal.estimate_position(g1, a1, g2, a2, rate=100.0, joint="hinge", restarts=3,
                                    seed=1, axis=([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]))
    np.testing.assert_allclose(big.o1, unit.o1, atol=1e-9)
    with pytest.raises(InputError, match="two real 3-vectors"):
        imucal.estimate_position(g1, a1, g2, a2, rate=100.0, joint="hinge",
                                 axis=np.ones((2, 3)) + 1j)
    with pytest.raises(InputError, match="units for sensor 'thigh' given twice"):
        imucal.make_recording({"thigh": {"gyr": g1, "acc": a1}}, rate=100.0,
                              units={"thigh": {"gyr": "deg/s"}, b"thigh": {"acc": "m/s^2"}})
    with pytest.raises(InputError, match="sample rate 'True' is not a number"):
        imucal.make_recording({"thigh": {"gyr": g1, "acc": a1}}, rate=True)
    hand = imucal.Recording(rate=100.0, sensors={"thigh": imucal.SensorData(
        gyr=g1.tolist(), acc=a1.tolist())}, time=np.arange(len(g1)) / 100.0)
    assert hand.select(["thigh"], 1.0, 2.0).n_samples == 100
    names = tmp_path / "map.json"
    names.write_text('{"thigh": "left_thigh"}')
    mapped = imucal.load_recording(SAMPLE, names=bytes(names))
    assert "left_thigh" in mapped.sensors


def test_what_no_recording_file_can_store_is_refused_up_front(tmp_path):
    # an empty sensor name was accepted, then h5py raised from inside; a dict in
    # extra_attrs raised h5py's "no native HDF5 equivalent" (a new-user trial)
    import imucal

    g = np.zeros((50, 3))
    with pytest.raises(InputError, match="a sensor's name is empty"):
        imucal.make_recording({"": {"gyr": g, "acc": g + 9.81}}, rate=100)
    rec = imucal.make_recording({"thigh": {"gyr": g, "acc": g + 9.81}}, rate=100)
    with pytest.raises(InputError, match=r"attribute 'd' \(dict\) cannot be stored in HDF5"):
        imucal.save_recording(rec, tmp_path / "x.h5", extra_attrs={"d": {"a": 1}})
    assert not (tmp_path / "x.h5").exists()
    imucal.save_recording(rec, tmp_path / "x.h5", extra_attrs={"subject": "p1", "n": [1, 2]})


def test_a_missing_value_in_a_pandas_float64_column_reads_as_missing():
    # pandas' nullable Float64 columns are accepted, but one pd.NA was "values that are
    # not numbers" (a new-user trial): it is a missing value, NaN
    import pandas as pd

    from imucal import estimate_axis

    rng = np.random.default_rng(0)
    frame = pd.DataFrame(rng.normal(size=(200, 3))).astype("Float64")
    frame.iloc[3, 1] = pd.NA
    with pytest.raises(InputError, match="first sensor's data contains NaN or Inf"):
        estimate_axis(frame, frame, rate=100)


def _built(rec, **change):
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    fields = dict(rate=rec.rate, sensors={"thigh": th, "shank": sh}, time=rec.time)
    return imucal.Recording(**{**fields, **change})


@pytest.mark.parametrize("change, said", [
    (dict(rate=None), "the recording's rate must be a positive number of Hz, got None"),
    (dict(time=None), r"the recording's time must be \(N,\) finite seconds"),
    ("short", r"sensor 'shank' gyr is \(1000, 3\) float64; a recording of 2000 samples"),
    ("two columns", r"sensor 'thigh' gyr is \(2000, 2\) float64"),
    ("nan", "sensor 'thigh' gyr is NaN or Inf at sample 10 and the recording lists no "
            "gaps; build it with imucal.make_recording"),
    ("dict", "sensor 'thigh': a recording's sensors map names"),
])
def test_a_recording_built_directly_is_checked(rec, change, said):
    # built by hand (the fields are public), it met no check: calibrate or joint_angles
    # ended in KeyError/TypeError/ValueError deep inside, and one NaN was blamed on the
    # motion (a new-user trial of the Python API)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    nan = th.gyr.copy()
    nan[10] = np.nan
    change = {
        "short": dict(sensors={"thigh": th, "shank": imucal.SensorData(sh.gyr[:1000],
                                                                        sh.acc[:1000])}),
        "two columns": dict(sensors={"thigh": imucal.SensorData(th.gyr[:, :2], th.acc),
                                     "shank": sh}),
        "nan": dict(sensors={"thigh": imucal.SensorData(nan, th.acc), "shank": sh}),
        "dict": dict(sensors={"thigh": {"gyr": th.gyr, "acc": th.acc}, "shank": sh}),
    }[change] if isinstance(change, str) else change
    with pytest.raises(InputError, match=said):
        _built(rec, **change)


def test_a_recording_built_directly_has_si_units_and_calibrates_as_loaded(rec):
    built = _built(rec)
    assert built.units == {"thigh": {"gyr": "rad/s", "acc": "m/s^2"},
                           "shank": {"gyr": "rad/s", "acc": "m/s^2"}}
    knee = ["knee=hinge:thigh,shank"]
    a = imucal.calibrate(built, restarts=5, seed=1, joints=knee)
    b = imucal.calibrate(rec, restarts=5, seed=1, joints=knee)
    assert np.array_equal(a.joints["knee"].j1, b.joints["knee"].j1)
    # a recording's own sensors (filtered, say) make a recording again, in SI units: the
    # file's units given with them converted them twice (a review)
    again = imucal.make_recording(rec.sensors, rate=rec.rate, units=rec.units)
    assert np.array_equal(again.sensor("foot").acc, rec.sensor("foot").acc)
    with pytest.raises(InputError, match="sensor 'thigh' is a SensorData, in rad/s and "
                                         "m/s\\^2 already; give it no other units"):
        imucal.make_recording(rec.sensors, rate=rec.rate, units={"thigh": {"gyr": "deg/s"}})
    with pytest.raises(InputError, match="the recording's units must be a mapping"):
        _built(rec, units=["deg/s"])


def test_results_recordings_and_calibrations_compare_by_value(rec, cal, tmp_path):
    # `==` raised numpy's "truth value of an array is ambiguous" on every one of them,
    # also for the round-trip check of a written calibration (a new-user trial)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    kw = dict(rate=rec.rate, restarts=5)
    a, b = (imucal.estimate_axis(th.gyr[:800], sh.gyr[:800], seed=1, **kw) for _ in "ab")
    c = imucal.estimate_axis(th.gyr[:800], sh.gyr[:800], seed=2, **kw)
    assert a == b and a != c and a != "axis"
    assert rec == imucal.load_recording(SAMPLE) and rec != rec.select(["thigh", "shank"])
    cal.write(tmp_path / "cal.json")
    back = imucal.load_calibration(tmp_path / "cal.json")
    assert back == cal and back.file is not None
    # (angles name the calibration they came from: the trial, or the file read back)
    assert imucal.joint_angles(rec, cal) == imucal.joint_angles(rec, cal)
    with pytest.raises(TypeError, match="unhashable"):
        hash(rec)


def test_calibrate_takes_a_settings_object_as_the_estimators_do(rec):
    # calibrate() took keywords only, and checked its smoothing apart from its settings
    # (an independent review of the estimator skeleton)
    from imucal.settings import CalibrateSettings

    knee = "knee=hinge:thigh,shank"
    settings = CalibrateSettings(joints=(knee,), restarts=5, seed=1, smoothing_s=2.0)
    a = imucal.calibrate(rec, settings=settings)
    b = imucal.calibrate(rec, joints=knee, restarts=5, seed=1, smoothing_s=2.0)
    assert a == b and a.joints["knee"].angle["smoothing_s"] == 2.0
    with pytest.raises(InputError, match=r"give settings or keyword arguments, not both "
                                         r"\(restarts\)"):
        imucal.calibrate(rec, settings=settings, restarts=7)
    with pytest.raises(InputError, match="smoothing_s must be from 0.01 to 600 s"):
        CalibrateSettings(smoothing_s=0.0)
    with pytest.raises(InputError, match="no joints given"):
        imucal.calibrate(rec, joints=[])


def test_a_fractional_subsample_is_refused_not_truncated():
    # resolve_subsample took 2.5 as 2 (int() drops the fraction; 0.5 was refused): a
    # review of the Raises sections
    from imucal.preprocess import resolve_subsample

    assert resolve_subsample(100.0, 10.0, 2.0) == 2
    for bad in (2.5, 0.5, 0, True):
        with pytest.raises(InputError, match="subsample must be a positive integer"):
            resolve_subsample(100.0, 10.0, bad)


def test_settings_and_joints_given_in_other_shapes(rec):
    # an array keyword beside settings raised numpy's ambiguity error, a generator of
    # joints a TypeError, a settings object's single joint string was read letter by
    # letter, and a Recording took no units=None where make_recording does (a review)
    from imucal.settings import AxisSettings, CalibrateSettings

    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    with pytest.raises(InputError, match="give settings or keyword arguments, not both"):
        imucal.estimate_axis(th.gyr, sh.gyr, rate=100.0, settings=AxisSettings(),
                             restarts=np.array([5, 6]))
    knee = "knee=hinge:thigh,shank"
    assert [j.name for j in CalibrateSettings(joints=knee).joints] == ["knee"]
    cal = imucal.calibrate(rec, joints=(j for j in [knee]), restarts=5, seed=1)
    assert list(cal.joints) == ["knee"]
    built = imucal.Recording(rate=rec.rate, sensors={"thigh": th}, time=rec.time, units=None)
    assert built.units == {"thigh": {"gyr": "rad/s", "acc": "m/s^2"}}


def test_a_rate_measured_from_time_steps_is_kept_unrounded():
    # rounded (to tidy documents), a 4 h recording at 1024 Hz written with its stamps had
    # its time axis rebuilt 0.58 samples off on reading (a review): documents round it,
    # computations keep it
    from imucal.timing import check_timing, reported_rate

    t = np.arange(50) / 1024.0000123456
    rate, _, _ = check_timing(None, t, t.size, "x")
    assert rate == 1.0 / np.median(np.diff(t)) and reported_rate(rate) == 1024.0000


def test_joint_angles_take_an_angles_settings_object(rec, cal, tmp_path):
    # the angles took keywords only, where the estimators and calibrate take settings (an
    # independent review of the estimator skeleton); the file is read when no calibration
    # object is given
    from imucal.settings import AnglesSettings

    cal.write(tmp_path / "cal.json")
    settings = AnglesSettings(calibration=str(tmp_path / "cal.json"), reference=1.0,
                              flexion_sign="+", smoothing_s=2.0)
    a = imucal.joint_angles(rec, settings=settings)
    b = imucal.joint_angles(rec, imucal.load_calibration(tmp_path / "cal.json"),
                            reference=1.0, flexion_sign="+", smoothing_s=2.0)
    assert a == b and a.joints["knee"].sign_source == "user"
    with pytest.raises(InputError, match=r"not both \(flexion_sign\)"):
        imucal.joint_angles(rec, settings=settings, flexion_sign="-")
    with pytest.raises(InputError, match="smoothing_s must be from"):
        AnglesSettings(calibration="x.json", smoothing_s=-1.0)
