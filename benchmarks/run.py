"""imucal performance targets (issue 5), each measured against its baseline in the same run.

    python benchmarks/run.py                     # all sections (make bench)
    python benchmarks/run.py solver startup      # some sections
    python benchmarks/run.py --json bench.json   # also write the figures as JSON

Sections:

solver   100 restarts of estimate_axis / estimate_position on the first 55 s of the shared
         real recording vs ONE start of qmt.jointAxisEstHingeOlsson (gyro residual only)
         on the same data (axis: left knee, and right knee as a second case; position:
         left ankle), interleaved, in-process with library defaults and no environment
         variables (goal, issue 14: < 0.5), and vs a plain Python loop of 100
         single-restart calls.
startup  ``imucal axis sample_data/circling.h5`` end to end vs ``python -c "import numpy,
         scipy.signal, h5py"`` (the import floor), and where the time goes.
long     a simulated 1 h, 100 Hz, three-sensor recording: axis + position end to end
         (target < 20 s together, peak memory < 1 GiB each), and how time and memory grow
         with duration and restarts.
jobs     a study of 48 five-minute recordings: ``--jobs 2`` vs ``--jobs 1`` throughput.

Timings are the best (minimum) of k repetitions, with the median alongside: other load on
the machine only ever adds time, so the minimum is the closest to the code's own cost.
Subprocess timings interleave the compared commands so that load hits both alike. The
section needing the shared recording (../shared/data relative to the repository) is
skipped with a note when it is absent; so is the qmt baseline when qmt is not installed.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# The in-process sections run with library defaults and no environment variables: the
# estimators limit BLAS to one thread themselves (imucal.multistart.one_blas_thread), as a
# notebook would call them. qmt is timed both with its default threads and with one BLAS
# thread, and the faster of the two is the baseline.

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "data" / "walk_and_leg_motions_100hz.h5"
SAMPLE = ROOT / "sample_data" / "circling.h5"
PY = sys.executable
SECTIONS = ("solver", "startup", "long", "jobs")

RESULTS: list[dict] = []  # one row per target, for the summary table and --json


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sections", nargs="*", metavar="SECTION",
                        help=f"any of {', '.join(SECTIONS)} (default: all)")
    parser.add_argument("--json", type=Path, help="write the measured figures here")
    args = parser.parse_args()
    unknown = set(args.sections) - set(SECTIONS)
    if unknown:
        parser.error(f"unknown section(s) {', '.join(sorted(unknown))}; use {', '.join(SECTIONS)}")
    sections = args.sections or list(SECTIONS)

    print(machine_line())
    for name in sections:
        print(f"\n== {name} " + "=" * (60 - len(name)))
        with other_load() as others:
            globals()[f"bench_{name}"]()
        if others.cores is not None:
            note = " (the figures above are pessimistic)" if others.cores > 0.2 else ""
            print(f"  other processes used {others.cores:.2f} of {os.cpu_count()} cores during "
                  f"this section{note}")
    summary()
    if args.json:
        args.json.write_text(json.dumps({"machine": machine(), "results": RESULTS}, indent=2)
                             + "\n")
    return 0


# ---------------------------------------------------------------------------------- helpers


def machine() -> dict:
    model = "unknown"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    import numpy
    import scipy

    return {"cpu": model, "cores": os.cpu_count(), "commit": _commit(),
            "python": platform.python_version(),
            "numpy": numpy.__version__, "scipy": scipy.__version__,
            "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None}


def machine_line() -> str:
    m = machine()
    load = "" if m["load_average"] is None else \
        f", load average {m['load_average'][0]:.2f}"
    return (f"machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, numpy "
            f"{m['numpy']}, scipy {m['scipy']}{load}; imucal at {m['commit']}")


def _commit() -> str:
    """The code measured: commit id, "+changes" when the work tree differs from it."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                              capture_output=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=ROOT, text=True, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "unknown commit"
    return head + (" +changes" if dirty.strip() else "")


