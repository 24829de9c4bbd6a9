"""The headless runner: one recording through load -> window -> estimate -> report.

Everything the ``axis``, ``position``, ``calibrate`` and ``angles`` commands do with a
recording, as plain functions that print nothing and return an :class:`Outcome`. The
single-file command prints an outcome (:mod:`imucal.cli`), a study turns each outcome
into one JSON line (:mod:`imucal.study`); neither the runner nor the study imports the
command line.

A command is one entry of :data:`COMMANDS`: how to estimate from two sensors, how to
build its JSON document and how to draw its figure. The options of one run are a
:class:`Job`, built (and checked) before any file is read.

Example::

    from imucal.runner import Job, run
    from imucal.settings import AxisSettings

    job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=20, seed=1))
    outcome = run(job, "walk.h5")
    outcome.exit_code, outcome.document["j1"]
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .errors import (
    INTERNAL_ERROR,
    ImucalError,
    InputError,
    NotIdentifiableError,
    exit_code_of,
    one_line,
)
from .recording import estimator_window, input_info
from .signals import unreported

__all__ = ["COMMANDS", "Command", "Job", "Outcome", "run", "parse_sensors", "table_name",
           "output_names",
           "check_table"]

@dataclass(frozen=True)
class Command:
    """What the runner needs to know about one estimating command.

    Attributes
    ----------
    estimate : ``(first, second, rate, kwargs) -> result``: fit the two sensors
        (:class:`imucal.recording.SensorData`, SI units) sampled at ``rate`` Hz;
        ``kwargs`` are the settings' :meth:`as_kwargs` with the window (s from the
        first sample given) filled in.
    report : ``(result, input_info=..., trace=...) -> dict``: the JSON document
        (docs/json.md).
    figure : ``(result, pair, document=None) -> matplotlib Figure``; ``pair`` reads
        "first - second", ``document`` is the report's JSON document, whose verdict,
        warnings and input the figure then states.
    process : for a command that works on the whole recording rather than on two sensors
        (``calibrate``, ``angles``): ``(job, recording, outcome) -> None`` fills the
        outcome (document, result, headline, warnings, and exit code and error for a
        result that is not usable); ``estimate``, ``report`` and ``figure`` are then None.
    """

    estimate: Callable[..., Any] | None
    report: Callable[..., dict] | None
    figure: Callable[..., Any] | None
    process: Callable[..., None] | None = None


def _estimate_axis(first, second, rate, kwargs):
    from .axis import estimate_axis

    return estimate_axis(first.gyr, second.gyr, rate=rate, acc1=first.acc, acc2=second.acc,
                         **kwargs)


def _estimate_position(first, second, rate, kwargs):
    from .position import estimate_position

    return estimate_position(first.gyr, first.acc, second.gyr, second.acc, rate=rate,
                             **kwargs)


def _report(name: str) -> Callable[..., dict]:
    def build(result, **kwargs):
        from . import report

        return {"axis": report.axis_report, "position": report.position_report}[name](
            result, **kwargs)

    return build


def _figure(name: str) -> Callable[..., Any]:
    def draw(result, pair, document=None):
        from . import plots

        return {"axis": plots.axis_figure, "position": plots.position_figure}[name](
            result, pair, document)

    return draw


def _process_calibrate(job, recording, outcome) -> None:
    """``imucal calibrate``: every joint of the recording in one document. Joints that
    are not identifiable or failed stay in it, marked; they make the outcome exit code 1
    (with the document) unless ``job.force``."""
    from .calibration import calibrate, standing_file
    from .restarts import resolve_seed

    s = job.settings
    # one seed for every joint, drawn here when none is given, so the file can say it
    seed = resolve_seed(s.seed)
    standing = None
    if s.standing is not None:
        try:  # (read as the trial is: the same units, rate and sensor map)
            standing = load(job, standing_file(s.standing, outcome.file))
        except InputError as err:
            raise InputError(f"{err} (the standing trial)") from None
        outcome.warnings.extend(f"{standing.source} (the standing trial): {w}"
                                for w in standing.warnings)
    cal = calibrate(recording, settings=replace(s, seed=seed), start=job.start, end=job.end,
                    standing=standing)
    if job.sensor_map is not None:
        cal.settings["sensor_map"] = str(job.sensor_map)
    names = ", ".join(f"{j.name} ({j.sensors[0]} -> {j.sensors[1]})"
                      for j in cal.joints.values())
    outcome.headline = (f"imucal calibrate: {recording.source}: {names}; "
                        f"{recording.n_samples} samples at {recording.rate:g} Hz "
                        f"({recording.duration:.1f} s){_window_text(job, cal.window_s)}")
    outcome.warnings.extend(f"{recording.source}: {w}" for w in recording.warnings)
    outcome.document, outcome.result = cal.to_document(), cal
    if s.calibrations is not None:
        outcome.document = _write_calibration(job, outcome.file, outcome.document)
    bad = [j for j in cal.joints.values() if j.verdict in ("not identifiable", "failed")]
    if bad and not job.force:
        # each joint with its own reason: they differ (one not identifiable, one failed)
        which = "; ".join(f"joint {j.name} ({j.verdict}): {j.reason()}" for j in bad)
        outcome.exit_code = NotIdentifiableError.exit_code
        outcome.error = (f"{recording.source}: {which}; the calibration is written with "
                         f"{'them' if len(bad) > 1 else 'it'} marked (--force: exit 0)")
        outcome.exception = NotIdentifiableError(outcome.error)


def _write_calibration(job, file: str, doc: dict) -> dict:
    """``doc`` written as ``file``'s calibration file in the settings' ``calibrations``
    folder (what ``calibrate --out`` writes); the document with ``calibration_file``, its
    path, for the study's line."""
    from .atomic import check_not_inputs, write_text_atomic
    from .report import dumps

    path = Path(job.settings.calibrations) / f"{_output_name(job, file)}.json"
    # (a study checks this once for all; a library caller's run, here)
    check_not_inputs([("--calibrations", path)], [file])
    check_replaceable(path, "--calibrations", file)
    # made when the first file is written: a study whose runs all fail leaves no folder
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, dumps(doc))
    return {**doc, "calibration_file": str(path)}


