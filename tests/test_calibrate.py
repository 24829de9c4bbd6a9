"""imucal.calibration.calibrate: joints from sensor names, explicit specs, the calibration file."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import axis_error_deg

from imucal import make_recording
from imucal.calibration import (
    FORMAT_VERSION,
    calibrate,
    discover_joints,
    load_calibration,
    parse_joint_spec,
)
from imucal.errors import InputError
from imucal.simulate import simulate


def _rec(names, n=20):
    z = np.zeros((n, 3))
    return make_recording({name: {"gyr": z, "acc": z + 1.0} for name in names}, rate=100.0,
                          source="names.h5")


def _joints(names):
    specs, notes = discover_joints(_rec(names))
    return {s.name: (s.kind, s.first, s.second) for s in specs}, notes


def test_joints_from_plain_names():
    joints, _ = _joints(["thigh", "shank", "foot"])
    assert joints == {"knee": ("hinge", "thigh", "shank"),
                      "ankle": ("spheroidal", "shank", "foot")}


def test_joints_of_both_legs_and_hips_from_a_pelvis():
    joints, _ = _joints(["pelvis", "left_thigh", "left_shank", "left_foot", "right_thigh",
                         "right_shank", "right_foot"])
    assert joints["left_hip"] == ("spheroidal", "pelvis", "left_thigh")
    assert joints["right_hip"] == ("spheroidal", "pelvis", "right_thigh")
    assert joints["left_knee"] == ("hinge", "left_thigh", "left_shank")
    assert joints["right_ankle"] == ("spheroidal", "right_shank", "right_foot")
    assert len(joints) == 6


def test_a_pelvis_sensor_is_found_by_every_name_calibrate_finds_it_by():
    # calibrate found hip=sacrum,left_thigh, but --sensors pelvis,left_thigh and
    # --joint hip=spheroidal:pelvis,left_thigh said "no sensor 'pelvis'"
    rec = _rec(["Sacrum", "left_thigh", "left_shank"])
    joints, _ = _joints(["Sacrum", "left_thigh", "left_shank"])
    assert joints["left_hip"] == ("spheroidal", "Sacrum", "left_thigh")
    for name in ("pelvis", "sacrum", "lower back", "hip", "left_pelvis"):
        assert rec.resolve(name) == "Sacrum"
    assert rec.resolve("left_thigh") == "left_thigh"


def test_joints_from_vendor_labels():
    joints, _ = _joints(["Pelvis", "Left Upper Leg", "Left Lower Leg", "Right Upper Leg",
                         "Right Lower Leg", "Sternum"])
    assert joints == {"left_hip": ("spheroidal", "Pelvis", "Left Upper Leg"),
                      "right_hip": ("spheroidal", "Pelvis", "Right Upper Leg"),
                      "left_knee": ("hinge", "Left Upper Leg", "Left Lower Leg"),
                      "right_knee": ("hinge", "Right Upper Leg", "Right Lower Leg")}


def test_a_segment_named_twice_is_noted_and_the_first_used():
    joints, notes = _joints(["thigh", "femur", "shank"])
    assert joints == {"knee": ("hinge", "thigh", "shank")}
    assert "'thigh' and 'femur' are both a thigh" in notes[0]


def test_no_joint_in_the_names():
    with pytest.raises(InputError, match="names.h5: no joint found from the sensor names"):
        calibrate(_rec(["a", "b"]))


def test_joint_specs():
    spec = parse_joint_spec("left_knee=hinge:left_thigh,left_shank")
    assert (spec.name, spec.kind, spec.first, spec.second) == (
        "left_knee", "hinge", "left_thigh", "left_shank")
    assert parse_joint_spec(" ankle = spheroidal : shank , foot ").second == "foot"


@pytest.mark.parametrize("bad, message", [
    ("left_knee", "use NAME=hinge:FIRST,SECOND"),
    ("knee=hinge:thigh", "use NAME=hinge:FIRST,SECOND"),
    ("knee=hinge:a,b,c", "use NAME=hinge:FIRST,SECOND"),
    ("knee=ball:thigh,shank", "unknown joint type 'ball'"),
    ("knee=hinge:thigh,Thigh", "two different sensors"),
    ("1knee=hinge:a,b", "use NAME=hinge:FIRST,SECOND"),
])
def test_bad_joint_specs(bad, message):
    with pytest.raises(InputError, match=message):
        parse_joint_spec(bad)


def test_explicit_joints_are_checked_against_the_recording():
    rec = _rec(["thigh", "shank"])
    with pytest.raises(InputError, match="no sensor 'knee_sensor'"):
        calibrate(rec, joints=["knee=hinge:thigh,knee_sensor"])
    with pytest.raises(InputError, match="joint 'knee' given twice"):
        calibrate(rec, joints=["knee=hinge:thigh,shank", "knee=spheroidal:thigh,shank"])


@pytest.fixture(scope="module")
def calibration():
    rec, truth = simulate(seed=1, mounting_seed=11, motion="protocol", duration=30.0,
                          gyr_noise=0.01, acc_noise=0.05)
    return calibrate(rec, restarts=20, seed=1), truth


def test_calibration_of_a_simulated_leg(calibration):
    cal, truth = calibration
    assert list(cal.joints) == ["knee", "ankle"]
    knee, ankle = cal.joints["knee"], cal.joints["ankle"]
    s = np.sign(knee.j1 @ truth["j1"])
    assert np.degrees(np.arccos(s * knee.j1 @ truth["j1"])) < 0.5
    assert np.degrees(np.arccos(s * knee.j2 @ truth["j2"])) < 0.5
    # the knee centre on the axis: the true centre's closest point (within 2 cm)
    for key in ("o1", "o2"):
        j = knee.j1 if key == "o1" else knee.j2
        d = np.subtract(getattr(knee, key), truth["knee"][key])
        assert np.linalg.norm(d - (d @ j) * j) < 0.02
    assert np.linalg.norm(ankle.o1 - truth["ankle"]["o1"]) < 0.02
    assert knee.verdict == "good" and knee.angle["flexion_sign"] in (1, -1)
    assert knee.axis["quality"]["verdict"] == "good" and "restarts" in knee.position
    assert ankle.angle is None and ankle.j1 is None


def test_calibration_file_round_trip(calibration, tmp_path):
    cal, _ = calibration
    path = tmp_path / "cal.json"
    cal.write(path)
    doc = json.loads(path.read_text())
    assert doc["format"] == "imucal-calibration" and doc["format_version"] == FORMAT_VERSION
    assert set(doc["joints"]["knee"]) >= {"joint", "sensors", "verdict", "j1", "j2", "o1",
                                          "o2", "angle", "axis", "position", "warnings"}
    assert doc["settings"]["joints"] == ["knee=hinge:thigh,shank",
                                         "ankle=spheroidal:shank,foot"]
    back = load_calibration(path)
    np.testing.assert_array_equal(back.joints["knee"].j1, cal.joints["knee"].j1)
    assert back.joints["knee"].angle == doc["joints"]["knee"]["angle"]
    assert back.file == str(path)


def test_load_calibration_errors(calibration, tmp_path):
    with pytest.raises(InputError, match="calibration file not found"):
        load_calibration(tmp_path / "none.json")
    # it exists, so not "not found" (an empty /dev/null was said to be missing)
    with pytest.raises(InputError, match="not a calibration file \\(not a regular file\\)"):
        load_calibration(tmp_path)
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(InputError, match="x.json: not a calibration file"):
        load_calibration(tmp_path / "x.json")
    (tmp_path / "axis.json").write_text(json.dumps({"command": "axis", "j1": [1, 0, 0]}))
    with pytest.raises(InputError, match="an imucal 'axis' result"):
        load_calibration(tmp_path / "axis.json")
    doc = calibration[0].to_document()
    # a calibrate result was told to "make one with imucal calibrate" (a fuzz review)
    (tmp_path / "fmt.json").write_text(json.dumps({**doc, "format": "x"}))
    with pytest.raises(InputError, match="an imucal 'calibrate' result whose \"format\" was "
                                         "changed: restore it or calibrate again"):
        load_calibration(tmp_path / "fmt.json")
    (tmp_path / "v9.json").write_text(json.dumps({**doc, "format_version": 9}))
    with pytest.raises(InputError, match="format version 9.*calibrate again"):
        load_calibration(tmp_path / "v9.json")
    # a failed knee may keep the axis that came before its centre stopped (calibrate
    # writes that): it loads, and is not used (hand-edited, angles were written, exit 0)
    failed = json.loads(json.dumps(doc))
    failed["joints"]["knee"]["verdict"] = "failed"
    (tmp_path / "failed.json").write_text(json.dumps(failed))
    knee = load_calibration(tmp_path / "failed.json").joints["knee"]
    assert knee.j1 is not None and knee.o1 is not None and not knee.usable
    # a byte-order mark (a Notepad edit) was "not readable as JSON"; recordings and maps
    # with one load
    (tmp_path / "bom.json").write_bytes(b"\xef\xbb\xbf" + json.dumps(doc).encode())
    assert load_calibration(tmp_path / "bom.json").joints.keys() == {"knee", "ankle"}
    doc["joints"]["knee"]["j1"] = [1, 2]
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="damaged calibration file.*knee' j1"):
        load_calibration(tmp_path / "bad.json")


@pytest.mark.parametrize(("key", "value", "match"), [
    ("zero_deg", None, "angle.zero_deg is None, not a finite number"),
    ("smoothing_s", 0, "angle.smoothing_s is 0, not a kernel half-width from 0.01 to 600 s"),
    ("smoothing_s", -3, "angle.smoothing_s is -3, not a kernel half-width"),
    # 1e-300 divided by zero, 1e9 asked for terabytes (exit 3, fuzz audit)
    ("smoothing_s", 1e-300, "angle.smoothing_s is 1e-300, not a kernel half-width"),
    ("smoothing_s", 1e9, "angle.smoothing_s is 1000000000.0, not a kernel half-width"),
    ("hinge_residual", -1, "angle.hinge_residual is -1, not a number >= 0"),
    ("acc_gyro_disagreement_deg", -5, "angle.acc_gyro_disagreement_deg is -5, not a number"),
    ("sensors", ["thigh"], "knee' sensors is \\['thigh'\\], not the names of its two sensors"),
    ("sensors", ["thigh", "shank", "foot"], "not the names of its two sensors"),
    ("hinge_residual", "x", "angle.hinge_residual is 'x', not a finite number"),
    ("flexion_sign", 0, "angle.flexion_sign is 0, not \\+1 or -1"),
    ("flexion_range_deg", [0, None], "angle.flexion_range_deg"),
    ("j1", [0, 0, 0], "knee' j1 is a zero vector"),
    ("flexion_range_deg", [60, 0], "p1 <= p99"),
    ("flexion_range_deg", [1e5, 2e5], "p1 <= p99"),
    ("zero_deg", 1e300, "angle.zero_deg is 1e\\+300, not an angle within"),
    ("zero_method", None, "angle.zero_method is None, not a text"),
    ("warnings", None, "angle.warnings is None, not a list of texts"),
    ("axis", 0.02, "knee' axis is not a JSON object"),
    # a TypeError of Python's words before; a string or true read as a number
    ("angle", [], "knee' angle is not a JSON object"),
    ("verdict", None, "knee' verdict is None, not one of good, use with care"),
    ("j1", [1, 2, "3"], "knee' j1 is \\[1, 2, '3'\\], not three numbers"),
    ("j1", [True, False, False], "knee' j1 is \\[True, False, False\\], not three numbers"),
    # read as "does not fit this recording" (exit 1) and "no usable hinge joint" (a trial)
    ("sensors", ["thigh", "thigh"], "knee' sensors names 'thigh' twice"),
    ("angle", None, "knee' has no angle block"),
    # exit 3 in angles, the last after its table of NaN angles was written (a fuzz review)
    ("j2", None, "knee' has j1 but no j2"),
    ("o2", None, "knee' has o1 but no o2"),
    ("o1", [1e308, 1e308, 0.0], "knee' o1 lies 1e\\+308 m from its sensor, not within 1000 m"),
    # null switched the fit check's test off ("limit -", "fits")
    ("hinge_residual", None, "angle.hinge_residual is None, not a finite number"),
])
def test_a_hand_edited_calibration_is_refused_on_loading(calibration, tmp_path, key, value,
                                                         match):
    # each of these ended in an internal error (exit 3) or, flexion_sign 0, in angles
    # mirrored without a word, when the file was applied
    doc = calibration[0].to_document()
    knee = doc["joints"]["knee"]
    (knee if key in ("j1", "j2", "o1", "o2", "axis", "sensors", "angle", "verdict")
     else knee["angle"])[key] = value
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="edited.json: damaged calibration file.*" + match):
        load_calibration(tmp_path / "edited.json")


@pytest.mark.parametrize(("key", "value", "match"), [
    ("sigma_s", "abc", "axis.time_offset.sigma_s is 'abc', not a finite number"),
    ("time_offset_s", None, None),  # null where nothing was applied: read as 0
    ("applied", "yes", "axis.time_offset.applied is 'yes', not true or false"),
    ("time_offset_s", float("nan"), "axis.time_offset.time_offset_s is nan, not a finite"),
    ("time_offset_s", 1e6, "time_offset_s is 1000000.0 s, beyond the \\+-10 s"),
])
def test_a_hand_edited_clock_offset_is_checked_on_loading(calibration, tmp_path, key, value,
                                                          match):
    # sigma_s "abc" was skipped as no number: the angles' band lost the offset's part
    # without a word (a new-user trial)
    doc = calibration[0].to_document()
    doc["joints"]["knee"]["axis"]["time_offset"][key] = value
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    if match is None:
        load_calibration(tmp_path / "edited.json")
        return
    with pytest.raises(InputError, match="edited.json: damaged calibration file.*" + match):
        load_calibration(tmp_path / "edited.json")


def test_a_hand_edited_axis_of_any_length_is_a_direction(calibration, tmp_path):
    # [1e300, 1e300, 0] overflowed the products with the rates (numpy's warning on stderr)
    doc = calibration[0].to_document()
    doc["joints"]["knee"]["j1"] = [1e300, 1e300, 0.0]
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    j1 = load_calibration(tmp_path / "edited.json").joints["knee"].j1
    np.testing.assert_allclose(j1, [2 ** -0.5, 2 ** -0.5, 0.0])


def test_a_joint_that_cannot_be_identified_does_not_lose_the_others():
    rec, _ = simulate(seed=3, motion="circling", duration=15.0, gyr_noise=0.01,
                      acc_noise=0.05)
    z = np.zeros((rec.n_samples, 3))
    # a foot sensor that reads nothing at all: the ankle cannot be estimated
    dead = make_recording({"thigh": rec.sensors["thigh"].__dict__,
                           "shank": rec.sensors["shank"].__dict__,
                           "foot": {"gyr": z, "acc": z + [0, 0, 9.81]}}, rate=rec.rate)
    # the simulator's accelerometers are exact (the default widens circling centres)
    cal = calibrate(dead, restarts=20, seed=1, acc_error=0.0)
    assert cal.joints["knee"].verdict == "good" and cal.joints["knee"].usable
    ankle = cal.joints["ankle"]
    assert ankle.verdict in ("failed", "not identifiable")
    assert ankle.warnings
    doc = cal.to_document()
    assert doc["joints"]["ankle"]["verdict"] == ankle.verdict


def test_a_window_too_short_for_every_joint_is_bad_input():
    # every joint came back `failed` (exit 1, a file of empty joints) where `imucal axis`
    # says the window is too short (exit 2)
    rec, _ = simulate(seed=3, motion="circling", duration=10.0)
    with pytest.raises(InputError, match=r"^<simulated>: only 17 samples left after window "
                                         r"and subsampling .* needs at least 30"):
        calibrate(rec, restarts=5, seed=1, start=5.0, end=5.5)


def test_results_and_parameters_are_documented():
    import dataclasses
    import inspect

    from test_documented import _documented_names

    from imucal.angles import JointAngle, JointAngles, joint_angles
    from imucal.calibration import Calibration, JointCalibration

    for cls in (Calibration, JointCalibration, JointAngle, JointAngles):
        missing = {f.name for f in dataclasses.fields(cls)} - _documented_names(cls.__doc__)
        assert not missing, f"{cls.__name__}: undocumented {sorted(missing)}"
    for func in (calibrate, joint_angles):
        missing = set(inspect.signature(func).parameters) - _documented_names(func.__doc__)
        assert not missing, f"{func.__name__}: undocumented {sorted(missing)}"


def test_a_failed_hinge_is_named_in_the_angles(calibration):
    import dataclasses

    from imucal.angles import joint_angles

    cal, _ = calibration
    failed = dataclasses.replace(cal.joints["knee"], name="other_knee", verdict="failed",
                                 j1=None, j2=None, o1=None, o2=None, angle=None,
                                 warnings=["other_knee: estimate stopped: no motion"])
    both = dataclasses.replace(cal, joints={**cal.joints, "other_knee": failed})
    rec, _ = simulate(seed=2, mounting_seed=11, motion="gait", duration=10.0)
    result = joint_angles(rec, both)
    assert list(result.joints) == ["knee"]
    assert "joint 'other_knee' has no angle: its calibration failed" in result.warnings[0]
    only_failed = dataclasses.replace(cal, joints={"other_knee": failed})
    with pytest.raises(InputError, match="no usable hinge joint"):
        joint_angles(rec, only_failed)


def test_a_knee_whose_own_trial_fails_the_fit_check_is_not_identifiable(real_recording):
    # 50-70 s of the shared recording: the right knee's axes are not one line at rest
    # (52-55 s) and its acc and gyro angles disagree by 88 deg; calibrate said "use with
    # care" (exit 0) and angles then refused the calibration on this very trial. The
    # still period was also reported at 2-5 s, on the window's clock
    cal = calibrate(real_recording, joints=["R=hinge:right_thigh,right_shank"], start=50.0,
                    end=70.0, restarts=10, seed=1)
    knee = cal.joints["R"]
    assert knee.verdict == "not identifiable"
    assert any("no recording can pass the fit check with this calibration: its own trial "
               "fails it (acc-gyro disagreement" in w for w in knee.warnings)
    start = knee.axis["quality"]["gravity"]["periods"][0]["start_s"]
    assert 52.0 < start < 53.0 and any("rest at 52-55 s" in w for w in knee.warnings)


def test_a_knee_calibrate_could_not_identify_loads_with_its_verdict(calibration,
                                                                     tmp_path):
    # rates 1000 times too large: calibrate (exit 1, file written as documented) stored
    # the knee's integrated zero, 37 472 deg, and `angles` called its own file damaged
    doc = calibration[0].to_document()
    knee = doc["joints"]["knee"]
    knee["verdict"] = "not identifiable"
    knee["angle"]["zero_deg"], knee["angle"]["flexion_range_deg"] = 37471.9, [-0.1, 75763.0]
    (tmp_path / "unidentified.json").write_text(json.dumps(doc))
    loaded = load_calibration(tmp_path / "unidentified.json")
    assert loaded.joints["knee"].angle["zero_deg"] == 37471.9
    assert loaded.joints["knee"].verdict == "not identifiable"
    knee["verdict"] = "good"  # an identified knee keeps the ranges checked
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="angle.zero_deg is 37471.9, not an angle within"):
        load_calibration(tmp_path / "edited.json")


@pytest.mark.parametrize("smoothing_s", [1e-300, 0.0, 1e9, float("nan")])
def test_an_implausible_fusion_kernel_is_a_usage_error(calibration, smoothing_s):
    # 1e-300 s divided by zero and 1e9 s asked for terabytes inside the fusion (exit 3)
    from imucal import joint_angles

    rec, _ = simulate(seed=2, mounting_seed=11, motion="gait", duration=8.0)
    with pytest.raises(InputError, match="smoothing_s must be from 0.01 to 600 s"):
        calibrate(rec, smoothing_s=smoothing_s)
    with pytest.raises(InputError, match="smoothing_s must be from 0.01 to 600 s"):
        joint_angles(rec, calibration[0], smoothing_s=smoothing_s)


def test_a_sensor_name_with_a_newline_is_reported_on_one_line(calibration, tmp_path):
    from conftest import run_imucal

    from imucal.writers import save_recording

    doc = calibration[0].to_document()
    doc["joints"]["knee"]["sensors"] = ["th\u00efgh\n", "shank"]
    (tmp_path / "cal.json").write_text(json.dumps(doc))
    rec, _ = simulate(seed=2, mounting_seed=11, motion="gait", duration=8.0)
    save_recording(rec, tmp_path / "walk.h5")
    run = run_imucal("angles", tmp_path / "walk.h5", "-c", tmp_path / "cal.json", text=True)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "no sensor 'th\u00efgh '" in run.stderr


def test_a_knee_names_each_warning_once_and_angles_quote_what_decided(real_recording):
    # the whole left knee of the shared recording: its centre is fitted about the axis and
    # carried every axis warning again ("position: axis: ..."), the trial's gravity check
    # came a third time from the angle; and angles quoted the knee's last warning ("no
    # recording can pass the fit check") as why it was not identifiable, not the axis'
    # blocking reason
    from imucal import joint_angles

    cal = calibrate(real_recording, joints=["L=hinge:left_thigh,left_shank"], restarts=10,
                    seed=1)
    knee = cal.joints["L"]
    assert knee.verdict == "not identifiable"
    # (10 since the relative sign's warning starts at an evidence of 2.5: 2.39 here)
    assert len(knee.warnings) == len(set(knee.warnings)) == 10
    assert sum("barely decide whether j1 and j2" in w for w in knee.warnings) == 1
    assert not [w for w in knee.warnings if w.startswith("position: axis: ")]
    assert sum("not one physical line" in w for w in knee.warnings) == 1
    reason = knee.reason()
    assert reason.startswith("axis: the angle about this axis") and "spans 191 deg" in reason
    angles = joint_angles(real_recording, cal)
    message = angles.joints["L"].check["message"]
    assert message.startswith(f"L: the calibration could not identify this joint ({reason})")


def test_a_hand_edited_reason_of_a_knee_that_is_not_identifiable_is_quoted_not_crashed(
        calibration, tmp_path):
    from imucal import joint_angles

    doc = calibration[0].to_document()
    knee = doc["joints"]["knee"]
    knee["verdict"] = knee["axis"]["quality"]["verdict"] = "not identifiable"
    knee["axis"]["quality"]["warnings"] = [17, None]
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    loaded = load_calibration(tmp_path / "edited.json")
    assert loaded.joints["knee"].reason() == "axis: 17"
    rec, _ = simulate(seed=2, mounting_seed=11, motion="gait", duration=8.0)
    message = joint_angles(rec, loaded).joints["knee"].check["message"]
    assert message.startswith("knee: the calibration could not identify this joint (axis: 17)")


def test_a_knee_whose_axis_offset_is_reworded_gives_its_axis_one_1_sigma(tmp_path):
    # the axis's offset won over the knee centre's, and the disagreement reworded the
    # axis's "uncertain" warning after the centre had copied it: the summary printed the
    # axis's 1-sigma as 9.7 and as 9.0 deg (an independent review)
    rec, _ = simulate(seed=4, motion="gait", rate=40.0, duration=30.0, gyr_noise=0.01,
                      acc_noise=0.05, soft_tissue_deg=1.0, soft_tissue_mm=2.0,
                      clock_offset={"shank": 0.05})
    knee = calibrate(rec, restarts=30, seed=1, joints=["knee=hinge:thigh,shank"]).joints["knee"]
    assert knee.axis["time_offset"].get("disagreement_s", 0) > 0
    uncertain = [w for w in knee.warnings if w.startswith("axis: the estimate is uncertain")]
    assert len(uncertain) == 1
    copies = [w.removeprefix("axis: ") for w in knee.position["quality"]["warnings"]
              if w.startswith("axis: ")]
    assert copies == knee.axis["quality"]["warnings"]


def test_a_refused_knee_axis_is_fitted_again_at_its_centres_clock():
    # the axis, fitted with the shank's 20 ms ignored, was refused ("two different axes
    # fit equally well") and kept 0 ms beside its centre's 21.3 ms: the knee had two
    # clocks, and its angles read 3.7 deg RMS off at the axis's (a new-user trial)
    rec, truth = simulate(seed=230, mounting_seed=23, motion="protocol", rate=100.0,
                          duration=30.0, gyr_noise=0.01, acc_noise=0.05, soft_tissue_deg=1.0,
                          soft_tissue_mm=2.0, clock_offset={"shank": 0.02}, gyr_bias=0.02)
    knee = calibrate(rec, seed=1, joints=["knee=hinge:thigh,shank"]).joints["knee"]
    axis, centre = knee.axis["time_offset"], knee.position["time_offset"]
    assert axis["time_offset_s"] == centre["time_offset_s"]
    assert abs(axis["time_offset_s"] - 0.02) < 0.003 and axis["found_by"] == "knee centre"
    assert knee.verdict != "not identifiable"
    e1, e2 = axis_error_deg(knee.j1, knee.j2, truth["knee"]["j1"], truth["knee"]["j2"])
    assert max(e1, e2) < 3 * max(knee.axis["quality"]["j1_uncertainty_deg"],
                                 knee.axis["quality"]["j2_uncertainty_deg"])


@pytest.mark.parametrize("warnings", [5, "text", ["the reason", 5]])
def test_the_reason_of_a_hand_edited_quality_block_is_text(warnings):
    from imucal.calibration import JointCalibration

    jc = JointCalibration("knee", "hinge", ("thigh", "shank"), verdict="not identifiable",
                          warnings=["axis: the reason"],
                          axis={"quality": {"verdict": "not identifiable",
                                            "warnings": warnings}})
    # (5 crashed with exit 3 in `angles`, "text" was quoted by its first letter)
    assert jc.reason() == "axis: the reason"


def test_a_standing_trial_says_only_that_nothing_moved():
    # a simulated standing trial: its ankle "applied" a clock offset of +191.5 ms, the
    # summary sent the user to the clocks, and the knee's gravity check came back under
    # "angle:" once the axis said only that nothing moved (an independent review)
    rec, _ = simulate(seed=3, motion="static", duration=20, rate=100)
    cal = calibrate(rec, restarts=5, seed=1)
    for jc in cal.joints.values():
        assert jc.verdict == "not identifiable"
        assert all("the sensors barely rotate" in w for w in jc.warnings), jc.warnings
        estimates = [e for e in (jc.axis, jc.position) if e]
        assert len(estimates) == (2 if jc.kind == "hinge" else 1)
        for block in (e["time_offset"] for e in estimates):
            assert block["not_estimated"] == "no motion" and not block["applied"]


def test_a_window_on_a_clock_that_starts_below_zero(tmp_path):
    # calibrate's start/end are on the recording's clock, as axis' are: -5 to 5 s of a clock
    # starting at -10 s was refused as "start must be in [0, inf)" (an independent review)
    from pathlib import Path

    from imucal import calibrate, load_recording

    rec = load_recording(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    neg = make_recording({n: {"gyr": s.gyr, "acc": s.acc} for n, s in rec.sensors.items()},
                         time=rec.time - 10.0)
    cal = calibrate(neg, start=-5, end=np.float64(5), restarts=5, seed=1,
                    joints=["knee=hinge:thigh,shank"])
    assert cal.window_s == (-5.0, 5.0) and type(cal.window_s[1]) is float
    with pytest.raises(InputError, match="window end 3 s must be after its start 5 s"):
        calibrate(neg, start=5, end=3, restarts=5, seed=1)


# ----------------------------------------------------------------- a standing trial's zero

@pytest.fixture(scope="module")
def knee_only():
    """The sample circling trial's knee (mounting 7), and its walk and truth."""
    import imucal

    cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
                           joints=["knee=hinge:thigh,shank"], restarts=20, seed=1)
    walk = imucal.load_recording("sample_data/walking.h5")
    truth = np.asarray(json.loads(open("sample_data/walking.truth.json").read())
                       ["knee_flexion_deg"])
    return cal, walk, truth