class other_load:
    """Average number of cores busy with other processes' work while the block ran.

    Total busy time from /proc/stat minus this process's and its children's CPU time
    (Linux only; ``cores`` None elsewhere). Timings on a shared machine are only
    comparable when this stays near 0.
    """

    def __enter__(self):
        self.cores = None
        self.start = self._sample()
        return self

    def __exit__(self, *exc):
        end = self._sample()
        if self.start is not None and end is not None:
            busy = end[0] - self.start[0]
            ours = end[1] - self.start[1]
            wall = end[2] - self.start[2]
            self.cores = max(0.0, (busy - ours) / wall)
        return False

    @staticmethod
    def _sample():
        try:
            fields = [int(x) for x in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
        except (OSError, ValueError):
            return None
        tick = os.sysconf("SC_CLK_TCK")
        busy = (sum(fields[:8]) - fields[3] - fields[4]) / tick  # minus idle and iowait
        import resource

        ours = sum(getattr(resource.getrusage(who), f)
                   for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
                   for f in ("ru_utime", "ru_stime"))
        return busy, ours, time.perf_counter()


def best_of(fn, k: int) -> tuple[float, float]:
    """(minimum, median) wall time of ``fn()`` over ``k`` runs, s."""
    times = []
    for _ in range(k):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times), statistics.median(times)


def interleaved_calls(calls: dict, k: int) -> dict[str, tuple[float, float]]:
    """(minimum, median) wall time of each in-process call over ``k`` interleaved rounds,
    s: load from other processes hits all of them alike."""
    times: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(k):
        for name, fn in calls.items():
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
    return {name: (min(v), statistics.median(v)) for name, v in times.items()}


def interleaved(commands: dict[str, list], k: int, env=None) -> dict[str, tuple[float, float]]:
    """(minimum, median) wall time of each command over ``k`` interleaved rounds, s."""
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(k):
        for name, cmd in commands.items():
            t = time.perf_counter()
            run = subprocess.run(cmd, capture_output=True, env=env)
            times[name].append(time.perf_counter() - t)
            if run.returncode != 0:
                raise SystemExit(f"benchmark command failed ({run.returncode}): "
                                 f"{' '.join(map(str, cmd))}\n{run.stderr.decode()}")
    return {name: (min(v), statistics.median(v)) for name, v in times.items()}


def peak_run(cmd: list) -> tuple[float, float]:
    """Wall time (s) and peak resident memory (MiB) of one command, in a fresh wrapper
    process so that no other child's peak counts."""
    probe = ("import resource, subprocess, sys, time\n"
             "t = time.perf_counter()\n"
             "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL)\n"
             "dt = time.perf_counter() - t\n"
             "peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss\n"
             "print(r.returncode, dt, peak / (1024 * 1024 if sys.platform == 'darwin' "
             "else 1024))\n")
    out = subprocess.run([PY, "-c", probe, *map(str, cmd)], capture_output=True, text=True,
                         check=True).stdout.split()
    if out[0] != "0":
        raise SystemExit(f"benchmark command failed ({out[0]}): {' '.join(map(str, cmd))}")
    return float(out[1]), float(out[2])


def imucal_cmd(*args) -> list:
    return [PY, "-m", "imucal", *map(str, args)]


def record(target: str, measured: str, baseline: str, ratio: float, goal: str, ok: bool | None):
    RESULTS.append({"target": target, "measured": measured, "baseline": baseline,
                    "ratio": round(ratio, 3), "goal": goal, "met": ok})
    verdict = {True: "met", False: "NOT met", None: "-"}[ok]
    print(f"  -> {target}: {measured} vs {baseline}: ratio {ratio:.2f} ({goal}: {verdict})")


def skip(what: str, why: str):
    RESULTS.append({"target": what, "skipped": why})
    print(f"  SKIPPED {what}: {why}")


def summary():
    print("\n== summary " + "=" * 53)
    for r in RESULTS:
        if "skipped" in r:
            print(f"  {r['target']:<50} skipped: {r['skipped']}")
        else:
            verdict = {True: "met", False: "NOT met", None: "-"}[r["met"]]
            print(f"  {r['target']:<50} ratio {r['ratio']:>6.2f}  ({r['goal']}: {verdict})")


