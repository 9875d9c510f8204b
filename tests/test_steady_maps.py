"""Steady maps: closed form for static + first-order chains, cached sweeps for the others.

The closed form must be what the chain reaches at rest, so every case is checked against the
simulated sweep (which converges to ``rtol = 1e-9`` of the output scale)."""

import math
import warnings

import numpy as np
import pytest

from uuvid.core import cache as disk
from uuvid.simulate.vehicle_sim import _command_range
from uuvid.thruster.blocks import (
    ESC,
    BessaDynamics,
    DCMotor,
    DeadZoneMap,
    Driver,
    FirstOrder,
    FirstOrderMotor,
    LoadCell,
    PolynomialMap,
    QuadraticMap,
    TableMap,
    Yoerger,
    ZeroOrder,
)
from uuvid.thruster.chain import ThrusterChain, steady_map_agreement
from uuvid.thruster.presets import PRESETS, laidani_chain, t200_chain

SWEEP_TOL = 1e-8  # relative to the output scale; the sweep itself stops at 1e-9


def _levels(chain, n=61):
    lo, hi, _ = _command_range(chain)
    return np.linspace(lo, hi, n)


def _assert_matches_sweep(chain, u):
    assert chain.steady_thrust(u).shape == u.shape
    agreement = steady_map_agreement(chain, u)
    assert agreement["closed_form"]
    assert agreement["max_relative_difference"] <= SWEEP_TOL


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(n for n in PRESETS if PRESETS[n]().has_closed_form_steady))
def test_every_qualifying_preset_matches_its_sweep(name):
    chain = PRESETS[name]()
    _assert_matches_sweep(chain, _levels(chain))


def _vehicle_chains():
    from uuvid.vehicle.definition import list_presets, load_vehicle

    out = {}
    for name in list_presets():
        v = load_vehicle(name)
        for i in range(len(v.layout)):
            c = v.thruster_chain(i)
            out.setdefault(c.name, c)
    return out


@pytest.mark.slow
def test_every_vehicle_preset_thruster_that_qualifies_matches_its_sweep():
    chains = _vehicle_chains()
    qualifying = [c for c in chains.values() if c.has_closed_form_steady]
    assert {"t200", "romeo-cv"} <= {c.name for c in qualifying}
    for c in qualifying:
        _assert_matches_sweep(c, _levels(c, 41))


def test_which_presets_have_a_closed_form():
    # a DC motor / tunnel thruster (Coulomb friction, water column) has none: it is swept
    assert PRESETS["t200"]().has_closed_form_steady
    assert PRESETS["laidani-a2212"]().has_closed_form_steady
    assert not PRESETS["auv2-tunnel-thruster"]().has_closed_form_steady
    assert not PRESETS["auv2-tunnel"]().has_closed_form_steady


def _esc(**kw):
    base = dict(neutral=1500.0, deadband=80.0, full_low=1100.0, full_high=1900.0, supply_voltage=16.0)
    base.update(kw)
    return ESC.from_range(**base)


