"""The report page and figures say what they show: links, wide tables, readable labels, units,
step metrics only for steps, input design consistent with its own ranges (issue 10, item 8)."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.core.html import Report
from uuvid.core.plots import _axis_label, plot_time_series
from uuvid.identify.vehicle.design import design_sine_experiment
from uuvid.uncertainty.params import si_unit

runner = CliRunner()


def test_full_page_lines_are_relative_links_and_tables_fit():
    html = (Report("r").add_links("Full pages:", ["sweep/index.html", "montecarlo/index.html"])
            .add_table([{f"c{i}": i for i in range(15)}]).to_html())
    assert '<a href="sweep/index.html">sweep/index.html</a>' in html
    assert '<a href="montecarlo/index.html">' in html
    # issue 22: a table wraps or is split to fit the page, it does not hide columns behind a
    # horizontal scroll bar (tests/test_user_output.py measures it)
    assert '<div class="tw"><table>' in html and "overflow-x" not in html
    for bad in ("/etc/passwd", "https://example.com/x", "javascript:alert(1)"):
        with pytest.raises(ValueError):
            Report("r").add_links("x", [bad])


@pytest.mark.slow
def test_stacked_y_labels_fit_their_own_axes():
    t = np.linspace(0, 1, 50)
    chans = {"motor_speed": t, "prop_speed": t, "thrust": t, "measured_thrust": t, "torque": t}
    units = {"motor_speed": "motor_speed [rad/s]", "prop_speed": "prop_speed [rad/s]",
             "thrust": "thrust [N]", "measured_thrust": "measured_thrust [N]", "torque": "torque [N·m]"}
    fig = plot_time_series(t, chans, ylabel_by_channel=units,
                           axes_groups=[["motor_speed", "prop_speed"], ["thrust", "measured_thrust"],
                                        ["torque"]])
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    xs = []
    for ax in fig.axes:
        lab = ax.yaxis.label.get_window_extent(r)
        box = ax.get_window_extent(r)
        assert lab.height <= box.height + 1e-6, ax.get_ylabel()  # no spill into the neighbours
        xs.append(lab.x1)
    assert max(xs) - min(xs) < 1.0  # aligned
    assert _axis_label(["motor_speed [rad/s]", "prop_speed [rad/s]"]).replace("\n", " ") == \
        "motor_speed, prop_speed [rad/s]"
    assert _axis_label(["thrust [N]", "torque [N·m]"]).replace("\n", " ") == "thrust [N] / torque [N·m]"


def test_sweep_parameters_without_a_given_unit_are_labelled_in_si():
    assert si_unit("voltage") == "V"
    assert si_unit("blocks[0].motor.time_constant") == "s"
    assert si_unit("linear_damping[surge]") == "N·s/m"
    assert si_unit("linear_damping[yaw]") == "N·m·s/rad"
    assert si_unit("added_mass[5]") == "kg·m²"
    assert si_unit("added_mass_scale") == ""


def test_square_input_gets_no_step_metrics():
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--signal",
                              "kind=square,low=0,high=24,period=1", "--t-end", "2", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["metrics_SI"] == {} and "step" in doc["metrics_note"]
    res = runner.invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "1", "--json"])
    assert json.loads(res.stdout)["metrics_SI"]["peak_output_thrust"] > 0


def test_design_says_when_its_nominal_lies_outside_its_inertia_range():
    d = design_sine_experiment(28.6, mass=93.75, mass_air=93.75, speed=-0.175)  # the paper's yaw
    lo, hi = 93.75 * 1.1, 93.75 * 2.0
    assert not lo <= d.mass <= hi
    assert any("outside the a-priori inertia range" in m and "in-air" in m for m in d.messages)
    inside = design_sine_experiment(28.6, mass=140.0, mass_air=93.75, speed=-0.175)
    assert not any("outside" in m for m in inside.messages)
