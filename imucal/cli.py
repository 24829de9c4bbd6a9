"""The ``imucal`` command line: parses options, runs, prints (docs/architecture.md).

``axis``, ``position`` and ``calibrate`` turn their options into a settings object and a
:class:`imucal.runner.Job` before any file is read (a bad value is a usage error), hand
them to :func:`imucal.runner.run` for one recording or :func:`imucal.study.run_study` for
several, and print the outcome. Data (JSON) goes to stdout or ``--out``; progress,
summaries and errors go to stderr. Exit status: 0 success, 1 the data cannot answer,
2 bad input or usage, 3 internal error (docs/errors.md).
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import sys
from pathlib import Path
from typing import Annotated

import typer

from . import __version__
from .atomic import (
    CLOSED_AT_START,
    check_not_inputs,
    check_writable,
    staged,
    write_stdout,
    write_text_atomic,
)
from .errors import (
    ImucalError,
    InputError,
    exit_code_of,
    number_text,
    one_line,
    say,
    signed_ms,
)
from .signals import raise_on_signals
from .signals import report as report_interruption
from .signals import unreported as unreported_interruption


def _examples(*lines: str) -> str:
    # "\b" stops click from re-wrapping the paragraph.
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


app = typer.Typer(
    name="imucal",
    help=(
        "Knee hinge axis and ankle joint centre from inertial sensors on thigh, shank and "
        "foot (Seel, Schauer, Raisch 2012). Results are JSON on stdout; messages go to "
        "stderr. Input units: rad/s, m/s^2, Hz, s (others by --gyr-units, "
        "--acc-units); results in m, mm and deg as each field's name says."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)

# Options shared by `axis` and `position`.
Rec = Annotated[str, typer.Argument(
    metavar="REC", show_default=False,
    help="Recording: a file or folder, imucal's HDF5/CSV or a vendor export (Xsens MT "
    "Manager, Movella DOT, APDM, x-IMU3, Shimmer, BIDS-motion; docs/formats.md); - reads "
    "CSV from stdin.")]
Recs = Annotated[list[str], typer.Argument(
    metavar="REC", show_default=False,
    help="Recording(s): files or folders, imucal's HDF5/CSV or vendor exports "
    "(docs/formats.md); - reads CSV from stdin. Several RECs: one JSON "
    "line per recording, in order (see --jobs).")]
# (a default of None shown as "1" printed "[default: (1)]"; whether --jobs was given is
# asked of click instead: _given)
Jobs = Annotated[int, typer.Option(
    "--jobs", "-j", min=0, help="A study (several RECs, or one with "
    "--jobs or --scheduler given): recordings processed at once, in separate "
    "processes (0: one per CPU core). Output is JSON Lines in input order, one object "
    "{file, exit_code, error, warnings, result} per recording; a failed recording gets an "
    "error line and the others go on; exit status: the highest of the recordings' codes "
    "(0 ok, 1 not identifiable, 2 bad input, 3 internal error). --out writes the lines "
    "to a file (complete or not at all); --plot needs a single REC without --jobs.")]
CalibrateJobs = Annotated[int, typer.Option(
    "--jobs", "-j", min=0, help="A study (several RECs, or one with "
    "--jobs or --scheduler given): recordings processed at once, in separate "
    "processes (0: one per CPU core). Output is JSON Lines in input order, one object "
    "{file, exit_code, error, warnings, result} per recording, result the calibration "
    "(also with exit_code 1: a joint not usable, marked); a failed recording gets an error "
    "line and the others go on; exit status: the highest of the recordings' codes. --out "
    "writes the lines to a file (complete or not at all).")]
Restarts = Annotated[int, typer.Option(min=1, help="Random restarts (initial values and data "
                                       "subsets).")]
Seed = Annotated[int | None, typer.Option(min=0, help="Random seed; default: a fresh one, "
                                          "recorded in the JSON.", show_default=False)]
Start = Annotated[float | None, typer.Option(help="Window start, s on the recording's time axis.",
                                             show_default=False)]
End = Annotated[float | None, typer.Option(help="Window end, s on the recording's time axis.",
                                           show_default=False)]
# (no min=: the settings check it, and typer's own check read NaN as "should be >= 0")
AxisCutoff = Annotated[float | None, typer.Option(
    "--cutoff", help="Low-pass cut-off, Hz, before the fit; default: none (raw rates fit "
    "eq. 1 best).", show_default=False)]
PositionCutoff = Annotated[float | None, typer.Option(
    "--cutoff", help="Low-pass cut-off, Hz; default: from the recording's spectrum "
    "(3 x the frequency below which most of the motion lies, within 4-12 Hz and at most "
    "0.4 x rate); 0 disables the filter.", show_default=False)]
Subsample = Annotated[int | None, typer.Option(min=1, help="Use every k-th sample; default: all "
                                               "without a filter, else about 2.5 per cut-off "
                                               "period.", show_default=False)]
def _output_file(value: str | Path) -> Path:
    """An output file's name, checked as typed: ``pathlib.Path`` drops a trailing '/'
    (``--out res/`` wrote a file named 'res') and typer turns '' into '.'."""
    if isinstance(value, Path):
        return value
    if value == "":
        raise typer.BadParameter("an empty file name; give a file name")
    if os.path.basename(value) in ("", ".", ".."):  # ("res/." became 'res' too)
        raise typer.BadParameter(f"'{value}' names a folder; give a file name")
    return Path(value)


def _output_folder(value: str | Path) -> Path:
    """An output folder's name as typed ('' became '.', the current folder)."""
    if isinstance(value, Path):
        return value
    if value == "":
        raise typer.BadParameter("an empty folder name; give a folder name")
    return Path(value)


def _dash_is_stdout(value: Path | None) -> Path | None:
    """``--out -``: standard output, as a REC of ``-`` is standard input (it wrote a file
    named '-')."""
    return None if value is not None and str(value) == "-" else value


Out = Annotated[Path | None, typer.Option(
    "--out", "-o", metavar="FILE", help="Write the JSON here instead of stdout (- : stdout).",
    show_default=False, parser=_output_file, callback=_dash_is_stdout)]
Plot = Annotated[Path | None, typer.Option(
    metavar="FILE", help="Write a convergence figure; the file name's extension picks the "
    "format: .png, .pdf or .svg.", show_default=False, parser=_output_file)]
Trace = Annotated[bool, typer.Option(
    "--trace", help="Also write every restart's cost per iteration into the JSON "
    "(restarts[].cost_trace, refined_cost_trace); by default each restart is summarised.")]
Rate = Annotated[float | None, typer.Option(
    help="Sample rate, Hz (CSV without a time column). With time stamps in the file it must "
         "agree with theirs within 10 %, and then wins.", show_default=False)]
GyrUnits = Annotated[str | None, typer.Option(
    help="Gyroscope units, rad/s or deg/s, of every sensor: for a CSV, and in place of what "
         "an HDF5 file or vendor export declares.", show_default=False)]
AccUnits = Annotated[str | None, typer.Option(
    help="Accelerometer units, m/s^2 or g, of every sensor: for a CSV, and in place of what "
         "an HDF5 file or vendor export declares.", show_default=False)]
Quiet = Annotated[bool, typer.Option(
    "--quiet", "-q", help="No progress, summary or estimate warnings on stderr (the JSON "
    "carries those); warnings about reading the file, and angles' warnings (a table cannot "
    "carry them), still print, as errors do, but in a study, whose JSON lines carry them "
    "too.")]
# (simulate and convert estimate nothing and write no JSON: Quiet's text was not theirs)
SimulateQuiet = Annotated[bool, typer.Option(
    "--quiet", "-q", help="No summary line on stderr; errors still print.")]
ConvertQuiet = Annotated[bool, typer.Option(
    "--quiet", "-q", help="No summary line and no warnings about reading the recording on "
    "stderr; errors still print.")]
def _input_file(value: str | Path) -> Path:
    """An input file's name as typed: typer turns '' (an unset "$MAP") into '.', which
    was then called a folder."""
    if isinstance(value, Path):
        return value
    if value == "":
        raise typer.BadParameter("'': empty file name")
    return Path(value)