def _process_angles(job, recording, outcome) -> None:
    """``imucal angles``: the knee flexion of the calibration's hinges over the recording.
    Angles a joint of which does not fit (or is not identifiable in the calibration) make
    the outcome exit code 1 with nothing reported, unless ``job.force``; with
    ``settings.tables`` the table is written there (``<name>.csv``) and named in the
    document's ``table``."""
    from .angles import joint_angles
    from .calibration import load_calibration

    s = job.settings
    cal = job.calibration_read or load_calibration(s.calibration)
    result = joint_angles(recording, cal, settings=s, start=job.start, end=job.end)
    # (the recording's own warnings are among the result's)
    outcome.warnings.extend(f"{recording.source}: {w}" for w in (
        *result.warnings, *(w for j in result.joints.values() for w in j.warnings)))
    problems = result.problems()
    if problems and not job.force:
        raise NotIdentifiableError(
            f"{recording.source} with {s.calibration}: {'; '.join(problems)}; nothing "
            "written (--force writes the angles with these warnings)")
    doc = result.to_document()
    if s.tables is not None:
        table = Path(s.tables) / f"{_output_name(job, outcome.file)}.csv"
        # (a study checks this once for all; a library caller's run, here)
        check_table(table, [outcome.file], s.calibration)
        check_replaceable(table, "--tables")
        # made when the first table is written: a run that writes none leaves no folder
        table.parent.mkdir(parents=True, exist_ok=True)
        result.write(table)
        doc["table"] = str(table)
    outcome.document, outcome.result = doc, result


