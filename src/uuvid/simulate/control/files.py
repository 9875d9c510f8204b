"""Controllers chosen by name or loaded from a user's Python file (scenario files and the CLI).

``pid`` is the built-in PID DP (:mod:`uuvid.simulate.control.blocks`), ``lqr`` the LQI designed on the
vehicle linearised at hover (:func:`uuvid.simulate.control.lqr.lqr`), and ``FILE.py:FACTORY``
a function in the user's file called as ``FACTORY(vehicle, context)`` that returns a
:class:`~uuvid.simulate.control.blocks.Controller`; ``context`` is a :class:`ControllerContext` (the
control step, the default PID gains, the mission and the scenario's ``options``).
:func:`write_example` writes a file to start from.
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

from uuvid.simulate.control.blocks import Controller
from uuvid.simulate.control.pid import DPGains

#: Built-in controllers by name.
BUILT_IN = ("pid", "lqr")


class ControllerFileError(ValueError):
    """A controller file or factory is missing or does not give a Controller."""


@dataclass(frozen=True)
class ControllerContext:
    """What a controller factory is given besides the vehicle."""

    dt: float  # control step (s)
    gains: DPGains  # the PID gains the built-in controller would fly with
    mission: object = None  # the WaypointMission
    options: dict = field(default_factory=dict)  # the scenario's controller.options


def parse_controller_arg(text: str) -> dict:
    """``pid`` | ``lqr`` | ``FILE.py:FACTORY`` (``FILE.py`` alone: factory ``make_controller``)
    → a scenario ``controller`` mapping."""
    t = text.strip()
    if t in BUILT_IN:
        return {"kind": t}
    path, _, factory = t.rpartition(":") if not t.endswith(".py") else (t, "", "")
    if not path.endswith(".py"):
        raise ControllerFileError(f"--controller: expected pid, lqr or FILE.py:FACTORY, got {text!r}")
    return {"kind": "python", "file": path, "factory": factory or "make_controller"}


def load_factory(path: str | Path, factory: str):
    """The function ``factory`` of the Python file ``path`` (imported as a module of its own)."""
    p = Path(path)
    if not p.is_file():
        raise ControllerFileError(f"controller file {p}: no such file")
    name = "uuvid_user_controller_" + hashlib.sha1(str(p.resolve()).encode()).hexdigest()[:12]
    spec = importlib.util.spec_from_file_location(name, p)
    if spec is None or spec.loader is None:  # no .py suffix: Python finds no loader for it
        raise ControllerFileError(f"controller file {p}: expected a Python file ending in .py "
                                  f"(got suffix {p.suffix!r}); rename it to {p.stem}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # numba and dataclasses look their module up
    try:
        spec.loader.exec_module(mod)  # type: ignore[union-attr]
    except Exception as e:
        sys.modules.pop(name, None)
        raise ControllerFileError(f"controller file {p}: importing it failed: "
                                  f"{type(e).__name__}: {e}") from e
    fn = getattr(mod, factory, None)
    if not callable(fn):
        found = sorted(k for k, v in vars(mod).items() if callable(v) and not k.startswith("_")
                       and getattr(v, "__module__", None) == name)
        raise ControllerFileError(f"controller file {p}: no function {factory!r} (functions "
                                  f"defined there: {', '.join(found) or 'none'})")
    return fn


def from_file(path: str | Path, factory: str, vehicle, context: ControllerContext) -> Controller:
    """``factory(vehicle, context)`` from the file ``path``; checks it returns a Controller."""
    fn = load_factory(path, factory)
    try:
        c = fn(vehicle, context)
    except Exception as e:
        raise ControllerFileError(f"controller file {path}: {factory}(vehicle, context) raised "
                                  f"{type(e).__name__}: {e}") from e
    if not isinstance(c, Controller):
        raise ControllerFileError(f"controller file {path}: {factory}(vehicle, context) returned "
                                  f"{type(c).__name__}, not a uuvid.simulate.control.blocks.Controller")
    # what a message names it by when it raises in flight (blocks.describe_origin)
    return replace(c, origin=f"controller file {path}: {factory}(vehicle, context)")


def make_controller(kind: str, vehicle, context: ControllerContext, *, file: str | Path | None = None,
                    factory: str = "make_controller", base: Path | None = None,
                    lqr_weights: dict | None = None) -> Controller | None:
    """The controller of a scenario: ``None`` for ``pid`` (the built-in loop with
    ``context.gains``), the hover LQI for ``lqr`` (Bryson weights ``lqr_weights``), the user's
    for ``python`` (``file`` relative to ``base``, the scenario's folder)."""
    if kind == "pid":
        return None
    if kind == "lqr":
        from uuvid.simulate.control.lqr import lqr

        return lqr(vehicle, **(lqr_weights or {}))
    if kind == "python":
        if not file:
            raise ControllerFileError("controller.file: a python controller needs its file")
        p = Path(file)
        if not p.is_absolute() and base is not None:
            p = base / p
        return from_file(p, factory, vehicle, context)
    raise ControllerFileError(f"controller.kind: expected pid, lqr or python, got {kind!r}")


def describe(controller: Controller | None) -> str:
    """One line naming the controller that flies (for summaries and reports)."""
    if controller is None:
        return "PID DP (built in)"
    return f"{controller.name} ({controller.output} output)"


EXAMPLE = '''"""A controller for uuvid's mission loop (generated by uuvid.simulate.control.files).

Fly it:  uuvid simulate mission square --controller {name}:make_controller
or in a scenario file:  controller: {{kind: python, file: {name}, factory: make_controller}}
"""

import math

import numpy as np
from numba import njit

from uuvid.simulate.control.blocks import Controller


@njit
def body_pd(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """PD on the body-frame position error and on yaw; writes the wrench [X Y Z K M N]."""
    q0, q1, q2, q3 = eta[3], eta[4], eta[5], eta[6]
    R = ((1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
         (2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)),
         (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)))
    for j in range(6):
        tau_out[j] = 0.0
    for i in range(3):
        e = 0.0
        v = 0.0
        for k in range(3):
            e += R[k][i] * (ref_pos[k] - eta[k])
            v += R[k][i] * ref_vel[k]
        tau_out[i] = params[i] * e + params[3 + i] * (v - nu[i])
    yaw = math.atan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2 * q2 + q3 * q3))
    tau_out[5] = (params[6] * ((ref_yaw - yaw + math.pi) % (2 * math.pi) - math.pi)
                  + params[7] * (ref_rate - nu[5]))


def make_controller(vehicle, context):
    """Called by uuvid with the vehicle and a ControllerContext (dt, gains, mission, options):
    here the PID's proportional and derivative gains, without the integrator."""
    g = context.gains
    kp = context.options.get("kp_scale", 1.0)
    params = np.array([*g.kp[:3], *g.kd[:3], g.kp[3], g.kd[3]], dtype=float)
    params[[0, 1, 2, 6]] *= kp
    return Controller(body_pd, params, np.zeros(0), "body-frame PD (example)")
'''


def write_example(path: str | Path) -> Path:
    """Write an example controller file (a body-frame PD, numba-compiled, with its factory)."""
    from uuvid.core.atomic import atomic_write_text

    p = Path(path)
    if p.suffix != ".py":
        raise ControllerFileError(f"{p}: a controller file ends in .py")
    atomic_write_text(p, EXAMPLE.format(name=p.name))
    return p