# ----------------------------------------------------------------------------------- solver


def bench_solver():
    if not REAL.exists():
        skip("solver vs qmt and loop", f"shared recording not found at {REAL}")
        return
    from threadpoolctl import threadpool_limits

    from imucal import estimate_axis, estimate_position, load_recording

    rec = load_recording(REAL)
    sl = slice(0, int(55 * rec.rate))  # first 55 s: 5500 samples at 100 Hz
    th, sh, ft = (rec.sensor(n) for n in ("left_thigh", "left_shank", "left_foot"))
    right_th, right_sh = rec.sensor("right_thigh"), rec.sensor("right_shank")
    print(f"  data: first 55 s of {REAL.name} ({sl.stop} samples per sensor)")

    # The solver comparisons run with synchronised clocks (time_offset=0): the clock-offset
    # search is a fixed cost per estimate, not per restart, and a loop of 100 single
    # restarts would pay it 100 times (a given offset's check, one profile, is paid in
    # both). "default" below times the command line's default.
    def axis100():
        return estimate_axis(th.gyr[sl], sh.gyr[sl], rate=rec.rate, restarts=100, seed=1,
                             time_offset=0)

    def axis100_default():
        return estimate_axis(th.gyr[sl], sh.gyr[sl], rate=rec.rate, restarts=100, seed=1)

    def axis100_right():  # the right knee converges more slowly, for qmt too
        return estimate_axis(right_th.gyr[sl], right_sh.gyr[sl], rate=rec.rate,
                             restarts=100, seed=1, time_offset=0)

    def position100():
        return estimate_position(sh.gyr[sl], sh.acc[sl], ft.gyr[sl], ft.acc[sl],
                                 rate=rec.rate, restarts=100, seed=1, time_offset=0)

    def position100_default():
        return estimate_position(sh.gyr[sl], sh.acc[sl], ft.gyr[sl], ft.acc[sl],
                                 rate=rec.rate, restarts=100, seed=1)

    def axis_loop():
        for s in range(100):
            estimate_axis(th.gyr[sl], sh.gyr[sl], rate=rec.rate, restarts=1, seed=s,
                          time_offset=0)

    def position_loop():
        for s in range(100):
            estimate_position(sh.gyr[sl], sh.acc[sl], ft.gyr[sl], ft.acc[sl], rate=rec.rate,
                              restarts=1, seed=s, time_offset=0)

    try:
        import qmt
    except ImportError:
        qmt = None

    def qmt_start(a, b, threads=None):
        def run():
            with contextlib.redirect_stdout(io.StringIO()), threadpool_limits(threads):
                # (qmt prints every iteration)
                qmt.jointAxisEstHingeOlsson(a.acc[sl], b.acc[sl], a.gyr[sl], b.gyr[sl],
                                            estSettings=dict(wa=0.0, wg=1.0))
        return run

    for name, batched, loop, pair, label in (
        ("axis", axis100, axis_loop, (th, sh), "left_thigh-left_shank"),
        ("axis, right knee", axis100_right, None, (right_th, right_sh),
         "right_thigh-right_shank"),
        ("position", position100, position_loop, (sh, ft), "left_shank-left_foot"),
        ("axis, default (clock-offset search on)", axis100_default, None, (th, sh),
         "left_thigh-left_shank"),
        ("position, default (clock-offset search on)", position100_default, None, (sh, ft),
         "left_shank-left_foot"),
    ):
        batched()  # warm caches and lazy imports
        share = _solver_share(batched)
        if qmt is None:
            t_imucal = best_of(batched, 7)
            skip(f"{name}: 100 restarts vs 1 qmt start", "qmt not installed (pip install "
                 "-e '.[bench]')")
        else:
            runs = {"imucal": batched, "qmt": qmt_start(*pair), "qmt1": qmt_start(*pair, 1)}
            for run in runs.values():
                run()
            t = interleaved_calls(runs, 7)
            t_imucal = t["imucal"]
            t_qmt = min(t["qmt"], t["qmt1"])
            print(f"  qmt jointAxisEstHingeOlsson, 1 start, {label}: best {t['qmt'][0]:.3f} s "
                  f"with its default BLAS threads, {t['qmt1'][0]:.3f} s with one (median "
                  f"{t['qmt'][1]:.3f} / {t['qmt1'][1]:.3f} s)")
        print(f"  imucal {name}, 100 restarts: best {t_imucal[0]:.3f} s (median "
              f"{t_imucal[1]:.3f} s); solver (Gauss-Newton/Newton) {share:.0%} of it")
        if qmt is not None:
            ratio = t_imucal[0] / t_qmt[0]
            record(f"{name}: 100 restarts vs 1 qmt start", f"{t_imucal[0]:.3f} s",
                   f"{t_qmt[0]:.3f} s", ratio, "< 0.5", ratio < 0.5)
        if loop is None:
            continue
        t_loop = best_of(loop, 1)
        print(f"  plain loop, 100 x {name} with restarts=1: {t_loop[0]:.3f} s")
        ratio = t_imucal[0] / t_loop[0]
        record(f"{name}: batched vs loop of 100 single starts", f"{t_imucal[0]:.3f} s",
               f"{t_loop[0]:.3f} s", ratio, "< 1", ratio < 1)