def check_table(table: Path, recordings, calibration: str, option: str = "--tables") -> None:
    """Refuse an angle table that would overwrite one of the ``recordings`` or the
    ``calibration`` file (links and other spellings of one file count as that file).

    Returns
    -------
    None

    Raises
    ------
    InputError
        ``table`` is one of the ``recordings`` or the ``calibration`` file; the message
        names the table and which of the two it would overwrite.

    Examples
    --------
    >>> from pathlib import Path
    >>> from imucal.runner import check_table
    >>> check_table(Path("knee/walk.csv"), ["walk.h5"], "cal.json")  # nothing in the way
    >>> try:
    ...     check_table(Path("walk.csv"), ["walk.csv"], "cal.json")
    ... except Exception as err:
    ...     print(str(err)[:47])
    walk.csv: --tables names an input recording and
    """
    from .atomic import check_not_inputs

    check_not_inputs([(option, table)], list(recordings))
    try:
        check_not_inputs([(option, table)], [calibration])
    except InputError:
        raise InputError(f"{table}: {option} would overwrite the calibration file; give "
                         "the tables another folder") from None


#: What the start of an output a study replaces holds: an angle table's header, a
#: calibration file's format (indented or compact: jq -c).
_OWN_OUTPUTS = {".csv": (b"time,", re.compile(rb"_flexion_deg")),
                ".json": (b"{", re.compile(rb'"format"\s*:\s*"imucal-calibration"'))}


def check_replaceable(path: Path, option: str, file: str | None = None) -> None:
    """Refuse a study's output named after its recording (``--tables``,
    ``--calibrations``) where a file is that is no such output: a vendor's
    ``session1/walk_01.csv`` beside ``walk_01.h5`` was replaced by its angle table with
    ``--tables session1`` (a new-user trial); or, given the recording ``file``, a
    calibration file of another recording (one subject per run into one folder: each
    ``s*/cal.h5`` is ``cal.json``, and subject 2's replaced subject 1's, a review). An
    earlier run's output of this recording is replaced.

    Returns
    -------
    None

    Raises
    ------
    InputError
        ``path`` exists and does not start as an angle table (``time,`` ...
        ``_flexion_deg``) or a calibration file does, or is the calibration file of
        another recording than ``file``.
    """
    path = Path(path)
    first, mark = _OWN_OUTPUTS.get(path.suffix, (b"", re.compile(b"")))
    try:
        if not stat.S_ISREG(os.stat(path).st_mode) and not path.is_dir():
            return  # a device or pipe is written through (/dev/null), as --out
        with open(path, "rb") as fh:
            start = fh.read(4096)
    except FileNotFoundError:
        return
    except OSError:  # a folder, unreadable: refused as not ours
        start = b""
    start = start.removeprefix(b"\xef\xbb\xbf").lstrip()  # (a BOM: a Notepad edit)
    if not (start.startswith(first) and mark.search(start)):
        what = "angle table" if path.suffix == ".csv" else "calibration file"
        raise InputError(f"{path}: a file is there that is no {what} of imucal (a "
                         f"recording?); {option} would overwrite it: give another folder")
    if file is not None and path.suffix == ".json":
        _check_same_trial(path, option, file)


def _check_same_trial(path: Path, option: str, file: str) -> None:
    """Refuse replacing the calibration file ``path`` of another recording than ``file``:
    the recording it names (as given, from wherever that run was) is ``file`` where the
    one path ends as the other (a study run again from another folder was refused, a
    review)."""
    import json

    try:
        made_from = json.loads(path.read_text(encoding="utf-8-sig"))["input"]["path"]
    except (OSError, ValueError, KeyError, TypeError):
        return  # (damaged: nothing to keep)
    if not isinstance(made_from, str):
        return
    old = Path(os.path.normpath(os.path.abspath(made_from))).parts
    new = Path(os.path.normpath(os.path.abspath(file))).parts
    tail = min(len(Path(os.path.normpath(p)).parts) for p in (made_from, file))
    if old[-tail:] == new[-tail:] or os.path.realpath(made_from) == os.path.realpath(file):
        return
    raise InputError(f"{path}: holds the calibration of {made_from}; {option} would replace "
                     f"it with {file}'s (names follow the recordings of one run: calibrate "
                     "the subjects in one run, or give each run its own folder)")


