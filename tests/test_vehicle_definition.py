"""Vehicle definition files: presets, sources, exact error paths, thruster model references."""

import copy
import math
import warnings

import numpy as np
import pytest
import yaml

from uuvid.core.units import G0
from uuvid.vehicle import (
    VehicleFileError,
    VehicleFileWarning,
    list_presets,
    load_vehicle,
    vehicle_from_dict,
)

BASE = {
    "name": "testbot",
    "source": {"citation": "made up for the tests"},
    "rigid_body": {"mass": 10.0, "buoyancy": 100.0, "center_of_gravity": [0, 0, 0.02],
                   "center_of_buoyancy": [0, 0, 0], "inertia": [0.2, 0.2, 0.3]},
    "hydrodynamics": {"added_mass": [5, 10, 12, 0.1, 0.1, 0.1],
                      "linear_damping": [4, 6, 5, 0.1, 0.1, 0.1],
                      "quadratic_damping": [18, 21, 37, 1.5, 1.5, 1.5]},
    "thrusters": [
        {"name": "A", "position": [0.2, 0.1, 0], "axis": [1, 0, 0], "model": "t200",
         "limits": [-40, 50]},
        {"name": "B", "position": [0.2, -0.1, 0], "axis": [1, 0, 0], "model": "t200",
         "limits": [-40, 50]},
        {"name": "C", "position": [0, 0, 0], "rpy_deg": [0, -90, 0], "model": "t200",
         "limits": [-40, 50], "installation": {"up_down": [1.0, 0.5]}},
    ],
    "modes": {"up_down": {"constraints": [{"A": 1, "B": -1}], "zero_dofs": ["yaw"]}},
    "allocation": {"dofs": ["surge", "heave", "yaw"]},
}


def errors_of(mutate) -> str:
    raw = copy.deepcopy(BASE)
    mutate(raw)
    with pytest.raises(VehicleFileError) as e:
        vehicle_from_dict(raw, where="bot.yaml")
    return str(e.value)


def test_base_file_builds():
    v = vehicle_from_dict(copy.deepcopy(BASE))
    assert v.layout.names == ("A", "B", "C")
    assert np.allclose(v.layout["C"].axis, [0, 0, 1])
    assert v.params.weight == pytest.approx(10.0 * G0)
    assert v.allocation_dofs == (0, 2, 5)
    assert v.modes["up_down"].eta_neg.tolist() == [1.0, 1.0, 0.5]


T = "thrusters"


@pytest.mark.parametrize("mutate, expected", [
    (lambda r: r[T][2].pop("position"), "bot.yaml: thrusters[2].position: missing"),
    (lambda r: r.pop("source"), "bot.yaml: source: missing"),
    (lambda r: r["rigid_body"].pop("mass"), "bot.yaml: rigid_body.mass: missing"),
    (lambda r: r[T][0].update(colour="red"), "bot.yaml: thrusters[0].colour: unknown key"),
    (lambda r: r["hydrodynamics"].update(added_mass=[1, 2, 3]),
     "bot.yaml: hydrodynamics.added_mass: expected 6 (diagonal) or 36"),
    (lambda r: r[T][1].update(position=[0, 0]), "bot.yaml: thrusters[1].position[2]: missing"),
    (lambda r: r[T][1].update(limits=[10, 50]),
     "bot.yaml: thrusters[1].limits: must be [min, max] with min <= 0 <= max"),
    (lambda r: r[T][0].pop("axis"),
     "bot.yaml: thrusters[0].axis: missing (give axis or rpy_deg)"),
    (lambda r: r[T][2].update(axis=[0, 0, 1]),
     "bot.yaml: thrusters[2].rpy_deg: give axis or rpy_deg, not both"),
    (lambda r: r[T][1].update(axis=[0, 0, 0]),
     "bot.yaml: thrusters[1].axis: must be a non-zero vector"),
    (lambda r: r[T][1].update(name="A"),
     "bot.yaml: thrusters[1].name: duplicate thruster name 'A'"),
    (lambda r: r[T][0].update(installation={"nope": 0.5}),
     "bot.yaml: thrusters[0].installation.nope: unknown mode"),
    (lambda r: r["modes"]["up_down"].update(constraints=[{"A": 1, "Q": 1}]),
     "bot.yaml: modes.up_down.constraints[0].Q: unknown thruster"),
    (lambda r: r["modes"]["up_down"].update(zero_dofs=["sideways"]),
     "bot.yaml: modes.up_down.zero_dofs[0]: Input should be 'surge'"),
    (lambda r: r["rigid_body"].pop("buoyancy"),
     "bot.yaml: rigid_body.buoyancy: missing (or give displaced_volume and water_density)"),
    (lambda r: r["rigid_body"].update(buoyancy=None, displaced_volume=0.01),
     "bot.yaml: rigid_body.water_density: missing (needed with displaced_volume)"),
    (lambda r: r["hydrodynamics"].update(linear_damping=[-4, 6, 5, 0.1, 0.1, 0.1]),
     "bot.yaml: hydrodynamics.linear_damping: VehicleParams.linear_damping[surge] = -4 < 0"),
    (lambda r: r["hydrodynamics"].update(added_mass=[-5, 1, 1, 1, 1, 1]),
     "bot.yaml: hydrodynamics.added_mass: VehicleParams.added_mass must be positive semi-def"),
    (lambda r: r["rigid_body"].update(mass=float("nan")),
     "bot.yaml: rigid_body.mass: Input should be a finite number"),
    (lambda r: r["allocation"].update(weights=[1, 2]),
     "bot.yaml: allocation.weights: expected 3 values"),
    (lambda r: r["allocation"].update(dofs=["surge", "twist"]), "bot.yaml: allocation.dofs[1]"),
    (lambda r: r.update(one_dof={"a": {"dof": "yaw", "mass": 1.0, "linear": 0.0}}),
     "bot.yaml: one_dof.a.linear: linear or quadratic drag must be > 0"),
])
def test_errors_name_the_exact_path(mutate, expected):
    assert expected in errors_of(mutate)


