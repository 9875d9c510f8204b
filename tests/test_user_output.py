"""What a user reads (issue 22): every number with its unit, every default said aloud, reports
that show all they hold."""

import json
from html.parser import HTMLParser

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


class Page(HTMLParser):
    """A report page as a headless reader sees it: images, links, tables (cell texts), style."""

    def __init__(self, text: str):
        super().__init__()
        self.images, self.links, self.tables, self.style, self.text = [], [], [], "", []
        self._in_style = False
        self._cell = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        elif tag == "a":
            self.links.append(a.get("href"))
        elif tag == "table":
            self.tables.append([])
        elif tag == "tr" and self.tables:
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "style":
            self._in_style = True
        elif tag == "wbr" and self._cell is not None:
            self._cell.append("\u200b")  # a line-break opportunity

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None and self.tables:
            self.tables[-1][-1].append("".join(self._cell))
            self._cell = None
        elif tag == "style":
            self._in_style = False

    def handle_data(self, data):
        if self._in_style:
            self.style += data
        elif self._cell is not None:
            self._cell.append(data)
        self.text.append(data)

    def get_text(self) -> str:
        return "".join(self.text)


#: The page's content width [px] (body max-width 1100 px less 2 × 1em padding) and a generous
#: character width at the tables' .92em of 16 px (proportional ≈ 8 px, monospace digits ≈ 8.8 px)
PAGE_PX, CHAR, PAD = 1068, 9.0, 19.0


def table_problems(html: str) -> list[str]:
    """Tables a reader cannot read whole: wider than the page even at their narrowest (every
    cell broken wherever the page lets it: spaces, <wbr>, long words when cells wrap anywhere),
    or put behind a horizontal scroll bar."""
    import re

    page = Page(html)
    anywhere = "overflow-wrap:anywhere" in page.style.replace(" ", "")
    out = []
    for selector, body in re.findall(r"([^{}]+)\{([^}]*)\}", page.style):
        if re.search(r"table|\.tw|\btd\b|\bth\b", selector) and re.search(
                r"overflow(-x)?\s*:\s*(auto|scroll|hidden)", body):
            out.append(f"{selector.strip()} scrolls or clips its overflow")
    for k, table in enumerate(page.tables):
        if not table:
            continue
        width = 0.0
        for j in range(max(len(r) for r in table)):
            longest = 0
            for r, row in enumerate(table):
                if j >= len(row):
                    continue
                text = row[j]
                numeric = r > 0 and re.fullmatch(r"[-+0-9.eE]+|NaN", text.strip()) is not None
                words = [w for w in re.split(r"[\s\u200b]+", text) if w]
                if not numeric and anywhere:
                    words = [w[:24] for w in words]
                longest = max([longest, *map(len, words)])
            width += longest * CHAR + PAD
        if width > PAGE_PX:
            out.append(f"table {k} ({' | '.join(table[0])[:60]}…) needs {width:.0f} px > {PAGE_PX}")
    return out


def test_wide_tables_wrap_or_split_and_keep_every_column():
    from uuvid.core.html import Report

    names = [f"rms_tracking_error_{i}_m" for i in range(14)]
    rows = [{"run": f"case {r}", **{n: 1234.5678 * (r + i) for i, n in enumerate(names)}}
            for r in range(3)]
    html = Report("r").add_table(rows, caption="wide").add_table([{"a": 1, "b": "x"}]).to_html()
    assert table_problems(html) == []
    page = Page(html)
    headers = [h.replace("\u200b", "") for t in page.tables for h in t[0]]
    assert set(headers) == {"run", "a", "b", *names}  # split, none hidden
    assert all(t[0][0].replace("\u200b", "") in ("run", "a") for t in page.tables)
    assert "part 1 of" in page.get_text()
    # headers dominate (a mission's metrics): "speed_" keeps its underscore when it breaks
    narrow = {f"speed_m_s_{i}": 1 for i in range(16)}
    assert table_problems(Report("r").add_table([narrow]).to_html()) == []


def test_predict_says_the_default_supply_voltage_it_used():
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1500,1900"])
    assert res.exit_code == 0, res.output
    assert "default 16 V" in res.stderr and "16 V supply" in res.stdout
    doc = json.loads(runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm",
                                         "1500,1900", "--json"]).stdout)
    assert doc["supply_voltage_V"] == 12.0 and "default" in doc["supply_voltage_source"]
    assert doc["warnings"] == []


