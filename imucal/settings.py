"""Estimator settings as frozen dataclasses that check themselves.

A settings object is built before any file is read, so a usage error (``--sign bogus``)
is reported as such, not blamed on a recording. The estimators accept the same values
as keyword arguments; :meth:`AxisSettings.as_kwargs` gives them.

Example::

    from imucal.settings import AxisSettings
    settings = AxisSettings(restarts=50, seed=1, sign="+x")   # InputError if invalid
    result = imucal.estimate_axis(gyr1, gyr2, rate=100, **settings.as_kwargs())
"""

from __future__ import annotations

import decimal
import math
import numbers
from dataclasses import asdict, dataclass, fields, replace
from os import PathLike

import numpy as np

from .errors import InputError
from .selection import MAX_SAMPLES

#: Sign conventions accepted by ``sign`` and ``j2_sign``.
SIGNS = ("auto", "+x", "-x", "+y", "-y", "+z", "-z")
#: Joint models of the position estimator.
JOINTS = ("spheroidal", "hinge")
#: Smallest ``max_samples`` that leaves an estimate worth reporting.
MIN_MAX_SAMPLES = 100
#: Largest time offset accepted, s: wireless clocks drift by tens of milliseconds, not
#: seconds; a larger number is a mistake in units.
MAX_TIME_OFFSET_S = 10.0
#: Default search range of the automatic time offset, +- s.
OFFSET_SEARCH_S = 0.2
#: Default iteration limit per restart and stage, both estimators.
MAX_ITERATIONS = 50
#: Default fraction of the samples each restart sees (the paper's "different subsets").
SUBSET_FRACTION = 0.5
#: Default 1-sigma of an accelerometer's error at 1 g, m/s^2 (:class:`PositionSettings`):
#: factory-calibrated MEMS accelerometers keep offsets of about 0.02-0.1 m/s^2.
ACC_ERROR_M_S2 = 0.05
#: Most restarts accepted: memory grows with restarts x samples (10 000 restarts on the
#: first 100 s of the shared real recording: peaks of 0.5 GB, 0.63 GB with every one of
#: its 10 000 samples), and 100 already show whether the answer depends on the start.
MAX_RESTARTS = 10_000
#: Largest ``acc_error`` accepted, m/s^2 (half of g: a larger number is a unit mistake).
MAX_ACC_ERROR_M_S2 = 5.0