def test_several_errors_are_reported_together():
    def m(r):
        r["thrusters"][0].pop("model")
        r["thrusters"][2].pop("limits")
    msg = errors_of(m)
    assert "thrusters[0].model: missing" in msg and "thrusters[2].limits: missing" in msg


def test_displaced_volume_and_inertia_about_origin(tmp_path):
    raw = copy.deepcopy(BASE)
    raw["rigid_body"].update(buoyancy=None, displaced_volume=0.0134, water_density=1000.0,
                             inertia=[0.2, 0.2, 0.3], inertia_about="origin")
    del raw["rigid_body"]["buoyancy"]
    v = vehicle_from_dict(raw)
    assert v.params.buoyancy == pytest.approx(1000 * G0 * 0.0134)
    # about the CG: I_g = I_o − m r_g² on the x and y axes
    assert np.allclose(np.diag(v.params.inertia), [0.2 - 10 * 0.02**2, 0.2 - 10 * 0.02**2, 0.3])
    assert np.allclose(np.diag(v.params.M_RB)[3:], [0.2, 0.2, 0.3])


def test_yaml_and_toml_files(tmp_path):
    p = tmp_path / "bot.yaml"
    p.write_text(yaml.safe_dump(BASE))
    assert load_vehicle(p).name == "testbot"
    t = tmp_path / "bot.toml"
    t.write_text("""
name = "tomlbot"
[source]
citation = "test"
[rigid_body]
mass = 10.0
buoyancy = 100.0
center_of_gravity = [0, 0, 0.02]
center_of_buoyancy = [0, 0, 0]
inertia = [0.2, 0.2, 0.3]
[hydrodynamics]
added_mass = [5, 10, 12, 0.1, 0.1, 0.1]
linear_damping = [4, 6, 5, 0.1, 0.1, 0.1]
quadratic_damping = [18, 21, 37, 1.5, 1.5, 1.5]
[[thrusters]]
name = "A"
position = [0.2, 0.1, 0]
axis = [1, 0, 0]
model = "t200"
""")
    with pytest.raises(VehicleFileError, match=r"bot.toml: thrusters\[0\].limits: missing"):
        load_vehicle(t)
    with pytest.raises(VehicleFileError, match="not a preset"):
        load_vehicle("no-such-vehicle")


# --------------------------------------------------------------------------- presets
def test_presets_load_and_state_their_source():
    names = list_presets()
    assert {"bluerov2", "bluerov2-heavy", "romeo", "auv2"} <= set(names)
    expected = {"bluerov2": ("Wu", 6), "bluerov2-heavy": ("von Benzon", 8),
                "romeo": ("Caccia", 8), "auv2": ("McLean", 4)}
    for n in names:
        v = load_vehicle(n)
        assert v.citation and v.B.shape == (6, v.layout.n)
        author, nthr = expected[n]
        assert author in v.citation and v.layout.n == nthr
        assert v.assumptions  # every preset lists what it assumed
        assert all(lo <= 0 <= hi for lo, hi in v.layout.limits)


