"""Calibrate every joint a recording's sensors allow, in one run and one file (issue 13).

:func:`calibrate` finds the joints from the sensor names (or takes them from explicit
specs, :func:`parse_joint_spec`) and estimates each: a knee is a hinge (``j1``, ``j2`` and
the knee centre on the axis, ``o1``, ``o2``), an ankle and a hip are spheroidal (``o1``,
``o2``). For every hinge it also measures what :func:`imucal.joint_angles` needs to apply
the calibration to other recordings: the flexion sign and zero, and the reference
statistics of the "does it still fit" check. The file format is in docs/json.md
(section "Calibration file"); :func:`load_calibration` reads it back.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import __version__
from .equality import ByValue
from .errors import ImucalError, InputError
from .quality import NOT_IDENTIFIABLE, is_still
from .recording import Recording, check_recording, estimator_window, input_info
from .sensor_names import normalised_name, segment_of
from .settings import ACC_ERROR_M_S2, MAX_TIME_OFFSET_S, OFFSET_SEARCH_S
from .timing import reported_rate

FORMAT = "imucal-calibration"
#: 2: the angle block's ``hinge_residual`` is relative to the angular rates, and its
#: statistics are taken with the second sensor at the axis' clock offset (version 1
#: files compare with neither: calibrate again).
FORMAT_VERSION = 2
KINDS = ("hinge", "spheroidal")
#: Segment pairs of the joints found from sensor names: (joint, kind, first, second).
JOINT_TYPES = (
    ("hip", "spheroidal", "pelvis", "thigh"),
    ("knee", "hinge", "thigh", "shank"),
    ("ankle", "spheroidal", "shank", "foot"),
)
_SPEC = re.compile(r"^\s*([A-Za-z][A-Za-z0-9_]*)\s*=\s*([a-z]+)\s*:\s*([^,]+),([^,]+)\s*$")
SPEC_USAGE = "use NAME=hinge:FIRST,SECOND or NAME=spheroidal:FIRST,SECOND, e.g. " \
             "left_knee=hinge:left_thigh,left_shank"


@dataclass(frozen=True)
class JointSpec:
    """One joint to calibrate: ``name`` (``knee``, ``left_knee``, ...), ``kind`` (hinge or
    spheroidal) and the two sensor names, proximal first (thigh before shank)."""

    name: str
    kind: str
    first: str
    second: str


@dataclass(eq=False)
class JointCalibration(ByValue):
    """The calibration of one joint.

    Attributes
    ----------
    name, kind, sensors : the joint (``sensors`` = (first, second) as in the recording).
    j1, j2 : hinge only: unit axis in the first / second sensor's frame, the same physical
        direction (None for a spheroidal joint or a failed estimate).
    o1, o2 : vector from the joint centre to the first / second sensor's origin, each in
        its sensor's frame, m (for a hinge: the point of the axis closest to both sensors).
    verdict : the joint's verdict: the worse of its estimates' (``good``, ``use with
        care``, ``not identifiable``), or ``failed`` when an estimate stopped.
    warnings : plain-language warnings of its estimates (and the error that stopped one).
    axis, position : the JSON documents of :func:`imucal.report.axis_report` /
        ``position_report`` (full quality blocks), or None.
    angle : hinge only: what applying the calibration needs (:func:`imucal.angles.
        reference_statistics`): flexion sign and zero, calibration-trial statistics.
    """

    name: str
    kind: str
    sensors: tuple[str, str]
    verdict: str
    j1: np.ndarray | None = None
    j2: np.ndarray | None = None
    o1: np.ndarray | None = None
    o2: np.ndarray | None = None
    warnings: list[str] = field(default_factory=list)
    axis: dict | None = None
    position: dict | None = None
    angle: dict | None = None

    def reason(self) -> str:
        """Why the joint is not usable, as the refusal of ``calibrate`` and the angles of
        a joint that is not identifiable quote it.

        Returns
        -------
        str
            The error that stopped its estimate (its last warning), or the first warning
            of the estimate that cannot identify it (blocking reasons come first), with a
            contradicted given clock offset named beside it, or else why its angle could
            not be calibrated (its last warning); "no reason recorded" when there is
            none (a hand-edited file).
        """
        if self.verdict == "failed":
            return self.warnings[-1] if self.warnings else "no reason recorded"
        for what, doc in (("axis", self.axis), ("position", self.position)):
            quality = doc.get("quality") if isinstance(doc, dict) else None
            if (isinstance(quality, dict) and quality.get("verdict") == NOT_IDENTIFIABLE
                    and isinstance(quality.get("warnings"), list) and quality["warnings"]):
                first, *others = quality["warnings"]
                from .time_offset import refusal_reason

                return f"{what}: {refusal_reason(first, others)}"
        return self.warnings[-1] if self.warnings else "no reason recorded"

    @property
    def usable(self) -> bool:
        """Whether the joint has its vectors (an estimate that stopped leaves none) and
        did not fail (a knee whose axis came but whose centre stopped keeps its axis)."""
        return (self.verdict != "failed" and self.o1 is not None
                and (self.kind != "hinge" or self.j1 is not None))


@dataclass(eq=False)
class Calibration(ByValue):
    """Result of :func:`calibrate` (or :func:`load_calibration`).

    Attributes
    ----------
    joints : joint name -> :class:`JointCalibration` (hips, knees, ankles; no side first,
        then left, then right).
    source : path of the calibration trial's recording.
    window_s : (start, end) of the time used, s on that recording's time axis.
    sample_rate_hz : its sample rate, Hz.
    settings : restarts, seed, window, time-offset mode, smoothing and the joint specs.
    version : imucal's version that made it.
    sensors : per sensor used, what the file said about it (serial, label, ...) and its
        units in the file.
    file : the calibration file it was read from (:func:`load_calibration`), else None;
        not compared by ``==`` (a calibration equals the one written and read back).
    """

    joints: dict[str, JointCalibration]
    source: str
    window_s: tuple[float, float]
    sample_rate_hz: float
    settings: dict
    version: str = __version__
    sensors: dict = field(default_factory=dict)
    file: str | None = field(default=None, compare=False)

    @property
    def hinges(self) -> list[JointCalibration]:
        """The joints calibrated as hinges (the knees), in file order."""
        return [j for j in self.joints.values() if j.kind == "hinge"]

    def to_document(self) -> dict:
        """The calibration file's JSON document (docs/json.md, "Calibration file").

        Returns
        -------
        document : dict
            Plain JSON values (NaN and Inf as None): ``format``, ``format_version``,
            ``imucal_version``, ``command`` ("calibrate"), ``input`` (trial path,
            ``sample_rate_hz`` in Hz, ``window_s`` in s, sensors), ``settings``, ``units``
            and ``joints``: per joint its kind, sensors, verdict, warnings, ``j1``/``j2``
            (hinges; unit vectors in the first / second sensor's frame), ``o1``/``o2``
            (m, each in its sensor's frame), the angle block (hinges) and the full axis /
            position documents.

        Examples
        --------
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
        ...                        restarts=10, seed=1)
        >>> doc = cal.to_document()
        >>> doc["format"], doc["format_version"], list(doc["joints"])
        ('imucal-calibration', 2, ['knee', 'ankle'])
        >>> knee = doc["joints"]["knee"]
        >>> knee["joint"], knee["sensors"], [round(x, 2) for x in knee["j1"]]
        ('hinge', ['thigh', 'shank'], [-0.42, -0.35, 0.84])
        """
        from .report import clean

        joints = {}
        for j in self.joints.values():
            entry = {"joint": j.kind, "sensors": list(j.sensors), "verdict": j.verdict,
                     "warnings": list(j.warnings)}
            if j.kind == "hinge":
                entry["j1"], entry["j2"] = _vec(j.j1), _vec(j.j2)
            entry["o1"], entry["o2"] = _vec(j.o1), _vec(j.o2)
            if j.kind == "hinge":
                entry["angle"] = j.angle
            entry["axis"], entry["position"] = j.axis, j.position
            joints[j.name] = entry
        return clean({
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "imucal_version": self.version,
            "command": "calibrate",
            "input": {"path": self.source, "sample_rate_hz": self.sample_rate_hz,
                      "window_s": list(self.window_s), "sensors": self.sensors},
            "settings": self.settings,
            "units": {"j1": "unit vector", "j2": "unit vector", "o1": "m", "o2": "m",
                      "angle": "deg (hinge_residual: ratio)"},
            "joints": joints,
        })

    def write(self, path: str | Path) -> None:
        """Write :meth:`to_document` as JSON to ``path`` (atomically: a temporary file
        beside it, then renamed; :func:`load_calibration` reads it back).

        Raises
        ------
        InputError
            ``path`` (or the temporary file beside it) cannot be written
            (:func:`imucal.atomic.write_atomic`).

        Examples
        --------
        >>> import json, tempfile
        >>> from pathlib import Path
        >>> import imucal
        >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
        ...                        restarts=10, seed=1)
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     cal.write(Path(folder) / "cal.json")
        ...     doc = json.loads((Path(folder) / "cal.json").read_text())
        >>> doc["command"], sorted(doc["joints"]), doc["units"]["o1"]
        ('calibrate', ['ankle', 'knee'], 'm')
        """
        from .atomic import write_text_atomic
        from .report import dumps

        write_text_atomic(path, dumps(self.to_document()))


def _vec(v):
    return None if v is None else [float(x) for x in v]


# ----------------------------------------------------------------------------- joints


def sensor_segment(name: str) -> tuple[str | None, str | None]:
    """Side and segment of a sensor name.

    Returns
    -------
    side : str or None
        ``"left"``, ``"right"`` or None (no side in the name; always None for the pelvis,
        which serves both hips).
    segment : str or None
        ``"thigh"``, ``"shank"``, ``"foot"`` or ``"pelvis"`` (synonyms included,
        :data:`imucal.sensor_names.SEGMENT_SYNONYMS`); None for any other name.

    Examples
    --------
    >>> from imucal.calibration import sensor_segment
    >>> sensor_segment("left_thigh"), sensor_segment("Shank"), sensor_segment("wrist")
    (('left', 'thigh'), (None, 'shank'), (None, None))
    """
    side, segment = segment_of(name)
    return (None, segment) if segment == "pelvis" else (side, segment)


def discover_joints(recording: Recording) -> tuple[list[JointSpec], list[str]]:
    """The joints the sensor names of ``recording`` allow.

    Per side (``left``, ``right`` or none): knee from thigh + shank, ankle from shank +
    foot, hip from the pelvis + thigh (one pelvis serves both hips). Names: ``knee`` etc.
    without a side, ``left_knee`` with one.

    Returns
    -------
    specs : list of JointSpec
        Hips, then knees, then ankles; within each, no side first, then left, then right.
        Empty when no pair of segments is found.
    notes : list of str
        One note per segment named by two sensors (the first one is used).

    Examples
    --------
    >>> import imucal
    >>> from imucal.calibration import discover_joints
    >>> specs, notes = discover_joints(imucal.load_recording("sample_data/circling.h5"))
    >>> [(s.name, s.kind, s.first, s.second) for s in specs], notes
    ([('knee', 'hinge', 'thigh', 'shank'), ('ankle', 'spheroidal', 'shank', 'foot')], [])
    """
    found: dict[tuple[str | None, str], str] = {}
    notes = []
    for name in recording.sensors:
        side, segment = sensor_segment(name)
        if segment is None:
            continue
        key = (side, segment)
        if key in found:
            notes.append(f"sensors '{found[key]}' and '{name}' are both a "
                         f"{(side + ' ') if side else ''}{segment}; used '{found[key]}' "
                         "(name the joints explicitly to choose)")
            continue
        found[key] = name
    pelvis = found.get((None, "pelvis"))
    sides = sorted({s for s, seg in found if seg != "pelvis"}, key=lambda s: (s is not None, s))
    specs = []
    for joint, kind, first, second in JOINT_TYPES:
        for side in sides:
            a = pelvis if first == "pelvis" else found.get((side, first))
            b = found.get((side, second))
            if a is not None and b is not None:
                specs.append(JointSpec(f"{side}_{joint}" if side else joint, kind, a, b))
    return specs, notes


def parse_joint_spec(text: str) -> JointSpec:
    """``"left_knee=hinge:left_thigh,left_shank"`` -> :class:`JointSpec`. Sensor names are
    checked against a recording later.

    Returns
    -------
    JointSpec
        Name, kind (``hinge`` or ``spheroidal``) and the two sensor names as written
        (stripped), proximal first.

    Raises
    ------
    InputError
        ``text`` is not ``NAME=KIND:FIRST,SECOND``, the kind is neither hinge nor
        spheroidal, or the two sensor names are the same; the message gives the
        expected form.

    Examples
    --------
    >>> from imucal.calibration import parse_joint_spec
    >>> parse_joint_spec("left_knee=hinge:left_thigh,left_shank")
    JointSpec(name='left_knee', kind='hinge', first='left_thigh', second='left_shank')
    """
    m = _SPEC.match(str(text))
    if m is None:
        raise InputError(f"joint '{text}': {SPEC_USAGE}")
    name, kind, first, second = (g.strip() for g in m.groups())
    if kind not in KINDS:
        raise InputError(f"joint '{text}': unknown joint type '{kind}'; use hinge or "
                         "spheroidal")
    if not first or not second or normalised_name(first) == normalised_name(second):
        raise InputError(f"joint '{text}': needs two different sensors; {SPEC_USAGE}")
    return JointSpec(name, kind, first, second)


def _joint_specs(recording: Recording, joints) -> tuple[list[JointSpec], list[str]]:
    if joints is None:
        specs, notes = discover_joints(recording)
        if not specs:
            raise InputError(
                f"{recording.source}: no joint found from the sensor names "
                f"({', '.join(recording.sensors)}); name sensors thigh/shank/foot/pelvis "
                "(with left_/right_) or give the joints, e.g. knee=hinge:A,B")
        return specs, notes
    specs = [j if isinstance(j, JointSpec) else parse_joint_spec(j) for j in joints]
    if not specs:
        raise InputError("no joints given")
    seen = set()
    out = []
    for s in specs:
        if s.name in seen:
            raise InputError(f"joint '{s.name}' given twice")
        seen.add(s.name)
        out.append(JointSpec(s.name, s.kind, recording.resolve(s.first),
                             recording.resolve(s.second)))
    return out, []


# ----------------------------------------------------------------------------- calibrate


def calibrate(recording: Recording, *, settings=None, joints=None, restarts: int = 100,
              seed: int | None = None, start: float | None = None, end: float | None = None,
              time_offset: float | str = "auto", offset_search: float = OFFSET_SEARCH_S,
              smoothing_s: float | None = None, sign: str = "auto", j2_sign: str = "auto",
              acc_error: float = ACC_ERROR_M_S2, standing=None) -> Calibration:
    """Calibrate every joint of ``recording`` (module docstring).

    Parameters
    ----------
    recording
        The calibration trial (ideally the paper's protocol: leg and foot circling, a few
        flexions, some walking, and a still standing moment for the angle's zero).
    settings
        A :class:`imucal.settings.CalibrateSettings` holding every setting below but the
        window (``start``, ``end``), instead of them (not both).
    joints
        None: found from the sensor names (:func:`discover_joints`); or a list of specs
        (``"left_knee=hinge:left_thigh,left_shank"`` or :class:`JointSpec`).
    restarts, seed, start, end, time_offset, offset_search
        As in :func:`imucal.estimate_axis` / :func:`imucal.estimate_position` (window in s
        on the recording's time axis); every joint uses the same.
    smoothing_s
        The angle fusion's kernel (:data:`imucal.fusion.SMOOTHING_S`), stored for
        :func:`imucal.joint_angles`.
    acc_error
        1-sigma of each accelerometer's error at 1 g, m/s^2, for the joint centres'
        uncertainty (:func:`imucal.estimate_position`).
    sign, j2_sign
        Every hinge axis's overall and relative sign, as in :func:`imucal.estimate_axis`
        ("auto", or "+x" ... "-z" to pin that component of j1 / j2 positive).
    standing
        A standing trial of the same mounting (a :class:`imucal.recording.Recording`, or
        its file, read with :func:`imucal.load_recording`): every hinge's zero is then its
        most extended still period (a straight knee, as a lab's static trial defines it)
        instead of the calibration trial's (:func:`zero_from_standing`); None (default):
        the settings' ``standing`` file, if any.

    Returns
    -------
    Calibration
        Per joint (``joints``, keyed ``knee``, ``left_knee``, ``ankle``, ``hip`` ...): the
        sensors, verdict, warnings, ``j1``/``j2`` (hinges), ``o1``/``o2`` (m), the full
        quality documents and, for hinges, the angle's reference statistics; plus the
        recording, imucal's version and the settings. ``write(path)`` saves it
        (docs/json.md, "Calibration file").

    Raises
    ------
    InputError
        ``recording`` is not a Recording, ``joints`` is an empty list, a joint spec that
        cannot be parsed or names a missing sensor, no joint the sensors allow, invalid
        settings, a window outside the recording, or bad input that stops every joint's estimate
        (a window too short for any: the first joint's error); a ``standing`` trial
        :func:`zero_from_standing` refuses. A joint whose estimate
        stops (not identifiable, a sensor gap in the window) is kept with verdict
        ``failed`` and the reason in its warnings; the others are unaffected.

    References
    ----------
    Seel, Schauer, Raisch (2012), IEEE CCA (the axes and positions); Seel, Raisch,
    Schauer (2014), Sensors 14:6891 (the knee centre on the axis, the flexion angle).

    Examples
    --------
    >>> import imucal
    >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
    ...                        restarts=20, seed=1, acc_error=0.0)  # simulated: exact
    >>> sorted(cal.joints), cal.joints["knee"].verdict
    (['ankle', 'knee'], 'good')
    """
    from .fusion import SMOOTHING_S
    from .settings import CalibrateSettings, as_real, resolve

    check_recording(recording)
    if isinstance(joints, str | JointSpec):  # one joint (a str was read letter by letter)
        joints = [joints]
    elif joints is not None:
        joints = list(joints)  # (a generator has no len, a review)
    if joints is not None and len(joints) == 0:
        raise InputError("no joints given")
    # usage errors before any joint runs (each joint's estimate would stop on them, and
    # they came back as joints marked `failed`); the window against the recording too
    checked = resolve(CalibrateSettings, settings, joints=tuple(joints or ()),
                      restarts=restarts, seed=seed, time_offset=time_offset,
                      offset_search=offset_search, acc_error=acc_error, sign=sign,
                      j2_sign=j2_sign, smoothing_s=smoothing_s)
    # the window is on the recording's clock, which may start below 0 (AxisSettings'
    # start/end count from the first sample: -5 to 5 s of a clock starting at -10 s was
    # refused as "start must be in [0, inf)", an independent review)
    asked = recording.window_slice(start, end)
    # the checked values from here on: a 0-d array (a number to the checks) stopped the
    # calibration file's JSON at the end
    restarts, seed, time_offset = checked.restarts, checked.seed, checked.time_offset
    offset_search, acc_error = checked.offset_search, checked.acc_error
    signs = {"sign": checked.sign, "j2_sign": checked.j2_sign}
    start, end = (None if v is None else as_real(v) for v in (start, end))
    smoothing_s = SMOOTHING_S if checked.smoothing_s is None else checked.smoothing_s
    specs, notes = _joint_specs(recording, list(checked.joints) or None)
    out: dict[str, JointCalibration] = {}
    windows, stopped = [], []
    for spec in specs:
        jc, window, err = _calibrate_joint(recording, spec, restarts=restarts, seed=seed,
                                           start=start, end=end, time_offset=time_offset,
                                           offset_search=offset_search,
                                           smoothing_s=smoothing_s, acc_error=acc_error,
                                           signs=signs)
        jc.warnings = notes + jc.warnings
        out[spec.name] = jc
        if window is not None:
            windows.append(window)
        stopped.append(err)
    if all(isinstance(err, InputError) for err in stopped):
        # bad input for every joint (a window too short for any estimate) is the
        # calibration's, as for `imucal axis`: not a file of joints marked `failed`
        message = str(stopped[0])  # the estimators' messages name no file
        raise InputError(message if message.startswith(recording.source)
                         else f"{recording.source}: {message}")
    t0 = float(recording.time[0])
    window_s = (min((w[0] for w in windows), default=t0 + asked.start / recording.rate),
                max((w[1] for w in windows), default=t0 + asked.stop / recording.rate))
    used = sorted({s for spec in specs for s in (spec.first, spec.second)})
    cal = Calibration(
        joints=out, source=recording.source, window_s=window_s,
        sample_rate_hz=reported_rate(recording.rate),
        settings={"restarts": restarts, "seed": seed, "start": start, "end": end,
                  "time_offset": time_offset, "offset_search_s": offset_search,
                  "smoothing_s": smoothing_s,
                  "acc_error_m_s2": acc_error, **signs,
                  "joints": [f"{s.name}={s.kind}:{s.first},{s.second}" for s in specs]},
        sensors={n: dict(recording.sensor_info.get(n, {}), units_in_file=dict(
            recording.units.get(n, {}))) for n in used},
    )
    if standing is None and checked.standing is not None:
        standing = standing_file(checked.standing, recording.source)
    return cal if standing is None else zero_from_standing(cal, standing)


def standing_file(standing: str, file: str) -> str:
    """The standing trial of the calibration trial ``file``: ``standing`` with
    ``{folder}`` replaced by ``file``'s folder (``.`` for none): a study of
    ``s*/calibration.h5`` with ``--standing '{folder}/static.h5'`` takes each subject's
    own.

    Returns
    -------
    str
        The standing trial's path.

    Examples
    --------
    >>> from imucal.calibration import standing_file
    >>> standing_file("{folder}/static.h5", "s01/calibration.h5")
    's01/static.h5'
    >>> standing_file("{folder}/static.h5", "cal.h5"), standing_file("st.h5", "s01/cal.h5")
    ('./static.h5', 'st.h5')
    """
    import os

    return standing.replace("{folder}", os.path.dirname(file.rstrip("/")) or ".")


def zero_from_standing(cal: Calibration, standing) -> Calibration:
    """``cal`` with every hinge's zero taken from a standing trial of the same mounting:
    the raw angle of its most extended still period (>= 1 s), measured with ``cal``
    (:func:`imucal.joint_angles` with ``reference="standing"``), becomes ``zero_deg``
    (``zero_trial`` names the trial). A calibration trial without a still stand otherwise
    sets 0 deg at its most extended posture, 5-7 deg of flexion in simulated walking
    protocols (a gait-lab trial: peak flexion read 57-59.5 deg for 64-66 deg).

    Parameters
    ----------
    cal
        The calibration (its hinges' flexion sign and fit-check references stay).
    standing
        The standing trial: a :class:`imucal.recording.Recording` or its file.

    Returns
    -------
    Calibration
        A new calibration; hinges without an ``angle`` block (not identifiable, failed)
        and spheroidal joints as they were.

    Raises
    ------
    InputError
        The standing trial cannot be read, lacks a hinge's sensors, has no still period
        of at least 1 s, or the calibration does not fit it (re-strapped in between): a
        zero from it would be wrong, so nothing is made (the message names the trial).

    Examples
    --------
    >>> import imucal
    >>> from imucal.calibration import zero_from_standing
    >>> from imucal.simulate import simulate
    >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
    ...                        joints=["knee=hinge:thigh,shank"], restarts=10, seed=1)
    >>> stand, truth = simulate(seed=9, mounting_seed=7, duration=5.0, motion="static")
    >>> knee = zero_from_standing(cal, stand).joints["knee"].angle
    >>> knee["zero_method"][:14], knee["zero_trial"]
    ('standing trial', '<simulated>')
    """
    from .angles import joint_angles
    from .loaders import load_recording
    from .rest import STILL_MIN_S

    if not isinstance(standing, Recording):
        try:
            standing = load_recording(standing)
        except InputError as err:
            raise InputError(f"{err} (the standing trial)") from None
    check_recording(standing)
    hinges = [j for j in cal.joints.values() if j.angle is not None]
    if not hinges:
        return cal
    try:
        # under either flexion direction: which still period is the most extended may
        # depend on it, and a trial too weak to decide leaves it to each recording
        measured = {sign: joint_angles(standing, cal, reference="standing",
                                       flexion_sign=text)
                    for sign, text in ((1, "+"), (-1, "-"))}
    except ImucalError as err:
        text = str(err)
        if "no still period" in text:  # (joint_angles' advice, a time, is not for this)
            text = (f"{standing.source}: no still period of at least {STILL_MIN_S:g} s: no "
                    "standing to take the knees' zero from")
        raise InputError(f"{text} (the standing trial)") from None
    # (a knee the calibration could not identify keeps its zero: no angle is read with it)
    usable = [jc for jc in hinges if measured[1].joints[jc.name].check[
        "calibration_verdict"] != "not identifiable"]
    _check_posture(standing, usable, measured)
    measured = {jc.name: measured[int(jc.angle["flexion_sign"])].joints[jc.name]
                for jc in usable}
    misfits = [w for jc in usable if not measured[jc.name].fits
               for w in measured[jc.name].warnings if "does not fit" in w]
    if misfits:
        raise InputError(f"{standing.source} (the standing trial, for the zero): "
                         f"{'; '.join(misfits)}; no zero taken from it")
    joints = dict(cal.joints)
    for jc in usable:
        zero = measured[jc.name].zero
        angle = dict(jc.angle, zero_deg=zero["raw_deg"], zero_time_s=zero["time_s"],
                     zero_method=f"standing trial: {zero['method']}",
                     zero_trial=standing.source)
        joints[jc.name] = replace(jc, angle=angle)
    return replace(cal, joints=joints)


#: How far, deg, a standing trial's two candidate stands (the most extended still period
#: under either flexion direction) may differ and still be one posture: a weight shift
#: between two stands moves the knee a degree or two, and one of them won by noise (their
#: start times refused ordinary trials, a review).
STAND_SPREAD_DEG = 5.0

#: How much more flexed, deg, than the calibration trial's most extended posture a
#: standing trial's knee may be (where the calibration decided the direction): a sitting
#: trial given as the stand (84 deg more) was taken, and every walk then failed its fit
#: check blaming clocks or straps (a review).
STAND_FLEXED_DEG = 15.0

#: How much more extended, deg, than the calibration trial's most extended posture a
#: standing trial's knee may be there: another subject's static trial was taken (10 of
#: 11 such pairings accepted read -23 to -126 deg; the right stands -1.9 to +7.5 deg, a
#: gait-lab trial), and its walks read up to 121 deg too flexed, "fits". Wider than the
#: flexed side: a calibration trial may never quite straighten the knee.
STAND_EXTENDED_DEG = 20.0


def _check_posture(standing, hinges, measured) -> None:
    """Refuse a standing trial that is no stand: where the calibration trial decided the
    flexion direction, a knee more flexed than that trial's most extended posture by more
    than :data:`STAND_FLEXED_DEG`, or more extended by more than
    :data:`STAND_EXTENDED_DEG`; where it did not, still periods whose postures differ by
    more than :data:`STAND_SPREAD_DEG`, since which is the straighter then depends on the
    direction each recording decides."""
    from .angles import SIGN_EVIDENCE_MIN

    def turn(a, b):  # a - b, deg, on the circle
        return (a - b + 180.0) % 360.0 - 180.0

    where = f"{standing.source} (the standing trial, for the zero): "
    for jc in hinges:
        plus, minus = (measured[s].joints[jc.name].zero for s in (1, -1))
        if abs(jc.angle["sign_evidence"]) >= SIGN_EVIDENCE_MIN:
            sign = int(jc.angle["flexion_sign"])
            chosen = plus if sign == 1 else minus
            flexed = sign * turn(chosen["raw_deg"], jc.angle["zero_deg"])
            if flexed > STAND_FLEXED_DEG:
                raise InputError(
                    f"{where}{jc.name}: its knee stands {flexed:.0f} deg more flexed than "
                    "the calibration trial's most extended posture (more than "
                    f"{STAND_FLEXED_DEG:g}): no straight stand (sitting? another "
                    "subject's trial?)")
            if flexed < -STAND_EXTENDED_DEG:
                raise InputError(
                    f"{where}{jc.name}: its knee stands {-flexed:.0f} deg more extended "
                    "than the calibration trial's most extended posture (more than "
                    f"{STAND_EXTENDED_DEG:g}): no knee of this mounting bends so (another "
                    "subject's trial?)")
        elif abs(turn(plus["raw_deg"], minus["raw_deg"])) > STAND_SPREAD_DEG:
            raise InputError(
                f"{where}{jc.name}: its still periods at {minus['time_s']:g} s and "
                f"{plus['time_s']:g} s differ by "
                f"{abs(turn(plus['raw_deg'], minus['raw_deg'])):.0f} deg (more than "
                f"{STAND_SPREAD_DEG:g}), and which is the straighter depends on the "
                "flexion direction, which the calibration trial did not decide; give a "
                "trial of one standing posture")


def _calibrate_joint(recording, spec: JointSpec, *, restarts, seed, start, end, time_offset,
                     offset_search, smoothing_s, acc_error, signs):
    """One joint; an estimate that stops leaves verdict ``failed`` and its reason."""
    jc = JointCalibration(spec.name, spec.kind, (spec.first, spec.second), verdict="failed")
    names = [spec.first, spec.second]
    try:
        used = recording.select(names, start, end)
        # the estimators get the window in its context, as the axis and position
        # commands do: their times (still periods) are then the recording's, not the
        # window's (a warning said "rest at 2-5 s" for 52-55 s)
        around, window = estimator_window(recording, names, start, end)
        _estimate_joint(jc, around, spec, input_info(recording, names, around),
                        {"rate": used.rate, "restarts": restarts, "seed": seed,
                         "time_offset": time_offset, "offset_search": offset_search,
                         **window}, acc_error, signs)
    except ImucalError as err:
        jc.warnings.append(f"{spec.name}: estimate stopped: {err}")
        return jc, None, err
    _verdict_of_estimates(jc)
    if spec.kind == "hinge":
        _angle_reference(jc, used, around, smoothing_s)
    return jc, (float(used.time[0]), float(used.time[-1]) + 1.0 / used.rate), None


def _estimate_joint(jc: JointCalibration, around, spec: JointSpec, info: dict, common: dict,
                    acc_error, signs) -> None:
    """The hinge axis (a hinge) and the joint centre into ``jc``: their reports (the
    calibration file's ``axis`` and ``position``) and vectors."""
    from . import estimate_axis, estimate_position
    from .axis import DOUBTED_SIGN, refuse_doubted_sign
    from .report import axis_report, position_report

    s1, s2 = around.sensors[spec.first], around.sensors[spec.second]
    axis = None
    if spec.kind == "hinge":
        axis = estimate_axis(s1.gyr, s2.gyr, acc1=s1.acc, acc2=s2.acc, **common, **signs)
        # (asked again below, once the knee centre has confirmed or replaced the offset:
        # the centre then has no "axis: " copy of it)
        axis.blocking[:] = [b for b in axis.blocking if not b.startswith(DOUBTED_SIGN)]
        jc.axis = axis_report(axis, input_info=info)
        jc.j1, jc.j2 = np.asarray(axis.j1, float), np.asarray(axis.j2, float)
    pos = estimate_position(s1.gyr, s1.acc, s2.gyr, s2.acc, joint=spec.kind, axis=axis,
                            acc_error=acc_error, **common)
    if axis is not None:  # one clock for the knee's axis and centre
        if common["time_offset"] == "auto":
            axis, pos = _one_clock(axis, pos, s1, s2, common, acc_error, signs)
        else:
            _one_check(axis, pos, s1, s2, common)
        axis = refuse_doubted_sign(axis, advice="")
        jc.axis = axis_report(axis, input_info=info)
        jc.j1, jc.j2 = np.asarray(axis.j1, float), np.asarray(axis.j2, float)
    jc.position = position_report(pos, input_info=info)
    jc.o1, jc.o2 = np.asarray(pos.o1, float), np.asarray(pos.o2, float)


def _one_clock(axis, pos, s1, s2, common: dict, acc_error, signs):
    """(axis, position) of a hinge at one clock offset: both estimates read the same two
    sensors, but each "auto" search sees the offset through its own constraint. Where
    they applied different offsets (:func:`imucal.time_offset.disagree`), the one both
    constraints fit best (:func:`imucal.time_offset.choose`) is the joint's, and the
    estimate that had the other is fitted again at it (``found_by`` names the estimate
    that found it, ``own`` keeps the other's own search).

    Why: on gait the sensors wobble on soft tissue in step with every stride, and a shift
    of the rates mimics part of that wobble; the axis's search (eq. 1, rates only) then
    applied 18-33 ms to clocks in sync (7 of 28 knees, simulated gait, 1 deg / 2 mm) and
    missed or misread a shank 20 ms late (0, 30-41 ms in 7 of 8), while the centre's
    (eq. 3, specific forces) found 0.0 and 18.4-20.7 ms at cost ratios 12-110. The
    angles read the knee at the axis's offset: 1.9-5.8 deg RMS off, 63-82 % within 3
    sigma, "fits". At the chosen offset: 0.19-0.73 deg (docs/accuracy.md). Sharp is not
    unbiased (circling with a gyroscope bias: the centre's offset 12 ms off at a 1-sigma
    of 0.6 ms, an independent review), so half the two searches' difference joins the
    offset's 1-sigma (:func:`imucal.time_offset.adopt`). A refused estimate overrules
    nothing: where one of the two is refused, the other's offset is the joint's without
    a vote (the refused one fitted again at it); where both are, each keeps its own."""
    from . import axis as axis_module
    from . import position as position_module
    from .time_offset import agree, choose, confirm, disagree, note_disagreement

    a, p = axis.time_offset, pos.time_offset
    if not (isinstance(a, dict) and isinstance(p, dict) and disagree(a, p)):
        if isinstance(p, dict) and p.get("applied") and not pos.blocking:
            confirm(axis, "knee centre")  # the same offset, specific forces
            _copy_axis_warnings(pos, axis)
            if not axis.blocking:
                agree(a, p)
        return axis, pos
    # (a centre on a refused axis carries the axis's reasons as "axis: ..." copies)
    pos_refused = any(not b.startswith("axis: ") for b in pos.blocking)
    if axis.blocking and pos_refused:  # a refused estimate overrules nothing
        return axis, pos
    if axis.blocking:
        # the centre's, without a vote: a refused axis's offset overrules nothing, but an
        # axis left at its own clock gave the knee two (simulated protocol with soft
        # tissue, shank 20 ms late: the axis refused at 0 ms beside a centre at 21.3 ms;
        # the angles read 3.7 deg RMS off at the axis's clock, 0.5 at the centre's, a
        # new-user trial)
        winner = 1
    elif pos_refused:
        winner = 0
    else:
        refits = _profiles(axis, pos, s1, s2, common["rate"], common["offset_search"])
        winner = choose(np.array([a["time_offset_s"], p["time_offset_s"]], float), *refits)
    if winner == 0:  # the axis's: the centre fitted again at it
        centre = position_module.adopt_offset(
            pos, a, "axis", s1.gyr, s1.acc, s2.gyr, s2.acc, joint="hinge", axis=axis,
            acc_error=acc_error, **common)
        # the angles read the axis's offset: its 1-sigma carries the disagreement too
        note_disagreement(axis, "axis", p, "the knee centre's search", unit="deg",
                          limit=axis_module.MAX_UNCERTAINTY_DEG)
        _copy_axis_warnings(centre, axis)
        return axis, centre
    # the centre's: the axis fitted again at it, and the centre at it on that axis (a
    # hinge's centre is the point of its axis line closest to the sensors); searching
    # again moved it on the real right knee, 10-30 s (-10.4 to -26.9 ms)
    axis = axis_module.adopt_offset(axis, p, "knee centre", s1.gyr, s2.gyr, acc1=s1.acc,
                                    acc2=s2.acc, **common, **signs)
    return axis, position_module.adopt_offset(
        None, p, p.get("found_by", "profile"), s1.gyr, s1.acc, s2.gyr, s2.acc, joint="hinge",
        axis=axis, acc_error=acc_error, versus=a, **common)


def _copy_axis_warnings(pos, axis) -> None:
    """The knee centre ``pos``'s copies ("axis: ...") of the warnings of the axis it was
    estimated on, made again from ``axis``'s current ones, where they stood: the knee's
    one clock withdraws an axis warning, or rewords its uncertainty once the offset's
    1-sigma carries a disagreement, after the centre copied them (the summary then gave
    the axis two 1-sigmas, an independent review)."""
    old = [i for i, w in enumerate(pos.warnings) if w.startswith("axis: ")]
    at = old[0] if old else len(pos.warnings)
    rest = [w for w in pos.warnings if not w.startswith("axis: ")]
    pos.warnings[:] = rest[:at] + [f"axis: {w}" for w in axis.warnings] + rest[at:]


def _one_check(axis, pos, s1, s2, common: dict) -> None:
    """A given clock offset checked once per hinge: where the axis's check and the
    centre's disagree on whether the data contradict it, the one both constraints fit
    best between the offset given and the contradicting check's estimate decides
    (:func:`imucal.time_offset.choose`); a contradiction it overrules is withdrawn
    (:func:`imucal.time_offset.withdraw`). Simulated gait with soft tissue 1 deg / 2 mm,
    clocks in sync, calibrated with ``--time-offset 0``: the axis's check alone
    contradicted 0 in 4 of 14 knees (found -32 to +21 ms, cost ratios 1.6-4.1; the
    centre's 0.5 ms or less, 1.0), and the knee angles' 1-sigma grew to 2.6-4.3 deg where
    0.4-0.7 deg covered the error; a shank 20 ms late given as 0 is still caught (by the
    centre's check there, the axis's missed it)."""
    from .time_offset import choose, withdraw

    a, p = axis.time_offset, pos.time_offset
    flags = (a.get("contradicted"), p.get("contradicted"))
    if sorted(map(str, flags)) != ["False", "True"]:
        return  # both or neither contradict it (or a check that could not run)
    claim = a if flags[0] else p
    refits = _profiles(axis, pos, s1, s2, common["rate"], float(claim["search_s"]))
    deltas = np.array([claim["time_offset_s"], claim["estimated_s"]], float)
    if choose(deltas, *refits) != 0:
        return
    if flags[1]:
        withdraw(pos, "axis")
        return
    withdraw(axis, "knee centre")
    _copy_axis_warnings(pos, axis)


def _profiles(axis, pos, s1, s2, rate: float, search: float) -> tuple:
    """The clock-offset profiles (``refit(deltas)``) of a knee's axis (eq. 1) and centre
    (eq. 3), each around its own estimate, over +-``search`` s."""
    from . import axis as axis_module
    from . import position as position_module

    return (axis_module.offset_profile(s1.gyr, s2.gyr, rate, search)(axis),
            position_module.offset_profile((s1.gyr, s1.acc, s2.gyr, s2.acc), rate,
                                           search)(pos))


def _verdict_of_estimates(jc: JointCalibration) -> None:
    """The worst verdict of the joint's estimates, and their warnings named by estimate,
    read from the reports, as :func:`load_calibration` reads them from a file."""
    docs = [d for d in (jc.axis, jc.position) if d is not None]
    jc.verdict = _worst([d["quality"]["verdict"] for d in docs])
    for d, what in zip(docs, ("axis", "position") if jc.kind == "hinge" else ("position",),
                       strict=True):
        # a knee's centre is fitted about its axis and carries the axis' warnings
        # ("axis: ..."): the joint's list names each once
        jc.warnings += [f"{what}: {w}" for w in d["quality"]["warnings"]
                        if not (what == "position" and jc.kind == "hinge"
                                and w.startswith("axis: "))]


def _angle_reference(jc: JointCalibration, used, around, smoothing_s) -> None:
    """A hinge's ``angle`` block (flexion sign, zero, the fit check's reference); its
    warnings make the joint "use with care", and a trial that fails the check itself or
    flexes beyond any knee makes it "not identifiable"."""
    from .angles import implausible_range, own_check_failure, reference_statistics

    try:
        jc.angle = reference_statistics(used, jc, smoothing_s=smoothing_s, context=around)
    except ImucalError as err:  # e.g. a trial without acceleration across the axis
        jc.verdict = "not identifiable"
        jc.warnings.append(f"angle: {jc.name}: no angle calibration: {err}")
        return
    a = jc.angle
    # an axis refused for want of motion: the angle's checks of it say nothing more (a
    # standing trial's gravity check came back under "angle:", a review)
    still = is_still([w for w in jc.warnings if w.startswith("axis: ")][:1])
    if a["warnings"] and not still:
        # the trial's gravity check is the axis' own: said once, by the axis
        jc.warnings += [f"angle: {w}" for w in a["warnings"]
                        if f"axis: {w.removeprefix(f'{jc.name}: ')}" not in jc.warnings]
        jc.verdict = _worst([jc.verdict, "use with care"])
    if implausible_range(jc.name, a["flexion_range_deg"]) or own_check_failure(
            jc.name, a["acc_gyro_disagreement_deg"], a["gravity_consistent"]):
        jc.verdict = _worst([jc.verdict, "not identifiable"])


_ORDER = ("good", "use with care", "not identifiable", "failed")


def _worst(verdicts: list[str]) -> str:
    return max(verdicts, key=lambda v: _ORDER.index(v) if v in _ORDER else len(_ORDER))


# ----------------------------------------------------------------------------- file


#: Largest calibration file read, bytes (one of every joint of both legs: about 60 KB).
MAX_FILE_BYTES = 10_000_000


def _study_lines_hint(data: bytes) -> str:
    """How to pick one calibration out of a ``calibrate`` study's JSON Lines (``data``),
    or "" for anything else: handed over whole, they read as a bare JSON error."""
    try:
        first = json.loads(data.split(b"\n", 1)[0].decode("utf-8-sig"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return ""
    if not (isinstance(first, dict) and {"file", "exit_code", "result"} <= first.keys()):
        return ""
    if b"\n" not in data.strip():  # one line of them
        result = first.get("result")
        if isinstance(result, dict) and result.get("format") == FORMAT:
            return ("; it is one line of a calibrate study's JSON Lines: its result is the "
                    "calibration, e.g. jq -c .result LINE > cal.json")
        return ("; it is one line of an imucal study's JSON Lines, and its result is no "
                "calibration")
    return ("; it is a study's JSON Lines, one line per recording: pick one recording's, "
            "e.g. jq -c 'select(.file == \"CAL.h5\") | .result' FILE > cal.json, or "
            "calibrate with --calibrations DIR for one file per recording")


def _json_problem(err: Exception) -> str:
    """What was wrong with a file read as JSON, short and without nested parentheses (its
    first 80 characters cut "(char 40" off in the middle)."""
    if isinstance(err, json.JSONDecodeError):
        return f"{err.msg} at line {err.lineno}, column {err.colno}"
    text = str(err).splitlines()[0] if str(err) else type(err).__name__
    text = text.replace("(", "").replace(")", "")
    return text if len(text) <= 80 else text[:77] + "..."


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration file written by :meth:`Calibration.write` (or ``imucal
    calibrate``).

    Parameters
    ----------
    path
        The calibration's JSON file (docs/json.md, "imucal calibrate"); not ``-``.

    Returns
    -------
    Calibration
        Its joints as written: per joint the verdict, the axes (unit vectors in the
        sensors' frames) and joint centres (m), the angle reference, the trial it came
        from and its settings.

    Raises
    ------
    InputError
        Naming the file: a missing file, a file that is not JSON or not a calibration,
        another format version, or a joint without its vectors.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import imucal
    >>> cal = imucal.calibrate(imucal.load_recording("sample_data/circling.h5"),
    ...                        restarts=10, seed=1)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     cal.write(Path(folder) / "cal.json")
    ...     again = imucal.load_calibration(Path(folder) / "cal.json")
    >>> sorted(again.joints) == sorted(cal.joints)
    True
    """
    from .atomic import as_path

    path = as_path(path, "a calibration file name")
    if str(path) == "-":
        raise InputError("-: a calibration is read from a file, not standard input; save it "
                         "first (imucal calibrate REC -o cal.json)")
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise InputError(f"{path}: calibration file not found (a symbolic link to nothing, "
                         "or a loop)")
    if not path.exists():
        raise InputError(f"{path}: calibration file not found")
    if path.is_dir():
        raise InputError(f"{path}: not a calibration file (not a regular file)")
    data = b""  # (an open or read that fails leaves nothing to hint from)
    try:
        # read once, up to a limit: a pipe (-c <(...)) can be read only once, and a
        # device has no size to check first (/dev/zero never ends)
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
        if not data:
            raise InputError(f"{path}: not a calibration file (it is empty)")
        if len(data) > MAX_FILE_BYTES:
            raise InputError(f"{path}: not a calibration file (more than {MAX_FILE_BYTES} "
                             "bytes; is it a recording?)")
        from .formats import utf16_text

        # a BOM: a Notepad edit; UTF-16: Windows PowerShell's `>` (jq .result > cal.json)
        doc = json.loads(utf16_text(data) or data.decode("utf-8-sig"))
    # ValueError: json's own errors, and integers of thousands of digits; RecursionError:
    # arrays nested a hundred thousand deep
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as err:
        from .formats import HDF5_SIGNATURE

        if data.startswith(HDF5_SIGNATURE):  # (read as JSON it was a codec's complaint)
            raise InputError(f"{path}: not a calibration file (an HDF5 file: a recording? "
                             "make the calibration from it with imucal calibrate)") from None
        raise InputError(f"{path}: not a calibration file (not readable as JSON: "
                         f"{_json_problem(err)}){_study_lines_hint(data)}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        command = doc.get("command") if isinstance(doc, dict) else None
        hint = (" (an imucal 'calibrate' result whose \"format\" was changed: restore it or "
                "calibrate again)" if command == "calibrate" else
                f" (an imucal '{command}' result; make one with imucal calibrate)"
                if isinstance(command, str) else _study_lines_hint(data))
        raise InputError(f"{path}: not a calibration file (no \"format\": \"{FORMAT}\"){hint}")
    version = doc.get("format_version")
    if version != FORMAT_VERSION:
        raise InputError(f"{path}: calibration format version {version!r}; this imucal "
                         f"({__version__}) reads version {FORMAT_VERSION}: calibrate again")
    try:
        joints = {name: _joint_from_doc(name, entry) for name, entry in doc["joints"].items()}
        inp = doc["input"]
        return Calibration(joints=joints, source=str(inp["path"]),
                           window_s=tuple(inp["window_s"]),
                           sample_rate_hz=float(inp["sample_rate_hz"]),
                           settings=dict(doc.get("settings", {})),
                           version=str(doc.get("imucal_version")),
                           sensors=dict(inp.get("sensors", {})), file=str(path))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise InputError(f"{path}: damaged calibration file ({type(err).__name__}: "
                         f"{str(err)[:200]})") from None


def _joint_from_doc(name: str, e: dict) -> JointCalibration:
    def vec(key):
        v = e.get(key)
        if v is None:
            return None
        # (float() took "3" and true as numbers from a hand-edited file)
        if not isinstance(v, list) or not all(isinstance(x, int | float)
                                              and not isinstance(x, bool) for x in v):
            raise ValueError(f"joint '{name}' {key} is {repr(v)[:60]}, not three numbers")
        a = np.asarray(v, dtype=float)
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise ValueError(f"joint '{name}' {key} is not a finite 3-vector")
        if key in ("o1", "o2") and not np.abs(a).max() <= MAX_CENTRE_M:
            # (1e308 overflowed to NaN angles that "fit", exit 3 after the table was written)
            raise ValueError(f"joint '{name}' {key} lies {np.abs(a).max():.3g} m from its "
                             f"sensor, not within {MAX_CENTRE_M:g} m")
        if key in ("j1", "j2"):
            big = np.abs(a).max()
            if not big > 0:
                raise ValueError(f"joint '{name}' {key} is a zero vector, not an axis")
            # a direction (1e300 overflowed the products with the rates); a unit vector as
            # written is kept to the last bit
            if not abs(np.linalg.norm(a / big) * big - 1.0) <= 1e-9:
                a = (a / big) / np.linalg.norm(a / big)
        return a

    if e["joint"] not in KINDS:
        raise ValueError(f"joint '{name}' has unknown type {e['joint']!r}")
    sensors = e["sensors"]
    if not (isinstance(sensors, list) and len(sensors) == 2
            and all(isinstance(n, str) for n in sensors)):
        raise ValueError(f"joint '{name}' sensors is {repr(sensors)[:80]}, not "
                         "the names of its two sensors")
    if sensors[0] == sensors[1]:  # (read as "does not fit this recording", exit 1)
        raise ValueError(f"joint '{name}' sensors names {sensors[0]!r} twice")
    for block in ("axis", "position", "angle"):
        if e.get(block) is not None and not isinstance(e[block], dict):
            raise ValueError(f"joint '{name}' {block} is not a JSON object")
        _check_offset_block(name, block, (e.get(block) or {}).get("time_offset"))
    # (a hand-edited null verdict wrote angles, exit 0; a failed joint may keep the
    # vectors that came before it stopped, and is not used: JointCalibration.usable)
    if e["verdict"] not in _ORDER:
        raise ValueError(f"joint '{name}' verdict is {e['verdict']!r}, not one of "
                         f"{', '.join(_ORDER)}")
    if (e["joint"] == "hinge" and e["verdict"] in ("good", "use with care")
            and e.get("angle") is None):  # (read as "no usable hinge joint")
        raise ValueError(f"joint '{name}' has no angle block, which calibrate writes for "
                         "every hinge it identifies")
    vectors = {key: vec(key) for key in ("j1", "j2", "o1", "o2")}
    for pair in (("j1", "j2"), ("o1", "o2")):  # (one of a pair missing: exit 3 in angles)
        if (vectors[pair[0]] is None) != (vectors[pair[1]] is None):
            given, missing = pair if vectors[pair[1]] is None else pair[::-1]
            raise ValueError(f"joint '{name}' has {given} but no {missing}")
    return JointCalibration(name=name, kind=e["joint"], sensors=tuple(sensors),
                            verdict=str(e["verdict"]), **vectors,
                            warnings=list(e.get("warnings", [])),
                            axis=e.get("axis"), position=e.get("position"),
                            angle=_angle_from_doc(name, e.get("angle"),
                                                  str(e["verdict"]) != NOT_IDENTIFIABLE))


#: No joint centre a calibration file stores lies further from its sensor than this, m
#: (estimates beyond 1 m are refused, and a refused one is still written).
MAX_CENTRE_M = 1000.0
#: The numbers of a ``time_offset`` block that the angles read (a hand-edited "abc" was
#: skipped as no number, and the angles' band lost the offset's part without a word).
_OFFSET_NUMBERS = ("time_offset_s", "estimated_s", "sigma_s", "model_sigma_s",
                   "sampling_sigma_s", "disagreement_s", "cost_ratio")


def _check_offset_block(name: str, where: str, block) -> None:
    """A ``time_offset`` block of a calibration file: a JSON object whose numbers are
    finite numbers or null and whose flags are true, false or absent."""
    if block is None:
        return
    if not isinstance(block, dict):
        raise ValueError(f"joint '{name}' {where}.time_offset is not a JSON object")
    for key in _OFFSET_NUMBERS:
        value = block.get(key)
        if value is not None and not _finite(value):
            raise ValueError(f"joint '{name}' {where}.time_offset.{key} is {value!r:.40}, "
                             "not a finite number")
    for key in ("time_offset_s", "estimated_s"):  # (1e6 s read as "never in the plane")
        if block.get(key) is not None and not abs(block[key]) <= MAX_TIME_OFFSET_S:
            raise ValueError(f"joint '{name}' {where}.time_offset.{key} is {block[key]!r:.40}"
                             f" s, beyond the +-{MAX_TIME_OFFSET_S:g} s a clock offset can be")
    for key in ("applied", "at_edge", "contradicted"):
        if block.get(key) is not None and not isinstance(block[key], bool):
            raise ValueError(f"joint '{name}' {where}.time_offset.{key} is "
                             f"{block[key]!r:.40}, not true or false")


#: No angle a calibration file stores lies beyond this, deg: the raw angle is the fused
#: angle of one trial (a few turns at most), its range a knee's.
MAX_ANGLE_DEG = 1e4


def _angle_from_doc(name: str, angle: dict | None, identified: bool = True) -> dict | None:
    """A hinge's ``angle`` block, checked where :func:`imucal.angles.joint_angles` relies
    on it: a hand-edited file with ``zero_deg: null`` or ``smoothing_s: 0`` otherwise
    ended in an internal error, and ``flexion_sign: 0`` in silently mirrored angles. The
    ranges only where the knee was ``identified``: a knee calibrate could not identify
    may have integrated any angle (rates 1000 times too large: a zero of 37 472 deg), and
    ``angles`` refuses it as not identifiable, not as a damaged file."""
    if angle is None:
        return None

    def bad(key, what):
        return ValueError(f"joint '{name}' angle.{key} is {angle[key]!r}, not {what}")

    sign = angle["flexion_sign"]
    if isinstance(sign, bool) or sign not in (1, -1):
        raise bad("flexion_sign", "+1 or -1")
    # the fit check's two references: null switched its test off ("limit -", "fits")
    for key, may_be_null in (("zero_deg", False), ("sign_evidence", False),
                             ("smoothing_s", False), ("zero_time_s", True),
                             ("hinge_residual", not identified),
                             ("acc_gyro_disagreement_deg", not identified)):
        if not (_finite(angle[key]) or (may_be_null and angle[key] is None)):
            raise bad(key, "a finite number")
    from .fusion import SMOOTHING_RANGE_S, check_smoothing

    try:
        check_smoothing(angle["smoothing_s"])
    except InputError:
        raise bad("smoothing_s", "a kernel half-width from {:g} to {:g} s".format(
            *SMOOTHING_RANGE_S)) from None
    for key in ("hinge_residual", "acc_gyro_disagreement_deg"):
        if angle[key] is not None and angle[key] < 0:
            raise bad(key, "a number >= 0")
    limit = MAX_ANGLE_DEG if identified else np.inf
    if not abs(angle["zero_deg"]) <= limit:
        raise bad("zero_deg", f"an angle within +-{MAX_ANGLE_DEG:g} deg")
    span = angle["flexion_range_deg"]
    if not (isinstance(span, list) and len(span) == 2 and all(map(_finite, span))
            and -limit <= span[0] <= span[1] <= limit):
        raise bad("flexion_range_deg", "[p1, p99] in deg, p1 <= p99")
    if not isinstance(angle["zero_method"], str):
        raise bad("zero_method", "a text")
    if not isinstance(angle.get("zero_trial"), str | None):
        raise bad("zero_trial", "a file name or null")
    if not (isinstance(angle.get("warnings", []), list)
            and all(isinstance(w, str) for w in angle.get("warnings", []))):
        raise bad("warnings", "a list of texts")
    return dict(angle)


def _finite(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)
