"""Mission loops compiled around a controller or a disturbance are cached on disk (issue 20
item 2): a later process loads the loop instead of compiling it (~10–40 s), and an edit to the
controller's own file compiles a new one instead of running stale machine code."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from uuvid.simulate.disturbances import no_disturbance
from uuvid.simulate.vehicle_sim import _disk_cached, _fly_loop, _importable, fly_quad

CTRL = """
from numba import njit


@njit(cache=False)
def my_ctrl(t, eta, nu, rp, rv, ryaw, rrate, params, state, dt, out):
    for j in range(6):
        out[j] = {gain} * (rp[j] - eta[j] if j < 3 else 0.0)
"""


def _module(tmp_path, monkeypatch, gain: float, name: str = "user_ctrl_mod"):
    d = tmp_path / "src"
    d.mkdir(exist_ok=True)
    (d / f"{name}.py").write_text(CTRL.format(gain=gain))
    monkeypatch.syspath_prepend(str(d))
    sys.modules.pop(name, None)
    import importlib

    return importlib.import_module(name)


def test_a_controller_in_a_file_gets_a_module_keyed_on_that_files_bytes(tmp_path, monkeypatch):
    """fly_quad calls its controller directly: its module imports the controller by name and is
    keyed on the controller file's bytes."""
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    m = _module(tmp_path, monkeypatch, 1.0)
    assert _importable(m.my_ctrl)[:2] == ("user_ctrl_mod", "my_ctrl")
    _disk_cached.cache_clear()
    loop = _disk_cached(fly_quad, m.my_ctrl)
    assert loop is not None
    made = sorted((tmp_path / "cache" / "mission_loops").glob("_uuvid_mission_loop_*.py"))
    assert len(made) == 1
    text = made[0].read_text()
    assert "from user_ctrl_mod import my_ctrl as _CTRL" in text and "_DIST" not in text
    assert "def fly_quad(" in text and "@njit" not in text.split("def fly_quad(")[0]
    # the same function again: the same module
    _disk_cached.cache_clear()
    assert _disk_cached(fly_quad, m.my_ctrl) is not None
    assert len(list((tmp_path / "cache" / "mission_loops").glob("*.py"))) == 1
    # the controller's file edited: a new module, the old one is never loaded for it
    m2 = _module(tmp_path, monkeypatch, 2.0)
    _disk_cached.cache_clear()
    assert _disk_cached(fly_quad, m2.my_ctrl) is not None
    assert len(list((tmp_path / "cache" / "mission_loops").glob("*.py"))) == 2
    _disk_cached.cache_clear()


def test_the_general_loop_takes_controller_and_disturbance_as_arguments(tmp_path, monkeypatch):
    """_fly_loop's module imports no controller: the controller and disturbance are its first
    two arguments (function pointers), so one module serves every controller."""
    from uuvid.simulate.vehicle_sim import _pointer_dispatcher, loop_config

    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    _disk_cached.cache_clear()
    _pointer_dispatcher.cache_clear()
    cfg = loop_config(np.array([0, 0, 1, 1]), np.array([False, True, False]), np.zeros(0))
    disp = _pointer_dispatcher(cfg)
    made = list((tmp_path / "cache" / "mission_loops").glob("_uuvid_mission_loop_*.py"))
    assert len(made) == 1 and disp.py_func.__module__ == made[0].stem
    text = made[0].read_text()
    assert "def _fly_loop(ctrl, dist, cparams," in text
    assert " import " not in text.split("def _fly_loop(")[0].split("globals().update")[1]
    body = text.split("def _fly_loop(")[1].split('"""')[2]  # past the docstring
    assert "_CTRL(" not in body and "_DIST(" not in body and "ctrl(k * dt" in body
    assert body.count("dist(k * dt + sub * h") == 2
    assert "    fast = True  # fixed" in text
    _disk_cached.cache_clear()
    _pointer_dispatcher.cache_clear()