SensorMap = Annotated[Path | None, typer.Option(
    "--map", metavar="FILE", show_default=False, parser=_input_file,
    help="Sensor map (any command; made for studies): device names or serials as the "
    "files give them -> the names to use, as JSON ({\"00B4D7D3\": \"left_thigh\"}) or "
    "KEY = NAME lines; keys match ignoring case, spaces, underscores and hyphens; keys "
    "mapped to one name are alternatives (e.g. one per participant). See docs/formats.md.")]
Debug = Annotated[bool, typer.Option("--debug", help="Show a traceback on errors.")]
Select = Annotated[bool, typer.Option(
    "--select/--no-select", help="Use only informative samples: drop still stretches and thin "
    "long recordings to --max-samples (the time ranges used are in the JSON).")]
MaxSamples = Annotated[int | None, typer.Option(
    min=100, help="With --select, at most this many samples enter the fit; default 3000.",
    show_default=False)]
TimeOffset = Annotated[str, typer.Option(
    "--time-offset", help="Clock offset of the second sensor, s (positive: its clock is "
    "late): auto (estimated from the constraint itself within +-0.2 s, see "
    "--offset-search, and applied when it clearly improves the fit; reported in "
    "time_offset), 0 (clocks in sync) or a number of seconds to apply (checked against "
    "the data: a warning where they clearly put it elsewhere).")]
OffsetSearch = Annotated[float, typer.Option(
    "--offset-search", metavar="SECONDS", help="How far --time-offset auto searches, +- s "
    "(at most 10; with a given offset, how far its check looks). Widen it when the "
    "sensors' clocks may differ by more than 0.2 s; a motion that repeats (gait, "
    "circling) can then show minima that are not the clock's (docs/method.md).")]
AccError = Annotated[float, typer.Option(
    "--acc-error", metavar="M/S^2", help="1-sigma of each accelerometer's error at 1 g, "
    "m/s^2: an offset of this size and a scale error of this / 1 g per axis, carried "
    "into the joint centre's 1-sigma where the motion cannot tell them from a move of the "
    "centre (steady circling). 0.02-0.1 after factory calibration; 0: calibrated.")]
Scheduler = Annotated[str | None, typer.Option(
    "--scheduler", metavar="ADDRESS", show_default=False,
    help="Run the study (several RECs, or one) on the Dask cluster whose scheduler "
    "listens at ADDRESS (e.g. tcp://host:8786) instead of local processes; same output and "
    "exit status as --jobs. Needs the dask extra (docs/performance.md).")]
Force = Annotated[bool, typer.Option(
    "--force", help="Write the result even when the data cannot identify it (exit 0; the "
    "JSON carries the warnings). Without it such a run writes nothing and exits 1.")]


@app.command(
    epilog=_examples(
        "imucal axis walk.h5 | jq .j1",
        "imucal axis walk.h5 --sensors left_thigh,left_shank --start 0 --end 55 \\",
        "    --out knee.json --plot knee.png",
        "cat rec.csv | imucal axis - --rate 100 --gyr-units deg/s",
        "imucal axis study/*.h5 --jobs 4 --seed 1 --out knees.jsonl   # a study, 4 processes",
        "jq -c 'select(.exit_code == 0) | [.file, .result.j1]' knees.jsonl",
    )
)
def axis(
    ctx: typer.Context,
    rec: Recs,
    sensors: Annotated[str, typer.Option(help="First (proximal) and second sensor, comma "
                                         "separated.")] = "thigh,shank",
    restarts: Restarts = 100,
    seed: Seed = None,
    start: Start = None,
    end: End = None,
    cutoff: AxisCutoff = None,
    subsample: Subsample = None,
    select: Select = True,
    max_samples: MaxSamples = None,
    out: Out = None,
    plot: Plot = None,
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    sign: Annotated[str, typer.Option(
        help="Overall sign of the axis: auto (j1's largest component positive) or +x, -x, "
        "+y, -y, +z, -z (that component of j1 is positive). j2 always points the same "
        "physical way as j1.")] = "auto",
    j2_sign: Annotated[str, typer.Option(
        "--j2-sign", help="Relative sign: auto (decided from the data by three tests, "
        "reported in quality.sign) or +x, -x, +y, -y, +z, -z to pin that component of j2 "
        "positive/negative, e.g. --sign +x --j2-sign +x when both sensors' x axes point "
        "laterally.")] = "auto",
    time_offset: TimeOffset = "auto",
    offset_search: OffsetSearch = 0.2,  # imucal.settings.OFFSET_SEARCH_S
    force: Force = False,
    trace: Trace = False,
    jobs: Jobs = 1,
    scheduler: Scheduler = None,
    quiet: Quiet = False,
    debug: Debug = False,
) -> None:
    """Hinge joint axis: j1 in the first sensor's frame, j2 in the second's (unit vectors)."""
    with _errors(debug):
        from .settings import AxisSettings

        settings = _settings(ctx, AxisSettings, restarts=restarts, seed=seed, cutoff=cutoff,
                             subsample=subsample, select=select,
                             max_samples=_max_samples(max_samples), sign=sign,
                             j2_sign=j2_sign, time_offset=time_offset,
                             offset_search=offset_search)
        job = _job(ctx, "axis", sensors, settings, start=start, end=end, rate=rate,
                   gyr_units=gyr_units, acc_units=acc_units, sensor_map=sensor_map,
                   force=force, trace=trace)
        raise typer.Exit(_estimate(job, rec, out=out, plot=plot,
                                   jobs=jobs if _given(ctx, "jobs") else None,
                                   scheduler=scheduler, quiet=quiet))


@app.command(
    epilog=_examples(
        "imucal position walk.h5 | jq .o1",
        "imucal position walk.h5 --sensors thigh,shank --joint hinge",
        "imucal position walk.h5 --out ankle.json --plot ankle.png",
        "imucal position circling.h5 --acc-error 0.01   # calibrated accelerometers",
        "imucal position study/*.h5 --jobs 0 > ankles.jsonl   # one process per core",
    )
)
def position(
    ctx: typer.Context,
    rec: Recs,
    sensors: Annotated[str, typer.Option(help="First (proximal) and second sensor, comma "
                                         "separated.")] = "shank,foot",
    joint: Annotated[str, typer.Option(help="spheroidal (ankle) or hinge (knee: reports the "
                                       "point of the axis closest to both sensors).")]
    = "spheroidal",
    restarts: Restarts = 100,
    seed: Seed = None,
    start: Start = None,
    end: End = None,
    cutoff: PositionCutoff = None,
    subsample: Subsample = None,
    select: Select = True,
    max_samples: MaxSamples = None,
    out: Out = None,
    plot: Plot = None,
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    sign: Annotated[str, typer.Option(
        help="With --joint hinge: overall sign of the estimated axis (see imucal axis "
        "--help).")] = "auto",
    j2_sign: Annotated[str, typer.Option(
        "--j2-sign", help="With --joint hinge: pin the relative sign of the estimated axis, "
        "which decides the line the knee point is taken on (see imucal axis --help).")]
    = "auto",
    time_offset: TimeOffset = "auto",
    offset_search: OffsetSearch = 0.2,  # imucal.settings.OFFSET_SEARCH_S
    acc_error: AccError = 0.05,  # imucal.settings.ACC_ERROR_M_S2 (kept out of start-up)
    force: Force = False,
    trace: Trace = False,
    jobs: Jobs = 1,
    scheduler: Scheduler = None,
    quiet: Quiet = False,
    debug: Debug = False,
) -> None:
    """Joint centre: o1, o2 = vectors from the joint centre to each sensor, own frame, m."""
    with _errors(debug):
        from .settings import PositionSettings

        settings = _settings(ctx, PositionSettings, restarts=restarts, seed=seed, joint=joint,
                             cutoff=cutoff, subsample=subsample, select=select,
                             max_samples=_max_samples(max_samples), sign=sign,
                             j2_sign=j2_sign, time_offset=time_offset,
                             offset_search=offset_search, acc_error=acc_error)
        job = _job(ctx, "position", sensors, settings, start=start, end=end, rate=rate,
                   gyr_units=gyr_units, acc_units=acc_units, sensor_map=sensor_map,
                   force=force, trace=trace)
        raise typer.Exit(_estimate(job, rec, out=out, plot=plot,
                                   jobs=jobs if _given(ctx, "jobs") else None,
                                   scheduler=scheduler, quiet=quiet))


