"""Property-based tests of the loaders: whatever the input, only the project's error comes out.

imucal runs unattended over hundreds of files, so a bad file must end in one
:class:`~imucal.errors.InputError` (one line, naming the file), never in another
exception. And when loading succeeds, the recording must keep the promises of
:mod:`imucal.recording`: finite float64 (N, 3) arrays, a positive rate, increasing time.

The HDF5 C library is not safe against arbitrary bytes: mutating bytes of a *valid* file
once made it loop forever (2 of ~18000 cases). So the in-process tests give h5py only
bytes it rejects at once (no HDF5 signature anywhere) or files h5py itself wrote from
arbitrary arrays and attributes; bytes behind a real signature (junk, truncated files)
are tried in a child process with a time limit.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path
from types import SimpleNamespace
from unittest import mock

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from test_loaders import write_h5

from imucal.errors import InputError
from imucal.formats import HDF5_SIGNATURE
from imucal.loaders import load_recording
from imucal.recording import Recording, make_recording
from imucal.sensor_checks import NONPHYSICAL, SENSOR_RANGE

# Modest example counts keep the whole file to a few seconds (the same tests ran clean on
# 20 times as many examples); derandomized, every run tries the same examples, so a
# failure repeats and the suite never flakes; no database, so nothing is left behind.
FAST = settings(max_examples=200, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])
SLOW = settings(max_examples=100, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def check_outcome(load, source: str) -> Recording | None:
    """Run ``load()``: it must return a sound recording or raise a one-line InputError, and
    so must selecting all its sensors for an estimate; returns the selection."""
    try:
        rec = load()
        assert_sound(rec, finite=False)
        rec = rec.select(list(rec.sensors))
    except InputError as err:
        message = str(err)
        assert message and "\n" not in message and "\r" not in message
        assert source in message
        return None
    assert_sound(rec)
    return rec


def assert_sound(rec: Recording, finite: bool = True) -> None:
    """The guarantees every estimator relies on (imucal.recording's docstring); a loaded
    recording may hold non-finite samples, and ``gaps`` says where."""
    assert np.isfinite(rec.rate) and rec.rate > 0
    n = rec.n_samples
    assert n >= 2
    assert rec.time.shape == (n,) and np.isfinite(rec.time).all()
    assert (np.diff(rec.time) > 0).all()
    assert rec.sensors and all(isinstance(name, str) for name in rec.sensors)
    for sensor in rec.sensors.values():
        for arr in (sensor.gyr, sensor.acc):
            assert arr.dtype == np.float64 and arr.shape == (n, 3)
            assert np.isfinite(arr).all() or not finite
    if finite:
        assert not rec.gaps
    else:
        bad = sum(int((~np.isfinite(getattr(s, k)).all(axis=1)).sum())
                  for s in rec.sensors.values() for k in ("gyr", "acc"))
        assert bad == sum(g.length for g in rec.gaps)
    assert all(isinstance(w, str) for w in rec.warnings)


# ----------------------------------------------------------------------- arbitrary bytes


def no_hdf5_signature(data: bytes) -> bool:
    return HDF5_SIGNATURE not in data


@FAST
@given(data=st.binary(max_size=3000).filter(no_hdf5_signature),
       suffix=st.sampled_from([".csv", ".txt", ".h5", ".hdf5", ".bin", ""]))
def test_arbitrary_bytes_in_a_file(data, suffix):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"input{suffix}"
        path.write_bytes(data)
        check_outcome(lambda: load_recording(path, rate=50.0), str(path))


@FAST
@given(data=st.binary(max_size=3000).filter(no_hdf5_signature))
def test_arbitrary_bytes_on_stdin(data):
    with mock.patch.object(sys, "stdin", SimpleNamespace(buffer=io.BytesIO(data))):
        check_outcome(lambda: load_recording("-", rate=50.0), "<stdin>")


# CSV-like text reaches deeper into the parser than random bytes: a plausible header,
# then cells drawn from numbers, words, separators, quotes and line breaks.
HEADER = "time,a_gyr_x,a_gyr_y,a_gyr_z,a_acc_x,a_acc_y,a_acc_z"
CELL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**20, 10**20).map(str),
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e999", "abc", '"', '"1,2"', "\t",
                     "time", "1.0.0", "0x10", "1,5", "\u00a0", "\ufeff"]),
    st.text(max_size=5),
)
ROW = st.lists(CELL, min_size=0, max_size=9).map(",".join)


@FAST
@given(header=st.one_of(st.just(HEADER), st.text(max_size=60), ROW),
       rows=st.lists(ROW, max_size=12),
       newline=st.sampled_from(["\n", "\r\n", "\r"]),
       encoding=st.sampled_from(["utf-8", "utf-8-sig", "latin-1", "utf-16"]))
def test_csv_like_text(header, rows, newline, encoding):
    text = newline.join([header, *rows])
    data = text.encode(encoding, errors="replace")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "input.csv"
        path.write_bytes(data)
        check_outcome(lambda: load_recording(path), str(path))


@FAST
@given(values=hnp.arrays(np.float64, st.tuples(st.integers(1, 40), st.just(6)),
                         elements=st.floats(allow_nan=True, allow_infinity=True)),
       timed=st.booleans())
def test_csv_with_arbitrary_numbers_loads_or_says_why(values, timed):
    n = values.shape[0]
    header = HEADER if timed else HEADER.removeprefix("time,")
    lines = [header]
    for i, row in enumerate(values):
        cells = [repr(float(v)) for v in row]
        lines.append(",".join(([repr(i / 50.0)] if timed else []) + cells))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "numbers.csv"
        path.write_text("\n".join(lines) + "\n")
        rec = check_outcome(lambda: load_recording(path, rate=None if timed else 50.0),
                            str(path))
    # (beyond SENSOR_RANGE a lone reading far above its neighbours is a corrupt packet:
    # [71, 0, 0] rad/s then [0, 0, 0] is one, made a gap and dropped at the edge)
    limits = np.repeat([SENSOR_RANGE["gyr"], SENSOR_RANGE["acc"]], 3)
    if rec is not None and np.isfinite(values).all() and (np.abs(values) <= limits).all():
        # Finite numbers are never altered on the way in (units are SI by default) ...
        np.testing.assert_array_equal(rec.sensors["a"].gyr, values[:, :3])
        assert rec.n_samples == n
    elif rec is not None:
        # ... but readings no sensor gives (a corrupt packet) are gaps, like NaN
        assert (np.abs(rec.sensors["a"].gyr) <= NONPHYSICAL["gyr"]).all()
        assert (np.abs(rec.sensors["a"].acc) <= NONPHYSICAL["acc"]).all()


# ------------------------------------------------------ arbitrary arrays and attributes

SHAPES = st.one_of(
    st.tuples(st.integers(0, 30), st.integers(1, 4)),
    st.tuples(st.integers(1, 4), st.integers(0, 30)),
    st.tuples(st.integers(0, 30)),
    st.tuples(st.integers(1, 8), st.just(3), st.integers(1, 2)),
)
DTYPES = st.sampled_from([np.float64, np.float32, np.float16, np.int16, np.uint8, np.int64,
                          np.bool_, np.complex128, "S4"])
ANY_ARRAY = hnp.arrays(DTYPES, SHAPES)
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)
ATTRIBUTE = st.one_of(
    st.none(),
    ANY_FLOAT,
    st.integers(-(2**63), 2**63 - 1),
    # HDF5 strings cannot hold NUL characters, so h5py could not write them
    st.text(max_size=12).filter(lambda t: "\x00" not in t),
    st.binary(max_size=12).filter(lambda b: b"\x00" not in b),
    st.sampled_from(["rad/s", "deg/s", "m/s^2", "g", "100", "1e2"]),
    hnp.arrays(st.sampled_from([np.float64, np.int32]), st.integers(0, 3)),
)
NAMES = st.sampled_from(["thigh", "shank", "left foot", "gyr", "acc", "\u00fcber", "x_1",
                         b"l\xe9g"])  # bytes: a name that is not UTF-8 in the file


def signals(n: int):
    """Mostly plausible (n, 3) signals, some with NaN/Inf, some of any shape and type."""
    plausible = hnp.arrays(np.float64, (n, 3), elements=st.floats(-1e3, 1e3))
    return st.one_of(  # a branch listed twice is drawn twice as often
        plausible,
        plausible,
        plausible,
        hnp.arrays(np.float64, (n, 3), elements=st.floats(-1e3, 1e3)
                   | st.sampled_from([np.nan, np.inf])),
        hnp.arrays(np.float64, (n, 3), elements=ANY_FLOAT),
        hnp.arrays(np.float32, (n, 3)),
        ANY_ARRAY,
    )


def times(n: int):
    """A time axis: none, regular, jittered, or arbitrary."""
    return st.one_of(
        st.floats(1e-3, 1.0).map(lambda dt: np.arange(n) * dt),
        st.none(),
        hnp.arrays(np.float64, n, elements=st.floats(-1e6, 1e6)),
        hnp.arrays(np.float64, st.integers(0, 32), elements=ANY_FLOAT),
        ANY_ARRAY,
    )


UNIT_TEXT = st.one_of(st.sampled_from(["rad/s", "deg/s", "m/s^2", "g", b"g", "G", "dps"]),
                      ATTRIBUTE)
PLAUSIBLE_RATE = st.floats(0.5, 1e4)


@st.composite
def layouts(draw):
    """(rate, time, {sensor: {kind: (data, units)}}): a valid recording, then a few changes.

    Starting valid and breaking zero to three things at a time reaches every check (and
    the success path) far more often than drawing every part at random.
    """
    n = draw(st.integers(2, 40))
    plausible = hnp.arrays(np.float64, (n, 3), elements=st.floats(-1e3, 1e3))
    rate, time = draw(PLAUSIBLE_RATE), None
    sensors = {name: {kind: (draw(plausible), None) for kind in ("gyr", "acc")}
               for name in draw(st.lists(NAMES, min_size=1, max_size=3, unique=True))}
    for _ in range(draw(st.integers(0, 3))):
        change = draw(st.sampled_from(["rate", "time", "time only", "signal", "units", "drop",
                                       "extra", "length", "gap"]))
        name = draw(st.sampled_from(sorted(sensors, key=str)))
        kinds = sensors[name]
        kind = draw(st.sampled_from(sorted(kinds))) if kinds else "gyr"
        data, units = kinds.get(kind, (draw(plausible), None))
        if change == "rate":
            rate = draw(ATTRIBUTE)
        elif change == "time":
            time = draw(times(n))
        elif change == "time only":
            rate, time = None, draw(times(n))
        elif change == "signal":
            kinds[kind] = (draw(signals(n)), units)
        elif change == "units":
            kinds[kind] = (data, draw(UNIT_TEXT))
        elif change == "drop":
            kinds.pop(kind, None)
        elif change == "extra":
            kinds["mag"] = (draw(signals(n)), None)
        elif change == "length":
            kinds[kind] = (draw(signals(draw(st.integers(0, 45)))), units)
        elif change == "gap" and np.ndim(data) == 2 and data.dtype == np.float64:
            start, length = draw(st.integers(0, n - 1)), draw(st.integers(1, n))
            data = data.copy()
            data[start:start + length, draw(st.integers(0, data.shape[1] - 1))] = draw(
                st.sampled_from([np.nan, np.inf, -np.inf]))
            kinds[kind] = (data, units)
    return rate, time, sensors


def write_layout(path: Path, rate, time, sensors) -> None:
    """Write a drawn layout: sensors {name: {kind: (data, units or None)}}."""
    write_h5(path, {name: {kind: data for kind, (data, _) in kinds.items()}
                    for name, kinds in sensors.items()},
             rate=rate, time=time,
             units={(name, kind): units for name, kinds in sensors.items()
                    for kind, (_, units) in kinds.items() if units is not None})


@SLOW
@given(layout=layouts(), rate=st.one_of(st.none(), st.none(), ANY_FLOAT))
def test_hdf5_with_arbitrary_arrays_and_attributes(layout, rate):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "arbitrary.h5"
        write_layout(path, *layout)
        check_outcome(lambda: load_recording(path, rate=rate), str(path))


@FAST
@given(layout=layouts())
def test_make_recording_with_arbitrary_arrays(layout):
    rate, time, raw = layout
    sensors = {name: {k: data for k, (data, _) in kinds.items()} for name, kinds in raw.items()}
    units = {name: {k: u for k, (_, u) in kinds.items() if u is not None}
             for name, kinds in raw.items()}
    check_outcome(lambda: make_recording(sensors, rate=rate, time=time, units=units,
                                         source="<prop>"), "<prop>")


@FAST
@given(signal=hnp.arrays(np.float64, st.tuples(st.integers(20, 200), st.just(3)),
                         elements=st.floats(-50, 50)),
       holes=st.lists(st.tuples(st.integers(0, 199), st.integers(1, 12),
                                st.sampled_from([np.nan, np.inf, -np.inf])), max_size=6))
def test_non_finite_samples_are_repaired_or_refused(signal, holes):
    n = signal.shape[0]
    damaged = signal.copy()
    for start, length, value in holes:
        damaged[start:start + length, start % 3] = value
    clean = np.tile([0.0, 0.0, 9.81], (n, 1))
    rec = check_outcome(lambda: make_recording(
        {"s": {"gyr": damaged, "acc": clean}}, rate=100.0, source="<gaps>"), "<gaps>")
    if rec is None:
        return
    kept = rec.n_samples
    if np.isfinite(damaged).all():
        assert kept == n
        assert not any("non-finite" in w for w in rec.warnings)
        return
    # Repairs never go unmentioned, and finite samples are kept as they were.
    assert any("non-finite" in w for w in rec.warnings)
    first = int(round(rec.time[0] * 100.0))
    original = damaged[first:first + kept]
    fine = np.isfinite(original).all(axis=1)
    np.testing.assert_array_equal(rec.sensors["s"].gyr[fine], original[fine])


# -------------------------------------------- bytes behind a real signature: child process

CHILD = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from imucal.errors import InputError
    from imucal.loaders import load_recording

    good = open(sys.argv[1], "rb").read()
    out = sys.argv[2]
    rng = np.random.default_rng(4)
    signature = good[:8]
    cases = [("truncated", good[:k]) for k in
             sorted(set(np.linspace(8, len(good) - 1, 150).astype(int).tolist()))]
    cases += [("junk", signature + rng.integers(0, 256, int(m), dtype=np.uint8).tobytes())
              for m in rng.integers(0, 4000, 150)]
    cases += [("zeros", signature + bytes(int(m))) for m in (0, 8, 100, 2000)]
    results = []
    for i, (kind, data) in enumerate(cases):
        path = f"{out}/case{i}.h5"
        with open(path, "wb") as fh:
            fh.write(data)
        print(kind, len(data), flush=True)  # the last line names a case that hangs
        try:
            load_recording(path)
            outcome = "loaded"
        except InputError as err:
            outcome = "InputError" if path in str(err) and "\\n" not in str(err) else str(err)
        except BaseException as err:
            outcome = f"{type(err).__name__}: {err}"
        results.append([kind, len(data), outcome])
    print("RESULTS " + json.dumps(results), flush=True)
    """
)


def test_junk_and_truncated_hdf5_in_a_child_process(tmp_path):
    from imucal.writers import save_recording

    rng = np.random.default_rng(0)
    sensors = {n: {"gyr": rng.normal(0, 2, (300, 3)), "acc": rng.normal(0, 9, (300, 3))}
               for n in ("thigh", "shank")}
    good = tmp_path / "good.h5"
    save_recording(make_recording(sensors, rate=100.0), good)
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    try:
        run = subprocess.run([sys.executable, str(script), str(good), str(tmp_path)],
                             capture_output=True, text=True, timeout=90)
    except subprocess.TimeoutExpired as err:
        last = (err.stdout or b"").splitlines()[-1:] if err.stdout else []
        raise AssertionError(f"HDF5 loading hung; last case started: {last}") from None
    assert run.returncode == 0, run.stderr[-2000:]
    results = json.loads(run.stdout.split("RESULTS ", 1)[1])
    bad = [r for r in results if r[2] != "InputError"]
    assert bad == []
    assert len(results) > 250