def test_functions_not_reachable_by_import_fly_the_cached_loop(tmp_path, monkeypatch):
    """A controller defined in a function (a notebook cell) cannot be imported by a generated
    module: fly_quad around it is compiled in memory, but the general loop takes it as an
    argument and stays the one cached module."""
    from numba import njit

    from uuvid.simulate.vehicle_sim import PointerLoop, _pointer_dispatcher, specialised_loop

    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))

    def make():
        @njit
        def local(t, eta, nu, rp, rv, ryaw, rrate, params, state, dt, out):
            out[0] = 0.0
        return local

    local = make()
    assert _importable(local) is None
    _disk_cached.cache_clear()
    _pointer_dispatcher.cache_clear()
    assert _disk_cached(fly_quad, local) is None
    assert not (tmp_path / "cache" / "mission_loops").exists()
    loop = specialised_loop(local, no_disturbance, ())
    assert isinstance(loop, PointerLoop) and loop.dispatcher is _pointer_dispatcher(())
    assert list((tmp_path / "cache" / "mission_loops").glob("*.py"))
    _disk_cached.cache_clear()
    _pointer_dispatcher.cache_clear()


SCRIPT = textwrap.dedent("""
    import json, sys
    from uuvid.simulate.disturbances import sinusoidal
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, mission_runner, setup_mission
    from uuvid.vehicle.definition import load_vehicle

    wave = sinusoidal(amplitude=(10.0, 0, 8.0, 0, 0, 0), period=5.0)
    s = setup_mission(load_vehicle("bluerov2"), square_mission(), t_end=5.0, disturbance=wave)
    r = fly_mission(s)
    loop = mission_runner(s)[0].loop
    assert not loop.py_func.__module__.startswith("uuvid.")  # the generated, cached module
    print(json.dumps({"hits": sum(loop.stats.cache_hits.values()),
                      "misses": sum(loop.stats.cache_misses.values()),
                      "end": r.state[-1, :3].tolist()}))
""")


@pytest.mark.slow
def test_a_second_process_loads_the_loop_from_disk(tmp_path):
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    runs = []
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert runs[0]["misses"] >= 1 and runs[0]["hits"] == 0  # compiled in the first
    assert runs[1]["hits"] >= 1 and runs[1]["misses"] == 0  # loaded in the second
    assert runs[0]["end"] == runs[1]["end"]


USER_SCRIPT = textwrap.dedent("""
    import json, sys
    import numpy as np
    from numba import njit
    from uuvid.simulate.control.blocks import Controller
    from uuvid.simulate.disturbances import sinusoidal
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, mission_runner, setup_mission
    from uuvid.vehicle.definition import load_vehicle

    def make(gain):  # a controller no module can import (a notebook cell's)
        @njit
        def hold(t, eta, nu, rp, rv, ryaw, rrate, params, state, dt, out):
            for j in range(3):
                out[j] = params[0] * (rp[j] - eta[j]) - params[1] * nu[j]
            for j in range(3, 6):
                out[j] = -params[1] * nu[j]
        return hold

    gain = float(sys.argv[1])
    c = Controller(make(gain), params=np.array([gain, 40.0]), state0=np.zeros(0))
    wave = sinusoidal(amplitude=(5.0, 0, 0, 0, 0, 0), period=4.0)  # the general loop
    s = setup_mission(load_vehicle("bluerov2"), square_mission(), t_end=3.0, controller=c,
                      disturbance=wave)
    r = fly_mission(s)
    loop = mission_runner(s)[0].loop
    print(json.dumps({"hits": sum(loop.stats.cache_hits.values()),
                      "misses": sum(loop.stats.cache_misses.values()),
                      "end": r.state[-1, :3].tolist()}))
""")


@pytest.mark.slow
def test_a_users_own_controller_flies_the_cached_loop_in_a_new_process(tmp_path):
    """Issue 20 item 2 (user controllers included): a controller written in the script itself
    (not importable) no longer compiles the mission loop in every process — a second process,
    with another controller, loads the loop from disk and flies its own controller."""
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    runs = []
    for gain in (30.0, 60.0):
        out = subprocess.run([sys.executable, "-c", USER_SCRIPT, str(gain)], env=env,
                             capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert runs[0]["misses"] >= 1
    assert runs[1]["hits"] >= 1 and runs[1]["misses"] == 0
    assert runs[0]["end"] != runs[1]["end"]  # each flew its own gain


def test_the_loop_is_keyed_on_the_compiled_code_not_every_file(tmp_path, monkeypatch):
    """A new version of uuvid's compiled code (a module that uses numba) names a new module; the
    digest leaves out files no compiled loop can reach (an edit to the CLI recompiled every loop
    in a checkout: 10–40 s each)."""
    from uuvid.core import cache as disk
    from uuvid.core.numba_cache import numba_sources_digest

    assert disk.compiled_code_version().endswith("+" + numba_sources_digest())
    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path / "cache"))
    m = _module(tmp_path, monkeypatch, 1.0)
    names = set()
    for version in ("0.0.0+one", "0.0.0+one", "0.0.0+two"):
        monkeypatch.setattr(disk, "compiled_code_version", lambda v=version: v)
        monkeypatch.setattr(disk, "code_version", lambda v=version: v + "-whole-tree")
        _disk_cached.cache_clear()
        names.add(_disk_cached(fly_quad, m.my_ctrl).py_func.__module__)
    assert len(names) == 2
    monkeypatch.setattr(disk, "code_version", lambda: "0.0.0+an-edit-outside-numba-code")
    _disk_cached.cache_clear()
    assert _disk_cached(fly_quad, m.my_ctrl).py_func.__module__ in names
    _disk_cached.cache_clear()