@dataclass(frozen=True)
class AxisSettings:
    """Settings of :func:`imucal.estimate_axis` (see its docstring for each meaning).

    Attributes
    ----------
    restarts : int
        Number of random starts, 1 to 10 000.
    seed : int or None
        Seed of the random starts and subsets, >= 0; None draws one.
    cutoff : float or None
        Zero-phase low-pass cut-off, Hz; None: the estimator's default; 0: no filter.
    subsample : int or None
        Use every k-th sample after filtering, >= 1; None: the estimator's default.
    subset : float
        Fraction of the samples each restart sees, in (0, 1].
    start, end : float or None
        Window in seconds from the first sample; None: from the start / to the end.
    max_iterations : int
        Iteration limit per restart and stage, >= 1.
    sign : str
        Overall sign convention of j1: "auto" or one of "+x", "-x", "+y", "-y", "+z", "-z".
    j2_sign : str
        Relative sign of j2: "auto" (decided from the data) or a pinned component.
    select : bool
        Informative-sample selection (drop still stretches, thin long recordings).
    max_samples : int or None
        With ``select``, at most this many samples enter the fit; None: no cap.
    time_offset : float or str
        The second sensor's clock lateness, s, or "auto".
    offset_search : float
        Search range of the automatic time offset, +- s, > 0; at least one sample (an
        estimate refuses a shorter one). With a given offset, the range over which the
        data are searched to check it (:func:`imucal.time_offset.check_given`; widened
        to reach the offset given).
    time_origin : float
        Time of the first sample given, s on the recording's clock: the still periods
        of the gravity check (and their warning) are reported on that clock.

    Raises
    ------
    InputError
        A setting of the wrong type or out of its range, or a window whose end is not
        after its start.
    """

    restarts: int = 100
    seed: int | None = None
    cutoff: float | None = None
    subsample: int | None = None
    subset: float = SUBSET_FRACTION
    start: float | None = None
    end: float | None = None
    max_iterations: int = MAX_ITERATIONS
    sign: str = "auto"
    j2_sign: str = "auto"
    select: bool = True
    max_samples: int | None = MAX_SAMPLES
    time_offset: float | str = "auto"
    offset_search: float = OFFSET_SEARCH_S
    time_origin: float = 0.0

    def __post_init__(self) -> None:
        _check_int(self, "restarts", 1, MAX_RESTARTS)
        _check_int(self, "max_iterations", 1)
        if self.seed is not None:
            _check_int(self, "seed", 0)
        if self.subsample is not None:
            _check_int(self, "subsample", 1)
        if self.max_samples is not None:
            _check_int(self, "max_samples", MIN_MAX_SAMPLES)
        if self.cutoff is not None:
            _check_number(self, "cutoff", low=0.0)
        _check_number(self, "subset", low=0.0, open_low=True, high=1.0)
        _check_number(self, "offset_search", low=0.0, open_low=True, high=MAX_TIME_OFFSET_S)
        _check_number(self, "time_origin", low=-math.inf)
        for name in ("start", "end"):
            if getattr(self, name) is not None:
                if as_real(getattr(self, name)) is None:  # worded as the window's check
                    raise InputError(f"window {name} must be a finite number of seconds, "
                                     f"got {getattr(self, name)!r}")
                _check_number(self, name, low=0.0)
        if self.start is not None and self.end is not None and self.end <= self.start:
            raise InputError(f"window end {self.end:g} s must be after its start "
                             f"{self.start:g} s")
        _check_signs(self)
        if not is_bool(self.select):  # (bool("no") is True: a string left it on)
            raise InputError(f"select must be True or False, got {self.select!r}")
        object.__setattr__(self, "select", bool(self.select))
        object.__setattr__(self, "time_offset", check_time_offset(self.time_offset))

    def as_kwargs(self) -> dict:
        """The settings as keyword arguments of the estimator.

        Returns
        -------
        kwargs : dict
            {field name: value}, every field (those of a subclass included), as checked.

        Examples
        --------
        >>> from imucal.settings import AxisSettings
        >>> kwargs = AxisSettings(restarts=20, seed=1).as_kwargs()
        >>> kwargs["restarts"], kwargs["seed"], kwargs["time_offset"]
        (20, 1, 'auto')
        """
        return asdict(self)

    def at_offset(self, seconds: float) -> AxisSettings:
        """These settings with the offset the automatic search chose, ``seconds``: the
        refit's (no search runs in it; the range searched is recorded by the search,
        ``time_offset.search_s``).

        Returns
        -------
        settings : AxisSettings
            Of the same class (a :class:`PositionSettings` stays one), with
            ``time_offset`` ``seconds`` (s) and ``offset_search`` the default.
        """
        return replace(self, time_offset=seconds, offset_search=OFFSET_SEARCH_S)


@dataclass(frozen=True)
class PositionSettings(AxisSettings):
    """Settings of :func:`imucal.estimate_position`: those of :class:`AxisSettings`
    (``sign`` and ``j2_sign`` act on the axis a hinge estimates; with a spheroidal joint
    anything but "auto" is an InputError) and

    Attributes
    ----------
    joint : str
        "spheroidal" (3 rotational DOF, the ankle) or "hinge" (the knee).
    acc_error : float
        1-sigma of each accelerometer's error at 1 g, m/s^2, >= 0: a constant offset of
        this size per axis and a scale error of ``acc_error`` / 1 g per axis, neither
        fitted; the joint centre's 1-sigma carries what the motion cannot tell from them
        (0: calibrated accelerometers).

    Raises
    ------
    InputError
        As :class:`AxisSettings`; also an unknown ``joint``, a ``sign`` or ``j2_sign``
        other than "auto" with a spheroidal joint, or ``acc_error`` outside [0, 5] m/s^2.
    """

    joint: str = "spheroidal"
    acc_error: float = ACC_ERROR_M_S2

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.joint, str) or self.joint not in JOINTS:
            raise InputError(f"joint must be one of {', '.join(JOINTS)}, got '{self.joint}'")
        for name in ("sign", "j2_sign"):  # (a spheroidal joint has no axis: ignored before)
            if self.joint != "hinge" and getattr(self, name) != "auto":
                raise InputError(f"{name} applies to the axis of joint hinge only, got "
                                 f"'{getattr(self, name)}' for joint '{self.joint}'")
        _check_number(self, "acc_error", low=0.0, high=MAX_ACC_ERROR_M_S2)