def test_bluerov2_numbers_are_the_wu_2018_set():
    p = load_vehicle("bluerov2").params
    assert p.mass == 11.5 and p.weight == 112.8 and p.buoyancy == 114.8
    assert np.allclose(np.diag(p.added_mass), [5.5, 12.7, 14.57, 0.12, 0.12, 0.12])
    assert np.allclose(np.diag(p.linear_damping), [4.03, 6.22, 5.18, 0.07, 0.07, 0.07])
    assert np.allclose(np.diag(p.quadratic_damping), [18.18, 21.66, 36.99, 1.55, 1.55, 1.55])
    lim = load_vehicle("bluerov2").layout.limits
    assert np.allclose(lim, [[-4.07 * G0, 5.25 * G0]] * 6, rtol=1e-4)  # T200 at 16 V


def test_heavy_numbers_are_the_von_benzon_2022_set():
    v = load_vehicle("bluerov2-heavy")
    p = v.params
    assert p.buoyancy == pytest.approx(1000 * G0 * 0.0134)
    assert np.allclose(p.r_b, [0, 0, -0.01])
    assert np.allclose(np.diag(p.quadratic_damping), [141, 217, 190, 1.192, 0.470, 1.5])
    assert np.linalg.matrix_rank(v.B) == 6


def test_romeo_numbers_and_thruster_model_file():
    v = load_vehicle("romeo")
    p = v.params
    assert p.mass_matrix[0, 0] == pytest.approx(890.0)  # identified surge mass
    assert p.mass_matrix[5, 5] == pytest.approx(84.0)  # identified yaw inertia
    assert np.diag(p.linear_damping)[[0, 2, 5]].tolist() == [46.9, 44.7, 20.5]
    assert np.diag(p.quadratic_damping)[[0, 2, 5]].tolist() == [306.2, 430.3, 49.5]
    assert p.net_weight == pytest.approx(0.7)
    chain = v.thruster_chain("HFL")  # c_V V|V| from the thrust tunnel
    assert np.allclose(chain.steady_thrust([10.0, -10.0]), [102.0, -109.0])
    yaw = v.one_dof["yaw"]
    assert (yaw.mass, yaw.linear, yaw.quadratic, yaw.eta_neg) == (84.0, 20.5, 49.5, 0.60)
    assert v.one_dof["heave"].eta_neg == 0.56


def test_thruster_model_references():
    assert load_vehicle("auv2").thruster_chain("V_bow").name == "auv2-tunnel-thruster"
    assert load_vehicle("bluerov2").thruster_chain(0).name == "t200"

    raw = load_vehicle("bluerov2")  # a file naming an unknown model says so
    assert raw.layout[0].model == "t200"


def test_auv2_layout_from_mclean():
    v = load_vehicle("auv2")
    xs = [t.position[0] for t in v.layout]
    assert xs[0] - xs[1] == pytest.approx(46 * 0.0254) and xs[2] - xs[3] == pytest.approx(
        34 * 0.0254)
    assert v.layout.limits[0, 1] == pytest.approx(0.50 * 4.4482216, rel=1e-4)
    al = v.allocator()
    assert al.controlled == (1, 2, 4, 5)
    assert np.allclose(v.B[[1, 2, 4, 5]] @ al.T[:, [1, 2, 4, 5]], np.eye(4))
    assert math.isclose(v.params.weight, v.params.buoyancy)


def test_validated_files_are_cached_by_content(tmp_path, monkeypatch):
    """A vehicle file validated once is read back from the disk cache (no parsing, no pydantic);
    the same file with other bytes is validated again, and an invalid one is never cached."""
    from uuvid.vehicle import definition

    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "v.yaml"
    path.write_text(definition.preset_path("bluerov2").read_text())
    first = load_vehicle(path)
    assert list((tmp_path / "cache" / "vehicles").glob("*.pkl"))

    def refuse(*a, **k):
        raise AssertionError("validated again although the file did not change")

    monkeypatch.setattr(definition, "vehicle_from_dict", refuse)
    again = load_vehicle(path)
    assert again is not first and again.path == first.path
    assert again.to_dict() == first.to_dict()
    np.testing.assert_array_equal(again.B, first.B)
    monkeypatch.undo()
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    raw = yaml.safe_load(path.read_text())
    raw["rigid_body"]["mass"] = 2 * raw["rigid_body"]["mass"]
    path.write_text(yaml.safe_dump(raw))
    assert load_vehicle(path).params.mass == pytest.approx(2 * first.params.mass)
    raw["rigid_body"]["mass"] = -1.0
    path.write_text(yaml.safe_dump(raw))
    for _ in range(2):  # an invalid file is reported every time
        with pytest.raises(VehicleFileError, match="rigid_body.mass"):
            load_vehicle(path)