def test_predict_names_a_command_that_is_no_pulse_width_by_the_models_unit(tmp_path):
    """--pwm feeds the model's command: a driver-first model (fitted on a bench whose command is
    in volts) printed it as pwm_us; its column is now 'command' and a warning says why."""
    f = tmp_path / "fo.yaml"
    f.write_text("name: fo\ninput: command\nblocks:\n- type: driver\n  deadband_fwd: 0.0\n"
                 "  deadband_rev: 0.05\n  offset: 0.0\n  gain_fwd: 1.0\n  gain_rev: 1.0\n"
                 "- type: first_order_motor\n  gain: 40.0\n  time_constant: 0.05\n"
                 "- type: quadratic\n  k_pos: 0.00035\n  k_neg: 0.00026\n")
    doc = json.loads(runner.invoke(app, ["thruster", "predict", str(f), "--pwm", "-4,2",
                                         "--json"]).stdout)
    assert "pwm_us" not in doc and doc["command"] == [-4.0, 2.0]
    assert any("not a pulse width" in w and "the column is command" in w for w in doc["warnings"])
    doc = json.loads(runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1700",
                                         "--json"]).stdout)
    assert doc["pwm_us"] == [1700.0] and doc["warnings"] == []
    exported = tmp_path / "a2212.yaml"  # an exported PWM model whose command_unit line was lost
    assert runner.invoke(app, ["thruster", "export", "laidani-a2212", "--to", "yaml", "--out-file",
                               str(exported)]).exit_code == 0
    exported.write_text("".join(ln for ln in exported.read_text().splitlines(keepends=True)
                                if "command_unit" not in ln))
    doc = json.loads(runner.invoke(app, ["thruster", "predict", str(exported), "--pwm", "1700",
                                         "--json"]).stdout)
    assert doc["pwm_us"] == [1700.0]
    assert any("neutral is 1500, a pulse width: read as µs" in w for w in doc["warnings"])


def test_predict_warns_outside_the_presets_data_voltages():
    res = runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1700:1900:100",
                              "--supply-voltage", "14", "--json"])
    doc = json.loads(res.stdout)
    assert any("outside the data's 12 V" in w for w in doc["warnings"]), doc["warnings"]
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1900",
                              "--supply-voltage", "14", "--json"])
    assert json.loads(res.stdout)["warnings"] == []  # inside the 12–16 V sheets
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1900",
                              "--supply-voltage", "20"])
    assert "outside the data's 12–16 V" in res.stderr


def test_readme_predict_example_is_inside_its_data_or_explained():
    from pathlib import Path

    readme = (Path(__file__).parents[1] / "README.md").read_text()
    for line in readme.splitlines():
        if line.startswith("uuvid thruster predict laidani-a2212") and "--supply-voltage" in line:
            assert "--supply-voltage 12 " in line, line
    assert "identified at 12 V only" in readme


@pytest.mark.slow
def test_thruster_simulate_prints_units_and_the_size_it_writes(tmp_path, monkeypatch):
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--signal",
                              "kind=sine,offset=1500,amplitude=400,period=2", "--t-end", "0.2"])
    assert res.exit_code == 0, res.output
    rows = {ln.split("│")[1].strip(): ln.split("│")[3].strip()
            for ln in res.stdout.splitlines() if ln.count("│") == 4}
    assert rows["command"] == "µs" and rows["thrust"] == "N" and rows["motor_speed"] == "rad/s"
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.2"])
    assert "│ s " in res.stdout and "│ N " in res.stdout
    import uuvid.cli.thruster_cmds as tc

    monkeypatch.setattr(tc, "CSV_WARN_BYTES", 1e4)  # a 2000 s run writes ~264 MB; same path
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--t-end", "0.5",
                              "--out", str(tmp_path / "sim"), "--json"])
    assert res.exit_code == 0, res.output
    size = (tmp_path / "sim" / "response.csv").stat().st_size
    assert "warning:" in res.stderr and "501 rows × 6 columns" in res.stderr and "--dt" in res.stderr
    mb = float(res.stderr.split("≈ ")[1].split(" MB")[0])
    assert abs(mb * 1e6 - size) < 0.1 * size
    assert json.loads(res.stdout)["units"]["channels"]["thrust"] == "N"


