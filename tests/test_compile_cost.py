"""What a cold process compiles: no compiled function pulls in numba's shape-mismatch message.

A row assignment between arrays inside a compiled function (``X[i] = x``, ``z[:] = x``) makes
numba compile the f-string of its "cannot assign slice of shape …" error, with ``str``/``repr``
of tuples and unicode concatenation: ≈ 2 s of compilation per process for a message that never
shows (measured in the cold demo, two processes: 4.4 s).  The kernels copy rows element by
element instead; this test compiles them in a fresh process with an empty numba cache and lists
what was compiled.
"""

import json
import os
import subprocess
import sys
import textwrap

import pytest

LISTEN = textwrap.dedent("""
    import json, sys
    import numpy as np
    import numba.core.event as ev

    names = []

    class Listen(ev.Listener):
        def on_start(self, event):
            pass

        def on_end(self, event):
            d = event.data.get("dispatcher")
            if d is not None:
                names.append(f"{d.py_func.__module__}.{d.py_func.__qualname__}")

    ev.register("numba:compile", Listen())
""")

SCRIPT = LISTEN + textwrap.dedent("""
    from uuvid.papers.caccia2000 import _integrate
    from uuvid.simulate.dive_synth import synthetic_dive, synthetic_horizontal_dive
    from uuvid.vehicle.definition import load_vehicle

    p = load_vehicle("bluerov2").params.to_array()
    x0 = np.zeros(13)
    x0[3] = 1.0
    _integrate(p, x0, np.zeros((3, 6)), 0.1, 2)
    synthetic_dive(duration=30.0, seed=1)
    synthetic_horizontal_dive(duration=10.0, seed=1, inflow_coefficient=0.01)
    json.dump(names, sys.stdout)
""")


def _compiled(tmp_path, script) -> list[str]:
    """Names of the functions numba compiles running ``script`` in a fresh process (empty caches)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               UUVID_KERNEL_CACHE=str(tmp_path / "kernels"))
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_kernels_compile_no_shape_mismatch_message(tmp_path):
    names = _compiled(tmp_path, SCRIPT)
    ours = [n for n in names if n.startswith("uuvid.")]
    assert {"uuvid.papers.caccia2000._integrate", "uuvid.simulate.dive_synth._pilot_steps",
            "uuvid.simulate.dive_synth._horizontal_inflow_steps"} <= set(ours), ours
    shape_msg = [n for n in names if "raise_with_shape_context" in n]
    assert shape_msg == [], "a compiled function assigns an array into a row or slice"


CHAIN_TWICE = LISTEN + textwrap.dedent("""
    from uuvid.papers import thruster_loop_study as st
    from uuvid.vehicle.definition import load_vehicle

    st.run_case(load_vehicle("bluerov2"), st.thruster_models()["tunnel"], "heading", 2.0)
    json.dump(names, sys.stdout)
""")


@pytest.mark.slow
def test_a_thruster_chain_is_compiled_once_for_sweeps_and_mission_loops(tmp_path):
    """The chain evaluation (``eval_chain_at``) is called by the chain's own integrator (a sweep)
    and by the mission loop's right-hand side: one signature for both (an omitted ``start``
    argument was a second one, ≈ 2 s more of compilation in a process that does both)."""
    names = _compiled(tmp_path, CHAIN_TWICE)
    assert "uuvid.simulate.vehicle_sim._rhs_d" in names and "uuvid.thruster.kernels.rk4_chain" in names
    assert names.count("uuvid.thruster.kernels.eval_chain_at") == 1, names


SMALL_SWEEP = LISTEN + textwrap.dedent("""
    import numpy as np
    from uuvid.thruster.presets import preset_chain

    preset_chain("laidani-a2212").sweep(np.linspace(1100.0, 1900.0, 9), settle_time=0.2)
    json.dump(names, sys.stdout)
""")


@pytest.mark.slow
def test_a_small_sweep_compiles_no_parallel_kernel(tmp_path, monkeypatch):
    """A sweep of a few levels is a fraction of a second of work: numba's parallel passes would
    add 1–3 s of compiling to it (the demo's workers run with one thread each)."""
    monkeypatch.setenv("NUMBA_NUM_THREADS", "2")
    names = _compiled(tmp_path, SMALL_SWEEP)
    assert "uuvid.thruster.kernels.sweep_chain_serial" in names, names
    assert "uuvid.thruster.kernels.sweep_chain" not in names, names


def test_parallel_and_serial_kernels_agree_and_parallel_pays_only_for_big_batches(monkeypatch):
    import numba
    import numpy as np

    from uuvid.thruster import kernels as K
    from uuvid.thruster.presets import preset_chain

    c = preset_chain("laidani-a2212").compile()
    u = np.linspace(1100.0, 1900.0, 7)
    X0 = np.zeros((u.size, int(c.soff[-1])))
    out = []
    for f in (K.sweep_chain, K.sweep_chain_serial):
        F, XF = np.empty((u.size, K.N_CHANNELS)), np.empty_like(X0)
        f(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch, c.exact, X0.copy(), u, 1e-3, 200, F, XF)
        out.append((F, XF))
    assert np.array_equal(out[0][0], out[1][0], equal_nan=True)  # (channels a chain lacks: NaN)
    assert np.array_equal(out[0][1], out[1][1])
    assert np.ptp(out[0][0][:, 0]) > 0  # the levels did not all give the same channels

    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)
    assert not K.parallel_pays(1, 10 ** 9)  # one run: nothing to share
    assert not K.parallel_pays(10, K.PARALLEL_MIN_STEPS // 10 - 1)
    assert K.parallel_pays(10, K.PARALLEL_MIN_STEPS // 10)
    monkeypatch.setattr(numba, "get_num_threads", lambda: 1)
    assert not K.parallel_pays(10, 10 ** 9)  # one thread: the parallel loop only compiles longer
