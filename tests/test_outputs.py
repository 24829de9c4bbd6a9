"""What the commands write besides the estimate: figures (format by extension, what the
panels show) and the size and contents of the JSON (compact by default, --trace)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_imucal, simulated

from imucal import plots
from imucal.axis import estimate_axis
from imucal.position import closest_point_on_axis, estimate_position
from imucal.restarts import settled

MAGIC = {".png": b"\x89PNG\r\n\x1a\n", ".pdf": b"%PDF-", ".svg": b"<?xml"}
#: Default JSON of 100 restarts, bytes: 58-59 KB on the shared real recording (knee axis,
#: ankle, knee as a hinge), 123-156 KB before restarts were summarised; the bound leaves
#: room for a few more quality fields, not for per-iteration traces.
MAX_DEFAULT_BYTES = 70_000


def imucal(*args):
    return run_imucal(*args)


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "sim.h5"
    assert imucal("simulate", path, "--seed", 4, "--duration", 8, "--quiet").returncode == 0
    return path


@pytest.mark.parametrize("name", ["knee.png", "knee.PDF", "knee.svg"])
def test_plot_format_follows_the_extension(rec, tmp_path, name):
    fig = tmp_path / name
    run = imucal("axis", rec, "--seed", 1, "--restarts", 5, "--plot", fig, "--quiet")
    assert run.returncode == 0, run.stderr
    data = fig.read_bytes()
    assert data.startswith(MAGIC[fig.suffix.lower()])
    if fig.suffix == ".svg":
        assert b"<svg" in data[:2000]
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # no temporary files left


@pytest.mark.parametrize("name", ["knee.jpg", "knee"])
def test_unknown_figure_format_is_refused_before_anything_is_written(rec, tmp_path, name):
    run = imucal("axis", rec, "--seed", 1, "--restarts", 5, "--plot", tmp_path / name,
                 "--out", tmp_path / "knee.json")
    assert run.returncode == 2
    line, = run.stderr.decode().splitlines()
    assert line.startswith("imucal: error: ") and "PNG, PDF or SVG" in line
    assert run.stdout == b"" and list(tmp_path.iterdir()) == []


def test_default_json_summarises_restarts(rec):
    run = imucal("position", rec, "--seed", 2, "--restarts", 100, "--quiet")
    assert run.returncode == 0, run.stderr
    assert len(run.stdout) < MAX_DEFAULT_BYTES
    doc = json.loads(run.stdout)
    assert len(doc["restarts"]) == 100
    for r in doc["restarts"]:
        assert set(r) == {"initial", "final", "refined", "iterations", "converged",
                          "reached_estimate", "final_cost", "refined_cost"}
        assert r["final_cost"] > 0 and r["refined_cost"] > 0
    # the estimate is the reached restart with the lowest cost on all samples
    reached = [r["refined_cost"] for r in doc["restarts"] if r["reached_estimate"]]
    assert min(reached) == pytest.approx(doc["quality"]["rms_residual"], rel=1e-3)
    # vectors stay on one line: the document is not one number per line
    assert len(run.stdout.splitlines()) < 20 * 100 + 200


def test_trace_adds_the_cost_per_iteration(rec):
    plain = imucal("axis", rec, "--seed", 2, "--restarts", 20, "--quiet")
    traced = imucal("axis", rec, "--seed", 2, "--restarts", 20, "--quiet", "--trace")
    assert plain.returncode == 0 and traced.returncode == 0, traced.stderr
    a, b = json.loads(plain.stdout), json.loads(traced.stdout)
    for r in b["restarts"]:
        assert len(r["cost_trace"]) == r["iterations"] + 1
        assert r["cost_trace"][-1] == r["final_cost"]
        assert r["refined_cost_trace"][-1] == r["refined_cost"]
        # the refinement starts where the subset stage ended
        assert r["refined_cost_trace"][0] > 0
    # the trace is the only difference
    for r in b["restarts"]:
        del r["cost_trace"], r["refined_cost_trace"]
    assert a == b
    assert len(traced.stdout) > len(plain.stdout)


def test_trace_travels_to_every_recording_of_a_study(rec, tmp_path):
    other = tmp_path / "copy.h5"
    other.write_bytes(rec.read_bytes())
    for flags, has_trace in (([], False), (["--trace"], True)):
        run = imucal("axis", rec, other, "--seed", 1, "--restarts", 5, "--quiet", *flags)
        assert run.returncode == 0, run.stderr
        lines = [json.loads(line) for line in run.stdout.splitlines()]
        assert len(lines) == 2
        for line in lines:
            assert ("cost_trace" in line["result"]["restarts"][0]) is has_trace


# --- what the figures show (in process: the Axes are inspected) ---

def _panel(fig, gid):
    found = [ax for ax in fig.axes if ax.get_gid() == gid]
    assert len(found) == 1
    return found[0]


def _points(ax, colour):
    """(x, y) of the scatter drawn in ``colour`` in the restart-spread panel."""
    coll, = [c for c in ax.collections if c.get_gid() == f"spread-{colour}"]
    return np.asarray(coll.get_offsets())


def _draw(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()


@pytest.fixture(scope="module")
def short_walk():
    return simulated(5, motion="walking", duration=12.0)[0]


@pytest.mark.parametrize("joint", ["spheroidal", "hinge"])
def test_position_spread_panel_is_in_mm_relative_to_the_estimate(short_walk, joint):
    names = ("shank", "foot") if joint == "spheroidal" else ("thigh", "shank")
    s1, s2 = (short_walk.sensor(n) for n in names)
    result = estimate_position(s1.gyr, s1.acc, s2.gyr, s2.acc, rate=short_walk.rate,
                               restarts=12, seed=3, joint=joint)
    fig = plots.position_figure(result, "test")
    _draw(fig)
    ax = _panel(fig, plots.SPREAD_GID)
    assert "mm" in ax.get_ylabel()
    assert ax.yaxis.get_offset_text().get_text() == ""  # no 1e-10+3.95e-2 style offsets
    subset = result.batch.x if result.line is None else \
        closest_point_on_axis(result.batch.x, result.line)
    expected = 1000 * (subset - np.concatenate([result.o1, result.o2]))
    keep = settled(result.batch.final_cost, result.reached)
    assert keep.sum() >= 6
    drawn = _points(ax, plots._REACHED)
    columns = np.rint(drawn[:, 0]).astype(int)
    for k in range(6):
        np.testing.assert_allclose(np.sort(drawn[columns == k, 1]), np.sort(expected[keep, k]),
                                   rtol=1e-9, atol=1e-9)
    # the reported spread is the RMS distance of exactly these points
    for name, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6))):
        rms = np.sqrt(np.mean(np.sum(expected[keep, sl] ** 2, axis=1)))
        assert rms == pytest.approx(result.spread_mm[name], rel=1e-6)
    # spreads of real subset fits are mm, not the 1e-10 m of refined restarts
    assert np.abs(drawn[:, 1]).max() > 0.01


def test_axis_figure_panels(short_walk):
    thigh, shank = short_walk.sensor("thigh"), short_walk.sensor("shank")
    result = estimate_axis(thigh.gyr, shank.gyr, rate=short_walk.rate, restarts=12, seed=3)
    fig = plots.axis_figure(result, "thigh - shank")
    _draw(fig)
    ax = _panel(fig, plots.SPREAD_GID)
    assert "deg" in ax.get_ylabel()
    drawn = _points(ax, plots._REACHED)
    keep = settled(result.batch.final_cost, result.reached)
    for k, name in enumerate(("j1", "j2")):
        angles = drawn[np.rint(drawn[:, 0]) == k, 1]
        assert angles.size == keep.sum()
        assert np.sqrt(np.mean(angles**2)) == pytest.approx(result.spread_deg[name], rel=1e-5)

    texts = {t.get_text() for a in fig.axes if a.get_legend()
             for t in a.get_legend().get_texts()}
    # the stages are named where the cost curves change samples (1200 samples: the
    # coarse stage runs)
    assert result.samples_used >= 2 * result.settings["coarse_samples"]
    assert any(t.startswith("coarse") for t in texts)
    assert any(t.startswith("subset") for t in texts)
    assert "refined on all samples" in texts
    for a in fig.axes:
        # no offset notation anywhere, and no legend inside a panel's data area
        assert a.yaxis.get_offset_text().get_text() == ""
        assert a.xaxis.get_offset_text().get_text() == ""
        legend = a.get_legend()
        if legend is not None:
            box, frame = legend.get_window_extent(), a.get_window_extent()
            assert not box.overlaps(frame) or box.y1 <= frame.y0 or box.x0 >= frame.x1
    # the joint-plane panels draw points, never lines across the gaps between the
    # selected time ranges
    planes = [a for a in fig.axes if "joint plane" in a.get_title()]
    assert len(planes) == 2
    for a in planes:
        assert not any(len(line.get_xdata()) > 2 for line in a.get_lines())
        assert sum(len(c.get_offsets()) for c in a.collections) == result.samples_used


def test_save_figure_refuses_unknown_formats(tmp_path):
    from matplotlib.figure import Figure

    with pytest.raises(ValueError, match="unknown figure format"):
        plots.save_figure(Figure(), tmp_path / "x.gif")
    assert list(tmp_path.iterdir()) == []


# --- the figures say how far to trust what they draw (figure review) ---

def _header_texts(fig):
    ax = _panel(fig, plots.HEADER_GID)
    return [(t.get_text(), t.get_color()) for t in ax.texts]


def test_axis_header_states_verdict_sigma_and_warnings(short_walk):
    thigh, shank = short_walk.sensor("thigh"), short_walk.sensor("shank")
    result = estimate_axis(thigh.gyr, shank.gyr, rate=short_walk.rate, restarts=12, seed=3)
    fig = plots.axis_figure(result, "thigh - shank")
    texts = _header_texts(fig)
    first, colour = texts[0]
    assert first.startswith(f"Verdict: {result.verdict}")
    assert colour == plots.VERDICT_COLOURS[result.verdict]
    joined = " ".join(t for t, _ in texts)
    # the reported 1-sigma, not only the (smaller) restart spread the panels draw
    for v in ("j1", "j2"):
        assert f"{v} {result.uncertainty_deg[v]:.3g} deg" in joined
        assert f"{v} {result.spread_deg[v]:.3g} deg" in joined
    assert f"{result.relative_residual:.1%}" in joined
    flex = result.excitation["flexion_rate_rms_deg_s"]
    assert f"RMS flexion rate {flex:.3g} deg/s" in joined
    for w in result.warnings:
        assert w[:60] in joined.replace("\n", " ")
    title = fig.get_suptitle()
    start, end = result.window
    assert f"window {start:g} to {end:g} s" in title
    assert f"{result.samples_used} samples used" in title and "seed 3" in title


def test_figure_states_what_the_json_says(short_walk):
    # the JSON's verdict counts the loader's warnings (a repaired gap: never "good") and
    # its window is on the recording's own time axis; the figure said "good" in green and
    # "window 2-12 s" for --start 1002 --end 1012 (review of the figure header). A "$"
    # in a file name was read as a formula (exit 3).
    from imucal.report import axis_report

    thigh, shank = short_walk.sensor("thigh"), short_walk.sensor("shank")
    result = estimate_axis(thigh.gyr, shank.gyr, rate=short_walk.rate, restarts=12, seed=3)
    info = {"path": "/data/cost_$5_to_$10.h5", "sensors": ["thigh", "shank"],
            "time_origin": 1000.0,  # the recording's clock at its first sample
            "load_warnings": ["sensor 'thigh' gyr: 3 non-finite sample(s) ... filled"]}
    doc = axis_report(result, input_info=info)
    assert doc["quality"]["verdict"] != result.verdict or result.verdict != "good"
    fig = plots.axis_figure(result, "thigh - shank", doc)
    _draw(fig)  # no mathtext error
    texts = _header_texts(fig)
    assert texts[0][0].startswith(f"Verdict: {doc['quality']['verdict']}")
    joined = " ".join(t for t, _ in texts)
    assert "warning: input: sensor 'thigh' gyr" in joined
    title = fig.get_suptitle()
    start, end = doc["input"]["window_s"]
    assert start >= 1000 and "cost_$5_to_$10.h5" in title and f"window {start:g} to {end:g} s" \
        in title


def test_a_still_window_is_red_and_drawn_to_scale():
    # a forced result of sensors that barely rotate looked like a clean fit: its panels
    # auto-scaled to a few hundredths of a rad/s of noise, and nothing said "refused"
    rng = np.random.default_rng(0)
    g1, g2 = (0.01 * rng.standard_normal((1500, 3)) for _ in range(2))
    result = estimate_axis(g1, g2, rate=100.0, restarts=8, seed=1, time_offset=0)
    assert result.verdict == "not identifiable"
    fig = plots.axis_figure(result, "a - b")
    texts = _header_texts(fig)
    assert texts[0][0].startswith("Verdict: NOT IDENTIFIABLE")
    assert texts[0][1] == "tab:red"
    assert any(t.startswith("not identifiable: ") and c == "tab:red" for t, c in texts)
    panels = [a for a in fig.axes if "joint plane" in a.get_title() or "Eq. (1)" in
              a.get_title()]
    assert len(panels) == 3
    for a in panels:
        lo, hi = a.get_xlim()
        assert hi - lo >= plots._MIN_RATE_SPAN / 2  # noise stays a dot in the middle


def test_hinge_centre_figure_marks_the_moved_estimate_and_names_the_coarse_stage(
        short_walk):
    thigh, shank = short_walk.sensor("thigh"), short_walk.sensor("shank")
    result = estimate_position(thigh.gyr, thigh.acc, shank.gyr, shank.acc,
                               rate=short_walk.rate, restarts=12, seed=3, joint="hinge")
    fig = plots.position_figure(result, "thigh - shank")
    _draw(fig)
    cost = next(a for a in fig.axes if a.get_title().startswith("Cost of"))
    marks = [line for line in cost.get_lines() if line.get_marker() == "D"]
    assert len(marks) == 1
    # the cost the JSON reports, at the moved point, not the best restart's own
    assert marks[0].get_ydata()[0] == pytest.approx(result.rms_residual, rel=1e-12)
    texts = {t.get_text() for a in fig.axes if a.get_legend()
             for t in a.get_legend().get_texts()}
    assert result.samples_used >= 2 * result.settings["coarse_samples"]
    assert any(t.startswith("coarse") for t in texts)
    joined = " ".join(t for t, _ in _header_texts(fig))
    assert f"o1 {result.uncertainty_mm['o1']:.3g} mm" in joined


def test_position_spread_dashes_are_each_components_rms(short_walk):
    shank, foot = short_walk.sensor("shank"), short_walk.sensor("foot")
    result = estimate_position(shank.gyr, shank.acc, foot.gyr, foot.acc,
                               rate=short_walk.rate, restarts=12, seed=3)
    fig = plots.position_figure(result, "shank - foot")
    ax = _panel(fig, plots.SPREAD_GID)
    d = 1000 * (result.batch.x - np.concatenate([result.o1, result.o2]))
    keep = settled(result.batch.final_cost, result.reached)
    levels = sorted({round(float(y), 9) for c in ax.collections if hasattr(c, "get_segments")
                     for seg in c.get_segments() for y in seg[:, 1] if y > 0})
    expected = sorted(round(float(np.sqrt(np.mean(d[keep, k] ** 2))), 9) for k in range(6))
    np.testing.assert_allclose(levels, expected, rtol=1e-6)


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_a_device_as_plot_is_written_before_the_json(rec, tmp_path):
    # a device cannot be put in place after the JSON: a copy that failed then left a
    # complete JSON on stdout with exit 2
    full = tmp_path / "full.png"
    full.symlink_to("/dev/full")
    run = imucal("axis", rec, "--seed", 1, "--restarts", 5, "--plot", full, "--quiet")
    assert run.returncode == 2 and b"No space left" in run.stderr
    assert run.stdout == b""


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_no_figure_is_left_by_a_run_whose_json_cannot_be_written(rec, tmp_path):
    fig = tmp_path / "knee.png"
    run = imucal("axis", rec, "--seed", 1, "--restarts", 5, "--plot", fig, "--out",
                 "/dev/full", "--quiet")
    assert run.returncode == 2 and b"No space left" in run.stderr
    assert list(tmp_path.iterdir()) == []  # neither the figure nor its temporary file
    ok = imucal("axis", rec, "--seed", 1, "--restarts", 5, "--plot", fig, "--quiet")
    assert ok.returncode == 0 and fig.read_bytes().startswith(MAGIC[".png"])


def test_nested_fields_without_a_unit_in_their_name_have_one_in_units():
    # sensitivity_per_ms (deg or mm per ms) and weak_direction had their units only in
    # docs/json.md (a new-user trial)
    sample = Path(__file__).parent.parent / "sample_data" / "circling.h5"
    for command, unit in (("axis", "deg per ms of offset"), ("position", "mm per ms of offset")):
        run = run_imucal(command, sample, "--restarts", "5", "--seed", "1", "-q", "--force",
                         text=True)
        doc = json.loads(run.stdout)
        assert doc["units"]["time_offset.sensitivity_per_ms"] == unit
        assert "sensitivity_per_ms" in doc["time_offset"]
        if command == "position":
            assert "mm" in doc["units"]["quality.weak_direction"]


def test_the_uncertainty_method_names_only_the_parts_its_result_has(rec):
    # the axis's text gave its formula with acc_error^2, a part no axis has (a new-user
    # trial); a joint centre's has it
    for command in ("axis", "position"):
        run = imucal(command, rec, "--seed", 1, "--restarts", 5, "--quiet", "--force")
        assert run.returncode == 0, run.stderr
        q = json.loads(run.stdout)["quality"]
        named = "acc_error" in q["uncertainty_method"]
        assert named == ("acc_error" in q["uncertainty_components"]) == (command == "position")
        assert "time_offset^2" in q["uncertainty_method"] and "gyr_bias^2" in \
            q["uncertainty_method"]


def test_window_seconds_carry_no_float_noise(tmp_path):
    # a window of a 40 Hz time column read [5.000000000000032, 20.000000000000245]: the
    # samples over the rate the time steps measure (a new-user trial)
    from imucal import load_recording, make_recording
    from imucal.runner import Job, run
    from imucal.settings import AxisSettings
    from imucal.writers import save_recording

    rec = load_recording(Path(__file__).resolve().parents[1] / "sample_data" / "circling.h5")
    data = {n: {"gyr": s.gyr, "acc": s.acc} for n, s in rec.sensors.items()}
    save_recording(make_recording(data, time=np.arange(rec.n_samples) / 40.0),
                   tmp_path / "r.csv")
    outcome = run(Job("axis", ("thigh", "shank"), AxisSettings(seed=1, restarts=5),
                      start=5.0), str(tmp_path / "r.csv"))
    assert outcome.document["input"]["window_s"] == [5.0, 50.0]