@pytest.mark.slow
def test_fit_table_prints_a_short_summary_and_keeps_the_whole_table_in_the_files(tmp_path):
    import numpy as np
    import yaml

    c = np.arange(1100.0, 1901.0, 4.0)  # 201 commands → 201 knots
    rng = np.random.default_rng(3)
    rows = [f"{a:g},{np.sign(a - 1500) * ((a - 1500) / 400) ** 2 * 40 + rng.normal(0, .2):.4f}"
            for a in np.repeat(c, 2)]
    (tmp_path / "b.csv").write_text("command,thrust\n" + "\n".join(rows) + "\n")
    args = ["thruster", "fit", str(tmp_path / "b.csv"), "--command-col", "command",
            "--thrust-col", "thrust", "--model", "table", "--out-model", str(tmp_path / "m.yaml")]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert len(res.stdout.splitlines()) <= 8 and "201 knots" in res.stdout
    assert "µs" in res.stdout and " N" in res.stdout and "T(1500)" not in res.stdout
    doc = json.loads(runner.invoke(app, [*args, "--json"]).stdout)
    assert len(doc["parameters"]) == 201
    blocks = yaml.safe_load((tmp_path / "m.yaml").read_text())["blocks"]
    assert len(next(iter(b for b in blocks if "input_values" in b))["input_values"]) == 201


def test_vehicle_info_has_json_units_and_tells_the_bluerov2_sets_apart():
    res = runner.invoke(app, ["vehicle", "info", "bluerov2"])
    assert res.exit_code == 0, res.output
    text = res.stdout
    assert "kg·m²" in text and "N·s²/m²" in text and "N·s/m" in text and "[surge, sway" in text
    assert "bluerov2-heavy" in text and "× apart in quadratic surge drag" in text
    doc = json.loads(runner.invoke(app, ["vehicle", "info", "bluerov2-heavy", "--json"]).stdout)
    assert doc["mass_kg"] == 13.5 and doc["units"]["quadratic_damping"][0] == "N·s²/m²"
    assert len(doc["thrusters"]) == 8 and doc["thrusters"][0]["limits_N"][1] > 50
    assert "7.8× apart" in doc["provenance_note"]
    doc = json.loads(runner.invoke(app, ["vehicle", "info", "romeo", "--json"]).stdout)
    assert doc["provenance_note"] is None


def _fake_hold():
    import numpy as np

    from uuvid.analysis.hold import CapabilityResult, EnduranceResult

    deg = np.arange(0.0, 360.0, 45.0)
    cap = CapabilityResult("rov", deg, 0.6 + 0.1 * np.cos(np.radians(deg)), supply_voltage=16.0)
    t = np.linspace(0, 3600, 5)
    endur = EnduranceResult("rov", 0.5, 30.0, t, np.linspace(.8, .1, 5), np.linspace(15, 12, 5),
                            np.linspace(11, 15, 5), np.linspace(50, 37, 5), 3600.0,
                            "loaded voltage below the minimum", np.ones((5, 3)),
                            1500 + np.outer(np.arange(5), [10, -10, 20]), ("A", "B", "C"))
    return cap, endur