@pytest.mark.slow
def test_a_warm_mission_process_imports_no_pydantic(tmp_path):
    """Issue 20: a plain mission with warm caches needs neither pydantic nor a vehicle-file
    parse (the validated preset comes from the cache)."""
    import os
    import subprocess
    import sys

    code = ("import sys\n"
            "from uuvid.simulate.reference import square_mission\n"
            "from uuvid.simulate.vehicle_sim import setup_mission\n"
            "from uuvid.vehicle.definition import load_vehicle\n"
            "setup_mission(load_vehicle('bluerov2'), square_mission())\n"
            "print(sorted(m for m in ('pydantic', 'typer', 'rich', 'pandas', 'matplotlib') "
            "if m in sys.modules))\n")
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                           check=True).stdout.strip() for _ in range(2)]
    assert runs[1] == "[]", runs


@pytest.mark.parametrize("change, factor", [
    ({"mass": 10_000.0}, "0.00"),  # the mass in grams
    ({"buoyancy": 10.0}, "0.102"),  # the buoyancy in kgf
])
def test_a_vehicle_far_from_neutral_is_named_with_the_likely_unit(change, factor):
    raw = copy.deepcopy(BASE)
    raw["rigid_body"].update(change)
    with pytest.warns(VehicleFileWarning, match="no vehicle that holds depth") as rec:
        vehicle_from_dict(raw, where="bot.yaml")
    msg = str(rec[0].message)
    assert msg.startswith("bot.yaml: rigid_body: the buoyancy") and factor in msg
    assert "mass in grams" in msg


def test_presets_and_a_trimmed_vehicle_load_without_a_warning():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        for name in list_presets():
            load_vehicle(name)
        raw = copy.deepcopy(BASE)
        raw["rigid_body"].update(buoyancy=1.9 * 10 * G0)  # 1.9 × the weight: a float, not a unit
        vehicle_from_dict(raw)


def test_the_warning_is_repeated_when_the_file_is_read_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    raw = copy.deepcopy(BASE)
    raw["rigid_body"]["mass"] = 10_000.0
    p = tmp_path / "grams.yaml"
    p.write_text(yaml.safe_dump(raw))
    from uuvid.vehicle import definition

    calls = []
    real = definition.vehicle_from_dict
    monkeypatch.setattr(definition, "vehicle_from_dict", lambda *a, **k: calls.append(1) or
                        real(*a, **k))
    for _ in range(2):  # parsed, then read back from the disk cache
        with pytest.warns(VehicleFileWarning, match=f"{p}: rigid_body: the buoyancy"):
            load_vehicle(p)
    assert len(calls) == 1  # the second load came from the cache


def test_the_command_line_shows_a_vehicle_warning_as_a_line_not_a_source_location(tmp_path):
    """`uuvid vehicle info grams.yaml`: 'warning: grams.yaml: rigid_body: …' on stderr — not the
    Python file and line that raised it — and the vehicle's inflow setting in the summary."""
    import os
    import subprocess
    import sys

    raw = copy.deepcopy(BASE)
    raw["rigid_body"]["mass"] = 10_000.0
    p = tmp_path / "grams.yaml"
    p.write_text(yaml.safe_dump(raw))
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    r = subprocess.run([sys.executable, "-m", "uuvid.cli.app", "vehicle", "info", str(p)], env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "warning: " + str(p) + ": rigid_body: the buoyancy" in r.stderr
    assert ".py:" not in r.stderr and "VehicleFileWarning" not in r.stderr
    assert "inflow: none" in r.stdout


@pytest.mark.parametrize("change, said", [
    ({"mass": 11_500.0, "weight": 112.8, "buoyancy": 114.8}, "the weight 112.8 N is 0.001 × m·g"),
    ({"weight": 1.15, "buoyancy": 1.17}, "the weight 1.15 N is 0.0102 × m·g"),  # in kgf... of 11.5
    ({"mass": 11_500.0, "weight": 112_800.0, "buoyancy": 114_800.0},
     "is a radius of gyration of"),  # every mass in grams, the inertia left in kg·m²
    # I_xx + I_yy < I_zz: no body of positive mass (a value from another vehicle, a typo)
    ({"inertia": [0.1, 0.1, 0.5]}, "principal moments 0.1, 0.1, 0.5 kg·m² — the largest exceeds"),
    ({"inertia": [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.5]]}, "principal moments 0.1, 0.1, 0.5"),
])
def test_a_weight_or_inertia_that_cannot_go_with_the_mass_is_named(change, said):
    """The buoyancy check compares buoyancy with the weight; a mass in grams with the weight left
    in N (or every mass-like number ×1000 and the inertia not) passed it silently."""
    raw = copy.deepcopy(BASE)
    raw["rigid_body"].update(mass=11.5, inertia=[0.16, 0.16, 0.16])
    raw["rigid_body"].pop("displaced_volume", None)
    raw["rigid_body"].update(change)
    with pytest.warns(VehicleFileWarning) as rec:
        vehicle_from_dict(raw, where="bot.yaml")
    msgs = [str(r.message) for r in rec]
    assert any(said in m for m in msgs), msgs


