"""Vehicle files whose keys disagree with one another or carry a unit slip a new user made: a
``one_dof`` key naming another DOF than its ``dof``, a battery capacity in mAh, a state-of-charge
axis in %, a mass edited without its weight."""

import copy
import os
import subprocess
import sys
import warnings

import pytest
import yaml

from uuvid.core.units import G0
from uuvid.vehicle import VehicleFileError, VehicleFileWarning, load_vehicle, vehicle_from_dict
from uuvid.vehicle.definition import PRESET_DIR, preset_path


def preset_raw(name: str = "bluerov2") -> dict:
    return yaml.safe_load(preset_path(name).read_text())


def build(raw: dict):
    """Load ``raw`` as the preset folder's file would be (its thruster models resolve there)."""
    return vehicle_from_dict(raw, where="bot.yaml", base_dir=PRESET_DIR)


def silent(raw: dict):
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)
        return build(raw)


HEAVE = {"dof": "heave", "mass": 29.4, "linear": 8.7, "quadratic": 53.3, "disturbance": -2.2}
YAW = {"dof": "yaw", "mass": 0.3, "linear": 0.0, "quadratic": 2.5, "disturbance": 0.014}


# ------------------------------------------------------------------ one_dof key vs its dof
@pytest.mark.parametrize("key", ["heave", "heave_down", "heave-slow"])
def test_a_one_dof_key_naming_another_dof_than_its_dof_is_refused(key):
    """Was: ``one_dof.heave.dof: yaw`` loaded, and the replay flew the heave block (29.4 kg) as
    the yaw model, reported as ``model: one_dof.heave``."""
    raw = preset_raw()
    raw["one_dof"] = {key: {**HEAVE, "dof": "yaw"}, "yaw": YAW}
    with pytest.raises(VehicleFileError) as e:
        build(raw)
    msg = str(e.value)
    assert f"bot.yaml: one_dof.{key}.dof" in msg
    assert "'yaw'" in msg and f"'{key}'" in msg and "set dof: heave" in msg


@pytest.mark.parametrize("key", ["heave", "heave_down", "fast_descent", "yawing"])
def test_one_dof_keys_that_agree_or_name_no_dof_load(key):
    raw = preset_raw()
    raw["one_dof"] = {key: HEAVE}
    assert silent(raw).one_dof[key].dof == "heave"


def test_romeo_one_dof_keys_agree_with_their_dofs():
    assert {m.dof for m in load_vehicle("romeo").one_dof.values()} >= {"surge", "heave"}


def test_vehicle_info_lists_the_one_dof_models_with_units():
    raw = preset_raw()
    raw["one_dof"] = {"heave": HEAVE, "yaw": YAW}
    v = silent(raw)
    text = v.summary()
    assert "one_dof (2 one-DOF models" in text
    assert "heave: heave, mass 29.4 kg, linear 8.7 N·s/m, quadratic 53.3 N·s²/m², disturbance " \
           "-2.2 N" in text
    assert "yaw: yaw, inertia 0.3 kg·m², linear 0 N·m·s/rad, quadratic 2.5 N·m·s²/rad²" in text
    d = v.to_dict()["one_dof"]
    assert d["heave"]["mass_kg"] == 29.4 and d["yaw"]["inertia_kg_m2"] == 0.3
    assert d["yaw"]["quadratic_N_m_s2_per_rad2"] == 2.5
    assert "one_dof" not in silent(preset_raw()).summary()