@pytest.mark.slow
def test_hold_report_has_index_endurance_figure_and_the_requested_current(tmp_path, monkeypatch):
    from uuvid.analysis import hold
    from uuvid.core.plots import figure_problems

    cap, endur = _fake_hold()
    fig = cap.plot(mark=(0.5, 30.0, True))
    assert any("requested 0.5 m/s from 30°" in ln.get_label() for ln in fig.axes[0].lines)
    efig = endur.plot()
    assert efig._suptitle.get_text() == endur.title()  # whole, not cut at 110 characters
    assert [t.get_text() for t in efig.axes[3].get_legend().get_texts()] == ["A", "B", "C"]
    assert figure_problems(fig) == [] and figure_problems(efig) == []
    # the command line: every output of --out, an index linking them (the slow physics faked)
    # (the command line checks its options, then calls the private twins that do not warn again)
    def no_physics(*a, **k):
        raise AssertionError("the public hold functions are not what the command line calls")

    for name, fake in (("capability", lambda *a, **k: cap), ("max_current", lambda *a, **k: (0.7, {})),
                       ("endurance", lambda *a, **k: endur)):
        monkeypatch.setattr(hold, f"_{name}", fake)
        monkeypatch.setattr(hold, name, no_physics)
    out = tmp_path / "hold"
    res = runner.invoke(app, ["vehicle", "hold", "bluerov2-heavy", "--current", "0.5,30",
                              "--battery", "0.8", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert {p.name for p in out.iterdir()} >= {"capability.png", "endurance.png", "hold.json",
                                                "index.html"}
    page = Page((out / "index.html").read_text())
    assert len(page.images) == 2 and "hold.json" in page.links
    assert "requested current" in page.get_text()


@pytest.mark.slow
@pytest.mark.realdata
def test_log_inspect_warns_only_about_merged_stamps_of_channels_it_uses(shared_data):
    from uuvid.io.ardusub import inspect_log

    for name in ("small.tlog", "2023-04-18_11-03-34.tlog"):
        ins = inspect_log(shared_data / "ardusub-bluerov2" / name)
        used = ins.depth_source["source"]  # the pressure sensor by default (issue 18)
        assert "SCALED_PRESSURE" in used, used
        merged = [w for w in ins.warnings if "merged" in w]
        for unused in ("VFR_HUD.alt", "GLOBAL_POSITION_INT.relative_alt"):  # depth is not read from them
            assert not any(unused in w for w in merged), merged


def test_inertia_fit_names_the_units_of_m_c_b():
    import numpy as np

    from uuvid.identify.vehicle.fit import fit_inertia

    t = np.arange(0.0, 120.0, 0.1)
    rng = np.random.default_rng(1)
    phi = -5.0 + 4.0 * np.sin(0.2 * t)
    v = np.zeros_like(t)  # m v' = φ − k v, m = 80, k = 20 (Euler is enough for a label test)
    for i in range(1, t.size):
        v[i] = v[i - 1] + 0.1 * (phi[i - 1] - 20.0 * v[i - 1]) / 80.0
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * 0.1)]) + rng.normal(0, 1e-3, t.size)
    for angle, units in ((False, ["kg", "N·s", "N"]), (True, ["kg·m²", "N·m·s", "N·m"])):
        fit = fit_inertia(t, x, phi, k=20.0, angle=angle, clean=False).fit
        assert [p.unit for p in fit.parameters] == units


@pytest.mark.slow
def test_design_input_prints_the_unit_of_offset_amplitude_distance():
    base = ["vehicle", "design-input", "--k", "28.6", "--mass-air", "93.75", "--speed", "-0.175"]
    rows = {}
    for dof in ("yaw", "surge"):
        res = runner.invoke(app, [*base, "--dof", dof])
        assert res.exit_code == 0, res.output
        rows[dof] = {ln.split("│")[1].strip(): ln.split("│")[2].strip()
                     for ln in res.stdout.splitlines() if ln.count("│") == 3}
    assert rows["yaw"]["offset φ₀"].endswith(" N·m") and rows["surge"]["offset φ₀"].endswith(" N")
    assert " N·m (limited by" in rows["yaw"]["amplitude Δφ"]
    assert " rad (" in rows["yaw"]["distance"] and rows["surge"]["distance"].endswith(" m")
    doc = json.loads(runner.invoke(app, [*base, "--json"]).stdout)
    assert doc["units"]["offset"] == "N | N·m" and doc["units"]["duration"] == "s"


@pytest.mark.slow
def test_sweep_summary_names_the_unit_of_every_metric_and_parameter(tmp_path):
    from uuvid.uncertainty.sweep import run_sweep

    f = tmp_path / "s.yaml"
    f.write_text("name: s\ntarget: {kind: thruster_step, chain: auv2-tunnel, t_end: 0.5, "
                 "substeps: 1}\nparameters:\n  - {name: tunnel_length, unit: in, values: [5, 20]}\n"
                 "  - {name: voltage, values: [12, 24]}\n"
                 "metrics: [peak_output_thrust, time_to_peak]\n")
    res = runner.invoke(app, ["sweep", str(f), "--out", str(tmp_path / "o"), "--backend",
                              "inprocess"])
    assert res.exit_code == 0, res.output
    assert "peak_output_thrust [N]" in res.stdout and "time_to_peak [s]" in res.stdout
    assert "wall time [s]" in res.stdout
    doc = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert doc["metrics"]["time_to_peak"]["unit"] == "s"
    text = run_sweep(f, backend="inprocess", report=False).summary()
    assert "tunnel_length [m]" in text and "voltage [V]" in text and "steady" not in text


