"""Controller blocks of the mission loop: :class:`Controller` (a numba or Python function with
its parameters, state and output kind — a generalized force, per-thruster thrusts or commands),
plain Python controllers called from the compiled loop, and the first-call output check.

The built-in controllers live beside it: :mod:`uuvid.simulate.control.pid` (PID DP) and
:mod:`uuvid.simulate.control.lqr` (LQI); user controller files in :mod:`uuvid.simulate.control.files`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit, objmode

#: What a :class:`Controller` outputs: a generalized force, per-thruster thrusts or commands.
OUTPUTS = ("wrench", "thrust", "command")


@dataclass(frozen=True)
class Controller:
    """A controller block for the mission loop (:func:`uuvid.simulate.vehicle_sim.setup_mission`).

    ``fn(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out)`` is called
    once per control step ``dt`` (its output held over the step, as a digital autopilot's):

    - ``t`` time (s); ``eta`` = [north, east, down, q0, q1, q2, q3] (NED position, unit
      quaternion body → NED); ``nu`` = [u, v, w, p, q, r] body velocities;
    - ``ref_pos``, ``ref_vel`` (3, NED), ``ref_yaw``, ``ref_rate`` (floats): the mission reference;
    - ``params`` (1-D float array, read only) and ``state`` (1-D float array, persistent across
      steps, modified in place; each flight starts from a copy of ``state0``);
    - ``tau_out``: the controller's output, every entry written each call; what it holds is
      ``output``:

      * ``"wrench"`` (6): the desired generalized force [X Y Z K M N] (N, N·m), body frame; the
        loop allocates it to the thrusters (the setup's ``allocation`` method) and inverts each
        thruster's steady map to its command;
      * ``"thrust"`` (n thrusters, the vehicle layout's order): each thruster's thrust (N, before
        the installation coefficients η); the loop skips the allocation, clips each to the
        thruster's limits (at the present supply voltage on a battery) and inverts the maps;
      * ``"command"`` (n): each thruster's raw command in its chain's input unit (e.g. PWM µs
        for an ESC-driven T200, volts for a motor) — straight to the thruster chain, no inverse
        map (a learned policy, an ArduSub-like mixer).

      In the :class:`~uuvid.simulate.vehicle_sim.MissionResult`, ``tau_cmd`` is the controller's
      wrench for ``"wrench"`` and otherwise ``B (η ∘ f)`` of the thrusts ``f`` sent on (the
      wrench they give at steady state); ``thrust_cmd`` is the allocated / clipped thrust, for
      ``"command"`` the steady thrust of the command (the inverse table read backwards, linear
      between its knots); ``scale`` is the allocation's, for ``"thrust"`` the smallest ratio
      clipped / requested (1: nothing clipped), for ``"command"`` 1.

    ``fn`` either a numba ``@njit`` function (called by the compiled loop through a function
    pointer at full speed: it compiles only itself, the loop is shared and cached; write
    ``tau_out`` and return nothing) or a plain
    Python callable with the same signature (called from the compiled loop through
    ``numba.objmode`` each step; slower — see ``uuvid bench``, case ``controllers``).  Batches
    (:func:`uuvid.simulate.batch.run_batch_fast`) fly a compiled wrench controller inside the
    SIMD kernel, one call per vehicle and step; the others one compiled loop per vehicle.
    :func:`~uuvid.simulate.vehicle_sim.setup_mission` calls it once at the start state (on a
    copy of ``state0``) to check it writes exactly the entries ``output`` asks for.

    An ``fn`` that raises during a flight ends it with a :class:`ControllerRaised` (a
    ``ValueError``) naming the controller (``origin``: where it came from, e.g. the controller
    file and factory :func:`uuvid.simulate.control.files.from_file` loaded it with), the
    exception and the simulated time of the step it raised at (a plain Python ``fn`` wherever it
    flies; a numba one in :func:`~uuvid.simulate.vehicle_sim.fly_mission`).
    """

    fn: object
    params: np.ndarray
    state0: np.ndarray
    name: str = ""  # default: the function's name
    output: str = "wrench"
    origin: str = ""  # who made it, for messages: "controller file f.py: make_controller(vehicle, context)"

    def __post_init__(self):
        p = np.ascontiguousarray(np.ravel(np.asarray(self.params, dtype=np.float64)))
        s = np.ascontiguousarray(np.ravel(np.asarray(self.state0, dtype=np.float64)))
        if not callable(self.fn):
            raise TypeError(f"Controller.fn must be callable, got {type(self.fn).__name__}")
        if self.output not in OUTPUTS:
            raise ValueError(f"Controller.output must be one of {', '.join(OUTPUTS)}, "
                             f"got {self.output!r}")
        p.flags.writeable = False
        object.__setattr__(self, "params", p)
        object.__setattr__(self, "state0", s)
        if not self.name:
            object.__setattr__(self, "name", getattr(self.fn, "__name__", "") or "user")

    @property
    def output_code(self) -> int:
        """0 wrench, 1 thrust, 2 command (the compiled loop's ``out_kind``)."""
        return OUTPUTS.index(self.output)

    def output_size(self, n_thrusters: int) -> int:
        """Length of ``tau_out``: 6 for a wrench, else one per thruster."""
        return 6 if self.output == "wrench" else int(n_thrusters)

    @property
    def compiled(self) -> bool:
        """True for a numba-compiled ``fn`` (runs inside the compiled loop)."""
        from numba.core.registry import CPUDispatcher

        return isinstance(self.fn, CPUDispatcher)


#: Plain Python controllers, by slot (``params[0]`` of :func:`python_controller`).
_PY_CONTROLLERS: dict[int, object] = {}
#: What messages call the controller of each slot (:func:`describe_origin`).
_PY_LABELS: dict[int, str] = {}


def describe_origin(controller: Controller) -> str:
    """The controller as the subject of a message (a verb follows): where it came from
    (``origin``) and its function, e.g. ``controller file c.py: make_controller(vehicle,
    context) returned the controller 'late', which`` or ``controller 'late' (function late in
    /path/c.py)``."""
    fn = getattr(controller.fn, "py_func", controller.fn)
    fname = getattr(fn, "__qualname__", None) or getattr(fn, "__name__", None) or type(fn).__name__
    if controller.origin:
        also = f" (function {fname})" if getattr(fn, "__name__", "") != controller.name else ""
        return f"{controller.origin} returned the controller {controller.name!r}{also}, which"
    code = getattr(fn, "__code__", None)
    where = f" in {code.co_filename}" if code is not None else ""
    return f"controller {controller.name!r} (function {fname}{where})"


class ControllerRaised(ValueError):
    """A controller raised during a flight: ``controller`` (its :func:`describe_origin`), ``t``
    (the simulated time of the control step it raised at, s), ``error`` (the exception, also
    the ``__cause__``) and ``where`` (`` (file.py line 11, in fn)``, or empty)."""

    def __init__(self, controller: str, t: float, error: BaseException, where: str = ""):
        self.controller, self.t, self.error, self.where = controller, float(t), error, where
        super().__init__(f"{controller} raised {type(error).__name__} at t = {self.t:.4g} s of "
                         f"the flight: {error}{where}")

    def __reduce__(self):  # picklable (worker processes hand it back)
        return type(self), (self.controller, self.t, self.error, self.where)


_UUVID = str(Path(__file__).resolve().parents[2])  # this package's folder


def _raised_where(error: BaseException, fn=None) -> str:
    """`` (file.py line 11, in late)``: the frame of ``error``'s traceback that raised it in the
    file of ``fn`` (the controller's function), else the innermost one outside uuvid and numba;
    nothing without one."""
    import os
    import traceback

    frames = traceback.extract_tb(error.__traceback__) if error.__traceback__ else []
    code = getattr(getattr(fn, "py_func", fn), "__code__", None)
    own = [f for f in frames if code is not None and f.filename == code.co_filename] or [
        f for f in frames if not os.path.abspath(f.filename).startswith(_UUVID + os.sep)
        and "numba" not in Path(f.filename).parts]
    if not own:
        return ""
    f = own[-1]
    return f" ({Path(f.filename).name} line {f.lineno}, in {f.name})"


def _call_python(slot, t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    fn = _PY_CONTROLLERS[int(slot)]
    try:
        fn(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out)
    except Exception as e:  # the loop's objmode hands it on: say who raised it and when
        raise ControllerRaised(_PY_LABELS.get(int(slot), "the controller"), t, e,
                               _raised_where(e, fn)) from e


@njit
def python_controller(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """Calls a plain Python controller (registered in slot ``params[0]``; its own params follow)
    from the compiled loop through ``numba.objmode`` (the arrays are shared, not copied)."""
    slot = params[0]
    own = params[1:]
    with objmode():
        _call_python(slot, t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, own, state, dt, tau_out)


def compiled_form(controller: Controller) -> tuple:
    """``(numba function, params)`` that the compiled loop calls for ``controller``: its own for a
    numba function, :func:`python_controller` with the callable registered for a Python one."""
    if controller.compiled:
        return controller.fn, controller.params
    slot = next((k for k, f in _PY_CONTROLLERS.items() if f is controller.fn), len(_PY_CONTROLLERS))
    _PY_CONTROLLERS[slot] = controller.fn
    _PY_LABELS[slot] = describe_origin(controller)
    return python_controller, np.concatenate([[float(slot)], controller.params])


def check_output(controller: Controller, n_thrusters: int, z0, ref, dt: float) -> None:
    """Call ``controller`` once at the start state ``z0`` and the first reference sample (on a
    copy of its state) and check it writes exactly the :meth:`Controller.output_size` entries
    its ``output`` asks for; raises ``ValueError`` saying what it wrote instead."""
    m = controller.output_size(n_thrusters)
    pad = 64
    buf = np.full(m + pad, np.nan)
    out = buf[:m]
    rp, rv, ry, rr = ref
    z = np.asarray(z0, dtype=np.float64)
    what = (f"controller {controller.name!r} (output={controller.output!r}) must write "
            f"{m} values" + (" [X Y Z K M N]" if m == 6 and controller.output == "wrench"
                             else f", one per thruster ({n_thrusters})"))
    try:
        controller.fn(0.0, z[0:7].copy(), z[7:13].copy(), np.array(rp[0], dtype=np.float64),
                      np.array(rv[0], dtype=np.float64), float(ry[0]), float(rr[0]),
                      controller.params, controller.state0.copy(), float(dt), out)
    except IndexError as e:
        raise ValueError(f"{what}; its first call wrote past them ({e})"
                         + _hint(controller, n_thrusters)) from None
    except Exception as e:
        raise ValueError(f"{describe_origin(controller)} failed on its first call (t = 0, start "
                         f"state): {type(e).__name__}: {e}{_raised_where(e, controller.fn)}") from e
    past = int(np.count_nonzero(~np.isnan(buf[m:])))
    if past:
        raise ValueError(f"{what}; its first call wrote {past} more" + _hint(controller, n_thrusters))
    missing = np.flatnonzero(np.isnan(out))
    if missing.size:
        raise ValueError(f"{what}; its first call left entries {missing.tolist()} unwritten "
                         "(or wrote NaN)" + _hint(controller, n_thrusters))


def _hint(controller: Controller, n: int) -> str:
    if controller.output == "wrench":
        return f" — for one value per thruster ({n}) give Controller(..., output='thrust' or 'command')"
    return " — for a generalized force give Controller(..., output='wrench')"