def test_an_inertia_too_large_for_the_vehicles_size_is_named(tmp_path):
    """`inertia: [160, 160, 160]` for an 11.5 kg BlueROV2 (a radius of gyration of 3.7 m, its
    thrusters within 0.19 m of the centre of gravity) loaded silently; too small an inertia was
    already said.  Its own 0.16 kg·m² and ten times that (0.37 m: heavy fittings far out) stay
    silent."""
    from uuvid.vehicle.definition import preset_path

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["rigid_body"]["inertia"] = [160.0, 160.0, 160.0]
    p = tmp_path / "bluerov2-big.yaml"
    p.write_text(yaml.safe_dump(raw))
    with pytest.warns(VehicleFileWarning, match=r"bluerov2-big\.yaml: rigid_body: inertia 160 kg·m² "
                                                r"about x with mass 11\.5 kg is a radius of "
                                                r"gyration of 3\.73 m — more than a vehicle of "
                                                r"11\.5 kg whose thrusters sit within 0\.19 m"):
        load_vehicle(p)
    for inertia in ([0.16, 0.16, 0.16], [1.6, 1.6, 1.6]):
        raw["rigid_body"]["inertia"] = inertia
        with warnings.catch_warnings():
            warnings.simplefilter("error", VehicleFileWarning)
            vehicle_from_dict(copy.deepcopy(raw), where="ok.yaml")


def test_an_inertia_too_large_for_the_mass_is_named():
    """Thrusters close in (0.22 m) leave the bound to the mass: a 10 kg vehicle about as dense as
    water spreads its mass no further than 3 × (0.01 m³)^(1/3) = 0.65 m."""
    raw = copy.deepcopy(BASE)
    raw["rigid_body"]["inertia"] = [0.2, 50.0, 50.0]  # 10 kg: 2.2 m
    with pytest.warns(VehicleFileWarning, match=r"radius of gyration of 2\.24 m .*at most about "
                                                r"0\.65 m"):
        vehicle_from_dict(raw, where="bot.yaml")


def test_positions_in_millimetres_are_named():
    raw = copy.deepcopy(BASE)
    for t in raw["thrusters"]:
        t["position"] = [1000.0 * x for x in t["position"]]
    with pytest.warns(VehicleFileWarning, match=r"position is [\d.]+ m from the body origin.*"
                                                 r"are the lengths in mm or cm"):
        vehicle_from_dict(raw, where="bot.yaml")


def test_a_thruster_model_that_resolves_to_nothing_is_said_on_load_with_the_nearest_preset():
    """'t300' (a typo) loaded silently; the first mission then failed with "(a placeholder)"."""
    raw = copy.deepcopy(BASE)
    raw["thrusters"][0]["model"] = "t300"
    with pytest.warns(VehicleFileWarning, match=r"thrusters A: model 't300' is neither a thruster "
                                                r"preset .* did you mean 't200'\?"):
        vehicle_from_dict(raw, where="bot.yaml")