@app.command(
    epilog=_examples(
        "imucal calibrate cal_trial.h5 --out cal.json",
        "imucal calibrate cal_trial.h5 --standing static.h5 --out cal.json   # 0 deg: standing",
        "imucal calibrate cal_trial.h5 --joint left_knee=hinge:left_thigh,left_shank \\",
        "    --joint right_knee=hinge:right_thigh,right_shank --seed 1 --out cal.json",
        "imucal angles walk1.h5 --calibration cal.json --out walk1_knee.csv",
        "imucal calibrate session*/calibration.h5 --jobs 4 --out cals.jsonl   # a study",
        "imucal calibrate s*/calibration.h5 --calibrations cal/ --jobs 0 > cals.jsonl",
        "imucal angles s01/walk*.h5 -c cal/s01/calibration.json --tables knee/s01/",
        "jq '.joints | map_values(.verdict)' cal.json",
    )
)
def calibrate(
    ctx: typer.Context,
    rec: Recs,
    joint: Annotated[list[str] | None, typer.Option(
        "--joint", metavar="NAME=KIND:FIRST,SECOND", show_default=False,
        help="A joint to calibrate (repeatable), KIND hinge or spheroidal, FIRST the "
        "proximal sensor, e.g. left_knee=hinge:left_thigh,left_shank. Default: every joint "
        "the sensor names allow (thigh/shank/foot/pelvis and synonyms, left_/right_ or "
        "vendor labels): knee (hinge), ankle and hip (spheroidal).")] = None,
    restarts: Restarts = 100,
    seed: Seed = None,
    start: Start = None,
    end: End = None,
    time_offset: Annotated[str, typer.Option(
        "--time-offset", help="Clock offset of each joint's second sensor, s (positive: "
        "its clock is late): auto (searched and applied per joint, see axis --help), 0 or "
        "a number of seconds applied to EVERY joint (the shank's for the knee, the foot's "
        "for the ankle): calibrate joints separately with --joint when they differ.")] = "auto",
    offset_search: OffsetSearch = 0.2,  # imucal.settings.OFFSET_SEARCH_S
    acc_error: AccError = 0.05,  # imucal.settings.ACC_ERROR_M_S2 (kept out of start-up)
    sign: Annotated[str, typer.Option(
        help="Overall sign of every hinge axis (see imucal axis --help).")] = "auto",
    j2_sign: Annotated[str, typer.Option(
        "--j2-sign", help="Pin every hinge axis's relative sign, e.g. --sign +x --j2-sign +x "
        "when both sensors' x axes point laterally (see imucal axis --help): the angles "
        "read their flexion direction through it.")] = "auto",
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", metavar="FILE", help="Write the calibration file (JSON) here instead "
        "of stdout (- : stdout).", show_default=False, parser=_output_file,
        callback=_dash_is_stdout)] = None,
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    force: Annotated[bool, typer.Option(
        "--force", help="Exit 0 even when a joint is not identifiable or its estimate "
        "failed. The calibration is written either way, such joints marked by their "
        "verdict (a failed one without vectors); without --force the exit status is 1.")]
    = False,
    standing: Annotated[str | None, typer.Option(
        "--standing", metavar="FILE", show_default=False,
        help="A standing trial of the same mounting (the lab's static trial): every "
        "knee's 0 deg is then its most extended still period (>= 1 s), the subject's stand, "
        "instead of the calibration trial's (its most extended still period, else its "
        "most extended posture: 5-7 deg of flexion in a walking protocol). Read as REC "
        "is (--rate, units, --map); {folder} stands for each REC's folder (a study of "
        "s*/cal.h5 with --standing '{folder}/static.h5': each subject's own). Refused "
        "(exit 2, nothing written) without such a period, when the calibration does not "
        "fit it, when its knee stands more than 15 deg more flexed (20 more extended) than "
        "the calibration trial's most extended posture, or when its still periods differ "
        "by more than 5 deg and the calibration trial left the flexion direction open; "
        "without {folder} for RECs in several folders.")] = None,
    calibrations: Annotated[Path | None, typer.Option(
        "--calibrations", metavar="DIR", show_default=False, parser=_output_folder,
        help="A study (of one REC or several): also write each recording's calibration "
        "file (what --out writes for one) as DIR/NAME.json, NAME its file or folder name "
        "without suffix, with as many of its folders as tell recordings of one name apart "
        "(s1/cal.h5 s2/cal.h5: DIR/s1/cal.json, DIR/s2/cal.json); each line's result "
        "names it (calibration_file). A recording that fails writes none.")] = None,
    jobs: CalibrateJobs = 1,
    scheduler: Scheduler = None,
    quiet: Quiet = False,
    debug: Debug = False,
) -> None:
    """Calibrate every joint of a calibration trial into one file: knee axis and centre
    (hinge), ankle and hip centres (spheroidal), with each joint's quality block and what
    `imucal angles` needs to apply it to other trials (docs/json.md, docs/angles.md)."""
    with _errors(debug):
        from .settings import CalibrateSettings

        settings = _settings(ctx, CalibrateSettings, joints=tuple(joint or ()),
                             restarts=restarts, seed=seed, time_offset=time_offset,
                             offset_search=offset_search, acc_error=acc_error, sign=sign,
                             j2_sign=j2_sign, standing=standing,
                             calibrations=None if calibrations is None else str(calibrations))
        job = _job(ctx, "calibrate", None, settings, start=start, end=end, rate=rate,
                   gyr_units=gyr_units, acc_units=acc_units, sensor_map=sensor_map,
                   force=force)
        folders = {os.path.dirname(r.rstrip("/")) for r in rec}
        if standing and standing != "-" and "{folder}" not in standing and len(folders) > 1:
            # (one subject's stand for every subject: walks 93-121 deg off, "fits", a
            # gait-lab trial)
            raise typer.BadParameter(
                f"{standing} would be every REC's standing trial, and they lie in "
                f"{len(folders)} folders: give each its own with {{folder}} (e.g. "
                "'{folder}/static.h5'), or calibrate them apart", ctx=ctx,
                param_hint="'--standing'")
        if standing == "-" and (len(rec) > 1 or "-" in rec):
            # (the second recording found standard input empty: a review)
            raise typer.BadParameter("- (standard input) is one standing trial for one REC "
                                     "read from a file", ctx=ctx, param_hint="'--standing'")
        _check_scheduler(scheduler, quiet)
        if _is_study(rec, jobs if _given(ctx, "jobs") else None, scheduler) \
                or calibrations is not None:
            from .study import run_study

            raise typer.Exit(run_study(job, rec, out=out, jobs=jobs, scheduler=scheduler,
                                       quiet=quiet))
        from .runner import run

        _check_outputs(out, None, rec[0], sensor_map)
        outcome = run(job, rec[0])
        for w in outcome.warnings:
            say(f"imucal: warning: {w}")
        if outcome.headline is not None and not quiet:
            say(outcome.headline)
        if outcome.document is None:
            raise outcome.exception
        _emit(outcome.document, out)
        if not quiet:
            _calibration_summary(outcome.document)
        if outcome.error is not None:
            say(f"imucal: error: {outcome.error}")
        raise typer.Exit(outcome.exit_code)


