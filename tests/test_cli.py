"""The command line: JSON on stdout, reports written, clear errors with exit status 2."""

import json
import re

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


@pytest.mark.slow
def test_reproduce_mclean1991_json():
    res = runner.invoke(app, ["reproduce", "mclean1991", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert [r["case"] for r in doc["table1"]][0] == "baseline"
    assert len(doc["table1"]) == 11
    for r in doc["table1"]:
        assert set(r) >= {"case", "peak_output_lbf", "max_true_lbf", "steady_lbf",
                          "time_constant_s", "steady_rpm"}
    assert {"motor", "gear_ratio", "prop_rpm", "thrust_lbf"} <= set(doc["load_matching"][0])
    assert doc["pulsing"]["rows"]
    assert abs(doc["identified"]["delta_alpha"] - 3.0) < 0.3
    assert abs(doc["identified"]["delta_beta"] - 0.185) < 0.02
    ef = doc["experiment_fit"]
    assert ef["mean_abs_rel_error"] < 0.15 < 0.30 < ef["thesis_mean_abs_rel_error"]
    assert ef["parameters"]


@pytest.mark.slow
def test_reproduce_laidani_json_and_out(tmp_path):
    res = runner.invoke(app, ["reproduce", "laidani", "--json", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert set(doc) >= {"full_forward_N", "full_reverse_N", "peak_forward_N", "dead_zone_us",
                        "saturation_us"}
    assert (tmp_path / "index.html").exists()


@pytest.mark.slow  # ≈ 30 s: the whole main job (CI runs it with --run-slow)
def test_demo_writes_report_folder(tmp_path):
    out = tmp_path / "demo"
    res = runner.invoke(app, ["demo", "--quick", "--out", str(out)], env={"UUVID_NO_PROGRESS": ""})
    assert res.exit_code == 0, res.output
    html = (out / "index.html").read_text()
    assert "data:image/png;base64," in html
    doc = json.loads((out / "demo.json").read_text())
    assert doc["model_file"]["round_trip_equal"] is True
    assert (out / "mclean1991" / "step_baseline.png").exists()
    # off a terminal (CliRunner's stderr is not a TTY) every stage prints one line with its time
    stages = [ln for ln in res.stderr.splitlines() if ln.startswith("uuvid demo: ")]
    assert len(stages) >= 8 and stages[-1].startswith("uuvid demo: done in ")
    assert all(ln.endswith(" s)") for ln in stages[:-1])
    # issue 10: no NaN in any table; the Heavy's envelope is confirmed with its attitude held
    assert "Speed envelope" in html and not re.search(r">\s*-?nan\s*<", html, re.I)
    heavy = doc["vehicle"]["envelopes"]["bluerov2-heavy"]["rows"]
    assert all(r["confirmed"] for r in heavy if r["dof"] in ("surge", "sway", "heave"))
    assert doc["linearize"]["pid"]["rms_position_error_m"] > 0
    # issue 19: dive → identify → replay → fly; the identified file beats the preset held out
    rp = {k: v["channels"] for k, v in doc["dive"]["replay"].items()}
    assert rp["identified (my-rov.yaml)"]["depth"]["rms"] < 0.6 * rp["preset bluerov2"]["depth"]["rms"]
    assert (out / "dive" / "my-rov.yaml").is_file() and doc["dive"]["mission"]["completed"]
    assert "dive/identify/index.html" in html
    # a reversed motor, a motor on another output and a depth offset in the dive: each said
    traps = doc["dive"]["traps"]
    assert len(traps) == 4 and not any(v == "NOT SAID" for v in traps.values()), traps
    # a T200 file exported at 16 V and run at 12 V falls short of the sheet law; at 12 V it holds it
    ex = {r["at 12 V"]: r["full forward [N]"] for r in doc["t200_sheets"]["export_at_12V"]}
    assert ex["file exported at 16 V"] < 0.85 * ex["the preset (its sheet law)"]
    assert ex["file exported with --supply-voltage 12"] == ex["the preset (its sheet law)"]
    # the sections ran in worker processes (one per core); the same numbers as in this process
    from uuvid.demo import _SECTIONS, _workers, run_demo

    assert doc["workers"] == _workers(None)
    assert set(doc["timings_s"]) == {t for t, _, _ in _SECTIONS}
    one = run_demo(tmp_path / "one", quick=True, workers=1)

    clocks = {"timings_s", "workers", "workers_used", "runtime_s", "seconds", "wall_time_s",
              "chunk_wall_time_s", "compile_time_s", "runs_per_s", "real_time_factor", "sweep_s",
              "steady_thrust_s"}  # how long things took, and which process: not results

    def numbers(d, root):
        def walk(x):
            if isinstance(x, dict):
                return {k: walk(v) for k, v in x.items() if k not in clocks}
            return [walk(v) for v in x] if isinstance(x, list) else x
        return json.loads(json.dumps(walk(d)).replace(str(root), "<out>"))

    assert one["workers"] == 1 and numbers(one, tmp_path / "one") == numbers(doc, out)
    # the sections wrote into a temporary folder swapped in at the end: no file names it
    # (a replay's summary named the model file it read there, a summary its figure)
    for root in (out, tmp_path / "one"):
        leaked = [str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()
                  and p.suffix in (".json", ".txt", ".html", ".md", ".csv", ".yaml")
                  and ".tmp-" in p.read_text(errors="replace")]
        assert not leaked, leaked
    assert (tmp_path / "one" / "index.html").read_text().replace(str(tmp_path / "one"), "") \
        .count("<img") == html.count("<img")


@pytest.mark.slow
def test_thruster_simulate_preset_json(tmp_path):
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--signal",
                              "kind=step,amplitude=24", "--t-end", "1.0", "--json", "--out",
                              str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["metrics_SI"]["max_true_thrust"] > 16
    assert (tmp_path / "response.csv").exists()
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.2", "--out",
                              str(tmp_path / "o")])
    assert res.exit_code == 0 and str(tmp_path / "o" / "index.html") in " ".join(res.output.split())


def test_thruster_simulate_bad_model_file_exit_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("blocks:\n  - type: first_order\n    time_constant: 0.1\n    tau: 3\n")
    res = runner.invoke(app, ["thruster", "simulate", str(bad)])
    assert res.exit_code == 2
    assert "blocks[0].tau" in res.output and "unknown key" in res.output


def test_thruster_simulate_bad_signal_exit_2():
    res = runner.invoke(app, ["thruster", "simulate", "laidani-a2212", "--signal", "kind=wobble"])
    assert res.exit_code == 2
    assert "wobble" in res.output


def test_missing_model_exit_2():
    res = runner.invoke(app, ["thruster", "show", "no-such-file.yaml"])
    assert res.exit_code == 2
    assert "no such model file" in res.output


def test_thruster_export_toml_round_trip(tmp_path):
    from uuvid.thruster.modelfile import load_chain
    from uuvid.thruster.presets import laidani_chain

    p = tmp_path / "m.toml"
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--to", "toml", "--out", str(p)])
    assert res.exit_code == 0, res.output
    assert load_chain(p) == laidani_chain()


def test_a_preset_exported_at_a_supply_voltage_follows_its_own_voltage_law(tmp_path):
    """`export t200` wrote the 16 V preset; used at 12 V its file followed V = duty × supply and
    gave 20 % less thrust than the preset (and the sheet), unsaid.  The export says the voltage,
    warns how far the file's law lands from the preset's, and --supply-voltage writes the preset
    at that supply by its own law."""
    import numpy as np

    from uuvid.thruster.modelfile import load_chain
    from uuvid.thruster.presets import preset_chain
    from uuvid.thruster.resolve import at_supply

    full = np.array([1100.0, 1900.0])
    p16, p12 = tmp_path / "t200.yaml", tmp_path / "t200_12V.yaml"
    res = runner.invoke(app, ["thruster", "export", "t200", "--out-file", str(p16)])
    assert res.exit_code == 0, res.output
    assert "exported at 16 V (the preset's own; set --supply-voltage)" in res.output
    m = re.search(r"at 12 V its full-command thrust is (\d+) % off the preset's", res.output)
    at12 = at_supply(load_chain(p16), 12.0).steady_thrust(full)
    own12 = preset_chain("t200", 12.0).steady_thrust(full)
    assert m and int(m.group(1)) == round(100 * np.max(np.abs(at12 / own12 - 1))) >= 15
    res = runner.invoke(app, ["thruster", "export", "t200", "--supply-voltage", "12",
                              "--out-file", str(p12)])
    assert res.exit_code == 0 and "exported at 12 V (--supply-voltage)" in res.output
    np.testing.assert_allclose(load_chain(p12).steady_thrust(full), own12, rtol=1e-12)
    res = runner.invoke(app, ["thruster", "export", "auv2-tunnel-thruster", "--supply-voltage", "12"])
    assert res.exit_code == 2 and "no ESC block" in res.output
    for extra in ([], ["--supply-voltage", "12"]):  # a KeyError traceback once
        res = runner.invoke(app, ["thruster", "export", "t200-physical", *extra])
        assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["thruster", "export", "t200-physical", "--to", "uuv-simulator"])
    assert res.exit_code == 2 and "has no UUV Simulator dynamics model" in res.output


def test_error_keeps_bracketed_column_names(tmp_path):
    """rich reads ``[s]`` as markup; the error must print the user's column names literally."""
    csv = tmp_path / "bench.csv"
    csv.write_text("time [s],pwm [us],thrust [N]\n0,1500,0\n1,1600,1\n2,1700,3\n")
    res = runner.invoke(app, ["thruster", "fit", str(csv), "--model", "quadratic", "--out-model",
                              str(tmp_path / "m.yaml"), "--command-col", "throttle",
                              "--thrust-col", "thrust [N]"])
    assert res.exit_code == 2
    assert "'time [s]', 'pwm [us]', 'thrust [N]'" in res.output


def test_table_cells_keep_brackets():
    from rich.console import Console

    from uuvid.cli.common import _table

    con = Console(width=200, record=True)
    con.print(_table("run [1]", [{"column [s]": "pwm [us]"}], ["column [s]"]))
    text = con.export_text()
    assert "run [1]" in text and "column [s]" in text and "pwm [us]" in text


def test_thruster_model_names_resolve_the_same_everywhere(tmp_path):
    """One resolver: ``t200-physical`` (the name ``log export`` prints) is a thruster model for
    ``thruster show`` and a scenario as well, not only for ``montecarlo``."""
    from uuvid.simulate.scenario import ScenarioError, build, scenario_from_dict

    res = runner.invoke(app, ["thruster", "show", "t200-physical"])
    assert res.exit_code == 0, res.output
    assert "t200-physical@16V" in res.output
    spec = scenario_from_dict({"vehicle": "bluerov2", "thruster_model": "no-such-model"})
    with pytest.raises(ScenarioError, match="not a thruster preset"):
        build(spec)


def test_current_of_the_wrong_length_says_what_is_expected():
    from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

    with pytest.raises(ScenarioError) as e:
        scenario_from_dict({"current": [0.1, 0]}, where="s.yaml")
    m = str(e.value)
    assert m.startswith("s.yaml: current: expected N,E,D (m/s)") and "Spec" not in m
    res = runner.invoke(app, ["simulate", "mission", "--current", "0.3"])
    assert res.exit_code == 2
    assert "expected N,E,D (m/s)" in res.output and "0.3,0,0" in res.output
    assert "tuple[float" not in res.output


@pytest.mark.slow  # two worker processes start (a few seconds)
def test_a_failing_demo_section_is_named_and_stops_the_others(tmp_path):
    """A section failing in a worker raised an AttributeError from the clean-up itself (the pool
    drops its processes on shutdown) and waited for the sections still running: it is named, and
    the others are stopped."""
    import time

    from uuvid.core.progress import progress_task
    from uuvid.demo import DemoSectionError, _run_sections

    bad = tmp_path / "a-file"  # every section that writes its folder fails
    bad.write_text("not a folder")
    t0 = time.perf_counter()
    with progress_task("t", disable=True) as task, \
            pytest.raises(DemoSectionError, match=r"^demo section '.+' failed: \w+Error: "):
        _run_sections(bad, True, 2, task)
    assert time.perf_counter() - t0 < 120


def test_demo_rebases_paths_inside_the_files_its_sections_wrote(tmp_path):
    """Paths under the demo's temporary folder, raw, JSON- or HTML-escaped, point at the final
    folder once rewritten; other text and binary files are left as they were."""
    from uuvid.demo import _rebase_files

    work, final = tmp_path / ".tmp-1-ab-out & co", tmp_path / "out & co"
    (work / "sub").mkdir(parents=True)
    (work / "sub" / "summary.txt").write_text(f"replay with my-rov ({work}/dive/my-rov.yaml)\n")
    (work / "sub" / "result.json").write_text(json.dumps({"figure": str(work / "a.png")}))
    import html as _html
    (work / "index.html").write_text(f"<p>{_html.escape(str(work))}/x.png</p>")
    (work / "plain.csv").write_text("t,x\n0,1\n")
    png = bytes(range(256)) + str(work).encode()
    (work / "a.png").write_bytes(png)
    changed = _rebase_files(work, final)
    assert sorted(p.name for p in changed) == ["index.html", "result.json", "summary.txt"]
    assert (work / "sub" / "summary.txt").read_text() == f"replay with my-rov ({final}/dive/my-rov.yaml)\n"
    assert json.loads((work / "sub" / "result.json").read_text()) == {"figure": str(final / "a.png")}
    assert (work / "index.html").read_text() == f"<p>{_html.escape(str(final))}/x.png</p>"
    assert (work / "plain.csv").read_text() == "t,x\n0,1\n" and (work / "a.png").read_bytes() == png