def test_an_inertia_matrix_written_as_three_rows_is_read_row_major():
    """[[Ixx, Ixy, Ixz], …] gave 'inertia[0]: Input should be a valid number' three times."""
    flat = copy.deepcopy(BASE)
    flat["rigid_body"]["inertia"] = [0.2, 0.01, 0, 0.01, 0.2, 0, 0, 0, 0.3]
    rows = copy.deepcopy(BASE)
    rows["rigid_body"]["inertia"] = [[0.2, 0.01, 0], [0.01, 0.2, 0], [0, 0, 0.3]]
    a, b = vehicle_from_dict(flat), vehicle_from_dict(rows)
    assert np.array_equal(np.asarray(a.params.inertia), np.asarray(b.params.inertia))
    bad = copy.deepcopy(BASE)
    bad["rigid_body"]["inertia"] = [[0.2, 0.3, 0], [0.3, 0.2, 0], [0, 0, 0.3]]
    with pytest.raises(VehicleFileError, match="positive definite"):
        vehicle_from_dict(bad)


def test_limits_beyond_what_the_thruster_model_gives_are_named(tmp_path):
    """A T200 fitted at 12 V (≈ 37 N) kept the 16 V preset's 51.5 N limits: the envelope flew
    ideal thrusters at the limits and "confirmed" the 16 V speed.  The file is named with the
    model's thrust at full command and the limits to set; limits within it stay silent."""
    import warnings

    import yaml

    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.presets import preset_chain

    save_chain(preset_chain("t200", 12.0), tmp_path / "t200_12V.yaml")
    raw = copy.deepcopy(BASE)
    for t in raw["thrusters"]:
        t["model"] = "t200_12V.yaml"
        t["limits"] = [-39.913, 51.485]
    p = tmp_path / "bot.yaml"
    p.write_text(yaml.safe_dump(raw))
    with pytest.warns(VehicleFileWarning, match=r"thrusters A, B, C: limits \[-39\.913, 51\.485\] N "
                                                r"exceed what their model 't200_12V\.yaml' gives at "
                                                r"full command \(its ESC at 12 V\), \[-28\.\d+, "
                                                r"36\.\d+\] N.*set limits: \[-28"):
        load_vehicle(p)
    for t in raw["thrusters"]:
        t["limits"] = [-28.0, 36.0]
    p.write_text(yaml.safe_dump(raw))
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        load_vehicle(p)


@pytest.mark.parametrize("dofs, expected", [
    (["surge", "heave", "surge"],
     "bot.yaml: allocation.dofs[2]: surge is named twice (also allocation.dofs[0])"),
    (["surge", "sway", "heave"],  # A and B push along x, C along z: nothing pushes sideways
     "bot.yaml: allocation.dofs[1]: sway: no thruster gives any force in sway"),
    (["surge", "heave", "yaw", "pitch"],
     "bot.yaml: allocation.dofs[3]: pitch: no thruster gives any moment in pitch"),
])
def test_allocation_dofs_the_thrusters_cannot_hold_are_refused(dofs, expected):
    """A DOF named twice, or one no thruster acts on, was accepted: the allocation then met the
    request in the least-squares sense (or kept one column of a repeated row) without a word."""
    msg = errors_of(lambda r: r["allocation"].update(dofs=dofs))
    assert expected in msg and "allocation.dofs" in msg


def test_allocation_dofs_dependent_on_another_are_refused_with_the_ratio():
    """The BlueROV2's horizontal thrusters sit 2 cm below the origin and its vertical pair at
    x = 0: its pitch moment is always 0.02 m × the surge force, so it cannot hold both."""
    raw = yaml.safe_load(open(load_vehicle("bluerov2").path))
    raw["allocation"]["dofs"] = ["surge", "sway", "heave", "roll", "pitch", "yaw"]
    with pytest.raises(VehicleFileError) as e:
        vehicle_from_dict(raw, where="b.yaml")
    assert str(e.value) == ("b.yaml: allocation.dofs[4]: pitch: the thrusters cannot hold it "
                            "independently of surge: every thrust gives pitch = 0.02 × surge (its "
                            "row of the thrust configuration matrix B is a combination of theirs), "
                            "so the allocation cannot set them all; leave pitch (or one of those) "
                            "out of allocation.dofs")
    from uuvid.vehicle.allocation import Allocator

    with pytest.raises(ValueError, match="named twice"):  # the library's own entry, too
        Allocator(load_vehicle("bluerov2").B, ("surge", "heave", 0))


