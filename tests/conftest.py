"""Shared fixtures: simulated recordings with known truth (small, fixed seeds)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from imucal.simulate import simulate

REAL_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / (
    "walk_and_leg_motions_100hz.h5"
)

# The signal tests send Ctrl-C (SIGINT) as a terminal does. A suite started in the
# background by a non-interactive shell (`nohup make test &`) inherits SIGINT ignored,
# which imucal rightly keeps ignored (test_cli.py), so five of them failed and one hung:
# every test process, and the commands it starts, gets a terminal's disposition back.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@cache
def simulated(seed: int, rate: float = 100.0, snr: float | None = 100.0,
              motion: str = "circling", duration: float = 20.0):
    """Cached (recording, truth) so several tests can share one simulation."""
    return simulate(seed=seed, rate=rate, duration=duration, snr=snr, motion=motion)


def axis_error_deg(j1, j2, truth_j1, truth_j2) -> tuple[float, float]:
    """Angles between estimate and truth, allowing one common sign flip only.

    The overall sign of a hinge axis is a convention, but j1 and j2 must point the same
    physical way, so flipping one of them alone counts as a ~180 deg error.
    """
    s = 1.0 if np.dot(j1, truth_j1) >= 0 else -1.0
    e1 = np.degrees(np.arccos(np.clip(s * np.dot(j1, truth_j1), -1, 1)))
    e2 = np.degrees(np.arccos(np.clip(s * np.dot(j2, truth_j2), -1, 1)))
    return float(e1), float(e2)


def run_imucal(*args, stdin: bytes | None = None, cwd=None, text: bool = False):
    """``imucal ARGS`` run in this process as the console script runs it
    (:func:`imucal.cli.main`: the same parsing, messages and exit codes), returned like
    ``subprocess.run(..., capture_output=True)``.

    A fresh interpreter costs about 1.5 s of imports per command; the suite runs hundreds
    of commands, so only the tests about the real process (entry point, stdin pipe,
    tracebacks, hash seeds) start one.
    """
    from click.testing import CliRunner

    from imucal import signals
    from imucal.cli import main

    argv = ["imucal", *map(str, args)]
    here, saved_argv = os.getcwd(), sys.argv
    with CliRunner().isolation(input=stdin) as (out, err, _):
        sys.argv = argv
        try:
            if cwd is not None:
                os.chdir(cwd)
            main()
            code = 0
        except SystemExit as end:
            code = end.code if isinstance(end.code, int) else int(end.code is not None)
        finally:
            sys.stdout.flush()  # text written to the wrappers reaches the bytes only now
            sys.stderr.flush()
            sys.argv = saved_argv
            os.chdir(here)
            signals.uninstall()  # main() took over Ctrl-C and SIGTERM for the command
        stdout, stderr = out.getvalue(), err.getvalue()
    if text:
        stdout, stderr = stdout.decode(), stderr.decode()
    return subprocess.CompletedProcess(argv, code, stdout, stderr)


@pytest.fixture(scope="session")
def real_recording():
    if not REAL_DATA.exists():
        pytest.skip(f"shared real recording not found at {REAL_DATA} (needs ../shared/data)")
    from imucal import load_recording

    return load_recording(REAL_DATA)