CHAINS = {
    # dead zone + saturation in the ESC (levels run past the saturation), per-direction quadratic
    "esc-deadzone-saturation": ThrusterChain(
        (_esc(), FirstOrderMotor(gain=20.0, time_constant=0.05), QuadraticMap(k_pos=2e-4, k_neg=1.5e-4)),
        name="a"),
    # asymmetric ESC with duty curvature, per-direction polynomial
    "esc-curvature-polynomial": ThrusterChain(
        (ESC(a_fwd=0.03, b_fwd=-45.5, a_rev=0.025, b_rev=-37.0, neutral=1500.0, deadzone_low=1480.0,
             deadzone_high=1515.0, saturation_low=1100.0, saturation_high=1900.0, supply_voltage=14.8,
             curvature_fwd=0.3, curvature_rev=-0.2),
         FirstOrderMotor(gain=131.3, time_constant=0.01),
         PolynomialMap(forward=(1e-8, 2e-5, 0.01, 0.0), reverse=(5e-9, 1e-5, 0.006, 0.0))),
        name="b"),
    # UUV Simulator style: command → first-order → Bessa dead-zone conversion
    "first-order-deadzone-map": ThrusterChain(
        (FirstOrder(time_constant=0.2), DeadZoneMap(rotor_constant_l=0.8, rotor_constant_r=1.1,
                                                    delta_l=-0.3, delta_r=0.2)), name="c"),
    "zero-order-table": ThrusterChain(
        (ZeroOrder(), TableMap(input_values=(-1.0, -0.2, 0.0, 0.3, 1.0),
                               output_values=(-40.0, -3.0, 0.0, 5.0, 50.0))), name="d"),
    # a first-order thrust lag after the map, and the rig's load cell (unit DC gain)
    "thrust-lag-and-load-cell": ThrusterChain(
        (_esc(), FirstOrderMotor(gain=20.0, time_constant=0.05), QuadraticMap(k_pos=2e-4, k_neg=1.5e-4),
         FirstOrder(time_constant=0.3), LoadCell()), name="e"),
    "yoerger": ThrusterChain((Yoerger(alpha=5.0, beta=30.0), QuadraticMap(k_pos=0.01, k_neg=0.008)),
                             name="f"),
    "bessa": ThrusterChain((BessaDynamics(jmsp=0.02, kv1=0.3, kv2=0.01, kt=1.5, rm=0.8),
                            QuadraticMap(k_pos=0.01)), name="g"),
    "bessa-no-quadratic-drag": ThrusterChain((BessaDynamics(jmsp=0.02, kv1=0.3, kv2=0.0),), name="h"),
    "static-only": ThrusterChain((_esc(), QuadraticMap(k_pos=0.2, k_neg=0.15)), name="i"),
}


@pytest.mark.slow
@pytest.mark.parametrize("key", sorted(CHAINS))
def test_closed_form_matches_the_sweep(key):
    chain = CHAINS[key]
    assert chain.has_closed_form_steady
    lo, hi, _ = _command_range(chain)
    span = hi - lo
    u = np.linspace(lo - 0.1 * span, hi + 0.1 * span, 73)  # past the saturation at both ends
    _assert_matches_sweep(chain, u)


def test_dead_band_driver_matches_the_sweep():
    """The identification's driver (ESC kernel: offset, dead band per direction, output limit)."""
    chain = ThrusterChain(
        (Driver(deadband_fwd=30.0, deadband_rev=20.0, offset=1500.0, gain_fwd=0.04, gain_rev=0.035,
                limit=14.0), FirstOrderMotor(gain=20.0, time_constant=0.05),
         QuadraticMap(k_pos=2e-4, k_neg=1.5e-4)), name="driver")
    u = np.linspace(1000.0, 2000.0, 73)  # through both dead-band edges and the output limit
    f = chain.steady_thrust(u)
    assert np.any(f == 0.0) and f.max() > 0 > f.min()
    _assert_matches_sweep(chain, u)


@pytest.mark.filterwarnings("ignore:t200_chain")  # 10 and 20 V: outside the T200 sheets (warned)
@pytest.mark.parametrize("supply", [10.0, 14.8, 16.0, 20.0])
def test_supply_voltage_moves_the_closed_form_as_the_sweep(supply):
    for chain in (laidani_chain(supply_voltage=supply), t200_chain(supply_voltage=supply)):
        _assert_matches_sweep(chain, _levels(chain, 41))


def test_closed_form_keeps_dead_zone_and_neutral_exact():
    chain = t200_chain()
    esc = chain.blocks[0]
    u = np.array([esc.neutral, esc.deadzone_low, esc.deadzone_high, esc.saturation_high + 100.0])
    f = chain.steady_thrust(u)
    assert f[0] == 0.0 and f[1] == 0.0 and f[2] == 0.0
    assert f[3] == chain.steady_thrust([esc.saturation_high])[0]  # saturated: held