@pytest.mark.slow
def test_the_command_line_refuses_the_mismatched_file_and_info_shows_one_dof(tmp_path):
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    raw = preset_raw()
    raw["one_dof"] = {"heave": HEAVE, "yaw": YAW}
    ok, bad = tmp_path / "ok.yaml", tmp_path / "bad.yaml"
    ok.write_text(yaml.safe_dump(raw))
    for p in PRESET_DIR.iterdir():  # the thruster model files the preset names, beside it
        if p.is_dir():
            (tmp_path / p.name).symlink_to(p)
    raw["one_dof"]["heave"]["dof"] = "yaw"
    bad.write_text(yaml.safe_dump(raw))
    run = [sys.executable, "-m", "uuvid.cli.app", "vehicle", "info"]
    r = subprocess.run(run + [str(ok)], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "heave: heave, mass 29.4 kg" in r.stdout and "yaw: yaw, inertia 0.3 kg·m²" in r.stdout
    r = subprocess.run(run + [str(bad)], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode != 0
    assert "one_dof.heave.dof: 'yaw' disagrees with its key 'heave'" in r.stderr + r.stdout


# ------------------------------------------------------------------ battery units
def test_a_capacity_in_mah_is_warned_of_with_the_likely_unit():
    """Was: 18000 (mAh in the Ah field) gave a BlueROV2 an endurance of 413 days, silently."""
    raw = preset_raw()
    raw["battery"]["capacity_ah"] = 18000
    with pytest.warns(VehicleFileWarning, match=r"battery\.capacity_ah: 18000 Ah") as rec:
        build(raw)
    msg = next(str(r.message) for r in rec if "capacity_ah" in str(r.message))
    assert "is it in mAh? (18 Ah)" in msg and "11.5 kg" in msg


def test_a_capacity_that_is_large_but_not_mah_is_said_without_the_mah_guess():
    raw = preset_raw()
    raw["battery"]["capacity_ah"] = 18_000_000
    with pytest.warns(VehicleFileWarning, match="expected amp-hours"):
        build(raw)


def test_a_plausible_battery_loads_in_silence():
    raw = preset_raw()
    raw["battery"]["capacity_ah"] = 300  # 5 kWh in an 11.5 kg vehicle: 438 Wh/kg, under the bound
    silent(raw)


def test_a_state_of_charge_axis_in_percent_is_refused():
    """Was: 0…100 passed "from <= 0 to >= 1", and --battery 0.8 then meant 0.8 %."""
    raw = preset_raw()
    raw["battery"]["ocv_soc"] = [100 * s for s in raw["battery"]["ocv_soc"]]
    with pytest.raises(VehicleFileError) as e:
        build(raw)
    msg = str(e.value)
    assert "bot.yaml: battery: ocv_soc ends at 100" in msg
    assert "state of charge is a fraction 0…1; is it in %?" in msg


# ------------------------------------------------------------------ mass vs weight
def test_a_mass_edited_without_its_weight_is_warned_of_naming_both():
    """Was: mass 11.5 → 15 kg left W = 112.8 N (23 % light of m·g) in silence."""
    raw = preset_raw()
    raw["rigid_body"]["mass"] = 15.0
    with pytest.warns(VehicleFileWarning, match=r"rigid_body\.weight 112\.8 N differs by -23\.3 %"
                      r" from rigid_body\.mass 15 kg"):
        build(raw)


def test_a_weight_within_one_percent_or_left_out_is_not_warned_of():
    silent(preset_raw())  # 112.8 N for 11.5 kg: 0.02 % from m·g
    raw = preset_raw()
    raw["rigid_body"]["mass"] = 15.0
    del raw["rigid_body"]["weight"]  # only the mass: W = m·g
    raw["rigid_body"]["buoyancy"] = 15.0 * G0
    assert silent(raw).params.weight == pytest.approx(15.0 * G0)
    raw["rigid_body"].update(weight=15.0 * 9.79, gravity=9.79)  # the file's own g
    silent(raw)


def test_the_weight_warning_is_repeated_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    raw = copy.deepcopy(preset_raw())
    raw["rigid_body"]["mass"] = 15.0
    raw["battery"]["capacity_ah"] = 18000
    for p in PRESET_DIR.iterdir():
        if p.is_dir():
            (tmp_path / p.name).symlink_to(p)
    f = tmp_path / "edited.yaml"
    f.write_text(yaml.safe_dump(raw))
    for _ in range(2):  # parsed, then read back from the disk cache
        with pytest.warns(VehicleFileWarning) as rec:
            load_vehicle(f)
        msgs = " ".join(str(r.message) for r in rec)
        assert "rigid_body.weight 112.8 N differs" in msgs and "is it in mAh?" in msgs