@app.command(
    epilog=_examples(
        "imucal angles walk.h5 --calibration cal.json > knee.csv",
        "imucal angles walk.h5 --calibration cal.json --out knee.csv --plot knee.png",
        "imucal angles walk.h5 -c cal.json --reference standing --out knee.h5",
        "imucal angles walk.h5 -c cal.json --reference 3.5 --flexion-sign +",
        "imucal angles walk.h5 -c cal.json --time-offset 0.015   # this trial's shank 15 ms late",
        "imucal angles walk_*.h5 -c cal.json --tables knee/ --jobs 2 > walks.jsonl",
    )
)
def angles(
    ctx: typer.Context,
    rec: Annotated[list[str], typer.Argument(
        metavar="REC", show_default=False,
        help="Recording(s): files or folders, imucal's HDF5/CSV or vendor exports "
        "(Xsens MT Manager, Movella DOT, APDM, x-IMU3, Shimmer, BIDS-motion; "
        "docs/formats.md); - reads CSV from stdin. Several RECs need --tables.")],
    calibration: Annotated[Path, typer.Option(
        "--calibration", "-c", metavar="CAL.json", show_default=False, parser=_input_file,
        help="Calibration file written by imucal calibrate (same sensors, same mounting).")],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", metavar="FILE", show_default=False, parser=_output_file,
        callback=_dash_is_stdout,
        help="Write the table here instead of CSV on stdout (- : stdout): .csv, or .h5/.hdf5 (one "
        "dataset per column with its units and, for a joint, its sensors and frame as "
        "attributes; the JSON summary as the root attribute 'imucal'). With --tables: the "
        "JSON Lines file.")] = None,
    plot: Annotated[Path | None, typer.Option(
        metavar="FILE", show_default=False, parser=_output_file, help="Write the figure "
        "(flexion over time with its 2-sigma band; the mean cycle when the flexion repeats "
        "regularly, as in walking): .png, .pdf or .svg. One REC, without --tables.")] = None,
    reference: Annotated[str | None, typer.Option(
        metavar="standing|SECONDS", show_default=False,
        help="What 0 deg means. Default: the calibration's zero (its trial's most extended "
        "still period, else its most extended posture), shared by every trial of the "
        "mounting; standing: this recording's most extended still period; a number: the "
        "angle at that time (s on this recording's time axis; its mean over +-0.1 s, so a "
        "single sample there need not read 0).")] = None,
    flexion_sign: Annotated[str, typer.Option(
        "--flexion-sign", metavar="auto|+|-",
        help="auto: decided on the calibration trial (knees flex more than they "
        "hyperextend), or on this recording when that was ambiguous (when both are, the "
        "calibration's guess is kept, with a warning); + / -: flexion is "
        "the right-handed rotation of the second segment about the calibration's axis, "
        "or the opposite.")] = "auto",
    time_offset: Annotated[str | None, typer.Option(
        "--time-offset", metavar="SECONDS", show_default=False,
        help="This recording's clock offset of each knee's second sensor (the shank), s, "
        "positive: its clock is late; taken as exact. Default: the calibration's, as a "
        "fixed latency persists between trials. For sensors synchronised anew for each "
        "recording (not searched here: soft tissue on a walk mimics offsets).")] = None,
    start: Start = None,
    end: End = None,
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    tables: Annotated[Path | None, typer.Option(
        "--tables", metavar="DIR", show_default=False, parser=_output_folder,
        help="A study (of one REC or several): write each recording's table as DIR/NAME.csv "
        "(NAME: its file or folder name without suffix, with as many of its folders as "
        "tell recordings of one name apart; DIR is made when the first table "
        "is written, or at the start for an --out inside it; none may be a recording or "
        "the calibration) and print one JSON "
        "line per recording {file, exit_code, error, warnings, result}, result the angles' "
        "summary with its 'table' (docs/angles.md); a recording whose angles do not fit "
        "gets exit_code 1 and no table (--force writes it).")] = None,
    force: Annotated[bool, typer.Option(
        "--force", help="Write the angles even when the calibration does not fit this "
        "recording or a knee in it is not identifiable (exit 0, the warnings on stderr). "
        "Without it such a run writes nothing and exits 1. A window where no angle can be "
        "measured at all (the joint never moves) exits 1 even with it.")] = False,
    jobs: Annotated[int, typer.Option(
        "--jobs", "-j", min=0, help="With --tables: recordings processed at once, in "
        "separate processes (0: one per CPU core); the lines stay in input order, a failed "
        "recording gets an error line and the others go on; exit status: the highest of "
        "the recordings' codes. Without --tables: a warning, and the recording runs "
        "here.")] = 1,
    scheduler: Annotated[str | None, typer.Option(
        "--scheduler", metavar="ADDRESS", show_default=False,
        help="With --tables and several RECs: run the study on the Dask cluster whose "
        "scheduler listens at ADDRESS (e.g. tcp://host:8786) instead of local processes; "
        "same output and exit status as --jobs. Needs the dask extra "
        "(docs/performance.md). One REC runs here (without --tables, with a warning).")]
    = None,
    quiet: Quiet = False,
    debug: Debug = False,
) -> None:
    """Flexion of every hinge (knee) of a calibration over a recording, deg: a table with
    `time` (s), `<joint>_flexion_deg` and `<joint>_flexion_sigma_deg` (1-sigma) per
    joint (docs/angles.md). Data on stdout or --out, messages on stderr; with --tables,
    a study: one table per recording in DIR and JSON Lines on stdout."""
    with _errors(debug):
        job = _angles_job(ctx, calibration, reference, flexion_sign, tables, time_offset,
                          start=start, end=end, rate=rate, gyr_units=gyr_units,
                          acc_units=acc_units, sensor_map=sensor_map, force=force)
        if tables is not None or len(rec) > 1:
            raise typer.Exit(_angles_study(ctx, job, rec, out=out, plot=plot, jobs=jobs,
                                           scheduler=scheduler, quiet=quiet))
        _check_scheduler(scheduler, quiet, runs_here=True)
        if _given(ctx, "jobs"):  # (ignored without a word; a new-user trial)
            say(f"imucal: warning: --jobs {jobs} is for studies (--tables); this recording "
                "runs here")
        from .formats import HDF5_SUFFIXES

        if out is not None and out.suffix.lower() not in {".csv", *HDF5_SUFFIXES}:
            raise typer.BadParameter(f"{out}: unknown table format "
                                     f"'{out.suffix or out.name}'; use .csv, .h5 or .hdf5",
                                     ctx=ctx, param_hint="'--out'")
        _check_outputs(out, plot, rec[0], sensor_map)
        check_not_inputs([("--out", out), ("--plot", plot)], [calibration])
        from dataclasses import replace

        from .calibration import load_calibration
        from .runner import run

        # missing or broken: said before the recording loads; read once (a pipe, -c <(...),
        # is empty the second time: a new-user trial)
        job = replace(job, calibration_read=load_calibration(calibration))
        outcome = run(job, rec[0])
        for w in outcome.warnings:  # (in a loop over trials, they say which trial)
            say(f"imucal: warning: {w}")
        if outcome.exception is not None:
            raise outcome.exception
        result = outcome.result
        figure = contextlib.nullcontext()
        if plot is not None:
            from .angle_plots import staged_angles_figure

            figure = staged_angles_figure(result, plot)
        with figure:  # the figure in place only once the table is
            if out is None:  # (a reader gone shows inside the error handler)
                write_stdout(result.to_frame().to_csv(index=False, float_format="%.6g"))
            else:
                result.write(out)
        if not quiet:
            _angles_summary(result, out)


def _angles_job(ctx: typer.Context, calibration, reference, flexion_sign, tables,
                time_offset, **options):
    """The runner's angles job; bad options are usage errors before any file is read."""
    from .settings import AnglesSettings

    start, end = options["start"], options["end"]
    if start is not None and end is not None and end <= start:
        raise typer.BadParameter(f"must be after --start ({start:g} s), got {end:g} s",
                                 ctx=ctx, param_hint="'--end'")
    ref = _reference(ctx, reference)
    if flexion_sign not in ("auto", "+", "-"):
        raise typer.BadParameter(f"must be auto, + or -, got '{flexion_sign}'", ctx=ctx,
                                 param_hint="'--flexion-sign'")
    settings = _settings(ctx, AnglesSettings, calibration=str(calibration), reference=ref,
                         flexion_sign=flexion_sign,
                         tables=None if tables is None else str(tables),
                         time_offset=time_offset)
    return _job(ctx, "angles", None, settings, **options)