TEMPLATE = '''
from numba import njit


@njit(cache=False)
def heavy(x):
    return x * 2.0


@njit(cache=False)
def light(x):
    return x + 1.0


@njit(cache=False)
def loop(x):
    """A loop with a configuration line, as fly_quad's."""
    flag = x > 0.0
    if flag:
        return heavy(x)
    return light(x)
'''


def _template(tmp_path, monkeypatch):
    d = tmp_path / "tpl"
    d.mkdir(exist_ok=True)
    (d / "loop_template_mod.py").write_text(TEMPLATE)
    monkeypatch.syspath_prepend(str(d))
    sys.modules.pop("loop_template_mod", None)
    import importlib

    return importlib.import_module("loop_template_mod")


def test_a_specialised_loop_compiles_only_its_branch_and_refuses_other_inputs(tmp_path,
                                                                           monkeypatch):
    """The configuration line becomes a constant: numba drops the branch it rules out before
    compiling (its callee is never compiled), and inputs that give the other configuration stop
    the loop with an error instead of flying the wrong branch."""
    from numba import njit

    from uuvid.simulate.vehicle_sim import _fixed_source, _template_source

    m = _template(tmp_path, monkeypatch)
    src = _fixed_source(_template_source(m.loop), (("flag", False),))
    assert "    flag = False" in src
    g = dict(vars(m))
    exec(compile(src, "<specialised>", "exec"), g)
    special = njit(g["loop"])
    assert special(-1.0) == 0.0
    assert not m.heavy.signatures and m.light.signatures  # the pruned branch: never compiled
    with pytest.raises(ValueError, match="specialised to flag = False"):
        special(1.0)
    with pytest.raises(SyntaxError):
        _fixed_source(src, (("nothing", True),))


def test_fly_quad_and_fly_loop_have_one_line_per_configuration_flag():
    """Every flag the runners fix is one top-level line of the loop (else the specialisation
    would silently fall back to compiling every branch)."""
    from uuvid.simulate.vehicle_sim import _fixed_source, _template_source, loop_config, quad_config

    quad = quad_config(np.zeros(3), np.zeros(0))
    assert [n for n, _ in quad] == ["still", "inflow"]
    _fixed_source(_template_source(fly_quad), quad)
    cfg = loop_config(np.array([0, 0, 1, 1]), np.array([False, True, False]), np.zeros(0))
    assert dict(cfg) == {"fast": True, "inflow": False}
    assert dict(loop_config(np.array([0, 1, 2]), np.array([True, True]), np.ones(3))) == {
        "fast": False, "inflow": True}  # two dynamic blocks: the general block dispatch
    _fixed_source(_template_source(_fly_loop), cfg)


@pytest.mark.slow
def test_two_processes_needing_one_loop_compile_it_once(tmp_path):
    """Processes that need the same uncached loop at once (the demo's sections) compile it once:
    the others wait on its lock and load it from disk (before, each compiled it: 2 × 13 s)."""
    env = {**os.environ, "UUVID_KERNEL_CACHE": str(tmp_path / "cache")}
    procs = [subprocess.Popen([sys.executable, "-c", USER_SCRIPT, str(g)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for g in (30.0, 60.0)]
    runs = []
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err[-2000:]
        runs.append(json.loads(out.strip().splitlines()[-1]))
    assert sorted(r["misses"] for r in runs) == [0, 1]
    assert sorted(r["hits"] for r in runs) == [0, 1]