def _output_name(job: Job, file: str) -> str:
    """The name of ``file``'s output in ``job``'s study (:func:`output_names`)."""
    return dict(job.output_names or ()).get(file) or table_name(file)


def table_name(file: str) -> str:
    """The name a study gives a recording's angle table: its file's (or vendor export
    folder's) name without suffix.

    Returns
    -------
    str
        ``"walk_01"`` for ``"session/walk_01.h5"`` or ``"session/walk_01/"``.

    Examples
    --------
    >>> from imucal.runner import table_name
    >>> table_name("session/walk_01.h5"), table_name("session/walk_01/")
    ('walk_01', 'walk_01')
    """
    return Path(file).stem or Path(file).resolve().stem  # ('.' has no stem of its own)


def output_names(files, output: str = "{}") -> dict[str, str]:
    """The names a study gives its recordings' output files (angle tables, calibration
    files): each file's (or vendor export folder's) name without suffix
    (:func:`table_name`); where several recordings share that name, their folders are
    added, as few as tell them apart, the same number for each of them
    (``s1/cal.h5``, ``s2/cal.h5`` -> ``s1/cal``, ``s2/cal``). One file given twice keeps
    one name.

    Parameters
    ----------
    files
        The recordings as given (paths, ``-`` for standard input).
    output
        The output file a name makes (``"knee/{}.csv"``), for the error message only.

    Returns
    -------
    dict
        file -> name (a relative POSIX path without suffix).

    Raises
    ------
    InputError
        Two recordings whose names cannot be told apart by their folders (``walk.h5`` and
        ``walk.csv`` in one folder): the message names both.

    Examples
    --------
    >>> from imucal.runner import output_names
    >>> output_names(["s1/cal.h5", "s2/cal.h5", "s2/walk.h5"])
    {'s1/cal.h5': 's1/cal', 's2/cal.h5': 's2/cal', 's2/walk.h5': 'walk'}
    """
    import os

    files = list(dict.fromkeys(str(f) for f in files))
    # (the folders as given, links not followed: a lab's subject folder may be one)
    parts = {f: Path(os.path.abspath(f)).parts[1:] for f in files}
    real = {f: os.path.realpath(f) for f in files}
    names = {f: table_name(f) for f in files}
    for name in sorted(set(names.values())):
        group = [f for f in files if names[f] == name]
        if len({real[f] for f in group}) == 1:
            continue
        for depth in range(1, max(len(parts[f]) for f in group)):
            tails = {f: "/".join((*parts[f][:-1][-depth:], name)) for f in group}
            if all(tails[a] != tails[b] for a in group for b in group if real[a] != real[b]):
                names.update(tails)
                break
        else:
            first, second = sorted(group)[:2]
            raise InputError(f"{first} and {second} would both write "
                             f"{output.format(name)}; give the recordings different names")
    return names


def _window_text(job: Job, window) -> str:
    """", window A to B s" for a headline when a window was asked for: the header describes
    the file as a whole, and then the part fitted."""
    if job.start is None and job.end is None:
        return ""
    return f", window {window[0]:g} to {window[1]:g} s"


#: The estimating commands by name. A new one is one entry here (plus its option parsing
#: in imucal.cli); see docs/architecture.md.
COMMANDS: dict[str, Command] = {
    "axis": Command(_estimate_axis, _report("axis"), _figure("axis")),
    "position": Command(_estimate_position, _report("position"), _figure("position")),
    "calibrate": Command(None, None, None, process=_process_calibrate),
    "angles": Command(None, None, None, process=_process_angles),
}