def test_a_current_in_the_vehicle_file_is_said_naming_where_a_current_is_given():
    """environment.current was accepted and ignored by missions, hold and the envelope (each
    takes the current its run is given), so a vehicle 'in 0.5 m/s' flew in still water unsaid.
    vehicle_rhs still reads it (the envelope's confirmation, synthetic dives): said, not refused.
    Zero is silent."""
    from uuvid.vehicle.definition import VehicleFileWarning

    raw = copy.deepcopy(BASE)
    raw["environment"] = {"current": [0.5, 0, 0]}
    with pytest.warns(VehicleFileWarning) as rec:
        v = vehicle_from_dict(raw, where="bot.yaml")
    msg = next(str(w.message) for w in rec if "environment.current" in str(w.message))
    assert msg.startswith("bot.yaml: environment.current: [0.5, 0.0, 0.0] m/s is read only where")
    for place in ("a scenario's current:", "uuvid simulate mission --current N,E,D",
                  "uuvid vehicle hold --current", "setup_mission"):
        assert place in msg
    assert np.all(v.params.current == [0.5, 0, 0])
    raw["environment"] = {"current": [0, 0, 0]}
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        assert np.all(vehicle_from_dict(raw).params.current == 0)


def test_a_direction_no_thrust_gives_is_named_with_the_one_way_thrusters():
    """Both vertical thrusters limited to [0, max] (pushing down only): heave cannot be pushed
    up at all; said on load, naming the DOF, the direction and the thrusters."""
    raw = yaml.safe_load(open(load_vehicle("bluerov2").path))
    for t in raw["thrusters"][4:]:
        t["limits"] = [0.0, 51.485]
    with pytest.warns(VehicleFileWarning) as rec:
        vehicle_from_dict(raw, where="noup.yaml", base_dir=load_vehicle("bluerov2").path.parent)
    said = [str(w.message) for w in rec if "allocation.dofs" in str(w.message)]
    assert len(said) == 1
    assert said[0].startswith("noup.yaml: allocation.dofs: heave climbing: no thrust within the "
                              "limits gives it (thrusters limited to one direction: "
                              "T5_vertical_right [0, 51.48] N, T6_vertical_left [0, 51.48] N), "
                              "only heave diving (up to 103 N)")


def test_a_thruster_model_that_is_a_vehicle_file_is_named_as_such(tmp_path):
    """A thruster's ``model:`` naming a vehicle file failed the first mission with the model
    schema's key errors ('blocks: missing parameter', 'rigid_body: unknown key', …)."""
    from uuvid.thruster.modelfile import NotAModelFileError

    other = tmp_path / "other.yaml"
    other.write_text(yaml.safe_dump(BASE))
    raw = copy.deepcopy(BASE)
    raw["thrusters"][0]["model"] = "other.yaml"
    p = tmp_path / "bot.yaml"
    # said when the vehicle is loaded (info and envelopes run on its limits), not only at a mission
    with pytest.warns(VehicleFileWarning, match="thrusters A: model 'other.yaml': not a thruster "
                      "model file: it looks like a vehicle file .* no simulation can fly"):
        v = vehicle_from_dict(raw, where=str(p), base_dir=tmp_path, path=p)
    with pytest.raises(NotAModelFileError) as e:
        v.thruster_chain(0)
    said = str(e.value)
    assert said.startswith(f"testbot: thruster A refers to model 'other.yaml': {other}: not a "
                           "thruster model file: it looks like a vehicle file (it has rigid_body, "
                           "hydrodynamics, thrusters); a thruster model file has blocks")
    assert "unknown key" not in said


def test_a_thruster_model_file_given_as_the_vehicle_is_named_as_such(tmp_path):
    """A thruster model file given as a vehicle listed the vehicle schema's key errors."""
    thr = tmp_path / "thr.yaml"
    thr.write_text("name: q\ninput: voltage\nblocks:\n  - {type: quadratic, k_pos: 1.0}\n")
    with pytest.raises(VehicleFileError) as e:
        load_vehicle(str(thr))
    said = str(e.value)
    assert said.startswith(f"{thr}: not a vehicle file: it looks like a thruster model file (it "
                           "has blocks); a vehicle file has name, source, rigid_body, hydrodynamics")
    assert "unknown key" not in said and "missing" not in said


def test_two_thrusters_at_the_same_place_pushing_the_same_way_are_said():
    """A copied thruster line (T6 at T5's position and axis) loaded without a word; the mission
    then tilted. Said on load; a pair at one place pushing opposite ways is not said."""
    from uuvid.vehicle.definition import preset_path

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    t5, t6 = raw["thrusters"][4], raw["thrusters"][5]
    t6["position"], t6["axis"] = list(t5["position"]), list(t5["axis"])
    with pytest.warns(VehicleFileWarning, match=f"thrusters {t5['name']} and {t6['name']} sit at the "
                      "same position .* pushing the same way"):
        vehicle_from_dict(copy.deepcopy(raw), where="dup.yaml")
    t6["axis"] = [-a for a in t5["axis"]]
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        vehicle_from_dict(copy.deepcopy(raw), where="pair.yaml")
        vehicle_from_dict(yaml.safe_load(preset_path("bluerov2-heavy").read_text()), where="h.yaml")