def _solver_share(fn) -> float:
    """Share of ``fn()``'s time spent inside the multistart's Gauss-Newton calls (every
    stage and quality refit)."""
    import imucal.multistart as module

    original = module.gauss_newton
    spent = [0.0]

    def timed(*args, **kwargs):
        t = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t

    module.gauss_newton = timed
    try:
        t = time.perf_counter()
        fn()
        total = time.perf_counter() - t
    finally:
        module.gauss_newton = original
    return spent[0] / total


# ---------------------------------------------------------------------------------- startup


SPLIT = r"""
import sys, time
t0 = time.perf_counter()
import numpy, scipy.signal, h5py
t1 = time.perf_counter()
import imucal.cli
t2 = time.perf_counter()
from imucal import estimate_axis, load_recording
from imucal import report
t3 = time.perf_counter()
rec = load_recording(sys.argv[1])
t4 = time.perf_counter()
r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate, seed=1)
t5 = time.perf_counter()
report.dumps(report.axis_report(r, input_info={"path": "x", "sensors": ["thigh", "shank"]}))
t6 = time.perf_counter()
heavy = sorted({m.split(".")[0] for m in sys.modules} & {"pandas", "matplotlib", "rich"})
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5, ",".join(heavy) or "-")
"""


def bench_startup():
    commands = {
        "floor": [PY, "-c", "import numpy, scipy.signal, h5py"],
        "python": [PY, "-c", "pass"],
        "axis": imucal_cmd("axis", SAMPLE, "--seed", 1, "-q"),
        "help": imucal_cmd("--help"),
    }
    t = interleaved(commands, 7)
    for name, cmd in commands.items():
        print(f"  {' '.join(map(str, cmd[1:]))[:60]:<60} best {t[name][0]:.3f} s "
              f"(median {t[name][1]:.3f} s)")
    splits = [list(map(float, out.split()[:6])) for out in (
        subprocess.run([PY, "-c", SPLIT, str(SAMPLE)], capture_output=True, text=True,
                       check=True).stdout for _ in range(5))]
    heavy = subprocess.run([PY, "-c", SPLIT, str(SAMPLE)], capture_output=True, text=True,
                           check=True).stdout.split()[6]
    best = [min(col) for col in zip(*splits, strict=True)]
    print(f"  in one process (best of 5): numpy+scipy.signal+h5py {best[0]:.3f} s, imucal.cli "
          f"{best[1]:.3f} s, estimators+report modules {best[2]:.3f} s, loading "
          f"{best[3]:.3f} s, estimate_axis {best[4]:.3f} s, report {best[5]:.3f} s")
    print(f"  heavy optional modules loaded by an axis run: {heavy}")
    ratio = t["axis"][0] / t["floor"][0]
    record("start-up: imucal axis vs import floor", f"{t['axis'][0]:.3f} s",
           f"{t['floor'][0]:.3f} s", ratio, "<= 2", ratio <= 2)