@dataclass(frozen=True)
class Job:
    """The options of one estimating run, the same for every recording of a study.

    Attributes
    ----------
    command : a key of :data:`COMMANDS`.
    sensors : the (first, second) sensor names; empty for a command that works on the
        whole recording (``calibrate``: its joints are in the settings; ``angles``: in
        the calibration).
    settings : the estimator's settings object (:class:`imucal.settings.AxisSettings`,
        :class:`~imucal.settings.PositionSettings`,
        :class:`~imucal.settings.CalibrateSettings`,
        :class:`~imucal.settings.AnglesSettings`); its own ``start``/``end`` and
        ``time_origin`` are replaced by the window below and the recording's clock.
    start, end : window, s on the recording's time axis; None: from the first / to the
        last sample.
    rate, gyr_units, acc_units : loading options for files that lack them (CSV).
    sensor_map : a ``--map`` file, or None.
    sensor_map_pairs : the map's (key, name) pairs as read once by a study
        (:func:`imucal.study.run_study`), or None: each recording reads ``sensor_map``.
    calibration_read : an angles job's calibration
        (:class:`imucal.calibration.Calibration`) as read once by the command or the
        study, or None: each recording reads ``settings.calibration`` (a pipe,
        ``-c <(...)``, can be read once only).
    output_names : (file, name) pairs of a study's recordings (:func:`output_names`), for
        their angle tables and calibration files; None, or a file not among them: its
        own name (:func:`table_name`).
    force : report a result the data cannot identify (with its warnings) instead of
        failing with exit code 1.
    trace : add every restart's cost per iteration to the document.

    Raises
    ------
    InputError
        On building: an unknown command, settings of another command, sensors a command
        does not take, a --start/--end that is no number or an end not after the start,
        a --rate no recording has, or units imucal does not know.
    """

    command: str
    sensors: tuple[str, ...]
    settings: Any
    start: float | None = None
    end: float | None = None
    rate: float | None = None
    gyr_units: str | None = None
    acc_units: str | None = None
    sensor_map: Path | None = None
    sensor_map_pairs: tuple[tuple[str, str], ...] | None = None
    output_names: tuple[tuple[str, str], ...] | None = None
    calibration_read: Any = None
    force: bool = False
    trace: bool = False

    def __post_init__(self) -> None:
        if self.command not in COMMANDS:
            raise InputError(f"unknown command '{self.command}'; known: "
                             f"{', '.join(COMMANDS)}")
        self._check_loading()
        if self.start is not None and self.end is not None and self.end <= self.start:
            raise InputError(f"--end must be after --start ({self.start:g} s), got "
                             f"{self.end:g} s")
        # (a library caller's mix-up failed deep inside as "internal error, report it")
        from .settings import AnglesSettings, AxisSettings, CalibrateSettings, PositionSettings

        wanted = {"axis": AxisSettings, "position": PositionSettings,
                  "calibrate": CalibrateSettings, "angles": AnglesSettings}[self.command]
        job = f"{'an' if self.command[0] == 'a' else 'a'} {self.command} job"
        if type(self.settings) is not wanted:
            raise InputError(f"{job} takes {wanted.__name__}, got "
                             f"{type(self.settings).__name__}")
        whole = self.command in ("calibrate", "angles")
        if len(self.sensors) != (0 if whole else 2):
            raise InputError(f"{job} takes "
                             + ("no sensors (its joints are in the "
                                + ("settings)" if self.command == "calibrate"
                                   else "calibration)") if whole else "two sensors")
                             + f", got {tuple(self.sensors)!r}")


    def _check_loading(self) -> None:
        """The window and the loading options, before any file is read: each recording
        of a study refused them alike, one error line each, naming the file (an
        independent review)."""
        from .sensor_checks import check_units
        from .settings import as_real
        from .timing import check_rate

        for option, value in (("--start", self.start), ("--end", self.end)):
            if value is not None and as_real(value) is None:
                raise InputError(f"{option} must be a finite number of seconds on the "
                                 f"recording's clock, got {value!r:.40}")
        if self.rate is not None:
            try:
                check_rate(self.rate)
            except InputError as err:
                raise InputError(f"--rate {err}") from None
        for option, kind, unit in (("--gyr-units", "gyr", self.gyr_units),
                                   ("--acc-units", "acc", self.acc_units)):
            if unit is not None:
                check_units(kind, unit, option)


