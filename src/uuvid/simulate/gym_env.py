"""Gymnasium environments: station keeping / waypoint tracking for any uuvid vehicle file.

``pip install uuvid[gym]``.  The plant is the 6-DOF model of :mod:`uuvid.vehicle.model`
(:func:`uuvid.vehicle.model.vehicle_rhs_into`, RK4 with ``substeps`` per control step ``dt``,
:func:`uuvid.simulate.station_keeping.rk4_held`) with ideal thrusters held over the step, clipped
to their limits, in a constant NED current (optionally randomised per episode).

* **Action** (``action="thrust"``, default): one value per thruster in ``[−1, 1]``; ``a ≥ 0`` asks
  for ``a · f_max``, ``a < 0`` for ``|a| · f_min`` of the thruster's ``limits``.  With
  ``action="force"``: one value per allocated DOF (``allocation.dofs`` of the vehicle file) in
  ``[−1, 1]`` of the largest force the thrusters give along it, allocated by the vehicle's
  allocator (:func:`uuvid.vehicle.allocation.allocate_compiled`).  Values outside ``[−1, 1]``
  (``±inf`` included) are clipped to the bound, as many Gymnasium environments do; a NaN is
  refused (``ValueError`` naming its index), and so is an action of another shape than the
  action space's (no reshaping: a transposed batch would send actions to the wrong thrusters).
* **Observation** (12, float32): target position error in body axes ``R(q)ᵀ(p_t − p)`` (m),
  roll, pitch and the wrapped yaw error ``ψ_t − ψ`` (rad), body velocities ``ν`` (m/s, rad/s).
* **Reward**: ``−(w_p |e_p| + w_a |[φ, θ, e_ψ]| + w_v |ν| + w_u |a|²/n_a) · dt`` (weights
  ``weights = (w_p, w_a, w_v, w_u)``).
* **Episode**: starts at rest at a uniformly random offset (``offset_range`` = ±[n, e, d, ψ]) from
  the first target; with ``waypoints`` (rows ``[n, e, d, ψ]``) the target moves on when the
  position error is below ``acceptance_radius``, and the last one is held.  Terminated when the
  position error exceeds ``max_distance`` (lost) or the state is no longer finite; truncated after
  ``max_steps``.  ``step()`` before ``reset()`` raises :class:`gymnasium.error.ResetNeeded`; a step
  after the episode ended warns (once) that ``reset()`` is needed, as Gymnasium's own
  environments do.  ``reset(options=...)`` takes ``None`` or ``{}`` (there are no reset options).
* **Options** are checked when the environment is made (``ValueError`` naming the option):
  ``dt`` > 0 with the RK4 step ``dt / substeps`` within the vehicle's stability bound
  (:func:`rk4_step_limit`, an estimate: past it a warning, past twice it refused),
  ``substeps`` (at most :data:`MAX_SUBSTEPS`), ``max_steps`` (and the vector env's ``num_envs``)
  whole numbers >= 1 (:func:`uuvid.core.checks.count`: a ``TypeError`` for one that is no
  number at all), ``offset_range``,
  ``current_range``, ``acceptance_radius``, ``weights`` finite and ≥ 0, ``current`` finite,
  ``max_distance`` > 0 (``inf``: never lost).

:class:`StationKeepingEnv` is one vehicle (passes ``gymnasium.utils.env_checker.check_env``);
:class:`StationKeepingVectorEnv` steps ``num_envs`` vehicles in one parallel compiled call
(numba ``prange``), next-step autoreset as in Gymnasium's own vector environments.

``inflow`` (``None``: the vehicle file's key; ``'none'``; ``'four-quadrant'``): the held thrusts
are taken to each thruster's advance speed at every RK4 stage (:mod:`uuvid.vehicle.inflow`,
issue 21); the action still scales the bollard limits.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit, prange

from uuvid.core.checks import MAX_SUBSTEPS  # re-exported: most RK4 steps per sample/step

try:
    import gymnasium as gym
    from gymnasium import spaces
    from gymnasium.error import ResetNeeded
    from gymnasium.vector import VectorEnv
    from gymnasium.vector.utils import batch_space
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("uuvid.simulate.gym_env needs gymnasium: pip install 'uuvid[gym]'") from e

from uuvid.core.checks import InputWarning, count
from uuvid.simulate.station_keeping import rk4_held, thrust_to_tau
from uuvid.thruster.inflow import inflow_thrust_nb
from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.inflow import check_geometry, state_advance_speeds_nb
from uuvid.vehicle.kinematics import normalise_state, quat_to_rotmat
from uuvid.vehicle.model import vehicle_rhs_into

N_OBS = 12


# ---------------------------------------------------------------------------------------------
# Compiled step
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def _observe(z, wp, obs):
    """Observation of state ``z`` for target ``wp = [n, e, d, ψ]``; returns ``(|e_p|, |e_att|)``."""
    R = quat_to_rotmat(z[3:7])
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    dn = wp[0] - z[0]
    de = wp[1] - z[1]
    dd = wp[2] - z[2]
    obs[0] = r00 * dn + r10 * de + r20 * dd
    obs[1] = r01 * dn + r11 * de + r21 * dd
    obs[2] = r02 * dn + r12 * de + r22 * dd
    obs[3] = math.atan2(r21, r22)
    obs[4] = -math.asin(min(1.0, max(-1.0, r20)))
    yaw = math.atan2(r10, r00)
    obs[5] = (wp[3] - yaw + math.pi) % (2.0 * math.pi) - math.pi
    for i in range(6):
        obs[6 + i] = z[7 + i]
    ep = math.sqrt(dn * dn + de * de + dd * dd)
    ea = math.sqrt(obs[3] * obs[3] + obs[4] * obs[4] + obs[5] * obs[5])
    return ep, ea


def work_size(n_thrusters: int) -> int:
    """Length of the scratch array :func:`_step_one` needs (no allocation in the hot loop)."""
    return 5 * 13 + 3 + 6 + 6 + 2 * n_thrusters


@njit(cache=True)
def _inflow_tau(zs, f, Bthr, vc, IPRM, IGEO, ua, tau):
    """``τ = B T(f, u_a)``: the held thrusts taken to the advance speed of the state ``zs``."""
    state_advance_speeds_nb(zs, vc, IGEO, ua)
    for i in range(f.size):
        ua[i] = inflow_thrust_nb(f[i], ua[i], IPRM)  # ua reused for the delivered thrust
    thrust_to_tau(Bthr, ua, tau)


@njit(cache=True)
def _rk4_held_inflow(z, f, Bthr, vp, vc, h, nsub, dvc, k1, k2, k3, k4, zt, tau, IPRM, IGEO, ua):
    """:func:`~uuvid.simulate.station_keeping.rk4_held` with the thrust at each stage's advance
    speed (issue 21)."""
    for _ in range(nsub):
        _inflow_tau(z, f, Bthr, vc, IPRM, IGEO, ua, tau)
        vehicle_rhs_into(z, tau, vp, vc, dvc, k1)
        for i in range(13):
            zt[i] = z[i] + 0.5 * h * k1[i]
        _inflow_tau(zt, f, Bthr, vc, IPRM, IGEO, ua, tau)
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k2)
        for i in range(13):
            zt[i] = z[i] + 0.5 * h * k2[i]
        _inflow_tau(zt, f, Bthr, vc, IPRM, IGEO, ua, tau)
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k3)
        for i in range(13):
            zt[i] = z[i] + h * k3[i]
        _inflow_tau(zt, f, Bthr, vc, IPRM, IGEO, ua, tau)
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k4)
        for i in range(13):
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        normalise_state(z)


@njit(cache=True)
def _step_one(z, act, wps, widx, mode, alloc, dofs, fscale, lo, hi, Bthr, vp, vc, dt, nsub, w,
              accept, obs, work, IPRM, IGEO):
    """One control step of one vehicle (``z`` in place); returns ``(reward, position error)``
    and the new waypoint index through ``widx[0]``.  ``work``: :func:`work_size` scratch."""
    n = Bthr.shape[1]
    na = act.size
    k1 = work[0:13]
    k2 = work[13:26]
    k3 = work[26:39]
    k4 = work[39:52]
    zt = work[52:65]
    dvc = work[65:68]
    tau = work[68:74]
    phi = work[74:80]
    f = work[80:80 + n]
    ua = work[80 + n:80 + 2 * n]
    for i in range(3):
        dvc[i] = 0.0
    if mode == 0:
        for i in range(n):
            a = min(1.0, max(-1.0, act[i]))
            f[i] = a * hi[i] if a >= 0.0 else -a * lo[i]
    else:
        for j in range(6):
            phi[j] = 0.0
        for j in range(na):
            phi[dofs[j]] = min(1.0, max(-1.0, act[j])) * fscale[j]
        allocate_compiled(alloc, phi, f)
        for i in range(n):
            f[i] = min(max(f[i], lo[i]), hi[i])
    if IPRM.size > 0:  # thrust at the advance speed (uuvid.vehicle.inflow.loop_arrays)
        _rk4_held_inflow(z, f, Bthr, vp, vc, dt / nsub, nsub, dvc, k1, k2, k3, k4, zt, tau, IPRM,
                         IGEO, ua)
    else:
        thrust_to_tau(Bthr, f, tau)
        rk4_held(z, tau, vp, vc, dt / nsub, nsub, dvc, k1, k2, k3, k4, zt)
    k = widx[0]
    ep, ea = _observe(z, wps[k], obs)
    if ep < accept and k + 1 < wps.shape[0]:
        widx[0] = k + 1
        ep, ea = _observe(z, wps[k + 1], obs)
    ev = 0.0
    for i in range(6):
        ev += z[7 + i] * z[7 + i]
    eu = 0.0
    for j in range(na):
        a = min(1.0, max(-1.0, act[j]))
        eu += a * a
    cost = w[0] * ep + w[1] * ea + w[2] * math.sqrt(ev) + w[3] * eu / na
    return -cost * dt, ep


@njit(cache=True, parallel=True)
def _step_batch(Z, A, wps, WIDX, active, mode, alloc, dofs, fscale, lo, hi, Bthr, vp, VC, dt,
                nsub, w, accept, OBS, REW, DIST, WORK, IPRM, IGEO):
    """:func:`_step_one` for every row of ``Z`` with ``active``; the others only observe."""
    for r in prange(Z.shape[0]):
        if active[r]:
            REW[r], DIST[r] = _step_one(Z[r], A[r], wps, WIDX[r:r + 1], mode, alloc, dofs, fscale,
                                        lo, hi, Bthr, vp, VC[r], dt, nsub, w, accept, OBS[r],
                                        WORK[r], IPRM, IGEO)
        else:
            ep, _ = _observe(Z[r], wps[WIDX[r]], OBS[r])
            REW[r] = 0.0
            DIST[r] = ep


# ---------------------------------------------------------------------------------------------
# Option and action checks (in Python, before the compiled calls)
# ---------------------------------------------------------------------------------------------
#: −z where RK4's amplification 1 + z + z²/2 + z³/6 + z⁴/24 reaches 1 on the real axis
#: (:data:`uuvid.simulate.dive_replay.RK4_LIMIT`)
_RK4_LIMIT = 2.785


def _real_array(name: str, value, shape: tuple[int, ...], what: str, *, minimum=None,
                allow_inf=False) -> np.ndarray:
    """``value`` as a float array broadcast to ``shape``; ``ValueError`` naming ``name`` unless it is
    numeric, finite (or ``+inf`` with ``allow_inf``) and ``≥ minimum``."""
    try:
        if isinstance(value, (str, bytes)) or np.asarray(value).dtype == bool:
            raise TypeError
        a = np.asarray(value, dtype=float)
        a = np.broadcast_to(a, shape).copy()
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {what}, got {value!r}") from None
    bad = np.isnan(a) | (np.isinf(a) & ~(allow_inf & (a > 0)))
    if minimum is not None:
        bad |= a < minimum
    if bad.any():
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return a


def _positive(name: str, value, what: str, **kw) -> float:
    v = float(_real_array(name, value, (), what, **kw))
    if not v > 0:
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return v


def rk4_step_limit(vehicle, current_speed: float = 0.0) -> tuple[float, int, float]:
    """``(h_max, dof, rate)``: the largest RK4 step (s) that keeps the vehicle's fastest damped
    mode stable, estimated per DOF from the diagonal mass and damping: the damping rate
    ``(D_l + 2 D_q |ν|) / M`` at the terminal speed ``|ν|`` the thrusters (``|B| · max |limit|``)
    can drive against that damping (plus ``current_speed`` in translation), and
    ``h_max = 2.785 / rate`` (RK4's real-axis stability limit).  ``dof``: the DOF that sets it.
    An estimate (coupling is ignored): steps near it may still grow at full thrust."""
    p = vehicle.params
    M = np.diag(np.asarray(p.mass_matrix, float))
    Dl = np.asarray(p.linear_damping, float)
    Dq = np.asarray(p.quadratic_damping, float)
    Dl = np.abs(np.diag(Dl) if Dl.ndim == 2 else Dl)
    Dq = np.abs(np.diag(Dq) if Dq.ndim == 2 else Dq)
    F = np.abs(np.asarray(vehicle.B, float)) @ np.max(np.abs(vehicle.layout.limits), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(Dq > 0, (-Dl + np.sqrt(Dl * Dl + 4 * Dq * F)) / (2 * np.where(Dq > 0, Dq, 1)),
                     0.0)
        v[:3] += current_speed
        rate = np.where(M > 0, (Dl + 2 * Dq * v) / np.where(M > 0, M, 1), 0.0)
    k = int(np.argmax(rate))
    return (_RK4_LIMIT / rate[k] if rate[k] > 0 else math.inf), k, float(rate[k])


def _check_reset_options(env, options) -> None:
    if options is None:
        return
    if not isinstance(options, dict):
        raise TypeError(f"{type(env).__name__}.reset: options must be None or a dict (accepted keys: "
                        f"none), got {type(options).__name__} {options!r}")
    if options:
        raise ValueError(f"{type(env).__name__}.reset: unknown options {sorted(map(str, options))}; "
                         "accepted keys: none (give None or {})")


def _check_action(action, shape: tuple[int, ...], what: str = "action") -> np.ndarray:
    """``action`` as a C-contiguous float64 array of exactly ``shape``; ``ValueError`` for another
    shape or a NaN (``±inf`` passes: the step clips it to ``[−1, 1]``)."""
    try:
        a = np.ascontiguousarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers of shape {shape}, got {action!r}") from None
    if a.shape != shape:
        raise ValueError(f"{what} shape {a.shape}, expected {shape}")
    nan = np.isnan(a)
    if nan.any():
        idx = [int(i[0]) if len(i) == 1 else tuple(int(j) for j in i) for i in np.argwhere(nan)]
        at = ", ".join(map(str, idx[:4])) + (f" … ({len(idx)} in all)" if len(idx) > 4 else "")
        raise ValueError(f"{what} contains NaN at index {at}")
    return a


#: Shortest control step (s): a thruster's command is updated at most every few ms (a 400 Hz ESC)
MIN_DT = 1e-4


def env_bytes(n_act: int, n_thrusters: int) -> int:
    """Memory one copy of :class:`StationKeepingVectorEnv` takes (bytes, an upper estimate): its
    share of the batched spaces (float32 bounds and their flags), of the state, current, counter,
    observation and scratch arrays, and of a step's temporaries (actions, the float32
    observation, rewards, flags, a reset's new states)."""
    spaces_ = 2 * (5 * N_OBS + 5 * n_act)
    state = 8 * (13 + 3 + 2 + N_OBS + 2 + work_size(n_thrusters)) + 1
    step = 8 * 2 * n_act + 4 * N_OBS + 8 * 2 + 3 + 8 * 16
    return 2 * (spaces_ + state + step)  # twice: numpy's temporaries in step() and reset()


# ---------------------------------------------------------------------------------------------
# Shared configuration
# ---------------------------------------------------------------------------------------------
class _Config:
    """Vehicle arrays and episode settings shared by the single and the vector environment."""

    def __init__(self, vehicle, *, dt, substeps, max_steps, action, offset_range, current,
                 current_range, waypoints, acceptance_radius, max_distance, weights, inflow):
        from uuvid.vehicle.definition import as_vehicle
        from uuvid.vehicle.inflow import loop_arrays

        v = as_vehicle(vehicle, "expected a preset name, a vehicle file or a Vehicle "
                                "(uuvid.vehicle.definition.load_vehicle)")
        self.vehicle = v
        lim = v.layout.limits
        if v.layout.n == 0:
            raise ValueError(f"{v.name}: the vehicle has no thrusters to act with")
        if not np.all(np.isfinite(lim)):
            bad = [t.name for t, row in zip(v.layout, lim) if not np.all(np.isfinite(row))]
            raise ValueError(f"{v.name}: thrusters {bad} have no finite limits; actions are "
                             "normalised to the limits")
        self.dt = _positive("dt", dt, "a finite number > 0 (s)")
        if self.dt < MIN_DT:
            raise ValueError(f"dt must be at least {MIN_DT:g} s (a control step shorter than any "
                             f"thruster's command update: is it in ms?), got {dt!r}")
        # at most MAX_SUBSTEPS: every step() would run minutes in an uninterruptible loop
        self.nsub = count("substeps", substeps, "a number of RK4 steps per control step",
                          maximum=MAX_SUBSTEPS,
                          hint=f"a step of dt/{MAX_SUBSTEPS:,} buys RK4 no accuracy, only time")
        self.max_steps = count("max_steps", max_steps, "a number of control steps per episode")
        self.lo = np.array(lim[:, 0], dtype=float, order="C")  # writable copies, as the compiled
        self.hi = np.array(lim[:, 1], dtype=float, order="C")  # step was built for (a vehicle's
        self.B = np.array(v.B, dtype=float, order="C")  # B and limits are read-only)
        self.vp = v.params.to_array()
        al = v.allocator()
        self.alloc = al.to_array("scale")  # uniform scaling: cheap per step, keeps the direction
        self.dofs = np.array(al.controlled, dtype=np.int64)
        if action == "thrust":
            self.mode, self.n_act = 0, v.layout.n
            self.fscale = np.zeros(len(self.dofs))
        elif action == "force":
            self.mode, self.n_act = 1, len(self.dofs)
            fs = []
            for d in self.dofs:
                phi = np.zeros(6)
                phi[d] = 1.0
                fs.append(al.max_along(phi))
            self.fscale = np.array(fs, dtype=float)
        else:
            raise ValueError(f"action must be 'thrust' or 'force', got {action!r}")
        self.offset_range = _real_array("offset_range", offset_range, (4,),
                                        "finite numbers >= 0 (one, or [n, e, d, yaw])", minimum=0.0)
        what = "3 finite numbers [n, e, d] (m/s)"
        if np.shape(current) != (3,):
            raise ValueError(f"current must be {what}, got {current!r}")
        self.current = _real_array("current", current, (3,), what)
        self.current_range = float(_real_array("current_range", current_range, (),
                                               "a finite number >= 0 (m/s)", minimum=0.0))
        wps = np.zeros((1, 4)) if waypoints is None else np.asarray(waypoints, dtype=float)
        if wps.ndim != 2 or wps.shape[1] != 4 or len(wps) == 0 or not np.all(np.isfinite(wps)):
            raise ValueError("waypoints must be rows of [north, east, down, yaw] (m, rad)")
        self.wps = np.ascontiguousarray(wps)
        self.accept = float(_real_array("acceptance_radius", acceptance_radius, (),
                                        "a finite number >= 0 (m)", minimum=0.0))
        self.max_distance = _positive("max_distance", max_distance,
                                      "a number > 0 (m; inf: never lost)", allow_inf=True)
        if np.ndim(weights) != 1 or np.size(weights) != 4:
            raise ValueError(f"weights must be 4 finite numbers >= 0 (w_p, w_a, w_v, w_u), "
                             f"got {weights!r}")
        self.w = _real_array("weights", weights, (4,), "4 finite numbers >= 0 (w_p, w_a, w_v, w_u)",
                             minimum=0.0)
        speed = float(np.linalg.norm(self.current)) + math.sqrt(2.0) * self.current_range
        hmax, dof, rate = rk4_step_limit(v, speed)
        if self.dt / self.nsub > hmax:
            # the bound is an estimate (uncoupled DOFs at their top speed): past twice it the
            # plant diverges, refused; just past it (a vehicle file whose identified inertia or
            # drag moves the bound under the default step) is said, and a diverging episode
            # ends on its non-finite state
            need = math.ceil(self.dt / hmax)
            msg = (f"dt / substeps = {self.dt:g} / {self.nsub} = {self.dt / self.nsub:.4g} s is "
                   f"beyond {v.name}'s RK4 stability bound {hmax:.4g} s (DOF {dof} damps at "
                   f"{rate:.3g}/s at full thrust): need dt <= {hmax * self.nsub:.4g} s, or "
                   f"substeps >= {need}")
            if self.dt / self.nsub > 2.0 * hmax:
                raise ValueError(msg)
            warnings.warn(msg + " (an estimate: episodes may diverge and end)", InputWarning,
                          stacklevel=3)
        arrays = loop_arrays(v, inflow)
        self.iprm, self.igeo = arrays if arrays is not None else (np.zeros(0), np.zeros((0, 13)))
        self.igeo = check_geometry(self.igeo)

    def initial_states(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``n`` random 13-states around the first waypoint and their currents."""
        off = rng.uniform(-1.0, 1.0, size=(n, 4)) * self.offset_range
        Z = np.zeros((n, 13))
        Z[:, 0:3] = self.wps[0, 0:3] + off[:, 0:3]
        yaw = self.wps[0, 3] + off[:, 3]
        Z[:, 3] = np.cos(yaw / 2)
        Z[:, 6] = np.sin(yaw / 2)
        VC = np.tile(self.current, (n, 1))
        if self.current_range > 0:
            VC[:, 0:2] += rng.uniform(-self.current_range, self.current_range, size=(n, 2))
        return Z, VC

    def spaces(self):
        act = spaces.Box(-1.0, 1.0, shape=(self.n_act,), dtype=np.float32)
        obs = spaces.Box(-np.inf, np.inf, shape=(N_OBS,), dtype=np.float32)
        return obs, act


_DEFAULTS = dict(dt=0.1, substeps=2, max_steps=400, action="thrust",
                 offset_range=(2.0, 2.0, 1.0, math.pi / 4), current=(0.0, 0.0, 0.0),
                 current_range=0.0, waypoints=None, acceptance_radius=0.25, max_distance=10.0,
                 weights=(1.0, 0.5, 0.1, 0.05), inflow=None)


class StationKeepingEnv(gym.Env):
    """One vehicle holding station (or following waypoints); see the module docstring.

    ``vehicle``: preset name, vehicle file, or a loaded :class:`uuvid.vehicle.definition.Vehicle`.
    """

    metadata = {"render_modes": []}

    def __init__(self, vehicle="bluerov2", **kw):
        unknown = set(kw) - set(_DEFAULTS)
        if unknown:
            raise TypeError(f"unknown options {sorted(unknown)}; known: {sorted(_DEFAULTS)}")
        self.cfg = _Config(vehicle, **{**_DEFAULTS, **kw})
        self.observation_space, self.action_space = self.cfg.spaces()
        self._z = np.zeros(13)
        self._vc = np.zeros(3)
        self._widx = np.zeros(1, dtype=np.int64)
        self._obs = np.zeros(N_OBS)
        self._work = np.zeros(work_size(self.cfg.B.shape[1]))
        self._steps = 0
        self._reset_done = False  # step() needs a reset() first
        self._ended = False  # the episode returned terminated or truncated
        self._warned_ended = False

    @property
    def state(self) -> np.ndarray:
        """The vehicle's 13-state ``[p, q, ν]`` (a copy)."""
        return self._z.copy()

    def reset(self, *, seed=None, options=None):
        _check_reset_options(self, options)
        super().reset(seed=seed)
        Z, VC = self.cfg.initial_states(self.np_random, 1)
        self._z = Z[0].copy()
        self._vc = VC[0].copy()
        self._widx[0] = 0
        self._steps = 0
        self._reset_done, self._ended, self._warned_ended = True, False, False
        _observe(self._z, self.cfg.wps[0], self._obs)
        return self._obs.astype(np.float32), {"waypoint": 0}

    def step(self, action):
        """One control step.  ``action``: shape ``(n_act,)``, clipped to ``[−1, 1]`` (``±inf`` to
        the bound); a NaN or another shape is a ``ValueError``.  Before ``reset()``:
        :class:`gymnasium.error.ResetNeeded`; after the episode ended: a warning (once)."""
        c = self.cfg
        if not self._reset_done:
            raise ResetNeeded("StationKeepingEnv: call reset() before step()")
        a = _check_action(action, (c.n_act,))
        if self._ended and not self._warned_ended:
            warnings.warn("StationKeepingEnv.step() after the episode ended (terminated or truncated "
                          "was returned): call reset() to start a new episode", UserWarning,
                          stacklevel=2)
            self._warned_ended = True
        rew, dist = _step_one(self._z, a, c.wps, self._widx, c.mode, c.alloc, c.dofs, c.fscale,
                              c.lo, c.hi, c.B, c.vp, self._vc, c.dt, c.nsub, c.w, c.accept,
                              self._obs, self._work, c.iprm, c.igeo)
        self._steps += 1
        terminated = bool(dist > c.max_distance or not np.all(np.isfinite(self._z)))
        truncated = bool(self._steps >= c.max_steps)
        self._ended = self._ended or terminated or truncated
        return (self._obs.astype(np.float32), float(rew), terminated, truncated,
                {"waypoint": int(self._widx[0]), "position_error": float(dist)})


class StationKeepingVectorEnv(VectorEnv):
    """``num_envs`` vehicles stepped in one parallel compiled call (next-step autoreset).

    Same options as :class:`StationKeepingEnv`; every copy flies the same vehicle with its own
    random start (and current, with ``current_range``).
    """

    metadata = {"render_modes": [], "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}

    def __init__(self, vehicle="bluerov2", num_envs: int = 16, **kw):
        unknown = set(kw) - set(_DEFAULTS)
        if unknown:
            raise TypeError(f"unknown options {sorted(unknown)}; known: {sorted(_DEFAULTS)}")
        self.num_envs = count("num_envs", num_envs, "a number of environment copies")
        self.cfg = _Config(vehicle, **{**_DEFAULTS, **kw})
        from uuvid.simulate.footprint import flight_memory_limit, size_text

        need, limit = self.num_envs * env_bytes(self.cfg.n_act, self.cfg.B.shape[1]), flight_memory_limit()
        if need > limit:  # before gymnasium's batch_space allocates its bounds
            most = int(limit // env_bytes(self.cfg.n_act, self.cfg.B.shape[1]))
            raise ValueError(f"num_envs = {self.num_envs:,} copies would take about {size_text(need)} "
                             f"of memory, more than the {size_text(limit)} one environment may take "
                             f"here: at most {most:,} copies")
        self.single_observation_space, self.single_action_space = self.cfg.spaces()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        n = self.num_envs
        self._Z = np.zeros((n, 13))
        self._VC = np.zeros((n, 3))
        self._widx = np.zeros(n, dtype=np.int64)
        self._steps = np.zeros(n, dtype=np.int64)
        self._obs = np.zeros((n, N_OBS))
        self._rew = np.zeros(n)
        self._dist = np.zeros(n)
        self._needs_reset = np.zeros(n, dtype=bool)
        self._work = np.zeros((n, work_size(self.cfg.B.shape[1])))
        self._reset_done = False  # step() needs a reset() first

    @property
    def states(self) -> np.ndarray:
        """The vehicles' 13-states (``num_envs`` × 13, a copy)."""
        return self._Z.copy()

    def _reset_rows(self, mask: np.ndarray) -> None:
        k = int(mask.sum())
        Z, VC = self.cfg.initial_states(self.np_random, k)
        self._Z[mask] = Z
        self._VC[mask] = VC
        self._widx[mask] = 0
        self._steps[mask] = 0

    def reset(self, *, seed=None, options=None):
        _check_reset_options(self, options)
        super().reset(seed=seed)
        self._reset_rows(np.ones(self.num_envs, dtype=bool))
        self._needs_reset[:] = False
        self._reset_done = True
        self._run(np.zeros((self.num_envs, self.cfg.n_act)), np.zeros(self.num_envs, dtype=bool))
        return self._obs.astype(np.float32), {}

    def _run(self, actions, active):
        c = self.cfg
        _step_batch(self._Z, actions, c.wps, self._widx, active, c.mode, c.alloc, c.dofs,
                    c.fscale, c.lo, c.hi, c.B, c.vp, self._VC, c.dt, c.nsub, c.w, c.accept,
                    self._obs, self._rew, self._dist, self._work, c.iprm, c.igeo)

    def step(self, actions):
        """One control step of every copy.  ``actions``: shape ``(num_envs, n_act)`` exactly (no
        reshaping), clipped to ``[−1, 1]``; a NaN is a ``ValueError`` naming ``(env, index)``.
        Before ``reset()``: :class:`gymnasium.error.ResetNeeded`."""
        c = self.cfg
        if not self._reset_done:
            raise ResetNeeded("StationKeepingVectorEnv: call reset() before step()")
        a = _check_action(actions, (self.num_envs, c.n_act), "actions")
        resetting = self._needs_reset
        if resetting.any():
            self._reset_rows(resetting)
        active = ~resetting
        self._run(a, active)
        self._steps[active] += 1
        terminated = active & ((self._dist > c.max_distance)
                               | ~np.all(np.isfinite(self._Z), axis=1))
        truncated = active & (self._steps >= c.max_steps)
        self._needs_reset = terminated | truncated
        return (self._obs.astype(np.float32), self._rew.copy(), terminated, truncated,
                {"waypoint": self._widx.copy()})