@dataclass(frozen=True)
class CalibrateSettings:
    """Settings of :func:`imucal.calibrate` (``imucal calibrate``).

    Attributes
    ----------
    joints : tuple of str or JointSpec
        Explicit joints (``"left_knee=hinge:left_thigh,left_shank"``), parsed into
        :class:`imucal.calibration.JointSpec`; empty: found from the sensor names.
    restarts, seed, time_offset, offset_search
        As in :class:`AxisSettings`; every joint uses the same.
    acc_error : float
        As in :class:`PositionSettings`, m/s^2; every joint centre uses the same.
    sign, j2_sign : str
        As in :class:`AxisSettings`, for every hinge's axis: pinning the relative sign
        where the mounting is known reaches the angles through the calibration.
    smoothing_s : float or None
        The angle fusion's kernel, s (:data:`imucal.fusion.SMOOTHING_S` when None),
        stored in the calibration for :func:`imucal.joint_angles`.
    standing : str or None
        A standing trial's file (same mounting): every hinge's zero is its most extended
        still period (:func:`imucal.calibration.zero_from_standing`); ``{folder}`` in it
        stands for the calibration trial's folder
        (:func:`imucal.calibration.standing_file`); None: the calibration trial's.
    calibrations : str or None
        A folder: a study writes each recording's calibration file there as
        ``<name>.json`` (:func:`imucal.runner.output_names`) and names it in its line
        (``calibration_file``); None: none is written (the runner's: not used by
        :func:`imucal.calibrate`).

    Raises
    ------
    InputError
        A joint spec that does not parse, a joint given twice, or a setting of the wrong
        type or out of its range (as in :class:`AxisSettings`; ``smoothing_s``:
        :func:`imucal.fusion.check_smoothing`).
    """

    joints: tuple = ()
    restarts: int = 100
    seed: int | None = None
    time_offset: float | str = "auto"
    offset_search: float = OFFSET_SEARCH_S
    acc_error: float = ACC_ERROR_M_S2
    sign: str = "auto"
    j2_sign: str = "auto"
    smoothing_s: float | None = None
    standing: str | None = None
    calibrations: str | None = None

    def __post_init__(self) -> None:
        from .calibration import JointSpec, parse_joint_spec
        from .fusion import check_smoothing

        # one joint given alone (a str was read letter by letter, a review)
        joints = (self.joints,) if isinstance(self.joints, str | JointSpec) else self.joints
        specs = tuple(j if isinstance(j, JointSpec) else parse_joint_spec(j) for j in joints)
        names = [s.name for s in specs]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"joint '{twice[0]}' given twice")
        object.__setattr__(self, "joints", specs)
        _check_int(self, "restarts", 1, MAX_RESTARTS)
        if self.seed is not None:
            _check_int(self, "seed", 0)
        object.__setattr__(self, "time_offset", check_time_offset(self.time_offset))
        _check_number(self, "offset_search", low=0.0, open_low=True, high=MAX_TIME_OFFSET_S)
        _check_number(self, "acc_error", low=0.0, high=MAX_ACC_ERROR_M_S2)
        _check_signs(self)
        if self.smoothing_s is not None:
            object.__setattr__(self, "smoothing_s", check_smoothing(self.smoothing_s))
        _check_folder(self, "calibrations")
        if self.standing is not None:
            if not isinstance(self.standing, str | PathLike) or not str(self.standing):
                raise InputError(f"standing must be a file name, got {self.standing!r}")
            object.__setattr__(self, "standing", str(self.standing))