def test_a_standing_trial_sets_the_knees_zero(knee_only, tmp_path):
    # the circling trial has no still stand: its zero, the most extended posture, read
    # the sample walk 19.2 deg low; a static trial of the same mounting (a knee flexed
    # 12.7 deg as it stands) makes the angles read from that posture
    import imucal
    from imucal.calibration import load_calibration, zero_from_standing

    cal, walk, truth = knee_only
    stand, stand_truth = simulate(seed=9, mounting_seed=7, duration=5.0, motion="static")
    standing_deg = float(np.mean(stand_truth["knee_flexion_deg"]))
    assert standing_deg == pytest.approx(12.67, abs=0.01)
    zeroed = zero_from_standing(cal, stand)
    angle = zeroed.joints["knee"].angle
    assert angle["zero_trial"] == "<simulated>" and angle["zero_time_s"] == 0.0
    assert angle["zero_method"].startswith("standing trial: most extended still period")
    # the sign and the fit check's references stay the calibration trial's
    assert {k: v for k, v in angle.items() if not k.startswith("zero")} == \
        {k: v for k, v in cal.joints["knee"].angle.items() if not k.startswith("zero")}
    before = imucal.joint_angles(walk, cal)
    after = imucal.joint_angles(walk, zeroed)
    error = (after.to_frame()["knee_flexion_deg"].to_numpy() - truth) + standing_deg
    assert abs(np.mean(error)) < 0.1 and np.sqrt(np.mean(error ** 2)) < 0.6
    old = before.to_frame()["knee_flexion_deg"].to_numpy() - truth
    assert np.mean(old) == pytest.approx(-19.18, abs=0.1)
    # no "not a straight knee" and no "chosen for the opposite direction": the walk
    # decides the direction the circling trial could not, and a stand is the same posture
    # under either
    assert before.joints["knee"].warnings and not after.joints["knee"].warnings
    assert after.joints["knee"].zero["time_in"] == "standing trial <simulated>"
    path = tmp_path / "cal.json"
    zeroed.write(path)
    assert load_calibration(path) == zeroed