def _angles_study(ctx: typer.Context, job, recs, *, out, plot, jobs, scheduler,
                  quiet) -> int:
    """``imucal angles`` over several recordings (or one with --tables): each table into
    the --tables folder, JSON Lines on stdout or --out; the exit status. The study checks
    the folder, the tables' names and the calibration before anything runs."""
    from .study import run_study

    if job.settings.tables is None:
        raise typer.BadParameter("several RECs need --tables DIR (one table per recording)",
                                 ctx=ctx, param_hint="'--tables'")
    if plot is not None:
        raise typer.BadParameter("draws one recording's angles: leave out --tables, or run "
                                 "'imucal angles REC --plot FILE.png' for the recordings to "
                                 "draw", ctx=ctx, param_hint="'--plot'")
    if recs == ["-"]:
        raise typer.BadParameter("each table is named after its recording's file, and - "
                                 "(standard input) has none: write its table with --out",
                                 ctx=ctx, param_hint="'--tables'")
    _check_scheduler(scheduler, quiet)
    if len(recs) == 1 and scheduler is not None:
        # (it ran here without a word: a review)
        say(f"imucal: warning: --scheduler {scheduler}: one recording runs here")
        scheduler = None
    return run_study(job, recs, out=out, plot=plot, jobs=jobs, scheduler=scheduler,
                     quiet=quiet)


def _reference(ctx: typer.Context, text: str | None):
    """--reference: None, "standing" or a time in s; anything else is a usage error."""
    if text is None or text.strip().lower() == "standing":
        return None if text is None else "standing"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise typer.BadParameter(f"must be standing or a time in s, got '{text}'", ctx=ctx,
                                 param_hint="'--reference'")
    return value


def _angles_summary(result, out) -> None:
    """Per joint on stderr: range, sign, zero, the fit check, gait."""
    from .angles import PLAUSIBLE_FLEXION_DEG

    low, high = PLAUSIBLE_FLEXION_DEG
    doc = result.to_document()
    where = "stdout" if out is None else str(out)
    say(f"imucal angles: {doc['input']['path']}: {doc['input']['samples']} samples at "
        f"{doc['input']['sample_rate_hz']:g} Hz, calibration {doc['calibration']} -> {where}")
    for j in doc["joints"].values():
        lo, hi = j["range_deg"]
        c = j["check"]
        # regular flexion peaks are found in circling the leg as well as in walking, so
        # the line names cycles, not a walk
        gait = "" if j["gait"] is None else (f"; {j['gait']['strides']} regular flexion "
                                             f"cycles of {j['gait']['stride_s']:.2f} s")
        say(f"  {j['column']}: {lo:.1f} to {hi:.1f} deg (median 1-sigma "
            f"{j['sigma_deg']['median']:.2f} deg), sign {j['flexion_sign']:+d} from "
            f"{j['sign_source']}, 0 = {j['zero']['method']}{gait}")
        # a knee the calibration marks not identifiable fails whatever the numbers say:
        # the line named only numbers within their limits
        marked = (c.get("calibration_verdict") == "not identifiable")
        say(f"    fit check: {'fits' if j['fits'] else 'DOES NOT FIT'} ("
            + ("not identifiable in the calibration; " if marked else "") + "hinge residual "
            f"{_num(c['hinge_residual'], 3)}, limit "
            f"{_num(c['hinge_residual_limit'], 3)}; acc-gyro disagreement "
            f"{_num(c['acc_gyro_disagreement_deg'], 2)} deg, limit "
            f"{_num(c['acc_gyro_disagreement_limit_deg'], 2)} deg"
            + (f"; gravity mismatch {c['gravity_mismatch_deg']:.0f} deg"
                if c.get("gravity_mismatch_deg") is not None else "")
            + (f"; {c['implausible_flexion_share']:.0%} of the flexion outside {low:g} to "
                f"{high:g} deg" if c.get("implausible_flexion_share") else "")
            + (f"; clock offset {signed_ms(c['clock_offset_s'], 1)} ms "
               f"{c['clock_offset_source']}" if c.get("clock_offset_source", "calibration")
               != "calibration" else "") + ")")


@app.command(
    epilog=_examples(
        "imucal simulate rec.h5 --seed 1",
        "imucal simulate rec.csv --rate 40 --snr 30 --motion gait",
        "imucal simulate rec.h5 --motion protocol --rate 40 --duration 30 --gyr-noise 0.01 "
        "--acc-noise 0.05",
        "imucal simulate rec.h5 --motion gait --soft-tissue-deg 2 --soft-tissue-mm 3 "
        "--clock-offset shank=0.02 --gyr-bias 0.02",
        "imucal simulate walk.h5 --seed 8 --mounting-seed 7 --motion gait --duration 30 "
        "# same mounting as --seed 7",
    )
)
def simulate(
    out: Annotated[Path, typer.Argument(
        metavar="OUT", show_default=False, parser=_output_file,
        help="Output recording, .h5, .hdf5 or .csv; the truth goes to OUT.truth.json beside it.",
    )],
    seed: Seed = None,
    rate: Annotated[float, typer.Option(min=1.0, help="Sample rate, Hz.")] = 100.0,
    duration: Annotated[float, typer.Option(min=0.1, help="Duration, s.")] = 20.0,
    snr: Annotated[float | None, typer.Option(
        help="Signal-to-noise ratio (RMS amplitude ratio per signal, > 0); inf: no noise. "
        "Default 100, or none when --gyr-noise or --acc-noise is given.", show_default=False,
    )] = None,
    motion: Annotated[str, typer.Option(
        help="circling, gait (walking with stride-to-stride variation), protocol (5 s "
        "circling, then gait), walking (legacy periodic gait), rigid-knee or static.")]
    = "circling",
    gyr_noise: Annotated[float | None, typer.Option(
        metavar="RAD/S", show_default=False,
        help="White gyroscope noise instead of --snr: std per component and sample, rad/s.",
    )] = None,
    acc_noise: Annotated[float | None, typer.Option(
        metavar="M/S^2", show_default=False,
        help="White accelerometer noise instead of --snr: std per component and sample, "
        "m/s^2.",
    )] = None,
    soft_tissue_deg: Annotated[float, typer.Option(
        metavar="DEG", help="Soft-tissue artefact: each sensor turns on its segment by up "
        "to this angle, deg (stride-locked, plus a 10-15 Hz wobble after heel strike); the "
        "joints stay exact.")] = 0.0,
    soft_tissue_mm: Annotated[float, typer.Option(
        metavar="MM", help="Soft-tissue artefact: each sensor shifts on its segment by up "
        "to this distance, mm.")] = 0.0,
    clock_offset: Annotated[list[str] | None, typer.Option(
        metavar="SENSOR=S", show_default=False,
        help="Clock offset of one sensor, s (repeatable, e.g. shank=0.02): positive = its "
        "clock is late, its samples show the motion later (its sample at t shows true time "
        "t - S).")] = None,
    gyr_bias: Annotated[list[str] | None, typer.Option(
        metavar="RAD/S|SENSOR=RAD/S|SENSOR=X,Y,Z", show_default=False,
        help="Constant gyroscope bias, rad/s, sensor frame: one magnitude for every sensor "
        "(random directions), or per sensor a magnitude or a vector (repeatable).")] = None,
    mounting_seed: Annotated[int | None, typer.Option(
        min=0, show_default=False,
        help="Seed of the sensor mounting alone (poses on the segments, segment "
        "lengths): recordings with different --seed but one --mounting-seed are trials of "
        "one session with the sensors left in place (calibrate on one, measure angles on "
        "another); the mounting equals the one of --seed N. Default: from --seed.")]
    = None,
    acc_bias: Annotated[list[str] | None, typer.Option(
        metavar="M/S^2|SENSOR=M/S^2|SENSOR=X,Y,Z", show_default=False,
        help="Constant accelerometer bias (offset), m/s^2, sensor frame, given like "
        "--gyr-bias (typical after factory calibration: 0.02-0.1).")] = None,
    quiet: SimulateQuiet = False,
    debug: Debug = False,
) -> None:
    """Simulate thigh-knee-shank-ankle-foot with sensors at random poses (paper Sec. III-A)."""
    with _errors(debug):
        from .report import clean
        from .simulate import MOTIONS, parse_clock_offsets, parse_sensor_bias
        from .simulate import simulate as run_simulation
        from .writers import save_recording

        if motion not in MOTIONS:
            raise InputError(f"--motion must be one of {', '.join(MOTIONS)}, got '{motion}'")
        if snr is not None and not snr > 0:
            raise InputError(f"--snr must be positive (inf: no noise), got {snr:g}")
        if snr is not None and not math.isinf(snr) and (gyr_noise is not None
                                                        or acc_noise is not None):
            raise InputError("give --snr or --gyr-noise/--acc-noise (physical units), not both")
        offsets, bias = parse_clock_offsets(clock_offset), parse_sensor_bias(gyr_bias)
        acc_offsets = parse_sensor_bias(acc_bias, "--acc-bias", "m/s^2")
        from .formats import HDF5_SUFFIXES

        if out.suffix.lower() not in {*HDF5_SUFFIXES, ".csv"}:
            raise InputError(f"{out}: unknown output format '{out.suffix or out.name}'; use "
                             ".h5, .hdf5 or .csv")
        truth_path = out.with_name(out.stem + ".truth.json")
        # rec.csv and rec.h5 would share rec.truth.json: the other one would be left
        # beside a truth of another seed and rate, silently
        # (any case: rec.H5 and rec.h5 are two files on Linux)
        siblings = ([p for p in out.parent.iterdir() if p.stem == out.stem]
                    if out.parent.is_dir() else [])
        for other in siblings:
            if (other.suffix.lower() in {*HDF5_SUFFIXES, ".csv"} and other.name != out.name
                    and other.is_file()):
                raise InputError(f"{out}: {other.name} lies beside it and would share "
                                 f"{truth_path.name}; give the recording another name")
        check_writable(out)
        recording, truth = run_simulation(
            seed=seed, rate=rate, duration=duration, motion=motion,
            snr="auto" if snr is None else None if math.isinf(snr) else snr,
            gyr_noise=gyr_noise, acc_noise=acc_noise, soft_tissue_deg=soft_tissue_deg,
            soft_tissue_mm=soft_tissue_mm, clock_offset=offsets, gyr_bias=bias,
            mounting_seed=mounting_seed, acc_bias=acc_offsets,
        )
        # an old truth file must not outlive the recording it described: a signal between
        # the two writes would pair the new recording with it
        truth_path.unlink(missing_ok=True)
        save_recording(recording, out)
        write_text_atomic(truth_path, json.dumps(clean(truth), indent=2) + "\n")
        if not quiet:
            say(f"imucal simulate: wrote {out} ({recording.n_samples} samples at "
                f"{recording.rate:g} Hz, motion {motion}, seed {truth['settings']['seed']}) "
                f"and {truth_path}")