def test_closed_form_runs_no_simulation(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("a closed-form chain was simulated")

    monkeypatch.setattr(ThrusterChain, "sweep", boom)
    assert np.all(np.isfinite(t200_chain().steady_thrust(np.linspace(1100, 1900, 401))))


# ------------------------------------------------------------------------------ disk cache
def _motor_chain(coulomb=2e-3, kq=2e-7):
    """Voltage → DC motor with Coulomb friction and a propeller: no closed form."""
    return ThrusterChain((DCMotor(coulomb_torque=coulomb, torque_coefficient=kq),
                          QuadraticMap(k_pos=1e-5)), input_kind="voltage", name="motor")


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "kc"))
    monkeypatch.setattr(disk, "_WARNED", set())
    return tmp_path / "kc" / "steady_maps"


LEVELS = np.linspace(-12.0, 12.0, 9)


def test_swept_table_is_cached_and_reused(cache_dir, monkeypatch):
    chain = _motor_chain()
    assert not chain.has_closed_form_steady
    first = chain.steady_thrust(LEVELS)
    files = list(cache_dir.glob("*.npy"))
    assert len(files) == 1
    np.testing.assert_array_equal(first, chain.sweep(LEVELS).final)

    def boom(*a, **k):
        raise AssertionError("swept again despite the cache")

    monkeypatch.setattr(ThrusterChain, "sweep", boom)
    np.testing.assert_array_equal(chain.steady_thrust(LEVELS), first)
    # another chain or other levels are other entries (computed, not read)
    with pytest.raises(AssertionError, match="swept again"):
        _motor_chain(coulomb=3e-3).steady_thrust(LEVELS)
    with pytest.raises(AssertionError, match="swept again"):
        chain.steady_thrust(LEVELS[:-1])
    with pytest.raises(AssertionError, match="swept again"):
        chain.steady_thrust(LEVELS, cache=False)


def test_corrupt_entry_is_recomputed_with_one_warning(cache_dir):
    chain = _motor_chain()
    good = chain.steady_thrust(LEVELS)
    (entry,) = cache_dir.glob("*.npy")
    entry.write_bytes(b"not an npy file")
    with pytest.warns(disk.CacheWarning, match="unreadable cache entry"):
        again = chain.steady_thrust(LEVELS)
    np.testing.assert_array_equal(again, good)
    np.testing.assert_array_equal(np.load(entry), good)  # rewritten
    np.save(entry, np.full(3, math.nan))  # wrong shape and values
    with pytest.warns(disk.CacheWarning, match="corrupt cache entry"):
        np.testing.assert_array_equal(chain.steady_thrust(LEVELS), good)


def test_unwritable_cache_warns_once_and_still_answers(tmp_path, monkeypatch):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder should be")
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(blocker))
    monkeypatch.setattr(disk, "_WARNED", set())
    chain = _motor_chain()
    with pytest.warns(disk.CacheWarning, match="unwritable cache"):
        a = chain.steady_thrust(LEVELS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the second failure stays quiet
        b = _motor_chain(coulomb=1e-3).steady_thrust(LEVELS)
    np.testing.assert_array_equal(a, chain.sweep(LEVELS).final)
    assert np.all(np.isfinite(b))


@pytest.mark.slow
def test_inverse_table_is_unchanged_by_the_closed_form(monkeypatch):
    """vehicle_sim's inverse thrust table from the closed form equals the one from the sweep."""
    from uuvid.simulate import vehicle_sim

    chain = t200_chain()
    vehicle_sim._inverse_table.cache_clear()
    t_closed, c_closed, z_closed = vehicle_sim._inverse_table(chain, 401)
    monkeypatch.setattr(ThrusterChain, "steady_thrust",
                        lambda self, u, cache=True: self.sweep(np.atleast_1d(u)).final)
    vehicle_sim._inverse_table.cache_clear()
    t_swept, c_swept, z_swept = vehicle_sim._inverse_table(chain, 401)
    vehicle_sim._inverse_table.cache_clear()
    scale = np.max(np.abs(t_swept))
    np.testing.assert_allclose(t_closed, t_swept, rtol=0, atol=SWEEP_TOL * scale)
    np.testing.assert_allclose(c_closed, c_swept, rtol=0, atol=1e-6 * (1900 - 1100))
    assert z_closed == z_swept


@pytest.mark.slow
def test_a_map_used_beyond_its_range_is_named():
    """Laidani's 5th-order polynomial of propeller speed turns down past the fastest speed of its
    bench data; at 14 V full command reaches it, and predict says so (at 12 V it does not)."""
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app
    from uuvid.thruster.chain import monotonicity_warnings

    x = np.linspace(-1.0, 1.0, 21)
    assert monotonicity_warnings(x, x**3) == []
    w = monotonicity_warnings(x, np.sin(2.5 * x))  # peaks at 0.63, falls after
    assert len(w) == 2 and w[0].startswith("forward") and w[1].startswith("reverse")
    r = CliRunner().invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1500:1900:50",
                                 "--supply-voltage", "12", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["warnings"] == []
    r = CliRunner().invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1500:1900:50",
                                 "--supply-voltage", "14", "--json"])
    assert r.exit_code == 0 and "beyond the range" in json.loads(r.stdout)["warnings"][0]