@pytest.mark.parametrize(("which", "phrase"), [
    ("walk", "no still period of at least 1 s: no standing to take the knees' zero from "
     "(the standing trial)"),
    ("other mounting", "(the standing trial, for the zero): knee: the calibration does not "
     "fit this recording (at rest the axis makes angles with the vertical"),
])
def test_a_standing_trial_that_cannot_give_the_zero_is_refused(knee_only, which, phrase):
    from imucal.calibration import zero_from_standing

    cal, walk, _ = knee_only
    stand = walk if which == "walk" else simulate(seed=9, mounting_seed=3, duration=5.0,
                                                  motion="static")[0]
    with pytest.raises(InputError, match="^.*$") as err:
        zero_from_standing(cal, stand)
    assert phrase in str(err.value)


def _stand(monkeypatch, knee_deg, then=None, hip_deg=0.0):
    """A static trial of the sample's mounting (7) with the knee flexed ``knee_deg``; with
    ``then`` = (t, knee_deg, hip_deg) it moves to that posture at t s (a second stand)."""
    import imucal.simulate as sim

    draw = sim._draw_motion
    deg = np.pi / 180

    def posture(rng, motion):
        m = draw(rng, motion)
        knee, hip = sim._Sines(knee_deg * deg), sim._Sines(hip_deg * deg)
        if then is not None:
            step = sim._Step(then[0], 0.1)
            knee = sim._Blend(step, knee, sim._Sines(then[1] * deg))
            hip = sim._Blend(step, hip, sim._Sines(then[2] * deg))
        return replace(m, knee_flexion=knee, hip_flexion=hip)

    monkeypatch.setattr(sim, "_draw_motion", posture)
    rec, truth = simulate(seed=9, mounting_seed=7, duration=10.0, motion="static")
    monkeypatch.setattr(sim, "_draw_motion", draw)
    return rec, truth