# ------------------------------------------------------------------------------------- long


def bench_long():
    with tempfile.TemporaryDirectory(prefix="imucal-bench-") as tmp:
        tmp = Path(tmp)
        scaling = []
        for minutes in (1, 10, 60):
            rec = tmp / f"walk_{minutes}min.h5"
            subprocess.run(imucal_cmd("simulate", rec, "--duration", 60 * minutes, "--seed", 5,
                                      "--motion", "walking", "-q"), check=True)
            a = peak_run(imucal_cmd("axis", rec, "--seed", 1, "-q"))
            p = peak_run(imucal_cmd("position", rec, "--seed", 1, "-q"))
            scaling.append((minutes, a, p))
            print(f"  {minutes:>3} min ({rec.stat().st_size / 2**20:5.1f} MiB file): axis "
                  f"{a[0]:.2f} s / {a[1]:.0f} MiB, position {p[0]:.2f} s / {p[1]:.0f} MiB")
        hour = tmp / "walk_60min.h5"
        r400 = peak_run(imucal_cmd("axis", hour, "--seed", 1, "-q", "--restarts", 400))
        print(f"  60 min, axis with 400 restarts: {r400[0]:.2f} s / {r400[1]:.0f} MiB (memory "
              "does not grow as restarts x samples)")
        _, a, p = scaling[-1]
        total, peak = a[0] + p[0], max(a[1], p[1])
        record("1 h recording: axis + position time", f"{total:.2f} s", "20 s budget",
               total / 20, "< 1", total < 20)
        record("1 h recording: peak memory", f"{peak:.0f} MiB", "1024 MiB budget",
               peak / 1024, "< 1", peak < 1024)


# ------------------------------------------------------------------------------------- jobs


def bench_jobs():
    # A study: 48 recordings of 5 min (8 simulated subjects, each file present 6 times
    # under its own name: the work per file is what matters, not the subject). Studies
    # have hundreds; fewer would mostly measure the fixed start-up (see the model line).
    distinct, copies, minutes = 8, 6, 5
    with tempfile.TemporaryDirectory(prefix="imucal-bench-") as tmp:
        files = []
        for i in range(distinct):
            first = Path(tmp) / f"subject{i}_0.h5"
            subprocess.run(imucal_cmd("simulate", first, "--duration", 60 * minutes, "--seed",
                                      100 + i, "--motion", "walking", "-q"), check=True)
            files.append(first)
            for c in range(1, copies):
                files.append(first.with_name(f"subject{i}_{c}.h5"))
                shutil.copyfile(first, files[-1])
        n = len(files)
        commands = {j: imucal_cmd("axis", *files, "--seed", 1, "-q", "--jobs", j)
                    for j in (1, 2)}
        commands["start"] = imucal_cmd("axis", files[0], "--seed", 1, "-q")
        t = interleaved(commands, 3)
    for j in (1, 2):
        print(f"  imucal axis, {n} recordings of {minutes} min, --jobs {j}: best "
              f"{t[j][0]:.2f} s (median {t[j][1]:.2f} s), {n / t[j][0]:.2f} recordings/s")
    # T = s + n w / speedup: the fixed part s (interpreter and imports, once per command)
    # and the work per recording w follow from the --jobs 1 runs with 1 and n recordings.
    per_file = (t[1][0] - t["start"][0]) / (n - 1)
    fixed = t["start"][0] - per_file
    speedup = (t[1][0] - fixed) / max(t[2][0] - fixed, 1e-9)
    print(f"  fixed start-up s = {fixed:.2f} s per command, work w = {per_file:.3f} s per "
          f"recording; after s, --jobs 2 processes recordings {speedup:.2f}x as fast as "
          "--jobs 1 (the ratio below tends to that for large studies)")
    ratio = t[1][0] / t[2][0]
    record(f"--jobs 2 vs --jobs 1 throughput ({n} recordings)", f"{n / t[2][0]:.2f} rec/s",
           f"{n / t[1][0]:.2f} rec/s", ratio, ">= 1.6", ratio >= 1.6)


if __name__ == "__main__":
    sys.exit(main())