@app.command(epilog=_examples("imucal info walk.h5", "imucal info rec.csv --rate 100 --json"))
def info(
    rec: Rec,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")]
    = False,
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    debug: Debug = False,
) -> None:
    """Sensors, sample rate (Hz, and where it came from), duration, units, and how much
    each sensor moves (gyro rms and peak in deg/s, |acc| - g rms in m/s^2); for a vendor
    export also every device's own rate, serial, start and dropped samples."""
    with _errors(debug):
        from .loaders import load_recording
        from .provenance import describe

        recording = load_recording(rec, rate=rate, gyr_units=gyr_units, acc_units=acc_units,
                                   names=sensor_map)
        doc = describe(recording)
        if as_json:
            write_stdout(json.dumps(doc, indent=2) + "\n")
            return
        # "rate" alone would read as the sample rate: the gyro columns say what they are
        w = max([16] + [len(n) + 2 for n in doc["sensors"]])  # long names keep the columns
        lines = [
            f"{doc['path']}: {doc['samples']} samples at {doc['sample_rate_hz']:g} Hz "
            f"({_seconds(doc['duration_s'])} s, t = {doc['time_s'][0]:g} to "
            f"{doc['time_s'][1]:g} s)",
            f"sample rate from {doc['sample_rate_from']}",
            f"{'sensor':<{w}}{'file units':<18}{'gyro rms deg/s':>16}{'gyro peak deg/s':>17}"
            f"{'|acc|-g rms m/s^2':>19}  motion",
        ]
        for name, s in doc["sensors"].items():
            units = f"{s['units']['gyr']}, {s['units']['acc']}"
            if s["gyr_rms_deg_s"] is None:
                lines.append(f"{name:<{w}}{units:<18}{'-':>16}{'-':>17}{'-':>19}  "
                             f"{s['motion']}")
                continue
            lines.append(
                f"{name:<{w}}{units:<18}{s['gyr_rms_deg_s']:>16.1f}{s['gyr_peak_deg_s']:>17.1f}"
                f"{s['acc_dynamic_rms_m_s2']:>19.2f}  {s['motion']}"
            )
        from .provenance import sensor_table

        lines += sensor_table(recording)
        lines += [f"note: {n}" for n in recording.provenance.get("notes", [])]
        for w in recording.warnings:
            lines.append(f"warning: {w}")
        write_stdout("\n".join(lines) + "\n")


def _seconds(value: float) -> str:
    """A duration for a headline: one decimal, but 0.02 s read "0.0 s" (a new-user
    trial)."""
    return f"{value:.1f}" if value >= 1 else f"{value:.2g}"


@app.command(epilog=_examples("imucal convert opal.h5 walk.h5",
                              "imucal convert dot_export/ walk.csv   # a folder of DOT files",
                              "imucal convert dot_export/ - | imucal axis -   # CSV on stdout"))
def convert(
    rec: Rec,
    out: Annotated[Path, typer.Argument(metavar="OUT", show_default=False,
                                        parser=_output_file,
                                        help="Output file, .h5/.hdf5 or .csv; - : CSV on "
                                             "stdout.")],
    rate: Rate = None,
    gyr_units: GyrUnits = None,
    acc_units: AccUnits = None,
    sensor_map: SensorMap = None,
    quiet: ConvertQuiet = False,
    debug: Debug = False,
) -> None:
    """Write a recording (any format imucal reads, such as a vendor export) in imucal's own
    HDF5 or CSV layout: the devices on one time grid, SI units, dropped samples as NaN;
    HDF5 also keeps the provenance (source format, files, serials, original rates) as
    root attributes (docs/formats.md)."""
    with _errors(debug):
        from .loaders import load_recording
        from .provenance import hdf5_attrs
        from .writers import save_recording

        stdout = str(out) == "-"  # a pipeline's CSV (it was "unknown output format '-'")
        if not stdout:
            _check_outputs(out, None, rec, sensor_map, out_name="OUT")
        recording = load_recording(rec, rate=rate, gyr_units=gyr_units, acc_units=acc_units,
                                   names=sensor_map)
        if stdout:
            from .writers import csv_text

            write_stdout(csv_text(recording))
        else:
            save_recording(recording, out, extra_attrs=hdf5_attrs(recording))
        if not quiet:
            for w in recording.warnings:
                say(f"imucal: warning: {recording.source}: {w}")
            say(f"imucal convert: wrote {'CSV to stdout' if stdout else out} "
                f"({len(recording.sensors)} sensors, {recording.n_samples} samples at "
                f"{recording.rate:g} Hz)")


def _settings(ctx: typer.Context, cls, **values):
    """The estimator's settings object from the options, before any file is read; a bad
    value is a usage error naming its option (exit 2)."""
    try:
        settings = cls(**values)
    except InputError as err:
        raise _usage_error(ctx, str(err)) from None
    return settings


def _job(ctx: typer.Context, command: str, sensors: str | None, settings, **options):
    """The runner's job from the options; a bad --sensors or window is a usage error.
    ``sensors`` None: a command on the whole recording (calibrate)."""
    from .runner import Job, parse_sensors

    try:
        return Job(command, () if sensors is None else parse_sensors(sensors), settings,
                   **options)
    except InputError as err:
        raise _usage_error(ctx, str(err)) from None


#: Settings fields (as their messages name them) -> the options that set them.
_OPTIONS = {"restarts": "--restarts", "seed": "--seed", "cutoff": "--cutoff",
            "subsample": "--subsample", "max_samples": "--max-samples", "sign": "--sign",
            "j2_sign": "--j2-sign", "time offset": "--time-offset", "joint": "--joint",
            "offset_search": "--offset-search",
            "acc_error": "--acc-error", "standing": "--standing"}