@pytest.fixture(scope="module")
def protocol_knee():
    """A protocol trial of the sample's mounting: it decides the flexion direction."""
    import imucal

    rec, _ = simulate(seed=11, mounting_seed=7, duration=30.0, motion="protocol")
    cal = imucal.calibrate(rec, joints=["knee=hinge:thigh,shank"], restarts=20, seed=1)
    assert abs(cal.joints["knee"].angle["sign_evidence"]) >= 0.15
    return cal


def test_two_stands_of_one_posture_give_the_zero_and_two_postures_are_refused(
        knee_only, monkeypatch):
    # a weight shift between two stands (hip 15 deg, knee 1 deg) won by noise under one
    # direction or the other: their start times refused the trial where the circling
    # calibration left the direction open (a review)
    from imucal.calibration import zero_from_standing

    cal, walk, truth = knee_only
    stand, _ = _stand(monkeypatch, 5.0, then=(5.0, 6.0, 15.0))
    zeroed = zero_from_standing(cal, stand)
    import imucal

    angles = imucal.joint_angles(walk, zeroed).to_frame()["knee_flexion_deg"].to_numpy()
    assert np.mean(angles - truth) == pytest.approx(-5.5, abs=0.7)
    # sitting after standing: which is the straighter depends on the direction
    sit, _ = _stand(monkeypatch, 5.0, then=(5.0, 90.0, 80.0))
    with pytest.raises(InputError, match=r"knee: its still periods at .* differ by 85 deg "
                       r"\(more than 5\), and which is the straighter depends on the "
                       "flexion direction"):
        zero_from_standing(cal, sit)