def test_inertias_a_body_can_have_are_not_warned_of():
    """A thin disc (I_zz = I_xx + I_yy, the limit) and the BASE vehicle load without a word."""
    for inertia in ([0.1, 0.1, 0.2], [0.2, 0.2, 0.3], [[0.2, 0.01, 0], [0.01, 0.2, 0], [0, 0, 0.3]]):
        raw = copy.deepcopy(BASE)
        raw["rigid_body"]["inertia"] = inertia
        with warnings.catch_warnings():
            warnings.simplefilter("error", VehicleFileWarning)
            vehicle_from_dict(raw, where="bot.yaml")


@pytest.mark.parametrize("axis, said", [
    ([0.5, 0.0, 0.05], r"thrusters\[0\]\.axis \(A\): \[0\.5, 0\.0, 0\.05\] has length 0\.5025, not 1 "
                       r"\(beyond 1%\), and is used normalised as \[0\.995, 0\.0, 0\.0995\]"),
    ([0.6, 0.7, 0.0], r"thrusters\[0\]\.axis \(A\): \[0\.6, 0\.7, 0\.0\] has length 0\.922, not 1 .*"
                      r"used normalised as \[0\.6508, 0\.7593, 0\.0\]"),
    ([1.0, 0.0, 0.2], r"length 1\.02, not 1"),
])
def test_an_axis_that_is_not_unit_length_nor_a_plain_direction_is_said(tmp_path, axis, said):
    """`axis: [0.5, 0, 0.05]` (a unit vector with a typo?) was normalised in silence; the warning
    names the key, the length and the axis used — on a cached load too."""
    import yaml

    raw = copy.deepcopy(BASE)
    raw["thrusters"][0]["axis"] = axis
    with pytest.warns(VehicleFileWarning, match=said):
        v = vehicle_from_dict(raw, where="bot.yaml")
    np.testing.assert_allclose(v.layout[0].axis, np.asarray(axis) / np.linalg.norm(axis))
    p = tmp_path / "bot.yaml"
    p.write_text(yaml.safe_dump(raw))
    for _ in range(2):  # the second load is the cached one
        with pytest.warns(VehicleFileWarning, match=said):
            load_vehicle(p)


@pytest.mark.parametrize("axis", [[1, 1, 0], [2, 0, 0], [1, -2, 0], [0.5, -0.5, 0.0],
                                  [0.7, 0.7, 0.0], [0.7071, 0.7071, 0.0], [0.6, 0.8, 0.0],
                                  [0.71, 0.71, 0.0], [1.0, 0.0, 0.1], [0.87, 0.5, 0.0]])
def test_a_plain_direction_or_a_rounded_unit_axis_loads_in_silence(axis):
    """Integers ([1, 1, 0] for 45°, [2, 0, 0]), equal components (normalising cannot turn them), a unit
    vector to two decimals (within 1 %), and rpy_deg (thruster C of BASE) say nothing."""
    import warnings

    raw = copy.deepcopy(BASE)
    raw["thrusters"][0]["axis"] = axis
    raw["thrusters"][1]["rpy_deg"] = [0, -30, 45]
    del raw["thrusters"][1]["axis"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        v = vehicle_from_dict(raw, where="bot.yaml")
    assert v.file_axes[1] is None and v.file_axes[2] is None


def test_B_and_limits_are_read_only():
    """``veh.B`` and ``veh.layout.limits`` are computed at every access: a write into one was lost
    without a word (the next access gave the old numbers); it now raises."""
    v = load_vehicle("bluerov2")
    with pytest.raises(ValueError, match="read-only"):
        v.B[0, 0] = 5.0
    with pytest.raises(ValueError, match="read-only"):
        v.layout.limits[0, 1] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        v.layout.B[:] = 0.0
    # what a caller does with them still works: a copy to change, the allocator's own arrays
    B = np.array(v.B)
    B[0, 0] = 5.0
    al = v.allocator()
    assert al.B.flags.writeable and al.limits.flags.writeable