@dataclass(frozen=True)
class AnglesSettings:
    """Settings of ``imucal angles`` (:func:`imucal.joint_angles` with a calibration file),
    the same for every recording of a study.

    Attributes
    ----------
    calibration : str
        The calibration file (``imucal calibrate``'s JSON), read by each run.
    reference : None, "standing" or float
        What 0 deg means, as in :func:`imucal.joint_angles` (a float: a time in s on
        each recording's time axis).
    flexion_sign : str
        "auto", "+" or "-", as in :func:`imucal.joint_angles`.
    tables : str or None
        A folder: each recording's table is written there as ``<name>.csv`` (its file or
        folder name without suffix, :func:`imucal.runner.output_names`) and named in its
        document (``table``); a study's
        recordings need it, one ``--out`` cannot hold their tables. None: no table is
        written (a single recording's command line writes its own).
    time_offset : float or None
        Every recording's own clock offset of the hinges' second sensors, s, as in
        :func:`imucal.joint_angles`; None: the calibration's.
    smoothing_s : float or None
        The fusion's kernel, s, as in :func:`imucal.joint_angles`; None: the
        calibration's.

    Raises
    ------
    InputError
        An empty calibration name, a reference, flexion sign, time offset or smoothing
        :func:`imucal.joint_angles` refuses, or an empty tables name.
    """

    calibration: str
    reference: object = None
    flexion_sign: str = "auto"
    tables: str | None = None
    time_offset: float | None = None
    smoothing_s: float | None = None

    def __post_init__(self) -> None:
        from .angles import _check_reference, _check_sign, check_trial_offset
        from .fusion import check_smoothing

        if not isinstance(self.calibration, str | PathLike) or not str(self.calibration):
            raise InputError(f"calibration must be a file name, got {self.calibration!r}")
        object.__setattr__(self, "calibration", str(self.calibration))
        object.__setattr__(self, "reference", _check_reference(self.reference))
        _check_sign(self.flexion_sign)
        object.__setattr__(self, "time_offset", check_trial_offset(self.time_offset))
        if self.smoothing_s is not None:
            object.__setattr__(self, "smoothing_s", check_smoothing(self.smoothing_s))
        _check_folder(self, "tables")


def _check_folder(settings, name: str) -> None:
    """An output folder's setting: None, or its name as a str."""
    value = getattr(settings, name)
    if value is not None:
        if not isinstance(value, str | PathLike) or not str(value):
            raise InputError(f"{name} must be a folder name, got {value!r}")
        object.__setattr__(settings, name, str(value))


def resolve(cls: type[AxisSettings], settings: AxisSettings | None, **kwargs) -> AxisSettings:
    """The settings an estimator runs with.

    Returns
    -------
    settings : AxisSettings
        ``settings`` itself, or ``cls(**kwargs)`` built (and so checked) from the
        estimator's keyword arguments when ``settings`` is None.

    Raises
    ------
    InputError
        ``settings`` is not a ``cls``, or it comes with keyword arguments that differ
        from their defaults (which of the two would win is not obvious); or ``kwargs``
        are invalid (``cls``'s own check).
    """
    if settings is None:
        return cls(**kwargs)
    if not isinstance(settings, cls):
        raise InputError(f"settings must be a {cls.__name__}, got {type(settings).__name__}")
    from .equality import same_value

    defaults = {f.name: f.default for f in fields(cls)}
    # (by value: an array keyword raised numpy's "truth value ... ambiguous", a review)
    both = sorted(k for k, v in kwargs.items() if not same_value(v, defaults[k]))
    if both:
        raise InputError(f"give settings or keyword arguments, not both ({', '.join(both)})")
    return settings


def _check_signs(settings) -> None:
    """``sign`` and ``j2_sign`` are each one of :data:`SIGNS`, else InputError."""
    for name in ("sign", "j2_sign"):
        # (an array compares element-wise: np.array('+x') passed, then failed inside)
        if not isinstance(getattr(settings, name), str) or getattr(settings, name) not in SIGNS:
            raise InputError(f"{name} must be one of {', '.join(SIGNS)}, got "
                             f"'{getattr(settings, name)}'")