@pytest.mark.parametrize(("knee_deg", "refused"), [
    (0.0, None), (12.0, None), (30.0, "more flexed"), (90.0, "more flexed"),
    (-35.0, "more extended")])
def test_a_stand_the_calibration_trial_never_came_near_is_refused(
        protocol_knee, monkeypatch, knee_deg, refused):
    # a sitting trial given as the stand was taken, and every walk then failed its fit
    # check blaming clocks or straps (a review); another subject's, reading far more
    # extended, read walks up to 121 deg too flexed, "fits" (a gait-lab trial); the
    # protocol's most extended posture is about 6 deg of flexion
    from imucal.calibration import zero_from_standing

    stand, _ = _stand(monkeypatch, knee_deg, hip_deg=80.0 if knee_deg == 90 else 0.0)
    if refused is None:
        assert zero_from_standing(protocol_knee, stand).joints["knee"].angle["zero_trial"]
        return
    with pytest.raises(InputError, match=rf"knee: its knee stands \d+ deg {refused} than "
                       "the calibration trial's most extended posture"):
        zero_from_standing(protocol_knee, stand)


def test_a_standing_zero_keeps_the_angles_checks_under_the_other_direction(knee_only,
                                                                          monkeypatch):
    # the circling calibration guessed the direction and the walk decides the other: a
    # sitting "stand" read the walk -86 to -24 deg, "fits", no warning (a review)
    import imucal
    from imucal.calibration import zero_from_standing

    cal, walk, _ = knee_only
    sit, _ = _stand(monkeypatch, 90.0, hip_deg=80.0)
    angles = imucal.joint_angles(walk, zero_from_standing(cal, sit))
    assert angles.joints["knee"].sign_source != "calibration"
    assert angles.problems() == ["joint 'knee': the calibration does not fit"]
    flexed, _ = _stand(monkeypatch, 30.0, hip_deg=10.0)
    angles = imucal.joint_angles(walk, zero_from_standing(cal, flexed))
    assert angles.problems() == []
    assert any("more than 15 deg beyond the calibration's straight knee" in w
               for w in angles.joints["knee"].warnings)


def test_a_standing_trial_leaves_knees_the_calibration_could_not_identify(real_recording):
    # the shared recording's knees are not identifiable over all of it; their zeros are
    # read by no angle, so their stands' postures (0 s and 12.4 s differ) refused the whole
    # calibration (exit 2) instead of leaving it as it was (exit 1, knees marked)
    import imucal
    from imucal.calibration import zero_from_standing

    cal = imucal.calibrate(real_recording, restarts=10, seed=1,
                           joints=["left_knee=hinge:left_thigh,left_shank"])
    knee = cal.joints["left_knee"]
    assert knee.verdict == "not identifiable" and abs(knee.angle["sign_evidence"]) < 0.15
    assert zero_from_standing(cal, real_recording) == cal