def test_thruster_loop_answer_names_the_bandwidths_tried_and_brackets_the_limit():
    from uuvid.papers.thruster_loop_study import _answer

    def rows(grid):  # the same truth: tunnel clean to 6, first-order and Yoerger cycle above 5
        return [{"kind": k, "model": m, "bandwidth": b, "limit_cycle": m != "tunnel" and b > 5,
                 "holds_reference": not (m != "tunnel" and b > 5)}
                for k in ("heading", "depth") for m in ("tunnel", "first-order", "yoerger")
                for b in grid]

    models = ["tunnel", "first-order", "yoerger"]
    demo = _answer(rows((2.0, 6.0)), models, (2.0, 6.0))
    cli = _answer(rows((1.0, 2.0, 4.0, 6.0)), models, (1.0, 2.0, 4.0, 6.0))
    assert demo[0]["heading"]["first-order"] == 2 and cli[0]["heading"]["first-order"] == 4
    assert "tried (2, 6 rad/s)" in demo[3] and "tried (1, 2, 4, 6 rad/s)" in cli[3]
    assert "first-order 2 (cycles at 6)" in demo[3] and "first-order 4 (cycles at 6)" in cli[3]


def _loop_rows(grid, fails, **extra):
    """Rows of the study: ``fails(kind, model, bandwidth)`` → ``"cycle"``, ``"drift"`` or None."""
    rows = []
    for k in ("heading", "depth"):
        thr = 0.5 if k == "heading" else 0.01
        for m in ("tunnel", "first-order", "yoerger"):
            for b in grid:
                f = fails(k, m, b)
                rows.append({"kind": k, "model": m, "bandwidth": b, "limit_cycle": f == "cycle",
                             "residual_p2p": 20 * thr if f else 0.1 * thr,
                             "final_error": 10 * thr if f == "drift" else 0.0,
                             "holds_reference": not f, **extra})
    return rows


LOOP_MODELS = ["tunnel", "first-order", "yoerger"]


def _loop_answer(*a):
    from uuvid.papers.thruster_loop_study import _answer

    return _answer(*a)


def test_thruster_loop_stable_bandwidth_stops_at_the_first_failure():
    """``uuvid study thruster-loop --bandwidths 1,…,100``: first-order heading cycled at 6, 10,
    20 rad/s and swung 9° (not holding 20°) at 50 and 100, yet its 'max stable bandwidth' was 100."""
    grid = (1.0, 2.0, 4.0, 6.0, 10.0, 20.0, 50.0, 100.0)

    def fails(k, m, b):
        if m == "tunnel":
            return None
        return "cycle" if 6 <= b <= 20 else ("drift" if b > 20 else None)

    stable, holds, _, text = _loop_answer(_loop_rows(grid, fails), LOOP_MODELS, grid)
    assert stable["heading"]["first-order"] == 4 and stable["depth"]["yoerger"] == 4
    assert "first-order 4 (cycles at 6)" in text
    assert holds["heading"] is True and "as McLean conjectured" in text


def test_thruster_loop_a_row_off_its_reference_is_not_stable():
    grid = (2.0, 6.0)
    stable, _, _, text = _loop_answer(
        _loop_rows(grid, lambda k, m, b: "drift" if m == "first-order" and b == 6 else None),
        LOOP_MODELS, grid)
    assert stable["heading"]["first-order"] == 2 and "first-order 2 (does not hold" in text


def test_thruster_loop_no_limit_in_range_is_no_verdict():
    grid = (1.0, 2.0)
    stable, holds, _, text = _loop_answer(_loop_rows(grid, lambda k, m, b: None), LOOP_MODELS, grid)
    assert stable["heading"]["tunnel"] == 2 and holds == {"heading": None, "depth": None}
    assert "as McLean conjectured" not in text and "no limit" in text


def test_thruster_loop_sustained_oscillation_sees_a_slow_large_cycle_and_a_drift():
    """At 50 rad/s the first-order heading swung 9° with an ~11 s period: under 4 mean crossings
    in the 20 s tail, so it was called 'no limit cycle'.  A growing error is not a decaying tail."""
    from uuvid.papers.thruster_loop_study import _sustained_oscillation

    t = np.arange(0, 20, 0.01)
    assert _sustained_oscillation(20 + 4.5 * np.sin(2 * np.pi * t / 11 + 1.0), 0.5)
    assert _sustained_oscillation(20 + 0.05 * t * np.sin(2 * np.pi * t / 3), 0.5)  # growing
    assert not _sustained_oscillation(20 + 2 * np.exp(-t / 2) * np.sin(2 * np.pi * t / 3), 0.5)
    assert not _sustained_oscillation(20 + 0.1 * np.sin(t), 0.5)