def check_time_offset(value) -> float | str:
    """A time offset checked: ``"auto"`` (any case, surrounding spaces allowed) or a
    finite number of seconds within +-``MAX_TIME_OFFSET_S`` (10 s), also as a string.

    Returns
    -------
    offset : float or str
        ``"auto"``, or the offset as a float, s.

    Raises
    ------
    InputError
        Neither "auto" nor a finite real number within +-10 s (a bool is no number).

    Examples
    --------
    >>> from imucal.settings import check_time_offset
    >>> check_time_offset(" Auto "), check_time_offset("0.02"), check_time_offset(-1)
    ('auto', 0.02, -1.0)
    """
    if isinstance(value, str):
        if value.strip().lower() == "auto":
            return "auto"
        try:
            value = float(value)
        except ValueError:
            raise InputError(f"time offset must be auto or a number of seconds, got "
                             f"'{value}'") from None
    number = as_real(value)
    if number is None or abs(number) > MAX_TIME_OFFSET_S:
        shown = f"{number:g}" if number is not None else repr(value)
        raise InputError(f"time offset must be auto or a finite number of seconds within "
                         f"+-{MAX_TIME_OFFSET_S:g} s, got {shown}")
    return number


def is_bool(value) -> bool:
    """Whether ``value`` is Python's or numpy's True/False, also as a 0-d array: Python
    reads True as 1, so no number, flag or time may be one.

    Returns
    -------
    is_bool : bool
        True for ``bool``, ``np.bool_`` and anything with a boolean dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.settings import is_bool
    >>> is_bool(True), is_bool(np.array(False)), is_bool(1)
    (True, True, False)
    """
    return isinstance(value, bool | np.bool_) or getattr(value, "dtype", None) == np.bool_


def as_real(value) -> float | None:
    """``value`` as a finite float when it is a real number (Python's or numpy's scalar,
    ``np.int64(10)`` from a notebook's arrays, a 0-d array such as ``np.load`` gives, or a
    ``decimal.Decimal``, which Python does not count as ``numbers.Real``), never a bool.

    Returns
    -------
    number : float or None
        The finite float; None for a bool, a string, an array other than a 0-d integer or
        float one, NaN, infinity or a number too large for a float.

    Examples
    --------
    >>> import decimal
    >>> import numpy as np
    >>> from imucal.settings import as_real
    >>> as_real(np.int64(10)), as_real(decimal.Decimal("0.5")), as_real(True), as_real("1")
    (10.0, 0.5, None, None)
    """
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if not isinstance(value, numbers.Real | decimal.Decimal) or is_bool(value):
        return None
    try:
        number = float(value)
    except (OverflowError, ValueError):  # (10**400; Decimal('sNaN'))
        return None
    return number if math.isfinite(number) else None


def _check_int(settings, name: str, low: int, high: int | None = None) -> None:
    value = getattr(settings, name)
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iu":
        value = value.item()
    if isinstance(value, numbers.Integral) and not is_bool(value):
        whole = int(value)  # (exact for any size: 10**400 restarts is too many, not a crash)
    elif isinstance(value, decimal.Decimal):  # exactly, not through a float: Decimal("1e30")
        if not (value.is_finite() and value == value.to_integral_value()):  # is 10**30
            raise InputError(f"{name} must be a whole number, got {value!r}")
        whole = int(value)
    else:
        number = as_real(value)
        if number is None or number != int(number):
            raise InputError(f"{name} must be a whole number, got {value!r}")
        whole = int(number)
    if whole < low:
        raise InputError(f"{name} must be at least {low}, got {whole}")
    if high is not None and whole > high:
        raise InputError(f"{name} must be at most {high}, got {whole}")
    object.__setattr__(settings, name, whole)


def _check_number(settings, name: str, *, low: float, high: float | None = None,
                  open_low: bool = False) -> None:
    given = getattr(settings, name)
    value = as_real(given)
    if value is None:
        raise InputError(f"{name} must be a finite number, got {given!r}")
    too_low = value <= low if open_low else value < low
    if too_low or (high is not None and value > high):
        bounds = f"{'(' if open_low else '['}{low:g}, {'inf)' if high is None else f'{high:g}]'}"
        raise InputError(f"{name} must be in {bounds}, got {value:g}")
    object.__setattr__(settings, name, float(value))