def test_swept_table_cache_is_keyed_on_the_code_version(cache_dir, monkeypatch):
    """Another code version (package version + source hash) is another entry."""
    from uuvid.thruster import chain as chain_mod

    chain = _motor_chain()
    chain.steady_thrust(LEVELS)
    monkeypatch.setattr(chain_mod, "_CODE_DIGEST", None)
    monkeypatch.setattr(disk, "code_version", lambda: "0.0.0+another-tree")

    def boom(*a, **k):
        raise AssertionError("swept again")

    monkeypatch.setattr(ThrusterChain, "sweep", boom)
    with pytest.raises(AssertionError, match="swept again"):
        chain.steady_thrust(LEVELS)


def test_source_digest_sees_every_source_and_data_file(tmp_path):
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    (tmp_path / "pkg" / "sub" / "b.yaml").write_text("k: 1\n")
    first = disk.source_digest(tmp_path / "pkg")
    (tmp_path / "pkg" / "sub" / "b.yaml").write_text("k: 2\n")
    second = disk.source_digest(tmp_path / "pkg")
    (tmp_path / "pkg" / "sub" / "b.yaml").rename(tmp_path / "pkg" / "b.yaml")
    assert len({first, second, disk.source_digest(tmp_path / "pkg")}) == 3
    assert disk.code_version().startswith(__import__("uuvid").__version__ + "+")


def test_numba_caches_of_uuvid_are_keyed_on_all_its_compiled_code(monkeypatch):
    """numba stamps a cached function by its own file only, so the mission loop kept running an
    edited controller's old code (control.dp_control, called from vehicle_sim): uuvid's functions
    carry a digest of every module that uses numba in their stamp as well."""
    import uuvid.core.numba_cache as nc
    from uuvid.simulate.control.pid import dp_control

    loc = dp_control._cache._impl._locator
    assert type(loc).__name__.startswith("Uuvid")
    stamp = loc.get_source_stamp()
    assert stamp[1] == nc.numba_sources_digest()
    monkeypatch.setattr(nc, "numba_sources_digest", lambda: "another-tree")
    assert loc.get_source_stamp() != stamp  # an edit anywhere in the compiled code: recompile
    assert not nc._ours(np.__file__)  # other packages keep numba's own locators


def test_a_cache_folder_is_checked_writable_once_per_process(monkeypatch):
    """numba writes a temporary file to check the cache folder for every ``cache=True`` function
    it decorates; uuvid's locators check a folder once (≈ 130 functions on a mission's path)."""
    import tempfile

    from numba import njit

    import uuvid.core.numba_cache as nc
    from uuvid.simulate.control.pid import dp_control

    folder = dp_control._cache._impl._locator.get_cache_path()
    assert folder in nc._WRITABLE

    def no_more(*a, **k):
        raise AssertionError("the folder was checked again")

    monkeypatch.setattr(tempfile, "TemporaryFile", no_more)
    again = njit(cache=True)(dp_control.py_func)  # a new dispatcher of the same file
    assert again._cache._impl._locator.get_cache_path() == folder