def test_thruster_loop_refuses_duplicate_bandwidths():
    from uuvid.papers.thruster_loop_study import run_study

    with pytest.raises(ValueError, match="bandwidths: 2 rad/s given twice"):
        run_study(bandwidths=(2.0, 4.0, 2.0))


def test_thruster_simulate_default_input_is_in_the_models_unit_and_said():
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--t-end", "0.3", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["signal"]["amplitude"] == 1900 and doc["metrics_SI"]["steady_thrust"] > 40
    assert "default input: step 1500 → 1900 µs" in res.stderr
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--t-end", "0.3",
                              "--signal", "kind=step,amplitude=24"])
    assert "outside 800–2200 µs" in res.stderr  # 24 µs: a volt meant, not a pulse width
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.3"])
    assert "default input: step 0 → 24 V" in res.stderr


@pytest.mark.slow  # the whole demo (≈ 30 s on a free machine)
def test_demo_report_shows_all_it_holds(tmp_path, monkeypatch):
    """The demo folder read headless: every figure titled with labelled, united axes; every table
    fits the page; every sub-report reachable from the main page."""
    from matplotlib.figure import Figure

    from uuvid.core.plots import figure_problems
    from uuvid.demo import run_demo

    seen, problems = set(), []
    original = Figure.savefig

    def savefig(fig, *a, **k):
        if id(fig) not in seen:
            seen.add(id(fig))
            title = fig._suptitle.get_text() if fig._suptitle else next(
                (ax.get_title() for ax in fig.axes if ax.get_title()), "")
            problems.extend(f"{title[:50]!r}: {p}" for p in figure_problems(fig))
        return original(fig, *a, **k)

    monkeypatch.setattr(Figure, "savefig", savefig)
    out = tmp_path / "demo"
    run_demo(out, quick=True, workers=1)  # in this process, where savefig is watched
    assert len(seen) > 20 and problems == [], problems
    pages = sorted(out.rglob("index.html"))
    assert len(pages) > 5
    for page in pages:
        assert table_problems(page.read_text()) == [], page
    main = Page((out / "index.html").read_text()).links
    for page in pages[1:] if pages[0] == out / "index.html" else pages:
        rel = page.relative_to(out).as_posix()
        if rel == "index.html":
            continue
        parent = page.parent.parent / "index.html"
        up = Page(parent.read_text()).links if parent.exists() and parent != out / "index.html" else []
        assert rel in main or page.relative_to(page.parent.parent).as_posix() in up, \
            f"{rel} is not linked from index.html"


def _surface():
    from test_result_surface import FACTORIES, SLOW

    return FACTORIES, SLOW


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in _surface()[1]
                                  else n for n in _surface()[0]])
def test_every_result_plot_is_titled_with_united_axes(name, tmp_path):
    from uuvid.core.plots import figure_problems

    fig = _surface()[0][name](tmp_path).plot()
    assert figure_problems(fig) == []


@pytest.mark.slow
def test_stability_table_names_the_speed_unit():
    from uuvid.vehicle.definition import load_vehicle
    from uuvid.vehicle.stability import static_stability

    rows = static_stability(load_vehicle("bluerov2")).rows()
    assert all("max_speed_m_s" in r and all(k != "max_speed" for k in r) for r in rows)


def test_an_output_folder_that_is_a_file_is_one_line_not_a_traceback(tmp_path):
    """`uuvid thruster simulate t200 --out afile` with afile an ordinary file: one `error:` line
    naming it, exit status 2 (it was a rich traceback ending in FileExistsError)."""
    import os
    import subprocess
    import sys

    (tmp_path / "afile").write_text("x")
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    r = subprocess.run([sys.executable, "-m", "uuvid.cli.app", "thruster", "simulate", "t200",
                        "--t-end", "0.5", "--out", str(tmp_path / "afile")], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    assert "a file of that name is in the way" in r.stderr
    assert "Traceback" not in r.stderr and (tmp_path / "afile").read_text() == "x"