@dataclass
class Outcome:
    """What one recording gave.

    Attributes
    ----------
    file : the recording as given.
    exit_code : 0 success, 1 not identifiable, 2 bad input, 3 internal error.
    error : the one-line message of a failure ("FILE: problem"), else None.
    exception : the exception behind ``error`` (for ``--debug``), else None.
    warnings : problems of the data used (its two sensors in its window), each
        "FILE: text", in the order found; the command line prints them as it loads.
    notes : for a result that is not identifiable, its further warnings ("FILE: text";
        the first warning is the reason, in ``error``).
    headline : "imucal axis: FILE: thigh -> shank, N samples at R Hz (D s)", once the
        estimate is done, else None.
    document : the JSON document (docs/json.md), or None when nothing is reported.
    result : the estimator's result object (for figures), or None.
    sensors : the (first, second) sensor names.
    """

    file: str
    exit_code: int = 0
    error: str | None = None
    exception: BaseException | None = None
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    headline: str | None = None
    document: dict | None = None
    result: Any = None
    sensors: tuple[str, ...] = ("", "")


def parse_sensors(text: str) -> tuple[str, str]:
    """``"thigh,shank"`` -> ``("thigh", "shank")``.

    Returns
    -------
    first, second : str
        The two sensor names, stripped of spaces (not yet resolved against a recording).

    Raises
    ------
    InputError
        Unless there are exactly two different non-empty names.

    Examples
    --------
    >>> from imucal.runner import parse_sensors
    >>> parse_sensors("shank, foot")
    ('shank', 'foot')
    """
    names = [s.strip() for s in text.split(",")]
    if len(names) != 2 or not all(names) or names[0] == names[1]:
        raise InputError(f"--sensors needs two different sensor names, e.g. thigh,shank; "
                         f"got '{text}'")
    return names[0], names[1]


def run(job: Job, file: str) -> Outcome:
    """Estimate ``job`` on one recording; never prints, never raises for a failure.

    Parameters
    ----------
    job
        The options (:class:`Job`).
    file
        A recording path (or folder of a vendor export), or ``"-"`` for CSV on stdin.

    Returns
    -------
    Outcome
        With ``exit_code`` 0 and a ``document`` on success (also for a result that is
        not identifiable with ``job.force``); otherwise the code, the message and the
        exception, plus whatever warnings came before the failure.

    Raises
    ------
    KeyboardInterrupt
        Only this (and other non-``Exception`` signals); every error becomes the outcome.

    Examples
    --------
    >>> from imucal.runner import Job, run
    >>> from imucal.settings import AxisSettings
    >>> job = Job("axis", ("thigh", "shank"), AxisSettings(restarts=10, seed=1))
    >>> outcome = run(job, "sample_data/circling.h5")
    >>> outcome.exit_code, outcome.document["quality"]["verdict"]
    (0, 'good')
    >>> [round(x, 2) for x in outcome.document["j1"]]  # thigh sensor's frame
    [-0.42, -0.35, 0.84]
    >>> missing = run(job, "no_such_file.h5")
    >>> missing.exit_code, missing.document
    (2, None)
    """
    outcome = Outcome(file=file, sensors=job.sensors)
    try:
        _run(job, file, outcome)
    except Exception as err:  # every failure becomes an outcome, bugs too
        interruption = unreported()
        if interruption is not None:
            # the command line's Ctrl-C or SIGTERM, turned into another error by the
            # code it hit (a module being imported: "initialization failed")
            raise interruption from err
        outcome.exception = err
        outcome.exit_code, outcome.error = error_of(err, file)
        outcome.document = outcome.result = None
    return outcome