def _usage_error(ctx: typer.Context, text: str) -> typer.BadParameter:
    """A usage error in typer's own form: "Invalid value for '--sign': sign must be ..."."""
    for name, option in _OPTIONS.items():
        if text.startswith(name + " "):
            return typer.BadParameter(text, ctx=ctx, param_hint=f"'{option}'")
    for option in ("--gyr-units", "--acc-units"):
        if text.startswith(option + ": "):
            return typer.BadParameter(text[len(option) + 2:], ctx=ctx,
                                      param_hint=f"'{option}'")
    for option in ("--sensors", "--start", "--end", "--rate"):
        if text.startswith(option + " "):
            return typer.BadParameter(text[len(option) + 1:], ctx=ctx,
                                      param_hint=f"'{option}'")
    return typer.BadParameter(text, ctx=ctx)


def _check_scheduler(scheduler, quiet, runs_here: bool = False) -> None:
    """``--scheduler``'s form checked whatever the number of recordings (a bad address
    passed silently with one); where the recording runs here all the same (``angles``
    without ``--tables``), say so."""
    if scheduler is None:
        return
    from .cluster import check_address

    check_address(scheduler)
    if runs_here:  # angles' warnings print with -q too (a table cannot carry them)
        say(f"imucal: warning: --scheduler {scheduler} is for studies (--tables); this "
            "recording runs here")


def _given(ctx: typer.Context, name: str) -> bool:
    """Whether option ``name`` was given, not left at its default (by the source's
    name: typer's own copy of click has its own ParameterSource)."""
    source = ctx.get_parameter_source(name)
    return source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP")


def _is_study(recs, jobs, scheduler) -> bool:
    """Several recordings, or one with ``--jobs`` or ``--scheduler`` given: a study's
    JSON Lines. A glob that matched one file turned a study into one pretty-printed
    document, which the study's jq line then read as nothing, exit 0 (a new-user
    trial)."""
    return len(recs) > 1 or jobs is not None or scheduler is not None


def _estimate(job, recs, *, out, plot, jobs, scheduler, quiet) -> int:
    """Run ``job`` on one recording (print its document) or a study; the exit status."""
    _check_scheduler(scheduler, quiet)
    if _is_study(recs, jobs, scheduler):
        from .study import run_study

        # (not given: one process; 0: one per core, as --help says: "or 1" made it one)
        return run_study(job, recs, out=out, plot=plot, jobs=1 if jobs is None else jobs,
                         scheduler=scheduler, quiet=quiet)
    from .runner import run

    rec = recs[0]
    _check_outputs(out, plot, rec, job.sensor_map)
    outcome = run(job, rec)
    for w in outcome.warnings:  # as they were found, -q or not
        say(f"imucal: warning: {w}")
    if outcome.headline is not None and not quiet:
        say(outcome.headline)
    if outcome.exception is not None:
        if not quiet:
            for w in outcome.notes:
                say(f"imucal: warning: {w}")
        raise outcome.exception
    doc = outcome.document
    with _staged_figure(plot, job, outcome, doc):  # in place only once the JSON is
        _emit(doc, out)
    if not quiet:
        _summary(doc, job.sensors)
    return 0


def _max_samples(value: int | None) -> int:
    """--max-samples left out means the estimators' default cap; their None means no cap,
    which on a 1 h recording puts all 360 000 samples into every restart."""
    from .selection import MAX_SAMPLES

    return MAX_SAMPLES if value is None else value


class _errors:
    """Turn the project's errors into one stderr line and an exit status."""

    def __init__(self, debug: bool):
        self.debug = debug

    def __enter__(self):
        return self

    def __exit__(self, kind, err, tb):
        if err is None or isinstance(err, (typer.Exit, SystemExit, typer.BadParameter)):
            return False
        if isinstance(err, BrokenPipeError):
            # a reader that stopped early (| head), with --debug too: quiet, with the
            # status of a process stopped by SIGPIPE; Python would complain again when it
            # flushes stdout at exit
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            raise typer.Exit(141)
        if self.debug:
            # the traceback, then the same line and status as without --debug: Python's
            # own exit status 1 read as "not identifiable" for any error (a new-user trial)
            import traceback

            traceback.print_exception(kind, err, tb)
        if isinstance(err, KeyboardInterrupt):  # Ctrl-C, SIGTERM, SIGHUP: imucal.signals
            raise typer.Exit(report_interruption(err))
        interruption = unreported_interruption()
        if interruption is not None:  # one that the code it hit turned into another error
            raise typer.Exit(report_interruption(interruption))
        code = exit_code_of(err)  # as a study's line gets (runner.error_of)
        if isinstance(err, ImucalError):
            say(f"imucal: error: {one_line(err)}")
        elif isinstance(err, OSError):
            where = f"{err.filename}: " if err.filename else ""
            say(one_line(f"imucal: error: {where}{err.strerror or err}"))
        elif isinstance(err, MemoryError):  # no bug to report: a shorter window needs less
            say("imucal: error: out of memory")
        else:
            say(f"imucal: internal error: {type(err).__name__}: {err} (rerun with --debug and "
                "report it)")
        raise typer.Exit(code)


def _check_outputs(out, plot, rec, sensor_map=None, out_name: str = "--out") -> None:
    """Usage errors of the output paths, before any file is read; ``out_name`` names the
    output as the command takes it (``convert``'s is its argument OUT)."""
    if plot is not None:
        from .plots import FORMATS

        if not plot.suffix and plot.name.lower() in FORMATS:  # ".png" is a name, no extension
            raise InputError(f"{plot}: give the figure a name before its extension, e.g. "
                             f"fit{plot.name}")
        if plot.suffix.lower() not in FORMATS:
            raise InputError(f"{plot}: unknown figure format '{plot.suffix or plot.name}'; "
                             f"--plot writes PNG, PDF or SVG by the file name's extension "
                             f"({', '.join(FORMATS)})")
    check_not_inputs([(out_name, out), ("--plot", plot)],
                     [rec] + ([sensor_map] if sensor_map is not None else []))
    for path in (out, plot):
        if path is not None:
            check_writable(path)


def _emit(doc: dict, out: Path | None) -> None:
    from .report import dumps

    text = dumps(doc)
    if out is None:
        write_stdout(text)
    else:
        write_text_atomic(out, text)


def _staged_figure(plot: Path | None, job, outcome, doc: dict):
    """The figure drawn and written to a temporary file; in place when the block ends."""
    if plot is None:
        return contextlib.nullcontext()
    from .plots import save_figure
    from .runner import COMMANDS

    pair = f"{job.sensors[0]} - {job.sensors[1]}"
    fig = COMMANDS[job.command].figure(outcome.result, pair, doc)
    return staged(plot, lambda tmp: save_figure(fig, tmp, plot.suffix))


def _summary(doc: dict, names) -> None:
    """Human summary on stderr, read back from the JSON document so both always agree."""
    v1, v2 = ("j1", "j2") if "j1" in doc else ("o1", "o2")
    units, q, conv = doc["units"], doc["quality"], doc["convergence"]
    unit = "" if units[v1] == "unit vector" else f" {units[v1]}"
    u = units["uncertainty"]
    sigma = "/".join(f"{q[f'{v}_uncertainty_{u}']:.2f}" if q[f"{v}_uncertainty_{u}"] is not None
                     else "-" for v in (v1, v2))
    reached = sum(r["reached_estimate"] for r in doc["restarts"])
    say(f"  {v1} ({names[0]}) = {_vec(doc[v1])}{unit}   {v2} ({names[1]}) = {_vec(doc[v2])}{unit}")
    say(f"  1-sigma {sigma} {u}; {reached}/{len(doc['restarts'])} restarts reached the estimate "
        f"(median {conv['iterations_median']:g}, max {conv['iterations_max']} iterations); "
        f"residual {q['rms_residual']:.4f} {units['rms_residual']} "
        # no signal at all (every sample 0): the ratio is undefined, null in the JSON
        f"({'-' if q['relative_residual'] is None else format(q['relative_residual'], '.1%')}"
        " of signal)")
    offset = _offset_text(doc.get("time_offset"))
    if offset:
        say(f"  clock offset of {names[1]}: {offset}")
    say(f"  verdict: {q['verdict']}")
    for w in q["warnings"]:
        say(f"  warning: {w}")


