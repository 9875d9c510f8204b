"""Gymnasium environments: station keeping / waypoint tracking for any uuvid vehicle file.

``pip install uuvid[gym]``.  The plant is the 6-DOF model of :mod:`uuvid.vehicle.model`
(:func:`uuvid.vehicle.model.vehicle_rhs_into`, RK4 with ``substeps`` per control step ``dt``,
:func:`uuvid.simulate.station_keeping.rk4_held`) with ideal thrusters held over the step, clipped
to their limits, in a constant NED current (optionally randomised per episode).

* **Action** (``action="thrust"``, default): one value per thruster in ``[−1, 1]``; ``a ≥ 0`` asks
  for ``a · f_max``, ``a < 0`` for ``|a| · f_min`` of the thruster's ``limits``.  With
  ``action="force"``: one value per allocated DOF (``allocation.dofs`` of the vehicle file) in
  ``[−1, 1]`` of the largest force the thrusters give along it, allocated by the vehicle's
  allocator (:func:`uuvid.vehicle.allocation.allocate_compiled`).
* **Observation** (12, float32): target position error in body axes ``R(q)ᵀ(p_t − p)`` (m),
  roll, pitch and the wrapped yaw error ``ψ_t − ψ`` (rad), body velocities ``ν`` (m/s, rad/s).
* **Reward**: ``−(w_p |e_p| + w_a |[φ, θ, e_ψ]| + w_v |ν| + w_u |a|²/n_a) · dt`` (weights
  ``weights = (w_p, w_a, w_v, w_u)``).
* **Episode**: starts at rest at a uniformly random offset (``offset_range`` = ±[n, e, d, ψ]) from
  the first target; with ``waypoints`` (rows ``[n, e, d, ψ]``) the target moves on when the
  position error is below ``acceptance_radius``, and the last one is held.  Terminated when the
  position error exceeds ``max_distance`` (lost); truncated after ``max_steps``.

:class:`StationKeepingEnv` is one vehicle (passes ``gymnasium.utils.env_checker.check_env``);
:class:`StationKeepingVectorEnv` steps ``num_envs`` vehicles in one parallel compiled call
(numba ``prange``), next-step autoreset as in Gymnasium's own vector environments.

``inflow`` (``None``: the vehicle file's key; ``'none'``; ``'four-quadrant'``): the held thrusts
are taken to each thruster's advance speed at every RK4 stage (:mod:`uuvid.vehicle.inflow`,
issue 21); the action still scales the bollard limits.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numba import njit, prange

try:
    import gymnasium as gym
    from gymnasium import spaces
    from gymnasium.vector import VectorEnv
    from gymnasium.vector.utils import batch_space
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("uuvid.simulate.gym_env needs gymnasium: pip install 'uuvid[gym]'") from e

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
# Shared configuration
# ---------------------------------------------------------------------------------------------
class _Config:
    """Vehicle arrays and episode settings shared by the single and the vector environment."""

    def __init__(self, vehicle, *, dt, substeps, max_steps, action, offset_range, current,
                 current_range, waypoints, acceptance_radius, max_distance, weights, inflow):
        from uuvid.vehicle.definition import load_vehicle
        from uuvid.vehicle.inflow import loop_arrays

        v = load_vehicle(vehicle) if isinstance(vehicle, (str, Path)) else vehicle
        self.vehicle = v
        lim = v.layout.limits
        if v.layout.n == 0:
            raise ValueError(f"{v.name}: the vehicle has no thrusters to act with")
        if not np.all(np.isfinite(lim)):
            bad = [t.name for t, row in zip(v.layout, lim) if not np.all(np.isfinite(row))]
            raise ValueError(f"{v.name}: thrusters {bad} have no finite limits; actions are "
                             "normalised to the limits")
        if not (dt > 0 and int(substeps) >= 1 and int(max_steps) >= 1):
            raise ValueError("need dt > 0, substeps >= 1 and max_steps >= 1")
        self.dt, self.nsub, self.max_steps = float(dt), int(substeps), int(max_steps)
        self.lo = np.ascontiguousarray(lim[:, 0])
        self.hi = np.ascontiguousarray(lim[:, 1])
        self.B = np.ascontiguousarray(v.B, dtype=float)
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
        self.offset_range = np.broadcast_to(np.asarray(offset_range, float), (4,)).copy()
        self.current = np.asarray(current, dtype=float).reshape(3)
        self.current_range = float(current_range)
        wps = np.zeros((1, 4)) if waypoints is None else np.asarray(waypoints, dtype=float)
        if wps.ndim != 2 or wps.shape[1] != 4 or len(wps) == 0 or not np.all(np.isfinite(wps)):
            raise ValueError("waypoints must be rows of [north, east, down, yaw] (m, rad)")
        self.wps = np.ascontiguousarray(wps)
        self.accept = float(acceptance_radius)
        self.max_distance = float(max_distance)
        self.w = np.asarray(weights, dtype=float).reshape(4)
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

    @property
    def state(self) -> np.ndarray:
        """The vehicle's 13-state ``[p, q, ν]`` (a copy)."""
        return self._z.copy()

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        Z, VC = self.cfg.initial_states(self.np_random, 1)
        self._z = Z[0].copy()
        self._vc = VC[0].copy()
        self._widx[0] = 0
        self._steps = 0
        _observe(self._z, self.cfg.wps[0], self._obs)
        return self._obs.astype(np.float32), {"waypoint": 0}

    def step(self, action):
        c = self.cfg
        a = np.asarray(action, dtype=np.float64).reshape(c.n_act)
        rew, dist = _step_one(self._z, a, c.wps, self._widx, c.mode, c.alloc, c.dofs, c.fscale,
                              c.lo, c.hi, c.B, c.vp, self._vc, c.dt, c.nsub, c.w, c.accept,
                              self._obs, self._work, c.iprm, c.igeo)
        self._steps += 1
        terminated = bool(dist > c.max_distance or not np.all(np.isfinite(self._z)))
        truncated = bool(self._steps >= c.max_steps)
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
        if int(num_envs) < 1:
            raise ValueError("num_envs must be >= 1")
        self.cfg = _Config(vehicle, **{**_DEFAULTS, **kw})
        self.num_envs = int(num_envs)
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
        super().reset(seed=seed)
        self._reset_rows(np.ones(self.num_envs, dtype=bool))
        self._needs_reset[:] = False
        self._run(np.zeros((self.num_envs, self.cfg.n_act)), np.zeros(self.num_envs, dtype=bool))
        return self._obs.astype(np.float32), {}

    def _run(self, actions, active):
        c = self.cfg
        _step_batch(self._Z, actions, c.wps, self._widx, active, c.mode, c.alloc, c.dofs,
                    c.fscale, c.lo, c.hi, c.B, c.vp, self._VC, c.dt, c.nsub, c.w, c.accept,
                    self._obs, self._rew, self._dist, self._work, c.iprm, c.igeo)

    def step(self, actions):
        c = self.cfg
        a = np.ascontiguousarray(actions, dtype=np.float64).reshape(self.num_envs, c.n_act)
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