def error_of(err: BaseException, file: str) -> tuple[int, str]:
    """Exit code and one-line message of an exception raised while processing ``file``.

    Returns
    -------
    exit_code : int
        The error's own code for imucal's errors, 2 for an operating system error, 3 for
        anything else (a bug, or memory exhausted).
    message : str
        One line, "FILE: problem".

    Examples
    --------
    >>> from imucal.runner import error_of
    >>> error_of(FileNotFoundError(2, "No such file or directory", "x.h5"), "x.h5")
    (2, 'x.h5: No such file or directory')
    """
    code = exit_code_of(err)
    if isinstance(err, ImucalError):
        return code, one_line(err)
    if isinstance(err, OSError):
        return code, one_line(f"{err.filename or file}: {err.strerror or err}")
    if isinstance(err, MemoryError):
        return INTERNAL_ERROR, f"{file}: out of memory"
    return INTERNAL_ERROR, one_line(f"{file}: internal error: {type(err).__name__}: {err} "
                                    "(rerun this file alone with --debug and report it)")


def load(job: Job, file: str):
    """``file`` read with ``job``'s loading options and sensor map.

    Returns
    -------
    Recording
        The recording, its sensors named as the map says.

    Raises
    ------
    InputError
        What :func:`imucal.load_recording` and the sensor map refuse.
    """
    from .loaders import load_recording

    recording = load_recording(file, rate=job.rate, gyr_units=job.gyr_units,
                               acc_units=job.acc_units,
                               names=None if job.sensor_map_pairs is not None
                               else job.sensor_map)
    if job.sensor_map_pairs is not None:
        from .sensor_map import apply_sensor_map

        recording = apply_sensor_map(recording, dict(job.sensor_map_pairs),
                                     source=str(job.sensor_map))
    return recording


def _run(job: Job, file: str, outcome: Outcome) -> None:
    command = COMMANDS[job.command]
    names = job.sensors
    recording = load(job, file)
    if command.process is not None:
        command.process(job, recording, outcome)
        return
    # as the file names them (raises with the list of sensors that exist): results,
    # units and messages then name what was used, not what was asked for
    names = [recording.resolve(n) for n in names]
    if names[0] == names[1]:
        raise InputError(f"{recording.source}: --sensors {','.join(job.sensors)} both find "
                         f"sensor '{names[0]}'; name two different sensors")
    # Only now the warnings: which of the file's problems matter depends on the sensors
    # and window used.
    used, window = estimator_window(recording, names, job.start, job.end)
    outcome.warnings.extend(f"{used.source}: {w}" for w in used.warnings)
    first, second = (used.sensor(n) for n in names)
    try:
        result = command.estimate(first, second, recording.rate,
                                  {**job.settings.as_kwargs(), **window})
    except InputError as err:
        raise InputError(f"{recording.source}: {err}") from None
    doc = command.report(result, input_info=input_info(recording, names, used),
                         trace=job.trace)
    what = f"{job.command} ({doc['joint']})" if "joint" in doc else job.command
    outcome.headline = (f"imucal {what}: {recording.source}: {names[0]} -> {names[1]}, "
                        f"{recording.n_samples} samples at {recording.rate:g} Hz "
                        f"({recording.duration:.1f} s)"
                        f"{_window_text(job, doc['input']['window_s'])}")
    if doc["quality"]["verdict"] == "not identifiable" and not job.force:
        # The first warning is the reason (blocking reasons come first); the others only
        # help a human reading along ("input: " ones were warnings at load already).
        from .time_offset import refusal_reason

        reason, *others = doc["quality"]["warnings"]
        outcome.notes.extend(f"{recording.source}: {w}" for w in others
                             if not w.startswith("input: "))
        raise NotIdentifiableError(
            f"{recording.source}: the data cannot identify the {what}: "
            f"{refusal_reason(reason, others)}; nothing written (--force writes the result "
            "with its warnings)")
    outcome.document, outcome.result = doc, result