def _offset_text(offset: dict | None) -> str:
    """What the clock-offset search of an estimate found (``"+28.1 ms (1-sigma 14.1 ms,
    applied)"``), or the offset given and what its check read (``"+0.0 ms given (the data
    read +19.7 ms, 1-sigma 0.3 ms: contradicted)"``); "" without a ``time_offset`` block."""
    if isinstance(offset, dict) and offset.get("mode") == "given":
        given = f"{signed_ms(offset['time_offset_s'], 1)} ms given"
        if offset.get("estimated_s") is None or offset.get("sigma_s") is None:
            return f"{given} (not checked: too few samples)"
        verdict = ": contradicted" if offset.get("contradicted") else ""
        if offset.get("at_edge"):  # the profile fell to the search's end: a bound
            return (f"{given} (the data read at least {signed_ms(offset['estimated_s'], 1)}"
                    f" ms, the end of the search{verdict})")
        return (f"{given} (the data read {signed_ms(offset['estimated_s'], 1)} ms, 1-sigma "
                f"{1000 * offset['sigma_s']:.1f} ms{verdict})")
    if not isinstance(offset, dict) or offset.get("mode") != "auto":
        return ""
    applied = "applied" if offset["applied"] else "not applied"
    sigma, found = offset["sigma_s"], offset["estimated_s"]
    if sigma is None and found != 0 and not offset["applied"]:  # the search's end: a bound
        return f"at least {signed_ms(found, 1)} ms (the end of the search, {applied})"
    if sigma is None and not offset["applied"]:
        # a window too short for the search, or no motion: nothing was estimated (it
        # printed "+0.0 ms (1-sigma - ms, not applied)", a new-user trial)
        if offset.get("not_estimated") == "no motion":
            return "not estimated (no motion)"
        return "not estimated (too few usable samples for the search)"  # (or none finite)
    return (f"{signed_ms(found, 1)} ms (1-sigma "
            f"{'-' if sigma is None else f'{1000 * sigma:.1f}'} ms, {applied})")


def _sigmas(result: dict, names: tuple[str, str], spec: str) -> str:
    """``"1-sigma 13.3/4.0 mm"`` of an embedded result's two vectors ("-": none)."""
    q, u = result["quality"], result["units"]["uncertainty"]
    values = "/".join("-" if q[f"{v}_uncertainty_{u}"] is None
                      else format(q[f"{v}_uncertainty_{u}"], spec) for v in names)
    return f"1-sigma {values} {u}"


def _calibration_summary(doc: dict) -> None:
    """One or two stderr lines per joint of a calibration document: verdict and numbers."""
    for name, j in doc["joints"].items():
        pair = f"{j['sensors'][0]} -> {j['sensors'][1]}"
        head = f"  {name} ({j['joint']}, {pair}): {j['verdict']}"
        if j["o1"] is None:
            say(head)
        elif j["joint"] == "hinge":
            a = j["angle"] or {}
            say(f"{head}; j1 = {_vec(j['j1'])}, j2 = {_vec(j['j2'])} "
                f"({_sigmas(j['axis'], ('j1', 'j2'), '.2f')}); centre o1 = {_vec(j['o1'])} m, "
                f"o2 = {_vec(j['o2'])} m ({_sigmas(j['position'], ('o1', 'o2'), '.1f')})")
            if a:
                from .angles import SIGN_EVIDENCE_MIN

                weak = ("; weak: each recording decides" if abs(a["sign_evidence"])
                        < SIGN_EVIDENCE_MIN else "")
                say(f"    flexion sign {a['flexion_sign']:+d} (evidence "
                    f"{a['sign_evidence']:+.2f}{weak}), zero: {a['zero_method']}; hinge "
                    f"residual {_num(a['hinge_residual'], 3)}, acc-gyro angle "
                    f"disagreement {_num(a['acc_gyro_disagreement_deg'], 2)} deg")
        else:
            say(f"{head}; o1 = {_vec(j['o1'])} m, o2 = {_vec(j['o2'])} m "
                f"({_sigmas(j['position'], ('o1', 'o2'), '.1f')})")
        # a knee's offset is its axis's (both of its estimates use it), a ball joint's its
        # centre's; the angles read the sensors with the offset applied here
        offset = _offset_text(((j["axis"] if j["joint"] == "hinge" else j["position"]) or {})
                              .get("time_offset"))
        if offset:
            say(f"    clock offset of {j['sensors'][1]}: {offset}")
        for w in j["warnings"]:
            say(f"    warning: {w}")


def _num(x, decimals: int) -> str:
    """A number of a JSON document, which has null where there is none (NaN)."""
    return "-" if x is None else number_text(x, decimals)


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:+.4f}" for x in v) + "]"



class _ClosedStdout:
    """Standard output when its descriptor was closed (``>&-``): writing the data fails
    with a message (it failed on None: exit 3), flushing nothing is no error."""

    def write(self, text):
        raise OSError(errno.EBADF, "standard output is closed: nothing can be written "
                      "there (give --out FILE, or do not close it)")

    def flush(self):
        pass

    def isatty(self):
        return False


def _closed_streams() -> None:
    """With standard error closed (``2>&-``), messages are dropped: ``print`` to a
    missing sys.stderr writes to stdout, into the JSON or CSV. With standard output
    closed, writing data to it is an error (:class:`_ClosedStdout`). A closed descriptor
    0, 1 or 2 is held by /dev/null: the next file opened would get it, and what a library
    or a worker process writes to 1 or 2 would land in that file."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            CLOSED_AT_START.add(fd)
            spare = os.open(os.devnull, os.O_RDWR)  # the lowest free descriptor: fd
            if spare != fd:
                os.dup2(spare, fd)
                os.close(spare)
    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w")  # for the rest of the process
    if sys.stdout is None:
        sys.stdout = _ClosedStdout()


def _version_callback(value: bool) -> None:
    if value:
        print(f"imucal {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[bool, typer.Option("--version", callback=_version_callback,
                                          is_eager=True, help="Show the version and exit.")]
    = False,
) -> None:
    pass


def main() -> None:
    """Console-script entry point."""
    # Before numpy loads (nothing above imports it): imucal's matrix products are small
    # (restarts x a few thousand samples), where a multi-threaded BLAS spends more time
    # waking threads than computing (measured on 2 cores: 0.14 ms single-threaded, 0.24
    # to 8 ms multi-threaded under load, for one 100 x 1600 by 1600 x 9 product), and
    # parallel work is done across recordings (--jobs). A setting in the environment wins.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    _closed_streams()
    try:
        os.getcwd()
    except OSError:  # every relative path, and a study's worker processes, need it
        say("imucal: error: the current folder no longer exists (it was deleted or moved); "
            "change to another folder")
        sys.exit(2)
    raise_on_signals()
    try:
        code = app(standalone_mode=False)
    except typer.Abort:  # end of input at a prompt
        code = report_interruption(KeyboardInterrupt())
    except KeyboardInterrupt as err:  # while typer builds the command, before it parses
        code = report_interruption(err)
    except Exception as err:
        # Usage errors (unknown option, unparsable value, missing argument) come from the
        # click layer typer builds on; they carry exit_code 2 and format_message().
        if isinstance(err, OSError):  # e.g. --help with standard output closed
            say(one_line(f"imucal: error: {err.strerror or err}"))
            sys.exit(2)
        if getattr(err, "exit_code", None) != 2 or not hasattr(err, "format_message"):
            raise
        if type(err).__name__ == "NoArgsIsHelpError":
            err.show()  # plain `imucal` or `imucal axis`: the help is the answer
        else:
            ctx = getattr(err, "ctx", None)
            command = ctx.command_path if ctx is not None else "imucal"
            say(f"imucal: error: {one_line(err.format_message())} (see '{command} --help')")
        code = 2
    interruption = unreported_interruption()  # one that came while typer parsed
    if interruption is not None:
        code = report_interruption(interruption)
    sys.exit(code if isinstance(code, int) else 0)
