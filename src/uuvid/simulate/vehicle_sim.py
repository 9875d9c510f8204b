"""A vehicle flying a mission: thrusters → allocation → vehicle → controller, one compiled loop.

Block diagram (Laidani et al. §5; Caccia et al. §II):

    reference ─► DP controller (PID, body frame) ─► τ_des ─► allocation (uniform scaling) ─► f_des
        ─► inverse steady map of each thruster model ─► command ─► thruster dynamics ─► f
        ─► installation coefficients η ─► τ = B η f ─► 6-DOF vehicle ─► state ─► controller

The controller and the allocation run once per step ``dt`` (zero-order hold, as a digital
autopilot does); the vehicle and thruster states advance together by RK4 with ``substeps`` steps
per ``dt``.  Every thruster of a vehicle shares one chain structure (its parameters may differ);
any chain of the thruster blocks works — a first-order thrust lag, or PWM → ESC → motor → map.
Outputs go into preallocated arrays; :func:`run_batch` flies many perturbed vehicles in parallel.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit, prange

from uuvid.core.checks import MAX_SUBSTEPS  # re-exported: most RK4 steps per sample/step
from uuvid.core.result import DictSummaryResult, jsonable
from uuvid.simulate.control.blocks import Controller, compiled_form
from uuvid.simulate.control.pid import PID_STATE_SIZE, DPGains, gains_from_bandwidth, pid, pid_controller
from uuvid.simulate.disturbances import Disturbance, no_disturbance
from uuvid.simulate.reference import (
    CANNOT_FLY,
    WaypointMission,
    current_limit_warning,
    level_speed_limit,
    vehicle_ref,
)
from uuvid.thruster import kernels
from uuvid.thruster.blocks import CHANNELS, K_FIRST_ORDER_MOTOR, ParameterError
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.inflow import inflow_thrust_at_nb, inflow_thrust_nb, tip_speed_nb
from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.inflow import check_geometry, state_advance_speeds_nb
from uuvid.vehicle.kinematics import normalise_state
from uuvid.vehicle.model import MAX_TILT_DEG, vehicle_rhs_into, vehicle_rhs_still_into

N_CH = len(CHANNELS)


# ---------------------------------------------------------------------------------------------
# Thruster bank: n thrusters sharing one chain structure
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ThrusterBank:
    """Compiled description of the vehicle's thrusters and the inverse of their steady maps."""

    chains: tuple[ThrusterChain, ...]
    kinds: np.ndarray
    poff: np.ndarray
    params: np.ndarray  # (n, P)
    soff: np.ndarray
    outch: np.ndarray
    in_ch: int
    exact: np.ndarray
    inv_thrust: np.ndarray  # (n, K) steady thrust, strictly increasing
    inv_command: np.ndarray  # (n, K) command giving it
    neutral: np.ndarray  # (n,) command for zero thrust

    @property
    def n(self) -> int:
        return len(self.chains)

    @property
    def n_states(self) -> int:
        return int(self.soff[-1])

    @classmethod
    def from_chains(cls, chains, points: int = 401) -> ThrusterBank:
        chains = tuple(chains)
        comp = [c.compile() for c in chains]
        k0 = comp[0]
        for i, c in enumerate(comp[1:], 1):
            if not (np.array_equal(c.kinds, k0.kinds) and np.array_equal(c.poff, k0.poff)
                    and np.array_equal(c.soff, k0.soff)):
                raise ValueError(f"thruster {i} ({chains[i].name}) has a different block structure "
                                 f"from thruster 0 ({chains[0].name}); one vehicle needs one structure")
        inv_t, inv_c, neutral = [], [], []
        for ch in chains:
            t, c, z = _inverse_table(ch, points)
            inv_t.append(t)
            inv_c.append(c)
            neutral.append(z)
        return cls(chains, k0.kinds, k0.poff, np.stack([c.params for c in comp]), k0.soff,
                   k0.outch, k0.in_ch, k0.exact, np.stack(inv_t), np.stack(inv_c),
                   np.array(neutral, dtype=float))


def _command_range(chain: ThrusterChain) -> tuple[float, float, float]:
    """(low, high, neutral) of a chain's input."""
    from uuvid.thruster.blocks import ESC

    first = chain.blocks[0]
    if isinstance(first, ESC) and math.isfinite(first.saturation_low):
        return first.saturation_low, first.saturation_high, first.neutral
    if chain.input_kind == "voltage":
        v = getattr(getattr(first, "motor", first), "resistance", None)
        vmax = 24.0 if v is not None else 12.0
        return -vmax, vmax, 0.0
    if chain.input_kind == "speed":
        raise ValueError(f"thruster model {chain.name!r} takes the propeller speed (rad/s) as its "
                         "input and holds no speed range: a mission commands a thruster through "
                         "its command range (an ESC or a command-driven model)")
    return -1.0, 1.0, 0.0


@functools.lru_cache(maxsize=64)
def _inverse_table(chain: ThrusterChain, points: int):
    """Steady thrust over the command range, made strictly increasing for inversion (memoised:
    a vehicle's identical thrusters share one table)."""
    if chain.input_kind == "thrust" or chain.signal_kinds[0] == "thrust":
        x = np.linspace(-1e4, 1e4, 3)
        return x.copy(), x.copy(), 0.0
    lo, hi, neutral = _command_range(chain)
    c = np.linspace(lo, hi, points)
    return _inverse_from(c, chain.steady_thrust(c), neutral, points)


def _inverse_from(c, f, neutral, points):
    """Strictly increasing (thrust, command) table of ``points`` rows from a steady map."""
    order = np.argsort(f, kind="stable")
    f, c = f[order], c[order]
    keep = np.concatenate([[True], np.diff(f) > 1e-12 * max(1.0, float(np.max(np.abs(f))))])
    f, c = f[keep], c[keep]
    # zero thrust → the neutral command exactly
    if f[0] < 0 < f[-1]:
        k = np.searchsorted(f, 0.0)
        f = np.insert(f, k, 0.0)
        c = np.insert(c, k, neutral)
        keep = np.concatenate([[True], np.diff(f) > 0])
        f, c = f[keep], c[keep]
    out_t = np.interp(np.linspace(0, 1, points), np.linspace(0, 1, f.size), f)
    out_c = np.interp(out_t, f, c)
    out_t.flags.writeable = False
    out_c.flags.writeable = False
    return out_t, out_c, neutral


_interp = kernels.interp_sorted


def battery_limits(bat: np.ndarray, volts) -> tuple[np.ndarray, np.ndarray]:
    """Thrust limits ``(lo, hi)`` (N) at supply voltages ``volts``, interpolated in the voltage
    grid of a :func:`battery_tables` array."""
    nv, nso = int(bat[5]), int(bat[7])
    o = 8 + 2 * nso
    vgrid, lo, hi = bat[o:o + nv], bat[o + nv:o + 2 * nv], bat[o + 2 * nv:o + 3 * nv]
    v = np.atleast_1d(np.asarray(volts, dtype=float))
    return np.interp(v, vgrid, lo), np.interp(v, vgrid, hi)


def battery_tables(bank: ThrusterBank, battery, soc0: float = 1.0, points: int = 401,
                   voltages: int = 25) -> np.ndarray:
    """Flat battery array for :func:`fly`: battery parameters, OCV table and, at a grid of supply
    voltages, the thrust limits, the inverse steady map (command for a thrust) and the supply
    current (the battery's thruster power model, e.g. the voltage-aware T200) of the vehicle's
    thruster chain with its ESC at that voltage (``chain.steady_thrust`` through
    :func:`_inverse_table`).  Needs identical chains whose first block is an ESC (the static
    prefix in front of the dynamics)."""
    import dataclasses

    from uuvid.core.checks import state_of_charge
    from uuvid.thruster.blocks import ESC
    from uuvid.thruster.physical import physical_model
    from uuvid.vehicle.power import SupplyThruster

    ch = bank.chains[0]
    if any(c != ch for c in bank.chains[1:]):
        raise ValueError("a battery run needs identical thruster chains")
    esc = ch.blocks[0]
    if not isinstance(esc, ESC) or len(ch.blocks) < 2 or not np.any(bank.soff[1:] > 0):
        raise ValueError(f"a battery run needs an ESC-driven chain (ESC → dynamics → map); "
                         f"{ch.name} starts with {type(esc).__name__}")
    if not esc.follows_supply:  # a map of the command: no voltage law to follow a sagging pack
        raise ValueError(f"a battery run needs thrusters whose thrust follows the supply voltage; "
                         f"{ch.name} is a map fitted on the command at the bench's supply (its "
                         "first block is no voltage source, follows_supply: false): fly without "
                         "the battery, or fit the thrusters with --model physical")
    soc0 = state_of_charge("soc0", soc0)
    st = SupplyThruster(physical_model(battery.thruster_power_model))
    vmin = max(min(battery.ocv_voltage) * 0.8, 1.0)
    vgrid = np.linspace(vmin, max(battery.ocv_voltage), voltages)
    # the chain of the power model itself (the default on a battery): its steady map is the
    # model's closed form (equal to chain.steady_thrust to 1e-10 N), much faster to tabulate
    closed = st.model.to_chain(esc.supply_voltage) == ch
    lo, hi, tt, tc, ti = [], [], [], [], []
    for v in vgrid:
        k = v / esc.supply_voltage
        e2 = dataclasses.replace(esc, a_fwd=esc.a_fwd * k, b_fwd=esc.b_fwd * k,
                                 a_rev=esc.a_rev * k, b_rev=esc.b_rev * k, supply_voltage=float(v))
        if closed:
            cg = np.linspace(esc.saturation_low, esc.saturation_high, points)
            t, c, _ = _inverse_from(cg, st.model.thrust(cg, float(v)), esc.neutral, points)
        else:
            t, c, _ = _inverse_table(dataclasses.replace(ch, blocks=(e2,) + ch.blocks[1:]), points)
        lo.append(t[0])
        hi.append(t[-1])
        tt.append(t)
        tc.append(c)
        ti.append(st.current(t, float(v)))
    so, vo = np.asarray(battery.ocv_soc, float), np.asarray(battery.ocv_voltage, float)
    return np.concatenate([[battery.capacity_ah, battery.resistance, battery.hotel_load_w, soc0,
                            esc.supply_voltage, voltages, points, so.size], so, vo, vgrid, lo, hi,
                           np.ravel(tt), np.ravel(tc), np.ravel(ti)]).astype(float)


# ---------------------------------------------------------------------------------------------
# Compiled loop
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def _rhs(z, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc, dvc, dz,
         thrust, tau, ch, blk):
    """Derivative of the combined state z = [vehicle (13), thruster states (n·ns)] (no
    disturbance force; :func:`_rhs_d`)."""
    _rhs_d(z, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc, dvc,
           dz, thrust, tau, ch, blk, np.zeros(6), np.zeros(0), np.zeros((0, 13)), np.zeros(0))


@njit(cache=True)
def _rhs_d(z, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc, dvc,
           dz, thrust, tau, ch, blk, tau_d, IPRM, IGEO, ua):
    """Derivative of the combined state z = [vehicle (13), thruster states (n·ns)] under the
    thrust and the disturbance force ``tau_d`` (body frame).

    Inflow (issue 21; ``IPRM`` empty: off, bollard thrusters as before): each chain's thrust is
    taken to its advance speed at this stage's state, ``u_a = (1 − w) axisᵀ(v_r + ω × r)``
    (:func:`uuvid.vehicle.inflow.state_advance_speeds_nb`, geometry ``IGEO``), through the
    four-quadrant map (:func:`uuvid.thruster.inflow.inflow_thrust_nb`, parameters ``IPRM``).

    ``tparams`` is (n, P); thruster i's states start at ``13 + i·ns``; ``blk`` is (n, nb).
    ``sig0[i]`` is the (held) input of block ``start`` of thruster i: the static blocks in front
    of the first dynamic one were evaluated once for the step."""
    n = tparams.shape[0]
    P = tparams.shape[1]
    ns = soff[soff.size - 1]
    nb = blk.shape[1]
    tflat = tparams.reshape(n * P)
    bflat = blk.reshape(n * nb)
    inflow = IPRM.size > 0
    if inflow:
        state_advance_speeds_nb(z, vc, IGEO, ua)
    for i in range(n):
        f = kernels.eval_chain_at(kinds, poff, tflat, i * P, soff, outch, in_ch, z, 13 + i * ns,
                                  sig0[i], dz, ch, bflat, i * nb, start)
        if inflow:
            f = inflow_thrust_nb(f, ua[i], IPRM)
        thrust[i] = f * (eta_p[i] if f >= 0.0 else eta_n[i])
    for k in range(6):
        s = tau_d[k]
        for i in range(n):
            s += B[k, i] * thrust[i]
        tau[k] = s
    vehicle_rhs_into(z[:13], tau, vp, vc, dvc, dz[:13])


@njit(cache=True, inline="always")
def _tau_from(th, st, B, tau, tau_d):
    n = th.shape[1]
    for k in range(6):
        acc = tau_d[k]
        for i in range(n):
            acc += B[k, i] * th[st, i]
        tau[k] = acc


@njit(cache=True, inline="always")
def _vehicle_rk4(z, h, th_stage, B, vp, vc0, vc1, vc2, dvc, tau, zt, K, tau_d, still, fsc):
    """One RK4 step of the 13 vehicle states with the thrust (``th_stage``) and the current
    (``vc0``, ``vc1``, ``vc2``, NED) known at t, t + h/2 and t + h, plus the held disturbance
    force ``tau_d``; ``still``: there is no current (its terms skipped; ``fsc``: 6 values of
    scratch).  The stages run in a loop (``K`` holds their 4 × 13 slopes) so that the
    right-hand side is compiled into the mission loop once, not four times."""
    for i in range(13):
        zt[i] = z[i]
    for st in range(4):
        _tau_from(th_stage, 0 if st == 0 else (1 if st < 3 else 2), B, tau, tau_d)
        kk = K[st]
        if still:
            vehicle_rhs_still_into(zt, tau, vp, fsc, kk)
        else:
            vehicle_rhs_into(zt, tau, vp, vc0 if st == 0 else (vc1 if st < 3 else vc2), dvc, kk)
        if st < 3:
            c = 1.0 if st == 2 else 0.5
            for i in range(13):
                zt[i] = z[i] + c * h * kk[i]
    for i in range(13):
        z[i] = z[i] + h / 6.0 * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])


@njit(cache=True, inline="always")
def _tau_inflow(th, st, zs, vc, B, tau, tau_d, eta_p, eta_n, IPRM, IGEO, ua):
    """``τ`` at one RK4 stage with the bollard thrusts ``th[st]`` taken to the advance speed of the
    stage state ``zs`` (:func:`_rhs_d`'s inflow, for the closed-form fast path)."""
    n = th.shape[1]
    state_advance_speeds_nb(zs, vc, IGEO, ua)
    for i in range(n):
        f = inflow_thrust_nb(th[st, i], ua[i], IPRM)
        ua[i] = f * (eta_p[i] if f >= 0.0 else eta_n[i])  # ua reused for the delivered thrust
    for k in range(6):
        acc = tau_d[k]
        for i in range(n):
            acc += B[k, i] * ua[i]
        tau[k] = acc


@njit(cache=True)
def _vehicle_rk4_inflow(z, h, th_stage, B, vp, vc0, vc1, vc2, dvc, tau, zt, k1, k2, k3, k4, tau_d,
                        eta_p, eta_n, IPRM, IGEO, ua, still, fsc, f0):
    """:func:`_vehicle_rk4` with thrust at the advance speed of each stage's own state;
    ``still``: no current (the still-water right-hand side, ``fsc`` 6 values of scratch);
    ``f0`` receives the delivered thrusts at the step's start (its first stage)."""
    for st in range(4):
        zs = z if st == 0 else zt
        kk = k1 if st == 0 else (k2 if st == 1 else (k3 if st == 2 else k4))
        vcs = vc0 if st == 0 else (vc1 if st < 3 else vc2)
        _tau_inflow(th_stage, 0 if st == 0 else (1 if st < 3 else 2), zs, vcs, B, tau, tau_d,
                    eta_p, eta_n, IPRM, IGEO, ua)
        if st == 0:
            for i in range(ua.size):
                f0[i] = ua[i]
        if still:
            vehicle_rhs_still_into(zs, tau, vp, fsc, kk)
        else:
            vehicle_rhs_into(zs, tau, vp, vcs, dvc, kk)
        if st < 3:
            c = 1.0 if st == 2 else 0.5
            for i in range(13):
                zt[i] = z[i] + c * h * kk[i]
    for i in range(13):
        z[i] = z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _ocv(BAT, soc):
    no = int(BAT[7])
    return kernels.interp_sorted(BAT[8:8 + no], BAT[8 + no:8 + 2 * no], soc)


@njit(cache=True)
def _set_limits(a, n, lo, hi):
    """Thrust limits ``[lo, hi]`` for every thruster in an allocation array (command limits and,
    for the bounded methods, the planned ones: η-scaled when compensating)."""
    m = int(a[1])
    olo = 3 + n * m
    ohi = olo + n
    oep = ohi + n
    oen = oep + n
    comp = a[2] != 0.0
    for i in range(n):
        a[olo + i] = lo
        a[ohi + i] = hi
    o = oen + n
    if a.size > o:
        opl = o + 3 + m + n
        for i in range(n):
            a[opl + i] = lo * a[oen + i] if comp else lo
            a[opl + n + i] = hi * a[oep + i] if comp else hi


@njit(cache=True)
def _thrusts_from_output(out_kind, cout, a, inv_t, inv_c, batt, vtt, vtc, jv, wv, B, eta_p, eta_n,
                         fdes, tau_rec):
    """Thrusts ``fdes`` from a per-thruster controller output, and the wrench they give at steady
    state ``tau_rec = B (η ∘ f)``; returns the step's scale.

    ``out_kind`` 1: ``cout`` are thrusts, clipped to the limits of the allocation array ``a``
    (the battery's at the present voltage); the scale is the smallest ratio clipped/requested.
    2: ``cout`` are commands; ``fdes`` is their steady thrust, the inverse tables (at the present
    voltage on a battery: ``vtt``, ``vtc`` rows ``jv``, ``jv + 1`` weighted by ``wv``) read from
    command to thrust; scale 1."""
    n = fdes.size
    m = int(a[1])
    olo = 3 + n * m
    ohi = olo + n
    s = 1.0
    for i in range(n):
        u = cout[i]
        if out_kind == 1:
            f = min(max(u, a[olo + i]), a[ohi + i])
            if f != u and u != 0.0:
                s = min(s, f / u)
        elif batt:
            f = (1 - wv) * _interp(vtc[jv], vtt[jv], u) + wv * _interp(vtc[jv + 1], vtt[jv + 1], u)
        else:
            f = _interp(inv_c[i], inv_t[i], u)
        fdes[i] = f
    for k in range(6):
        acc = 0.0
        for i in range(n):
            acc += B[k, i] * fdes[i] * (eta_p[i] if fdes[i] >= 0.0 else eta_n[i])
        tau_rec[k] = acc
    return s


#: The controller and disturbance blocks the built-in loops call (:func:`fly`, :func:`fly_quad`,
#: the PID batch): module globals, so numba compiles them into the loop (direct, inlinable calls)
#: and those loops are cached; any other pair is passed to the loop as function pointers
#: (:func:`_pointer_source`, :class:`PointerLoop`).
_CTRL = pid_controller
_DIST = no_disturbance


def _dynamic_block(soff) -> int:
    """The one block of a chain with states (``soff``: the blocks' state offsets); −1 when none
    has, −2 when several have (no closed-form fast path)."""
    nb = len(soff) - 1
    dyn = -1
    for b in range(nb):
        if soff[b + 1] > soff[b]:
            if dyn >= 0:
                dyn = -2
            elif dyn == -1:
                dyn = b
    return dyn


_dynamic_block_nb = njit(cache=True, inline="always")(_dynamic_block)


@njit(cache=True)
def fly(z0, vp, B, alloc, eta_p, eta_n, dofs, kinds, poff, tparams, soff, outch, in_ch, exact,
        inv_t, inv_c, gains, ref_pos, ref_vel, ref_yaw, ref_rate, vc, dt, nsub,
        Z, F, FDES, TAU, SCALE, VCT, DVCT, BAT, VOUT, IPRM, IGEO):
    """:func:`_fly_loop` with the built-in PID DP controller (``gains`` =
    :meth:`DPGains.to_array`) and no disturbance force (the cached default kernel)."""
    _fly_loop(gains.ravel(), np.zeros(PID_STATE_SIZE), np.zeros(0), False, 0, z0, vp, B, alloc,
              eta_p, eta_n, dofs, kinds, poff, tparams, soff, outch, in_ch, exact, inv_t, inv_c,
              ref_pos, ref_vel, ref_yaw, ref_rate, vc, dt, nsub, Z, F, FDES, TAU, SCALE, VCT, DVCT,
              BAT, VOUT, IPRM, IGEO)


@njit(cache=True)
def _fly_loop(cparams, cstate, dparams, use_dist, out_kind, z0, vp, B, alloc, eta_p, eta_n, dofs, kinds,
              poff, tparams, soff, outch, in_ch, exact, inv_t, inv_c, ref_pos, ref_vel, ref_yaw,
              ref_rate, vc, dt, nsub, Z, F, FDES, TAU, SCALE, VCT, DVCT, BAT, VOUT, IPRM, IGEO):
    """Fly ``ref_*.shape[0]`` steps of ``dt``; writes states ``Z``, delivered thrusts ``F``,
    allocated thrusts ``FDES``, controller output ``TAU`` and allocation scale ``SCALE``.

    Controller (:class:`uuvid.simulate.control.blocks.Controller`): ``_CTRL(t, eta, nu, ref_pos[k],
    ref_vel[k], ref_yaw[k], ref_rate[k], cparams, cstate, dt, cout)`` once per step,
    ``cstate`` modified in place; ``out_kind`` (:attr:`Controller.output_code`): ``cout`` is
    the wrench (6) to allocate (0), the thrusts (n) to clip to the limits (1), or the
    commands (n) sent as they are (2).  Disturbance (:mod:`uuvid.simulate.disturbances`, when
    ``use_dist``): ``_DIST(t, eta, nu, dparams, tau_d)`` at the start of every substep, added to
    ``B η f``.

    Current (NED): ``vc`` constant when ``VCT`` has no rows; otherwise piecewise linear,
    ``v_c(t_k + s) = VCT[k] + DVCT[k]·s`` over step k (``DVCT`` is its rate, passed to the
    vehicle model as ν̇_c, so the relative velocity ν_r = ν − ν_c is consistent).

    Battery (``BAT`` from :func:`battery_tables`, empty for an ideal supply): each step the
    supply voltage ``V = OCV(SOC) − R I`` (I of the previous step) sets the thrust limits of the
    allocation and the inverse maps (tables at a grid of voltages, interpolated), scales the ESC
    output (duty × supply), and the battery current ``Σ I_i(T_i, V) + P_hotel/V`` discharges
    ``SOC``; ``VOUT[k] = [V, I, SOC, command of each thruster]``.

    Inflow (``IPRM``/``IGEO`` from :func:`uuvid.vehicle.inflow.loop_arrays`; empty: off): the
    thrust at each RK4 stage follows the advance speed of that stage's state (:func:`_rhs_d`;
    on the closed-form fast path :func:`_vehicle_rk4_inflow`)."""
    nsteps = ref_pos.shape[0]
    n = tparams.shape[0]
    nz = z0.size
    nb = kinds.size
    ns = soff[soff.size - 1]
    z = z0.copy()
    zt = np.empty(nz)
    zn = np.empty(nz)
    k1 = np.zeros(nz)
    k2 = np.zeros(nz)
    k3 = np.zeros(nz)
    k4 = np.zeros(nz)
    dvc = np.zeros(3)
    vc0 = vc.copy()  # current at the RK4 stage times t, t + h/2, t + h
    vc1 = vc.copy()
    vc2 = vc.copy()
    varying = VCT.shape[0] > 0
    thrust = np.zeros(n)
    tau = np.zeros(6)
    ch = np.empty(N_CH)
    blk = np.empty((n, max(nb, 1)))
    blk2 = np.empty((n, max(nb, 1)))
    tau_des = np.zeros(6)
    cout = tau_des if out_kind == 0 else np.zeros(n)
    tau_d = np.zeros(6)
    fdes = np.zeros(n)
    cmd = np.zeros(n)
    h = dt / nsub
    start = 0
    while start < nb and soff[start + 1] == soff[start]:
        start += 1  # static blocks in front of the first dynamic one: once per step
    if start == nb:
        start = 0
    sig0 = np.zeros(n)
    P = tparams.shape[1]
    tflat = tparams.reshape(n * P)
    bflat = blk.reshape(n * max(nb, 1))
    # Fast path: one first-order block with a static front and back (e.g. ESC → first-order motor →
    # map, or a first-order thrust lag): under the held command its state is known exactly at every
    # instant, so the thrust at the RK4 stage times is evaluated in closed form.
    dyn = _dynamic_block_nb(soff)
    fast = dyn >= 0 and exact[dyn] != 0 and soff[nb] == 1
    inflow = IPRM.size > 0
    ua = np.zeros(n)
    f0 = np.zeros(n)
    th_stage = np.zeros((3, n))
    tgt = np.zeros(n)
    tconst = np.zeros(n)
    # the lag's decay over 0, h/2 and h: the time constants are fixed for the flight, so the
    # exponentials are taken once, not 4 per thruster and step
    lag = np.ones((3, n))
    if fast:
        for i in range(n):
            tconst[i] = tparams[i, poff[dyn] + (1 if kinds[dyn] == K_FIRST_ORDER_MOTOR else 0)]
            for st in range(3):
                lag[st, i] = math.exp(-0.5 * st * h / tconst[i])
    # the common static back of the fast path, one quadratic map (ESC → first-order motor → map):
    # evaluated inline from its two coefficients — the general block dispatch in the innermost
    # loop (3 stages × n thrusters per step) cost more than the rest of the step's thrusters
    quad = fast and dyn + 2 == nb and kinds[nb - 1] == kernels.K_QUADRATIC
    qk = np.zeros((n, 2))
    if quad:
        for i in range(n):
            qk[i, 0] = tparams[i, poff[nb - 1]]
            qk[i, 1] = tparams[i, poff[nb - 1] + 1]
    still = not varying and vc[0] == 0.0 and vc[1] == 0.0 and vc[2] == 0.0
    fsc = np.zeros(6)
    K4 = np.zeros((4, 13))  # RK4 slopes of the fast path
    jtab = np.zeros(n, dtype=np.int64)  # interval of the last inverse-table read, per thruster
    # battery (BAT from battery_tables; empty: ideal supply, the chains' own voltage)
    batt = BAT.size > 0
    b_cap = BAT[0] if batt else 1.0
    b_res = BAT[1] if batt else 0.0
    b_hotel = BAT[2] if batt else 0.0
    soc = BAT[3] if batt else 1.0
    v_nom = BAT[4] if batt else 1.0
    nv = int(BAT[5]) if batt else 2
    K = int(BAT[6]) if batt else 1
    no = int(BAT[7]) if batt else 0
    ob = 8 + 2 * no
    vgrid = BAT[ob:ob + nv] if batt else np.zeros(2)
    vlo = BAT[ob + nv:ob + 2 * nv] if batt else np.zeros(2)
    vhi = BAT[ob + 2 * nv:ob + 3 * nv] if batt else np.zeros(2)
    ot = ob + 3 * nv
    vtt = BAT[ot:ot + nv * K].reshape(nv, K) if batt else np.zeros((2, 1))
    vtc = BAT[ot + nv * K:ot + 2 * nv * K].reshape(nv, K) if batt else np.zeros((2, 1))
    vti = BAT[ot + 2 * nv * K:ot + 3 * nv * K].reshape(nv, K) if batt else np.zeros((2, 1))
    alc = alloc.copy()
    i_prev = 0.0
    volt = 0.0
    wv = 0.0
    jv = 0
    for k in range(nsteps):
        if varying:
            for j in range(3):
                dvc[j] = DVCT[k, j]
        # controller and allocation (held over the step)
        _CTRL(k * dt, z[0:7], z[7:13], ref_pos[k], ref_vel[k], ref_yaw[k], ref_rate[k], cparams,
             cstate, dt, cout)
        s = 1.0
        if batt:  # supply voltage from the battery state; limits and inverse maps follow it
            volt = _ocv(BAT, soc) - b_res * i_prev
            volt = min(max(volt, vgrid[0]), vgrid[nv - 1])
            jv = 0
            while jv < nv - 2 and vgrid[jv + 1] < volt:
                jv += 1
            wv = (volt - vgrid[jv]) / (vgrid[jv + 1] - vgrid[jv])
            _set_limits(alc, n, (1 - wv) * vlo[jv] + wv * vlo[jv + 1],
                        (1 - wv) * vhi[jv] + wv * vhi[jv + 1])
            if out_kind == 0:
                s = allocate_compiled(alc, tau_des, fdes)
        elif out_kind == 0:
            s = allocate_compiled(alloc, tau_des, fdes)
        if out_kind != 0:
            s = _thrusts_from_output(out_kind, cout, alc, inv_t, inv_c, batt, vtt, vtc, jv, wv,
                                     B, eta_p, eta_n, fdes, tau_des)
        for i in range(n):
            if batt:
                cmd[i] = (1 - wv) * _interp(vtt[jv], vtc[jv], fdes[i]) + \
                    wv * _interp(vtt[jv + 1], vtc[jv + 1], fdes[i])
            else:
                cmd[i], jtab[i] = kernels.interp_sorted_from(inv_t[i], inv_c[i], fdes[i], jtab[i])
            if out_kind == 2:
                cmd[i] = cout[i]
            sig0[i] = cmd[i]
            if start > 0:  # static prefix (e.g. the ESC), evaluated once for the held command
                sig0[i] = kernels.eval_chain_prefix(kinds, poff, tflat, i * P, cmd[i], bflat,
                                                    i * max(nb, 1), start)
            if batt:  # the ESC gives duty × supply: its output follows the voltage
                sig0[i] *= volt / v_nom
        if batt:
            amps = b_hotel / volt
            for i in range(n):
                amps += (1 - wv) * _interp(vtt[jv], vti[jv], fdes[i]) + \
                    wv * _interp(vtt[jv + 1], vti[jv + 1], fdes[i])
            VOUT[k, 0] = volt
            VOUT[k, 1] = amps
            VOUT[k, 2] = soc
            for i in range(n):
                VOUT[k, 3 + i] = cmd[i]
            soc -= amps * dt / (3600.0 * b_cap)
            i_prev = amps
        # record the state at the start of the step
        for i in range(nz):
            Z[k, i] = z[i]
        for j in range(6):
            TAU[k, j] = tau_des[j]
        SCALE[k] = s
        if fast:
            for i in range(n):
                pb = poff[dyn]
                if kinds[dyn] == K_FIRST_ORDER_MOTOR:
                    tgt[i] = tparams[i, pb] * sig0[i]
                else:
                    tgt[i] = sig0[i]
            for sub in range(nsub):
                if use_dist:
                    _DIST(k * dt + sub * h, z[0:7], z[7:13], dparams, tau_d)
                if varying:
                    for j in range(3):
                        vc0[j] = VCT[k, j] + DVCT[k, j] * (sub * h)
                        vc1[j] = VCT[k, j] + DVCT[k, j] * ((sub + 0.5) * h)
                        vc2[j] = VCT[k, j] + DVCT[k, j] * ((sub + 1.0) * h)
                for i in range(n):
                    o = 13 + i * ns
                    x0 = z[o]
                    for st in range(3):
                        xs = tgt[i] + (x0 - tgt[i]) * lag[st, i]
                        if quad:  # the map's own arithmetic (kernels._static_block)
                            f = (qk[i, 0] if xs >= 0.0 else qk[i, 1]) * (xs * abs(xs))
                        else:
                            f = kernels.eval_static_range(kinds, poff, tflat, i * P, xs, dyn + 1, nb)
                        if inflow:  # the bollard thrust; advance speed and η per RK4 stage
                            th_stage[st, i] = f
                        else:
                            th_stage[st, i] = f * (eta_p[i] if f >= 0.0 else eta_n[i])
                    z[o] = x0  # thruster state advanced below, exactly
                if sub == 0:
                    for i in range(n):
                        F[k, i] = th_stage[0, i]  # with inflow: set by the RK4 step below
                        FDES[k, i] = fdes[i]
                if inflow:
                    _vehicle_rk4_inflow(z, h, th_stage, B, vp, vc0, vc1, vc2, dvc, tau, zt, k1, k2,
                                        k3, k4, tau_d, eta_p, eta_n, IPRM, IGEO, ua, still, fsc,
                                        f0)
                    if sub == 0:
                        for i in range(n):
                            F[k, i] = f0[i]
                else:
                    _vehicle_rk4(z, h, th_stage, B, vp, vc0, vc1, vc2, dvc, tau, zt, K4, tau_d, still, fsc)
                for i in range(n):
                    o = 13 + i * ns
                    z[o] = tgt[i] + (z[o] - tgt[i]) * lag[2, i]
                normalise_state(z)
            continue
        for sub in range(nsub):
            if use_dist:
                _DIST(k * dt + sub * h, z[0:7], z[7:13], dparams, tau_d)
            if varying:
                for j in range(3):
                    vc0[j] = VCT[k, j] + DVCT[k, j] * (sub * h)
                    vc1[j] = VCT[k, j] + DVCT[k, j] * ((sub + 0.5) * h)
                    vc2[j] = VCT[k, j] + DVCT[k, j] * ((sub + 1.0) * h)
            _rhs_d(z, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc0, dvc,
                   k1, thrust, tau, ch, blk, tau_d, IPRM, IGEO, ua)
            if sub == 0:
                for i in range(n):
                    F[k, i] = thrust[i]
                    FDES[k, i] = fdes[i]
            for i in range(nz):
                zt[i] = z[i] + 0.5 * h * k1[i]
            _rhs_d(zt, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc1, dvc,
                   k2, thrust, tau, ch, blk2, tau_d, IPRM, IGEO, ua)
            for i in range(nz):
                zt[i] = z[i] + 0.5 * h * k2[i]
            _rhs_d(zt, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc1, dvc,
                   k3, thrust, tau, ch, blk2, tau_d, IPRM, IGEO, ua)
            for i in range(nz):
                zt[i] = z[i] + h * k3[i]
            _rhs_d(zt, sig0, start, vp, B, eta_p, eta_n, kinds, poff, tparams, soff, outch, in_ch, vc2, dvc,
                   k4, thrust, tau, ch, blk2, tau_d, IPRM, IGEO, ua)
            for i in range(nz):
                zn[i] = z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            for i in range(n):  # first-order thruster blocks under a held input: exact update
                for b in range(nb):
                    if exact[b]:
                        o = 13 + i * ns + soff[b]
                        if kinds[b] == K_FIRST_ORDER_MOTOR:
                            target = tparams[i, poff[b]] * blk[i, b]
                            tc = tparams[i, poff[b] + 1]
                        else:
                            target = blk[i, b]
                            tc = tparams[i, poff[b]]
                        ex = math.exp(-h / tc)
                        zn[o] = ex * z[o] + (1.0 - ex) * target
            for i in range(nz):
                z[i] = zn[i]
            normalise_state(z)


# not inline="always": numba's inlining would bind its eleven arrays to new names in the RK4 stage
# loop, eleven reference-count increments and decrements per stage (atomic calls numba cannot
# prune across the loops in between); a plain call (LLVM inlines it) takes none.
@njit(cache=True)
def _tau_inflow_still(th, vt, st, x, B, tau, eta_p, eta_n, IPRM, IGEO, thr):
    """:func:`_tau_inflow` in still water with no disturbance force, the advance speed, the map
    and the sum ``B T`` in one pass over the thrusters (the same arithmetic in the same order:
    ``ν_r = ν`` is what :func:`~uuvid.vehicle.inflow.state_advance_speeds_nb` gives with no
    current; ``vt[st]`` the tip speeds of ``th[st]``, :func:`~uuvid.thruster.inflow.tip_speed_nb`);
    ``thr`` receives the delivered thrusts.  :func:`fly_quad`'s still-water RK4 stage."""
    u, v, w, p, q, r = x[7], x[8], x[9], x[10], x[11], x[12]
    t0 = t1 = t2 = t3 = t4 = t5 = 0.0
    for i in range(IGEO.shape[0]):
        ua = (IGEO[i, 7] * u + IGEO[i, 8] * v + IGEO[i, 9] * w + IGEO[i, 10] * p + IGEO[i, 11] * q
              + IGEO[i, 12] * r)
        f = inflow_thrust_at_nb(th[st, i], vt[st, i], ua, IPRM)
        f = f * (eta_p[i] if f >= 0.0 else eta_n[i])
        thr[i] = f
        t0 += B[0, i] * f
        t1 += B[1, i] * f
        t2 += B[2, i] * f
        t3 += B[3, i] * f
        t4 += B[4, i] * f
        t5 += B[5, i] * f
    tau[0], tau[1], tau[2], tau[3], tau[4], tau[5] = t0, t1, t2, t3, t4, t5


@njit(cache=True)
def fly_quad(cparams, cstate, z0, vp, B, alloc, eta_p, eta_n, poff, tparams, inv_t, inv_c,
             ref_pos, ref_vel, ref_yaw, ref_rate, vc, dt, nsub, Z, F, FDES, TAU, SCALE, IPRM,
             IGEO):
    """:func:`_fly_loop` specialised to its commonest configuration: every thruster ESC →
    first-order motor → quadratic map (:func:`quad_chain`), a wrench controller (``_CTRL``, the
    built-in PID), no disturbance, a constant current (``vc``, NED; zero: still water), an ideal
    supply; with inflow (``IPRM``/``IGEO`` of :func:`_inflow_or_empty`, empty: off) the bollard
    thrusts are taken to each RK4 stage's advance speed (:func:`_vehicle_rk4_inflow`).  Only
    what that mission uses is compiled, with nothing generic left in the step (no block
    dispatch); the same arithmetic as :func:`_fly_loop`'s closed-form fast path in the same
    order, so the same numbers, bit for bit
    (``tparams``/``poff``: the bank's parameters, blocks ESC, motor, map; ``cparams``/``cstate``
    the controller's, as :func:`_fly_loop`'s).  :func:`compiled_quad` gives it a user's wrench
    controller as a function pointer."""
    nsteps = ref_pos.shape[0]
    n = tparams.shape[0]
    nz = z0.size
    z = z0.copy()
    zt = np.empty(13)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    K4 = np.zeros((4, 13))
    fsc = np.zeros(12)  # scratch (6) and a zero disturbance force (6)
    tau = np.empty(6)
    tau_des = np.zeros(6)
    fdes = np.zeros(n)
    tgt = np.zeros(n)
    th = np.zeros((3, n))
    vt = np.zeros((3, n))  # with inflow: the tip speeds of th (tip_speed_nb)
    lag = np.ones((3, n))
    jtab = np.zeros(n, dtype=np.int64)
    still = vc[0] == 0.0 and vc[1] == 0.0 and vc[2] == 0.0
    inflow = IPRM.size > 0
    ua = np.zeros(n)
    f0 = np.zeros(n)
    dvc = np.zeros(3)
    pe = poff[0]  # the ESC's parameters, the motor's (gain, time constant), the map's (k+, k−)
    pm = poff[1]
    pq = poff[2]
    h = dt / nsub
    for i in range(n):
        for st in range(3):
            lag[st, i] = math.exp(-0.5 * st * h / tparams[i, pm + 1])
    for k in range(nsteps):
        _CTRL(k * dt, z[0:7], z[7:13], ref_pos[k], ref_vel[k], ref_yaw[k], ref_rate[k], cparams,
              cstate, dt, tau_des)
        s = allocate_compiled(alloc, tau_des, fdes)
        for i in range(n):  # inverse steady map, then the ESC: the motor speed aimed at
            c, jtab[i] = kernels.interp_sorted_from(inv_t[i], inv_c[i], fdes[i], jtab[i])
            tgt[i] = tparams[i, pm] * kernels.esc_output(tparams[i], pe, c)
        for i in range(nz):
            Z[k, i] = z[i]
        for j in range(6):
            TAU[k, j] = tau_des[j]
        SCALE[k] = s
        for sub in range(nsub):
            for i in range(n):  # thrust at the RK4 stage times, the motor's lag in closed form
                x0 = z[13 + i]
                for st in range(3):
                    xs = tgt[i] + (x0 - tgt[i]) * lag[st, i]
                    f = (tparams[i, pq] if xs >= 0.0 else tparams[i, pq + 1]) * (xs * abs(xs))
                    if inflow:  # the bollard thrust; advance speed and η per RK4 stage
                        th[st, i] = f
                        vt[st, i] = tip_speed_nb(f, IPRM)
                    else:
                        th[st, i] = f * (eta_p[i] if f >= 0.0 else eta_n[i])
            if sub == 0:
                for i in range(n):
                    F[k, i] = th[0, i]  # with inflow: set by the RK4 step below
                    FDES[k, i] = fdes[i]
            if inflow and still:
                # :func:`_vehicle_rk4_inflow` in still water without a disturbance force: the
                # advance speed, map and ``B T`` of each stage in one pass (_tau_inflow_still),
                # the stages in a loop (K4 their slopes) so the right-hand side is compiled in
                # once.  Written out here, not an inlined function: numba would count a
                # reference to each of its arrays every step (atomic calls, ≈ 10 % of the step)
                for i in range(13):
                    zt[i] = z[i]
                for st in range(4):
                    kk = K4[st]
                    _tau_inflow_still(th, vt, 0 if st == 0 else (1 if st < 3 else 2), zt, B, tau,
                                      eta_p, eta_n, IPRM, IGEO, ua)
                    if st == 0 and sub == 0:
                        for i in range(n):
                            F[k, i] = ua[i]
                    vehicle_rhs_still_into(zt, tau, vp, fsc, kk)
                    if st < 3:
                        c = 1.0 if st == 2 else 0.5
                        for i in range(13):
                            zt[i] = z[i] + c * h * kk[i]
                for i in range(13):
                    z[i] = z[i] + h / 6.0 * (K4[0, i] + 2.0 * K4[1, i] + 2.0 * K4[2, i] + K4[3, i])
            elif inflow:
                _vehicle_rk4_inflow(z, h, th, B, vp, vc, vc, vc, dvc, tau, zt, k1, k2, k3, k4,
                                    fsc[6:12], eta_p, eta_n, IPRM, IGEO, ua, still, fsc, f0)
                if sub == 0:
                    for i in range(n):
                        F[k, i] = f0[i]
            elif still:
                _vehicle_rk4(z, h, th, B, vp, vc, vc, vc, dvc, tau, zt, K4, fsc[6:12], True, fsc)
            else:
                _vehicle_rk4(z, h, th, B, vp, vc, vc, vc, dvc, tau, zt, K4, fsc[6:12], False, fsc)
            for i in range(n):
                o = 13 + i
                z[o] = tgt[i] + (z[o] - tgt[i]) * lag[2, i]
            normalise_state(z)


# A loop specialised to one configuration (compiled_quad, specialised_loop) has the lines that
# read the configuration from its inputs as constants: numba drops the branches that
# configuration cannot take before it inlines and types anything, so a cold process compiles one
# RK4 form instead of four (fly_quad: ≈ 40 s instead of ≈ 75 s on one core).
def quad_config(vc, IPRM) -> tuple[tuple[str, bool], ...]:
    """The configuration :func:`fly_quad` reads from its inputs, as :func:`compiled_quad` takes it:
    still water (``vc`` zero) and inflow on (``IPRM`` not empty) — the same tests as the loop's."""
    still = bool(vc[0] == 0.0 and vc[1] == 0.0 and vc[2] == 0.0)
    return (("still", still), ("inflow", bool(IPRM.size > 0)))


def _fixed_source(src: str, fixed) -> str:
    """``src`` with each ``    name = <expression>`` line of ``fixed`` (``(name, bool)`` pairs)
    replaced by the constant, and a check that the inputs give it (a ``ValueError`` in the loop,
    never a silently wrong flight); a ``SyntaxError`` unless each name is assigned exactly once
    at the loop's top level, on one line."""
    lines = src.splitlines()
    for name, value in fixed:
        hits = [i for i, ln in enumerate(lines) if ln.startswith(f"    {name} = ")]
        if len(hits) != 1:
            raise SyntaxError(f"{name!r} is assigned {len(hits)} times at the loop's top level")
        expr = lines[hits[0]].split("=", 1)[1].split("#", 1)[0].strip()
        v = bool(value)
        lines[hits[0]:hits[0] + 1] = [
            f"    {name} = {v!r}  # fixed: a loop specialised to it",
            f"    if bool({expr}) != {v!r}:",
            f"        raise ValueError('this mission loop is specialised to {name} = {v!r}; its "
            "inputs give the other')"]
    return "\n".join(lines) + "\n"


def _template_source(template) -> str:
    """The loop's source (a numba dispatcher's or a plain function's) without its decorator
    lines."""
    import inspect

    lines = inspect.getsource(getattr(template, "py_func", template)).splitlines()
    while lines and lines[0].startswith("@"):
        lines.pop(0)
    return "\n".join(lines) + "\n"


@functools.lru_cache(maxsize=32)
def compiled_quad(ctrl_fn, fixed: tuple = ()):
    """:func:`fly_quad` for a wrench controller's numba function, specialised with ``fixed``
    (:func:`quad_config`) to one configuration (memoised).  The built-in PID is called directly
    (the benchmarked loop; :func:`fly_quad` itself with no configuration, else a module cached
    on disk); any other controller through a pointer (:class:`PointerLoop`): one loop per
    configuration, cached on disk, for every controller."""
    if ctrl_fn is not _CTRL:
        return PointerLoop(_pointer_dispatcher(tuple(fixed), "fly_quad"), ctrl_fn, no_disturbance,
                           _QUAD_LAYOUT)
    cached = _disk_cached(fly_quad, ctrl_fn, fixed)
    if cached is None and not fixed:
        cached = fly_quad
    if cached is None:
        cached = _in_memory(fly_quad, fixed, _CTRL=ctrl_fn)
    # a source that cannot be read: the general loop (the built-in PID's is numba-cached)
    return cached if cached is not None else fly_quad


def _in_memory(template, fixed: tuple, pointer: bool = False, **names):
    """The loop ``template`` compiled in this process around ``names`` (``_CTRL=…``), or taking
    the controller and disturbance as arguments (``pointer``, :func:`_pointer_source`),
    specialised to ``fixed`` (:func:`_fixed_source`; ``()``: the general loop); ``None`` when the
    loop's source cannot be read and it has to be rewritten."""
    import types

    g = dict(template.py_func.__globals__)
    g.update(names)
    fname = template.py_func.__name__
    if not fixed and not pointer:
        return njit(types.FunctionType(template.py_func.__code__, g, fname))
    try:
        src = _loop_source(template, fixed, pointer)
    except (OSError, SyntaxError):
        return None
    exec(compile(src, f"<uuvid {fname} {dict(fixed)}{' (pointers)' if pointer else ''}>", "exec"), g)
    return njit(g[fname])


def quad_chain(bank: ThrusterBank) -> bool:
    """Are the bank's chains ESC → first-order motor → quadratic map (:func:`fly_quad`)?"""
    return (bank.kinds.size == 3 and int(bank.kinds[0]) == kernels.K_ESC
            and int(bank.kinds[1]) == K_FIRST_ORDER_MOTOR
            and int(bank.kinds[2]) == kernels.K_QUADRATIC and bank.n_states == 1)


@njit(cache=True)
def _summarise_run(Z, F, SC, ref_pos, out):
    """``out = [max tracking error, rms tracking error, max |thrust|, final position error,
    min allocation scale, max tilt (deg)]`` of one flight (:data:`RUN_COLUMNS`); the tilt is the
    angle of the body z axis from the vertical, ``acos(1 − 2(ε₁² + ε₂²))``."""
    nsteps = ref_pos.shape[0]
    n = F.shape[1]
    emax = 0.0
    esum = 0.0
    fmax = 0.0
    smin = 1.0
    cmin = 1.0
    for k in range(nsteps):
        cmin = min(cmin, 1.0 - 2.0 * (Z[k, 4] * Z[k, 4] + Z[k, 5] * Z[k, 5]))
        d = 0.0
        for j in range(3):
            d += (Z[k, j] - ref_pos[k, j]) ** 2
        d = math.sqrt(d)
        emax = max(emax, d)
        esum += d * d
        smin = min(smin, SC[k])
        for i in range(n):
            fmax = max(fmax, abs(F[k, i]))
    d = 0.0
    for j in range(3):
        d += (Z[nsteps - 1, j] - ref_pos[nsteps - 1, j]) ** 2
    out[0] = emax
    out[1] = math.sqrt(esum / nsteps)
    out[2] = fmax
    out[3] = math.sqrt(d)
    out[4] = smin
    out[5] = math.degrees(math.acos(max(-1.0, min(1.0, cmin))))


_LOOP = _fly_loop


def _batch_template(cparams, cstate0, dparams, use_dist, out_kind, z0, VP, B, alloc, eta_p, eta_n, dofs,
                    kinds, poff, TP, soff, outch, in_ch, exact, inv_t, inv_c, ref_pos, ref_vel,
                    ref_yaw, ref_rate, VC, dt, nsub, OUT, IPRM, IGEO):
    """Vehicles (rows of ``VP``, ``TP``, ``VC``) flying the mission in parallel through ``_LOOP``
    (:func:`_fly_loop`; with a user's controller the pointer loop, :func:`compiled_loop`);
    each vehicle starts from its own copy of the controller state ``cstate0``; ``OUT[r]`` from
    :func:`_summarise_run`.  ``IPRM``/``IGEO``: the inflow arrays of :func:`_fly_loop` (empty:
    bollard thrusters), shared by every vehicle — each flies the loop's own per-stage advance
    speed, so a batch vehicle is the single flight's arithmetic."""
    nrun = VP.shape[0]
    nsteps = ref_pos.shape[0]
    n = TP.shape[1]
    for r in prange(nrun):
        Z = np.empty((nsteps, z0.size))
        F = np.empty((nsteps, n))
        FD = np.empty((nsteps, n))
        TAU = np.empty((nsteps, 6))
        SC = np.empty(nsteps)
        _LOOP(cparams, cstate0.copy(), dparams, use_dist, out_kind, z0, VP[r], B, alloc, eta_p, eta_n, dofs,
              kinds, poff, TP[r], soff, outch, in_ch, exact, inv_t, inv_c, ref_pos, ref_vel,
              ref_yaw, ref_rate, VC[r], dt, nsub, Z, F, FD, TAU, SC, np.zeros((0, 3)),
              np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), IPRM, IGEO)
        _summarise_run(Z, F, SC, ref_pos, OUT[r])


_fly_batch_pid = njit(cache=True, parallel=True)(_batch_template)


def fly_batch(z0, VP, B, alloc, eta_p, eta_n, dofs, kinds, poff, TP, soff, outch, in_ch, exact,
              inv_t, inv_c, gains, ref_pos, ref_vel, ref_yaw, ref_rate, VC, dt, nsub, OUT,
              inflow_arrays=None):
    """Many vehicles (rows of ``VP``, thruster params ``TP[r]``, currents ``VC[r]``) flying the same
    mission in parallel with the built-in PID DP (:func:`fly` per vehicle; a compiled, cached
    ``prange`` kernel).  ``OUT[r] = [max tracking error, rms tracking error, max |thrust|,
    final position error, min allocation scale]``.  ``inflow_arrays``: ``(IPRM, IGEO)`` of
    :func:`uuvid.vehicle.inflow.loop_arrays` (``None``: bollard thrusters)."""
    IPRM, IGEO = _inflow_or_empty(inflow_arrays)
    _fly_batch_pid(np.ascontiguousarray(gains, dtype=np.float64).ravel(), np.zeros(PID_STATE_SIZE),
                   np.zeros(0), False, 0, z0, VP, B, alloc, eta_p, eta_n, dofs, kinds, poff, TP, soff,
                   outch, in_ch, exact, inv_t, inv_c, ref_pos, ref_vel, ref_yaw, ref_rate, VC, dt,
                   nsub, OUT, IPRM, IGEO)


def _inflow_or_empty(inflow_arrays) -> tuple[np.ndarray, np.ndarray]:
    """``(IPRM, IGEO)`` for the compiled loops: the setup's inflow arrays, or empty ones (off)."""
    if inflow_arrays is None:
        return np.zeros(0), np.zeros((0, 13))
    IPRM, IGEO = inflow_arrays
    return np.ascontiguousarray(IPRM, dtype=np.float64), check_geometry(IGEO)


def loop_config(soff, exact, IPRM) -> tuple[tuple[str, bool], ...]:
    """The configuration :func:`_fly_loop` reads from its inputs that decides what it compiles,
    as :func:`specialised_loop` takes it (the same tests as the loop's): the closed-form fast
    path (one first-order block, exact, one state) or the general block dispatch, and inflow on
    or off.  Current, battery and still water stay decided at run time: their code is small or
    inlined into both paths, and every configuration fixed here is one more loop a process that
    flies many kinds of mission compiles."""
    nb = len(soff) - 1
    dyn = _dynamic_block(soff)
    fast = bool(dyn >= 0 and exact[dyn] != 0 and soff[nb] == 1)
    return (("fast", fast), ("inflow", bool(IPRM.size > 0)))


@functools.lru_cache(maxsize=64)
def _pointer_dispatcher(fixed: tuple = (), name: str = "_fly_loop"):
    """The loop ``name`` (:func:`_fly_loop` or :func:`fly_quad`) taking its controller and
    disturbance as arguments (function pointers, :func:`_pointer_source`), specialised to
    ``fixed`` (:func:`loop_config`, :func:`quad_config`; ``()``: general): cached on disk
    (:func:`_disk_cached`), else compiled in this process; memoised."""
    template = {"_fly_loop": _fly_loop, "fly_quad": fly_quad}[name]
    loop = _disk_cached(template, None, fixed) or _in_memory(template, fixed, pointer=True)
    if loop is None:
        raise RuntimeError(f"uuvid's mission loop source (vehicle_sim.{name}) cannot be read: "
                           "reinstall uuvid with its .py files")
    return loop


def specialised_loop(ctrl_fn, dist_fn, fixed: tuple):
    """:func:`_fly_loop` around a controller and a disturbance, specialised to one configuration
    (:func:`loop_config`): numba drops the branches it cannot take before compiling, so a single
    flight compiles one thruster path and one RK4 form instead of all of them.

    The loop takes the controller and the disturbance as function pointers
    (:class:`PointerLoop`): it is compiled once per configuration and cached on disk, whatever the
    controller — a user's own controller (in a file, a notebook cell or plain Python) compiles
    only itself (≈ 0.1–1 s), not the loop (≈ 10–20 s).  Called as the loop without its first two
    arguments."""
    return PointerLoop(_pointer_dispatcher(tuple(fixed)), ctrl_fn, dist_fn)


@functools.lru_cache(maxsize=4)
def _pointer_batch(parallel: bool):
    """:func:`_batch_template` taking the controller and disturbance as function pointers, flying
    the general pointer loop (:func:`_pointer_dispatcher`); compiled once per process."""
    g = dict(_batch_template.__globals__)
    g["_LOOP"] = _pointer_dispatcher(())
    src = _pointer_source(_template_source(_batch_template), "_batch_template", "_LOOP(")
    exec(compile(src, "<uuvid _batch_template (pointers)>", "exec"), g)
    return njit(parallel=parallel)(g["_batch_template"])


@functools.lru_cache(maxsize=32)
def compiled_loop(ctrl_fn, dist_fn, parallel: bool = True):
    """``(loop, batch)``: :func:`_fly_loop` and a batch kernel around a controller and a
    disturbance function (numba functions, :class:`~uuvid.simulate.control.blocks.Controller`),
    both :class:`PointerLoop` s (called as :func:`_fly_loop` and :func:`_batch_template` without
    their first two arguments), memoised.

    The loop is the general one (every branch), compiled once and cached on disk for any
    controller (:func:`specialised_loop`).  The batch kernel flies one vehicle per thread
    (``prange``; ``parallel=False``: one after another, for controllers that call back into
    Python); it is compiled once in each process."""
    return (PointerLoop(_pointer_dispatcher(()), ctrl_fn, dist_fn),
            PointerLoop(_pointer_batch(bool(parallel)), ctrl_fn, dist_fn))


def _importable(fn) -> tuple[str, str, str] | None:
    """``(module, name, file)`` of a module-level numba function reachable by import, else None."""
    import sys

    py = getattr(fn, "py_func", None)
    if py is None:
        return None
    mod, name = py.__module__, py.__qualname__
    m = sys.modules.get(mod)
    f = getattr(m, "__file__", None) if m is not None else None
    if "<" in name or "." in name or getattr(m, name, None) is not fn or not f:
        return None
    return mod, name, f


def _loop_source(template, fixed: tuple, pointer: bool) -> str:
    """The source of the loop ``template`` specialised to ``fixed`` (:func:`_fixed_source`) and,
    with ``pointer``, taking the controller and disturbance as arguments (:func:`_pointer_source`)."""
    src = _fixed_source(_template_source(template), fixed)
    return _pointer_source(src, template.py_func.__name__) if pointer else src


def _pointer_source(src: str, fname: str, call: str = "") -> str:
    """``src`` (a loop's source, :func:`_template_source`) with the controller and disturbance
    as its first two arguments (``ctrl``, ``dist``) instead of the module globals ``_CTRL`` and
    ``_DIST`` (numba then calls them through a pointer: one compiled loop for every controller);
    ``call`` (e.g. ``"_LOOP("``): a loop it calls, passed the two on.  ``SyntaxError`` when the
    source does not have that shape."""
    head = f"def {fname}("
    if not src.startswith(head) or (call and call not in src) or "_CTRL(" not in src \
            and not call:
        raise SyntaxError(f"{fname}: not a loop calling _CTRL (or {call or '…'})")
    src = src.replace(head, head + "ctrl, dist, ", 1)
    if call:
        return src.replace(call, call + "ctrl, dist, ")
    return src.replace("_CTRL(", "ctrl(").replace("_DIST(", "dist(")


@functools.lru_cache(maxsize=32)
def _disk_cached(template, ctrl_fn=None, fixed: tuple = ()):
    """The mission loop ``template`` (:func:`_fly_loop`, :func:`fly_quad`) from a generated module
    on disk (``~/.cache/uuvid/mission_loops``, ``UUVID_KERNEL_CACHE`` moves it) that numba
    caches.  ``ctrl_fn`` given: the loop calls that controller directly (the module imports it by
    name as ``_CTRL``; :func:`fly_quad`'s form); ``None``: the loop takes the controller and
    disturbance as arguments (:func:`_pointer_source`; :func:`_fly_loop`'s form, one module for
    every controller).  The module's name is a digest of uuvid's compiled-code version (its
    version and the modules that use numba: :func:`~uuvid.core.cache.compiled_code_version`), the
    loop's name, form and configuration and the bytes of the loop's and the controller's files,
    so an edit to any of them compiles a new module instead of running stale machine code; the
    loop's source is read only to write a new module.  ``fixed``: ``(name, bool)`` pairs of the
    loop's top-level configuration lines to make constants (:func:`quad_config`,
    :func:`loop_config`, :func:`_fixed_source`).  ``None`` when the controller is not importable
    by name or the cache cannot be written (the caller compiles in memory)."""
    import importlib.util
    import os
    import sys

    from uuvid.core.cache import cache_dir, compiled_code_version, digest, file_digest

    refs = [] if ctrl_fn is None else [_importable(ctrl_fn)]
    if None in refs:
        return None
    fname = template.py_func.__name__
    try:
        # the bytes of the template's file stand for its source (inspect, ≈ 15 ms, reads the
        # source only to write a new module)
        key = digest(compiled_code_version(), fname, [(str(k), bool(v)) for k, v in fixed],
                     "pointers" if ctrl_fn is None else "direct",
                     file_digest(template.py_func.__code__.co_filename),
                     [(m, n) for m, n, _ in refs], [file_digest(f) for _, _, f in refs])[:20]
        modname = f"_uuvid_mission_loop_{key}"
        d = cache_dir("mission_loops")
        path = d / f"{modname}.py"
        if not path.is_file():  # written whole (os.replace) or not at all
            body = _loop_source(template, fixed, pointer=ctrl_fn is None)
            text = ("# generated by uuvid.simulate.vehicle_sim._disk_cached — do not edit\n"
                    "import uuvid.simulate.vehicle_sim as _vs\n\n"
                    "globals().update({k: v for k, v in vars(_vs).items() if not k.startswith('__')})\n"
                    + "".join(f"from {m} import {n} as _CTRL  # noqa: E402\n" for m, n, _ in refs)
                    + "\n\n" + body)
            d.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
            tmp.write_text(text)
            os.replace(tmp, path)
        mod = sys.modules.get(modname)
        if mod is None:
            spec = importlib.util.spec_from_file_location(modname, path)
            mod = importlib.util.module_from_spec(spec)
            sys.modules[modname] = mod
            spec.loader.exec_module(mod)
        if ctrl_fn is not None and mod._CTRL is not ctrl_fn:
            return None
        return njit(cache=True)(getattr(mod, fname))
    except (OSError, ImportError, SyntaxError, TypeError, AttributeError):
        return None


#: How a loop's own arguments give the argument types of the controller it calls, ``(t, eta, nu,
#: ref_pos[k], ref_vel[k], ref_yaw[k], ref_rate[k], params, state, dt, out)``, and of the
#: disturbance, ``(t, eta, nu, params, tau_out)`` (``None``: a float; ``"slice"``: a C-contiguous
#: state slice; ``"ro"``: read-only C-contiguous; ``("row", i)``: a row of loop argument ``i``;
#: ``("elem", i)``: an element of it; ``i``: it; the controller's state is a writable C-contiguous
#: array, as the batch's copy of it), and which loop arguments are the blocks' parameters (passed
#: read-only, as a Controller's own).
_LOOP_LAYOUT = {"ctrl": (None, "slice", "slice", ("row", 21), ("row", 22), ("elem", 23),
                         ("elem", 24), 0, "slice", None, "slice"),
                "dist": (None, "slice", "slice", 2, "slice"), "readonly": (0, 2)}
#: :data:`_LOOP_LAYOUT` of :func:`fly_quad` (no disturbance: the pointer it is given is never called).
_QUAD_LAYOUT = {"ctrl": (None, "slice", "slice", ("row", 12), ("row", 13), ("elem", 14),
                         ("elem", 15), 0, "slice", None, "slice"),
                "dist": (None, "slice", "slice", "ro", "slice"), "readonly": (0,)}


class PointerLoop:
    """A compiled loop (a numba dispatcher whose first two arguments are the controller and the
    disturbance, :func:`_pointer_source`) with the pair it flies: calling it with the loop's
    other arguments compiles (or loads from disk) the loop for their types with the pair as
    function pointers — one machine code for every controller of the same types — and runs
    it.  ``stats`` and ``py_func`` are the dispatcher's; ``signatures`` the pair's own flights."""

    def __init__(self, dispatcher, ctrl_fn, dist_fn, layout=None):
        self.dispatcher = dispatcher
        self.ctrl_fn = ctrl_fn
        self.dist_fn = dist_fn
        self.layout = _LOOP_LAYOUT if layout is None else layout
        self._flown: set = set()  # the full signatures this pair has flown

    @property
    def signatures(self) -> list:
        """The signatures this controller/disturbance pair has flown (empty before its first
        call: the shared loop may be compiled, but not yet for this pair's types, and the pair
        itself not at all — so :func:`fly_mission` times that first call apart)."""
        return sorted(self._flown, key=str)

    stats = property(lambda self: self.dispatcher.stats)
    py_func = property(lambda self: self.dispatcher.py_func)

    def __call__(self, *args):
        from numba import typeof

        args = list(args)
        for i in self.layout["readonly"]:  # the blocks' parameters: read-only, as a
            a = np.asarray(args[i]).view()  # Controller's own (one loop for either)
            a.flags.writeable = False
            args[i] = a
        types_ = tuple(typeof(a) for a in args)
        full = (_function_type(self.ctrl_fn, self.layout["ctrl"], types_),
                _function_type(self.dist_fn, self.layout["dist"], types_)) + types_
        disp = self.dispatcher
        if full not in disp.overloads:
            _compile_once(disp, full)
        self._flown.add(full)
        return disp.overloads[full].entry_point(self.ctrl_fn, self.dist_fn, *args)


def _compile_once(disp, sig) -> None:
    """Compile (or load from numba's disk cache) ``disp`` for ``sig``.  A loop cached on disk is
    compiled under a lock on its module: processes that need it at once (the demo's sections)
    wait for the first, then load its machine code instead of compiling it again."""
    import warnings

    from numba.core.errors import NumbaExperimentalFeatureWarning

    lock = None
    mod = disp.py_func.__module__
    if mod.startswith("_uuvid_mission_loop_"):
        try:
            import fcntl

            from uuvid.core.cache import cache_dir

            lock = open(cache_dir("mission_loops") / f"{mod}.lock", "a")  # noqa: SIM115
            fcntl.flock(lock, fcntl.LOCK_EX)
        except (ImportError, OSError):  # no fcntl (Windows), or no lock there: compile anyway
            if lock is not None:
                lock.close()
            lock = None
    try:
        with warnings.catch_warnings():  # numba's first-class functions: used as documented
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
            disp.compile(sig)
    finally:
        if lock is not None:
            lock.close()  # closing the file releases the lock


def _function_type(fn, spec, loop_types):
    """The numba ``FunctionType`` the loop calls ``fn`` through: its argument types from the
    loop's (``spec``: a layout's ``ctrl``/``dist``, :data:`_LOOP_LAYOUT`), its return type what
    ``fn`` compiles to for them (a controller that returns a value, not ``None``, gets a loop
    compiled for that type: once, cached on disk, but not the shared one)."""
    from numba import types

    c1 = types.Array(types.float64, 1, "C")
    args = []
    for s in spec:
        if s is None:
            args.append(types.float64)
        elif s == "slice":
            args.append(c1)
        elif s == "ro":
            args.append(types.Array(types.float64, 1, "C", readonly=True))
        elif isinstance(s, tuple) and s[0] == "row":
            t = loop_types[s[1]]
            args.append(t.copy(ndim=1, layout="C" if t.layout == "C" else "A"))
        elif isinstance(s, tuple):
            args.append(loop_types[s[1]].dtype)
        else:
            args.append(loop_types[s])
    args = tuple(args)
    if args in fn.overloads:
        return types.FunctionType(fn.overloads[args].signature)
    if getattr(fn, "_can_compile", True):
        fn.compile(args)
        return types.FunctionType(fn.overloads[args].signature)
    # declared with its own signature(s) (``@njit(sig)``): the one the loop's arguments convert to
    # (e.g. C-contiguous arrays to an "A" layout), as a direct call would choose
    from numba import typeof

    sig = fn.typingctx.resolve_function_type(typeof(fn), args, {})
    if sig is None or tuple(sig.args) not in fn.overloads:
        name = getattr(fn, "__name__", "the controller")
        raise TypeError(f"{name} is declared with the signatures {fn.signatures}, none of which "
                        f"takes the mission loop's arguments {args}: leave out the signature "
                        "(@njit) or declare one these convert to")
    return types.FunctionType(fn.overloads[tuple(sig.args)].signature)


# ---------------------------------------------------------------------------------------------
# Python API
# ---------------------------------------------------------------------------------------------
def _path_end(mission) -> float | None:
    """When a waypoint mission's reference reaches its last waypoint (its duration less the
    final hold); ``None`` for a mission that does not say."""
    try:
        return float(mission.duration) - float(getattr(mission, "hold", 0.0))
    except (AttributeError, TypeError, ValueError):
        return None


def path_cut(setup) -> float | None:
    """When the setup's path ends (s) if its flight stops before that (a ``t_end`` shorter than
    the mission's path), else ``None``: such a flight is not ``completed``."""
    end = _path_end(setup.mission)
    stop = float(setup.t[-1] + setup.dt)
    # a flight of the mission's own duration stops within half a step of it (the step count is
    # rounded): that is the path flown to its end, not a cut
    return end if end is not None and stop < end - 0.5 * setup.dt - 1e-9 else None


@dataclass(frozen=True)
class MissionResult(DictSummaryResult):
    """Time series of a flown mission plus its ``metrics`` (tracking errors, thrust, timing…).

    ``summary()`` is the text of the common result surface; ``summary["key"]`` still reads
    ``metrics`` (the field was called ``summary`` before)."""

    t: np.ndarray
    state: np.ndarray  # (N, 13 + thruster states)
    thrust: np.ndarray  # (N, n) delivered (η-scaled) thrust
    thrust_cmd: np.ndarray  # (N, n) allocated thrust
    tau_cmd: np.ndarray  # (N, 6) controller output
    scale: np.ndarray  # (N,) allocation scale (1 = achievable)
    ref_pos: np.ndarray
    ref_yaw: np.ndarray
    thruster_names: tuple[str, ...]
    thrust_limits: np.ndarray  # (n, 2)
    metrics: dict = field(default_factory=dict)
    supply: np.ndarray | None = None  # (N, 3 + n) [V, battery current, SOC, commands] on a battery

    report_title = "Mission"
    summary_field = "metrics"

    def _summary_text(self) -> str:
        from uuvid.simulate.mission_report import mission_text

        return mission_text(self)

    def to_dict(self) -> dict:
        """The metrics and thruster names (the time series: :meth:`to_frame`)."""
        return jsonable({"metrics": dict(self.metrics), "thruster_names": list(self.thruster_names),
                         "n_samples": int(self.t.size)})

    def plot(self):
        """Top view, tracking error and thruster forces."""
        from uuvid.simulate.mission_report import mission_overview

        return mission_overview(self)

    @property
    def position(self) -> np.ndarray:
        return self.state[:, 0:3]

    @property
    def velocity(self) -> np.ndarray:
        return self.state[:, 7:13]

    @property
    def tracking_error(self) -> np.ndarray:
        return np.linalg.norm(self.position - self.ref_pos, axis=1)

    def to_frame(self):
        """The time series as a DataFrame (what ``uuvid simulate --out`` writes to
        ``timeseries.csv``), SI values with the unit in every column name, as uuvid's other tables
        (``t_s``, ``depth_m``, ``yaw_rad``): ``t_s``; ``north_m``, ``east_m``, ``down_m`` and their
        ``ref_*_m``; ``roll_rad``, ``pitch_rad``, ``yaw_rad``, ``ref_yaw_rad`` (radians, the
        summary's angles are degrees); ``u_mps``, ``v_mps``, ``w_mps``, ``p_rad_s``, ``q_rad_s``,
        ``r_rad_s``; per thruster ``thrust_<name>_N`` (delivered) and ``thrust_cmd_<name>_N``
        (allocated); ``tracking_error_m``; ``allocation_scale`` (dimensionless, 1 = achievable).
        Before these units the columns were ``time``, ``north``, ``roll``, ``u``, ``thrust_<name>``…"""
        import pandas as pd

        from uuvid.vehicle.kinematics import quat_to_euler

        eul = quat_to_euler(self.state[:, 3:7])
        cols = {"t_s": self.t}
        for j, nm in enumerate(("north", "east", "down")):
            cols[f"{nm}_m"] = self.state[:, j]
            cols[f"ref_{nm}_m"] = self.ref_pos[:, j]
        for j, nm in enumerate(("roll", "pitch", "yaw")):
            cols[f"{nm}_rad"] = eul[:, j]
        cols["ref_yaw_rad"] = self.ref_yaw
        for j, nm in enumerate(("u_mps", "v_mps", "w_mps", "p_rad_s", "q_rad_s", "r_rad_s")):
            cols[nm] = self.state[:, 7 + j]
        for i, nm in enumerate(self.thruster_names):
            cols[f"thrust_{nm}_N"] = self.thrust[:, i]
            cols[f"thrust_cmd_{nm}_N"] = self.thrust_cmd[:, i]
        cols["tracking_error_m"] = self.tracking_error
        cols["allocation_scale"] = self.scale
        return pd.DataFrame(cols)


@dataclass(frozen=True)
class MissionSetup:
    """Everything the compiled loop needs, built once from a vehicle and a mission."""

    vehicle: object
    bank: ThrusterBank
    mission: WaypointMission
    gains: DPGains
    dt: float
    substeps: int
    alloc: np.ndarray
    dofs: np.ndarray
    eta_p: np.ndarray
    eta_n: np.ndarray
    B: np.ndarray
    vp: np.ndarray
    current: np.ndarray
    t: np.ndarray
    ref: tuple
    current_model: object = None
    current_series: tuple | None = None  # (v_c (N, 3), v̇_c (N, 3)) when the current varies
    allocation: str = "scale"
    battery: object = None
    battery_array: np.ndarray | None = None
    controller: Controller | None = None  # None: the built-in PID DP with ``gains``
    disturbance: Disturbance | None = None
    inflow_arrays: tuple | None = None  # (map params, geometry) of the inflow model; None: off
    inflow: str = "none"  # the inflow model in force (the metrics say it)
    inflow_source: str = "vehicle file"  # where it came from: vehicle file, scenario file, option
    #: with inflow: the propeller map flown and whether it is assumed or measured (the metrics say
    #: it, :func:`uuvid.vehicle.propeller_note.propeller_map_note`)
    propeller_map: str = ""

    def blocks(self):
        """``(loop, batch, ctrl params, ctrl state0, dist params, use_dist, out_kind)`` of a
        setup with a user controller or a disturbance (:func:`compiled_loop`)."""
        from uuvid.simulate.control.blocks import compiled_form, python_controller

        c = self.controller or pid(self.gains)
        cfn, cpar = compiled_form(c)
        d = self.disturbance
        loop, batch = compiled_loop(cfn, d.fn if d is not None else no_disturbance,
                                    cfn is not python_controller)
        return (loop, batch, np.ascontiguousarray(cpar), c.state0,
                d.params if d is not None else np.zeros(0), d is not None, c.output_code)

    def z0(self) -> np.ndarray:
        z = np.zeros(13 + self.bank.n * self.bank.n_states)
        z[0:3] = self.ref[0][0]
        yaw = self.ref[2][0]
        z[3] = math.cos(yaw / 2)
        z[6] = math.sin(yaw / 2)
        return z


#: Design speeds (m/s) of surge, sway, heave for the cruise-lag rule of :func:`default_gains`
#: (the square mission's 0.5 m/s horizontal and 0.25 m/s vertical speeds).
CRUISE_SPEED = (0.5, 0.5, 0.25)
#: Largest steady position lag (m) a PID loop may have while cruising at :data:`CRUISE_SPEED`
#: against the vehicle's drag (before the integral catches up): the lag the default bandwidth
#: gives the BlueROV2 in surge (0.172 m), so vehicles with more drag do not track worse.
MAX_CRUISE_LAG = 0.175


def default_gains(vehicle, omega=(1.5, 1.5, 1.5, 2.0), max_lag: float = MAX_CRUISE_LAG,
                  attitude_bandwidth: float = 4.0) -> DPGains:
    """Bandwidth-placed PID gains from the vehicle's mass, added mass and damping.

    The bandwidth of surge, sway, heave is raised where the drag at the cruise speed U would make
    the loop lag more than ``max_lag``: cruising, the P term carries the drag,
    ``k_p e = (d_l + d_q U) U`` with ``k_p = m ω²`` (Fossen 2011, §12.2.6), so
    ``ω ≥ √((d_l + d_q U) U / (m e_max))``.  (The Heavy's surge/sway drag is ~6× the BlueROV2's
    for a similar mass: at ω = 1.5 rad/s it lagged 0.6 m on the square mission.)
    Vehicles whose thrusters control roll and pitch hold them level at ``attitude_bandwidth``
    (rad/s); the Heavy's metacentric height is 1 cm, so the restoring moment alone lets it pitch
    40° on the square mission at 2 rad/s."""
    p = vehicle.params
    M = p.mass_matrix
    idx = [0, 1, 2, 5]
    mass = [M[i, i] for i in idx]
    dl = np.diag(np.asarray(p.linear_damping).reshape(6, 6) if np.size(p.linear_damping) == 36
                 else np.diag(p.linear_damping))
    dq = np.diag(np.asarray(p.quadratic_damping).reshape(6, 6)
                 if np.size(p.quadratic_damping) == 36 else np.diag(p.quadratic_damping))
    damping = [dl[i] for i in idx]
    omega = [float(w) for w in omega]
    for j, (i, u) in enumerate(zip(idx[:3], CRUISE_SPEED)):
        drag = (dl[i] + dq[i] * u) * u
        omega[j] = max(omega[j], math.sqrt(drag / (mass[j] * max_lag)))
    al = vehicle.allocator()
    tau_max = []
    for i in idx:  # the largest force along each DOF the thrusters give with uniform allocation
        if i not in al.controlled:
            tau_max.append(0.0)
            continue
        phi = np.zeros(6)
        phi[i] = 1.0
        most = float(al.max_along(phi))
        if not most > 0.0:  # a thruster limited to one direction: T φ's own direction gives
            # none (the PID's limit was 0 and the mission stalled), other thrust mixes do — what
            # the bounded allocation missions fly can give, either way (a direction no thrust
            # gives is said when the vehicle is loaded)
            most = max(al.reach(phi), al.reach(-phi))
        tau_max.append(most)
    g = gains_from_bandwidth(mass, damping, tau_max, omega=tuple(omega))
    if 3 in al.controlled and 4 in al.controlled:  # thrusters can level the vehicle: hold attitude
        import dataclasses

        w = attitude_bandwidth
        kp = tuple(float(M[i, i] * w**2) for i in (3, 4))
        kd = tuple(float(2 * M[i, i] * w) for i in (3, 4))
        g = dataclasses.replace(g, kp_attitude=kp, kd_attitude=kd)
    return g


MAX_STEPS = 2_000_000
"""Most control steps one flight may hold in memory (≈ 0.5 kB each: 5.5 h at dt = 0.01 s)."""


def step_count(duration: float, dt: float, name: str = "t_end", dt_name: str = "dt",
               max_steps: int | None = None) -> int:
    """The number of steps of ``dt`` in ``duration``, checked before anything is allocated:
    ``ValueError`` naming ``name``/``dt_name`` for a non-finite or sub-step duration or more than
    ``max_steps`` (default :data:`MAX_STEPS`) steps."""
    limit = MAX_STEPS if max_steps is None else int(max_steps)
    try:
        T, h = float(duration), float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a duration in seconds, got {duration!r}") from None
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"{dt_name} = {h:g} s: expected a finite step > 0")
    if not (math.isfinite(T) and T > 0):
        raise ValueError(f"{name} = {T:g} s: expected a finite duration > 0 (check the mission's "
                         "waypoints and speeds)")
    n = T / h
    if n < 0.5:
        raise ValueError(f"{name} = {T:g} s is shorter than one step ({dt_name} = {h:g} s); give "
                         f"a duration of at least {dt_name}")
    if n > limit:
        raise ValueError(f"{name} = {T:g} s at {dt_name} = {h:g} s is {int(round(n)):,} steps, more than "
                         f"the {limit:,} one flight may hold in memory; shorten {name} or raise "
                         f"{dt_name}")
    # half a step or more is one step: round() alone takes 0.5 to 0 (half to even) and left no step
    return max(int(round(n)), 1)


#: Most RK4 steps (control steps × substeps) one flight may take: ≈ 1 µs each on a BlueROV2, so a
#: few minutes of a compiled loop no keyboard interrupt stops.
MAX_INTEGRATION_STEPS = 200_000_000


def _mission_inputs(vehicle, mission):
    """The vehicle (a preset name or vehicle file loaded, as the Gym environment takes it) and the
    mission, or ``TypeError`` naming the argument (a string, ``None`` or a list failed later with
    an ``AttributeError`` naming neither)."""
    from uuvid.vehicle.definition import as_vehicle

    vehicle = as_vehicle(vehicle, "expected a Vehicle (uuvid.vehicle.definition.load_vehicle), a "
                                  "preset name or a vehicle file")
    if not (callable(mission) and hasattr(mission, "duration")):
        raise TypeError(f"mission: expected a WaypointMission (uuvid.simulate.reference, e.g. "
                        f"square_mission()), got {type(mission).__name__} {mission!r:.80}")
    return vehicle, mission


def _check_numbers(dt, substeps, t_end, max_steps, gains, current) -> None:
    """:func:`setup_mission`'s numbers and gains, each named in its error."""
    from uuvid.core import checks

    checks.real("dt", dt, "a control step in s")
    checks.positive("dt", dt, "s")
    checks.count("substeps", substeps, "a number of RK4 steps per control step", maximum=MAX_SUBSTEPS,
                  hint="a step of dt/10,000 buys RK4 no accuracy, only time")
    if t_end is not None:
        checks.real("t_end", t_end, "a duration in s (or None: the mission's)")
    if max_steps is not None:
        checks.count("max_steps", max_steps, "a number of control steps")
    if gains is not None:
        checks.of_type("gains", gains, DPGains, "uuvid.simulate.control.pid.DPGains (e.g. "
                       "default_gains(vehicle)) or None")
    if not hasattr(current, "sample"):
        try:
            if current is None or isinstance(current, (str, bytes)):
                raise TypeError
            np.asarray(current, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"current = {current!r}: expected three NED components in m/s (numbers) "
                            "or a current model of uuvid.simulate.currents") from None


def setup_mission(vehicle, mission: WaypointMission, *, dt: float = 0.01, substeps: int = 1,
                  gains: DPGains | None = None, thruster_chain: ThrusterChain | None = None,
                  current=(0.0, 0.0, 0.0), modes=None, t_end: float | None = None,
                  allocation: str = "priority", battery=None, soc0: float = 1.0,
                  controller: Controller | None = None,
                  disturbance: Disturbance | None = None,
                  max_steps: int | None = None, inflow: str | None = None,
                  inflow_source: str | None = None, propeller: str | None = None) -> MissionSetup:
    """Prepare a vehicle (from :func:`uuvid.vehicle.definition.load_vehicle`, or a preset name or
    vehicle file, loaded) for a mission.

    ``substeps``: RK4 steps per control step ``dt``, a whole number from 1 to :data:`MAX_SUBSTEPS`,
    and at most :data:`MAX_INTEGRATION_STEPS` in all (the compiled loop cannot be interrupted).

    ``current``: a constant NED vector or a model of :mod:`uuvid.simulate.currents`;
    ``allocation``: the saturation method of :meth:`uuvid.vehicle.allocation.Allocator.allocate`
    run at every control step (default ``priority``: exact whenever achievable);
    ``battery`` (:class:`uuvid.vehicle.power.Battery`, or ``True`` for the vehicle file's) makes
    the supply voltage a state, starting at ``soc0`` (:func:`battery_tables`);
    ``controller`` (:class:`uuvid.simulate.control.blocks.Controller`; default: the built-in PID DP with
    ``gains``, :func:`~uuvid.simulate.control.pid.pid`) and ``disturbance``
    (:class:`uuvid.simulate.disturbances.Disturbance`, a generalized force on the vehicle);
    ``max_steps`` (default :data:`MAX_STEPS`) bounds the time series held in memory.
    ``inflow`` (``None``: the vehicle file's ``inflow`` key; ``'none'``: bollard thrusters, as
    before issue 21; ``'four-quadrant'``): thrust at each thruster's advance speed
    (:func:`uuvid.vehicle.inflow.loop_arrays`); ``inflow_source`` (default: ``'vehicle file'``
    without ``inflow``, else ``'option'``) is what the metrics say it came from.  With inflow on,
    a ``thruster_chain`` in place of the vehicle's models flies the map of ``propeller`` (the
    preset or model file it came from: t200, t200-physical, or a file with a four-quadrant
    ``inflow`` section).
    """
    from uuvid.simulate.currents import as_current

    vehicle, mission = _mission_inputs(vehicle, mission)
    _check_numbers(dt, substeps, t_end, max_steps, gains, current)
    if len(vehicle.layout) == 0:
        raise ValueError(f"vehicle {vehicle.name!r} has no thrusters: nothing can fly a mission")
    if controller is not None and not isinstance(controller, Controller):
        raise TypeError("controller must be a uuvid.simulate.control.blocks.Controller(fn, params, "
                        f"state0), got {type(controller).__name__}")
    if disturbance is not None and not isinstance(disturbance, Disturbance):
        raise TypeError("disturbance must be a uuvid.simulate.disturbances.Disturbance(fn, params), "
                        f"got {type(disturbance).__name__}")
    n = len(vehicle.layout)
    own_chain = thruster_chain  # the caller's replacement chain (None: the vehicle's own models)
    if battery is True:
        battery = vehicle.battery
        if battery is None:
            raise ValueError(f"{vehicle.name} has no battery block in its vehicle file")
    if (battery is not None and thruster_chain is None and battery.thruster_power_model ==
            "t200-physical" and all(t.model == "t200" for t in vehicle.layout)):
        # on a battery, Blue Robotics thrusters default to the voltage-aware T200 fit (the
        # model the battery's currents come from) instead of the 16 V approximate preset
        from uuvid.thruster.physical import physical_model

        thruster_chain = physical_model().to_chain(max(battery.ocv_voltage))
    chains = [thruster_chain or vehicle.thruster_chain(i) for i in range(n)]
    for i, ch in enumerate(chains):
        if ch.input_kind == "speed" and own_chain is not None:  # the caller's, not the file's
            raise ValueError(f"thruster_chain ({ch.name}) takes the propeller speed (rad/s) as its "
                             "input, not a command, so a mission cannot drive the thrusters with it; "
                             "give a command-driven chain (e.g. the t200 preset, or a fit against "
                             "the command)")
        if ch.input_kind == "speed":  # a bench fit of thrust against propeller speed
            ref = vehicle.layout[i].model
            raise ValueError(
                f"{vehicle.name}: thrusters[{i}] ({vehicle.layout[i].name}): model {ref!r} takes the "
                "propeller speed (rad/s) as its input, not a command, so a mission cannot drive it; "
                "give a command-driven model (e.g. t200, or a fit against the command) as model, and "
                "to fly a four-quadrant map fitted on a bench in a flow name that file as the "
                "thruster's propeller: (vehicle file)")
    bank = ThrusterBank.from_chains(chains)
    al = vehicle.allocator(modes)
    alloc = al.to_array(allocation)
    dofs = np.array(al.controlled, dtype=np.int64)
    ep, en = al.eta
    T = t_end if t_end is not None else mission.duration
    n_steps = step_count(T, dt, "t_end" if t_end is not None else "the mission's duration",
                         max_steps=max_steps)
    if n_steps * int(substeps) > MAX_INTEGRATION_STEPS:  # before the loop, which cannot be stopped
        raise ValueError(f"substeps = {int(substeps):,}: {n_steps:,} control steps × {int(substeps):,} "
                         f"substeps is {n_steps * int(substeps):,} RK4 steps, more than the "
                         f"{MAX_INTEGRATION_STEPS:,} one flight may take (minutes of a compiled loop "
                         "that cannot be interrupted); lower substeps or shorten the flight")
    t = np.arange(n_steps) * dt
    ref = mission(t)
    cm = as_current(current)
    series = None
    if cm.is_constant:
        const = np.asarray(cm.sample(t[:1], dt)[0][0], dtype=float)
    else:
        vct, dvct = cm.sample(t, dt)
        series = (np.ascontiguousarray(vct), np.ascontiguousarray(dvct))
        const = np.asarray(vct[0], dtype=float)
    bat = battery_tables(bank, battery, soc0) if battery is not None else None
    arrays, mode, pnote = _inflow_arrays(vehicle, inflow, own_chain, propeller)
    setup = MissionSetup(vehicle, bank, mission, gains or default_gains(vehicle), dt,
                         int(substeps), alloc, dofs, np.asarray(ep, float), np.asarray(en, float),
                         np.array(vehicle.B, dtype=float, order="C"), vehicle.params.to_array(),
                         const, t, ref, cm, series, allocation, battery, bat, controller,
                         disturbance, arrays, mode, inflow_source or (
                             "vehicle file" if inflow is None else "option"), propeller_map=pnote)
    if controller is not None:
        _check_controller(setup)
    return setup


def _inflow_arrays(vehicle, inflow, thruster_chain, propeller=None):
    """The loop's inflow arrays.  A chain the caller put in place of the vehicle's models flies
    the map of ``propeller`` (the preset or model file it came from, relative to the working
    folder); without one it has none of its own (the voltage-aware T200 model
    :func:`setup_mission` picks itself on a battery is the same thruster and keeps the vehicle's
    map).  Returns ``(arrays, inflow model, propeller map note)``."""
    import dataclasses

    from uuvid.vehicle.inflow import loop_arrays, resolve_inflow
    from uuvid.vehicle.propeller_note import vehicle_propeller_note

    mode = resolve_inflow(vehicle, inflow)
    if mode != "none" and propeller is not None:
        from pathlib import Path

        from uuvid.thruster.resolve import is_preset

        ref = str(propeller) if is_preset(propeller) else str(Path(propeller).resolve())
        vehicle = dataclasses.replace(vehicle, propellers=(ref,) * len(vehicle.layout))
    elif thruster_chain is not None and mode != "none":
        raise ValueError(f"inflow {mode!r} flies each thruster's propeller map, and thruster_chain= "
                         "replaces the vehicle's models with a chain that names none: give "
                         "propeller= (the preset or model file it came from, with a map: t200, "
                         "t200-physical, or a file with a four-quadrant inflow section) or "
                         "inflow='none'")
    arrays = loop_arrays(vehicle, inflow)
    note = vehicle_propeller_note(vehicle, inflow) if arrays is not None else ""
    return arrays, mode, note


def _check_controller(setup: MissionSetup) -> None:
    """A user controller writes what its ``output`` says (:func:`~uuvid.simulate.control.blocks.
    check_output`); commands can be read back as thrust (increasing inverse tables)."""
    from uuvid.simulate.control.blocks import check_output

    c = setup.controller
    b = setup.bank
    rising = np.all(np.diff(b.inv_command, axis=1) > 0, axis=1)
    if c.output == "command" and setup.battery_array is None and not np.all(rising):
        bad = int(np.flatnonzero(~rising)[0])
        raise ValueError(f"output='command': thruster {bad} ({b.chains[bad].name}) has a "
                         "command that does not increase with thrust; the loop cannot read "
                         "its steady thrust back (give output='thrust')")
    if c.fn is not pid_controller:
        check_output(c, b.n, setup.z0(), setup.ref, setup.dt)


def allocation_method(alloc: np.ndarray) -> str:
    """The saturation method stored in an allocation array (:meth:`Allocator.to_array`)."""
    from uuvid.vehicle.allocation import _METHOD_CODE, SATURATION_METHODS

    n, m = int(alloc[0]), int(alloc[1])
    o = 3 + n * m + 4 * n
    code = 0.0 if alloc.size <= o else float(alloc[o])
    return next(k for k in SATURATION_METHODS if _METHOD_CODE[k] == code)


def _first_bad(a: np.ndarray, bad: np.ndarray) -> str:
    idx = np.unravel_index(int(np.flatnonzero(bad.ravel())[0]), a.shape)
    return f"[{', '.join(str(int(i)) for i in idx)}] = {float(a[idx])!r}"


def _positive_slots(bank: ThrusterBank) -> list[tuple[int, int, str, bool]]:
    """``(thruster, slot, "block.field", strict)`` for every block parameter its block requires
    positive (strict) or non-negative, found by asking the block itself: the slot is where the
    field lands in ``params_array``, the rule is the block's own validation of a tiny positive
    value, of 0 and of −v."""
    import dataclasses

    rules = []
    for i, ch in enumerate(bank.chains):
        poff = ch.compile().poff
        for j, blk in enumerate(ch.blocks):
            base = blk.params_array()
            for f in dataclasses.fields(blk):
                v = getattr(blk, f.name)
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                        math.isfinite(v) and v > 0):
                    continue
                try:
                    moved = dataclasses.replace(blk, **{f.name: 1.5 * v}).params_array()
                except Exception:  # noqa: BLE001 - a field the block does not take this way
                    continue
                d = np.flatnonzero(moved != base) if moved.shape == base.shape else []
                if len(d) != 1 or base[d[0]] != v:
                    continue
                ok = []  # the block accepts a tiny positive value, 0, −v?
                for trial in (1e-6 * v, 0.0, -v):
                    try:
                        dataclasses.replace(blk, **{f.name: trial})
                        ok.append(True)
                    except ParameterError:
                        ok.append(False)
                    except Exception:  # noqa: BLE001
                        ok.append(None)
                if ok[0] is True and ok[1:] in ([False, False], [True, False]):
                    # a sign rule alone (not a relation to another field, as saturation limits)
                    rules.append((i, int(poff[j]) + int(d[0]), f"{blk.TYPE}.{f.name}",
                                  ok[1] is False))
    return rules


def batch_inputs(setup: MissionSetup, vehicle_params, thruster_params=None,
                 currents=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(VP, TP, VC)`` for the compiled batch loops, checked before any of them runs: shapes
    ``(R, N_PARAMS)``, ``(R, n, P)`` of the setup's bank and ``(R, 3)``; no NaN; infinities only
    where the setup's own thruster parameters have them (an absent limit). ``ValueError`` names
    the argument, the element and what was expected."""
    from uuvid.vehicle.model import LAYOUT_VERSION, N_PARAMS, P_VERSION

    b = setup.bank
    VP = np.ascontiguousarray(np.atleast_2d(np.asarray(vehicle_params, dtype=float)))
    if VP.ndim != 2 or VP.shape[1] != N_PARAMS:
        raise ValueError(f"vehicle_params: expected (runs, {N_PARAMS}) rows of "
                         f"VehicleParams.to_array(), got shape {VP.shape}")
    R = VP.shape[0]
    if not np.all(np.isfinite(VP)):
        raise ValueError(f"vehicle_params{_first_bad(VP, ~np.isfinite(VP))}: expected finite "
                         "values (rows of VehicleParams.to_array())")
    if np.any(VP[:, P_VERSION] != LAYOUT_VERSION):
        raise ValueError(f"vehicle_params{_first_bad(VP[:, :1], VP[:, :1] != LAYOUT_VERSION)}: "
                         f"column 0 is the layout version {LAYOUT_VERSION:g}; build the rows "
                         "with VehicleParams.to_array()")
    TP = (np.ascontiguousarray(thruster_params, dtype=float) if thruster_params is not None
          else np.ascontiguousarray(np.broadcast_to(b.params, (R,) + b.params.shape)))
    if TP.shape != (R,) + b.params.shape:
        raise ValueError(f"thruster_params: expected shape {(R,) + b.params.shape} (runs, "
                         f"thrusters, parameters of the setup's bank), got {TP.shape}")
    bad = np.isnan(TP) | (np.isinf(TP) & np.isfinite(b.params)[None])
    if bad.any():
        raise ValueError(f"thruster_params{_first_bad(TP, bad)}: expected finite values (start "
                         "from the setup's bank.params)")
    for i, slot, name, strict in _positive_slots(b):
        v = TP[:, i, slot]
        low = v <= 0 if strict else v < 0
        if low.any():
            r = int(np.flatnonzero(low)[0])
            raise ValueError(f"thruster_params[{r}, {i}, {slot}] = {float(v[r])!r}: that slot is "
                             f"{name}, which must be {'> 0' if strict else '>= 0'}")
    VC = (np.ascontiguousarray(currents, dtype=float) if currents is not None
          else np.zeros((R, 3)) + setup.current)
    if VC.shape != (R, 3):
        raise ValueError(f"currents: expected shape ({R}, 3) (NED m/s per run), got {VC.shape}")
    if not np.all(np.isfinite(VC)):
        raise ValueError(f"currents{_first_bad(VC, ~np.isfinite(VC))}: expected finite NED m/s")
    return VP, TP, VC


def require_constant_current(setup: MissionSetup) -> None:
    """Batch runs take a constant current and an ideal supply (inflow flies: each vehicle's
    thrust follows its advance speed per RK4 stage, as in :func:`fly_mission`)."""
    if setup.battery_array is not None:
        raise ValueError("batch runs take an ideal supply; fly a battery run with fly_mission")
    if setup.current_series is not None:
        raise ValueError("batch runs take a constant current per vehicle; this setup's current "
                         f"varies ({getattr(setup.current_model, 'kind', '?')}): fly it with "
                         "fly_mission")


#: Largest roll or pitch (deg) a mission may reach and still count as flown (``completed``): the
#: level limit of steady flight and station keeping (:data:`uuvid.vehicle.stability.MAX_TILT_DEG`).
MISSION_MAX_TILT_DEG = MAX_TILT_DEG


def mission_completed(max_error, final_error, max_tilt_deg):
    """A mission is flown when the vehicle followed the path (max tracking error < 1 m, final
    < 0.25 m) and stayed level (tilt ≤ :data:`MISSION_MAX_TILT_DEG`); works on arrays too."""
    return ((np.asarray(final_error) < 0.25) & (np.asarray(max_error) < 1.0)
            & (np.asarray(max_tilt_deg) <= MISSION_MAX_TILT_DEG))


def attitude_metrics(quats: np.ndarray, ref_yaw: np.ndarray) -> dict:
    """Largest roll, pitch, tilt (angle of the body z axis from the vertical,
    ``acos(1 − 2(ε₁² + ε₂²))``) and heading error (deg) over a flight (quaternions ``(N, 4)``)."""
    q = np.asarray(quats, float)
    n, e1, e2, e3 = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = np.arctan2(2 * (n * e1 + e2 * e3), 1 - 2 * (e1**2 + e2**2))
    pitch = np.arcsin(np.clip(2 * (n * e2 - e3 * e1), -1.0, 1.0))
    yaw = np.arctan2(2 * (n * e3 + e1 * e2), 1 - 2 * (e2**2 + e3**2))
    tilt = np.arccos(np.clip(1 - 2 * (e1**2 + e2**2), -1.0, 1.0))
    herr = (np.asarray(ref_yaw, float) - yaw + np.pi) % (2 * np.pi) - np.pi
    return {"max_roll_deg": float(np.degrees(np.max(np.abs(roll)))),
            "max_pitch_deg": float(np.degrees(np.max(np.abs(pitch)))),
            "max_tilt_deg": float(np.degrees(np.max(tilt))),
            "max_heading_error_deg": float(np.degrees(np.max(np.abs(herr))))}


def mission_tilt_warning(setup: MissionSetup, att: dict) -> str:
    """Why a mission tilted past :data:`MISSION_MAX_TILT_DEG`, with the speed the vehicle can
    fly level (:func:`uuvid.vehicle.stability.static_stability`) when that explains it."""
    msg = (f"the vehicle tilted {att['max_tilt_deg']:.1f}° (roll {att['max_roll_deg']:.1f}°, "
           f"pitch {att['max_pitch_deg']:.1f}°), beyond the {MISSION_MAX_TILT_DEG:g}° level limit")
    try:
        lim = level_speed_limit(setup.vehicle)
    except Exception:  # noqa: BLE001 - the warning stands without the explanation
        return msg
    speed = getattr(setup.mission, "speed", None)
    if lim is not None and speed is not None and speed > lim:
        msg += (f"; the mission's {speed:g} m/s is above the {setup.vehicle.name}'s level-flight "
                f"limit {lim:.2f} m/s (uuvid vehicle stability {setup.vehicle.name}) — fly slower")
    return msg


#: Reference speeds (m/s, rad/s) below this count as "the mission does not ask for that motion".
UNALLOCATED_MOTION_TOL = 1e-3


def unallocated_motion_warning(setup: MissionSetup) -> str:
    """Why the vehicle cannot follow the mission's reference when it moves in a DOF the thrusters
    are not allocated to (``allocation.dofs`` of the vehicle file, the modes' zero DOFs): the
    reference velocity in the body frame of the reference heading — surge, sway, heave — and
    its yaw rate, each against :data:`UNALLOCATED_MOTION_TOL`; ``""`` when every motion asked for
    is allocated, or when the controller bypasses the allocation (it outputs each thruster's
    thrust or command, as the LQI does)."""
    from uuvid.vehicle.model import DOF_NAMES

    if setup.controller is not None and setup.controller.output_code != 0:
        return ""

    ctrl = {int(d) for d in setup.dofs}
    _, ref_vel, ref_yaw, ref_rate = (np.asarray(a, float) for a in setup.ref)
    c, sn = np.cos(ref_yaw), np.sin(ref_yaw)
    body = {0: c * ref_vel[:, 0] + sn * ref_vel[:, 1], 1: -sn * ref_vel[:, 0] + c * ref_vel[:, 1],
            2: ref_vel[:, 2], 5: ref_rate}
    asked = []
    for d, v in body.items():
        big = np.abs(v) > UNALLOCATED_MOTION_TOL
        if d not in ctrl and np.any(big):
            k = int(np.argmax(big))
            unit = "rad/s" if d == 5 else "m/s"
            asked.append(f"{DOF_NAMES[d]} (up to {float(np.max(np.abs(v))):.2g} {unit}, from "
                         f"t = {float(setup.t[k]):.4g} s)")
    if not asked:
        return ""
    names = ", ".join(DOF_NAMES[d] for d in sorted(ctrl)) or "nothing"
    return (f"the mission moves in {', '.join(asked)}, which the thrusters are not allocated to "
            f"(the {setup.vehicle.name}'s allocation controls {names}): the vehicle cannot "
            "follow that part of the path — add the DOF to allocation.dofs in the vehicle file, "
            "or fly a mission that faces its path")


def mission_runner(setup: MissionSetup):
    """``(run, compiled, outputs)``: ``run(k)`` flies the first ``k`` steps of the setup with the
    compiled loop :func:`fly_mission` uses, into ``outputs`` = ``(Z, F, FD, TAU, SC, VOUT)``
    (preallocated for the whole mission); ``compiled``: that loop is already compiled or loaded
    in this process.  The loop is :func:`fly_quad` for the configuration it is specialised to
    (a wrench controller — the built-in PID, cached, or the setup's, passed as a function
    pointer by :func:`compiled_quad` — no disturbance, a constant current, an ideal supply, inflow or
    not, chains ESC → first-order motor → quadratic map), else :func:`_fly_loop` with the
    setup's controller (the built-in PID by default) and disturbance as function pointers,
    specialised to the setup's configuration (:func:`specialised_loop`, :func:`loop_config`).
    Either way only the branches the configuration takes are compiled; ``run.loop`` is that
    loop."""
    s = setup
    N = s.t.size
    b = s.bank
    z0 = s.z0()
    Z = np.empty((N, z0.size))
    F = np.empty((N, b.n))
    FD = np.empty((N, b.n))
    TAU = np.empty((N, 6))
    SC = np.empty(N)
    ref_pos, ref_vel, ref_yaw, ref_rate = (np.ascontiguousarray(a) for a in s.ref)
    VCT, DVCT = s.current_series if s.current_series is not None else (np.zeros((0, 3)),) * 2
    BAT = s.battery_array if s.battery_array is not None else np.zeros(0)
    VOUT = np.zeros((N if BAT.size else 0, 3 + b.n))
    IPRM, IGEO = _inflow_or_empty(s.inflow_arrays)
    c = s.controller
    if (s.disturbance is None and (c is None or c.output_code == 0) and not BAT.size
            and not VCT.shape[0] and quad_chain(b)):  # the specialised loop
        cfn, cpar, cstate0 = _CTRL, s.gains.to_array().ravel(), np.zeros(PID_STATE_SIZE)
        if c is not None:  # a wrench controller: the same loop, the controller a pointer
            cfn, cpar = compiled_form(c)
            cpar, cstate0 = np.ascontiguousarray(cpar), c.state0
        vc = np.asarray(s.current, dtype=float)
        loop = compiled_quad(cfn, quad_config(vc, IPRM))

        def run(k):
            loop(cpar, cstate0.copy(), z0, s.vp, s.B, s.alloc, s.eta_p, s.eta_n, b.poff, b.params,
                 b.inv_thrust, b.inv_command, ref_pos[:k], ref_vel[:k], ref_yaw[:k], ref_rate[:k],
                 vc, s.dt, s.substeps, Z[:k], F[:k], FD[:k], TAU[:k], SC[:k], IPRM, IGEO)
        compiled = bool(loop.signatures)
    else:  # the loop compiled for the setup's configuration, its controller and disturbance passed
        c = s.controller or pid(s.gains)
        cfn, cpar = compiled_form(c)
        cpar, cstate0 = np.ascontiguousarray(cpar), c.state0
        d = s.disturbance
        dpar, use_d, okind = (d.params if d is not None else np.zeros(0)), d is not None, \
            c.output_code
        loop = specialised_loop(cfn, d.fn if d is not None else no_disturbance,
                                loop_config(b.soff, b.exact, IPRM))

        def run(k):
            loop(cpar, cstate0.copy(), dpar, use_d, okind, z0, s.vp, s.B, s.alloc, s.eta_p, s.eta_n,
                 s.dofs, b.kinds, b.poff, b.params, b.soff, b.outch, b.in_ch, b.exact,
                 b.inv_thrust, b.inv_command, ref_pos[:k], ref_vel[:k], ref_yaw[:k], ref_rate[:k],
                 s.current, s.dt, s.substeps, Z[:k], F[:k], FD[:k], TAU[:k], SC[:k], VCT, DVCT, BAT,
                 VOUT[:k] if BAT.size else VOUT, IPRM, IGEO)
        compiled = bool(loop.signatures)
    run.loop = loop  # the compiled loop it flies (its numba dispatcher: cache statistics…)
    return run, compiled, (Z, F, FD, TAU, SC, VOUT)


def _fly_steps(run, k: int, setup: MissionSetup, Z: np.ndarray) -> None:
    """``run(k)`` (:func:`mission_runner`); an exception a compiled user controller or a
    disturbance raised (the loop itself raises none) comes out as a
    :class:`~uuvid.simulate.control.blocks.ControllerRaised` naming it and the time of the step
    it raised at, as a plain Python controller's does: the loop writes a step's state row once
    the step's control is computed, so the first row left unwritten is that step's."""
    from uuvid.simulate.control.blocks import ControllerRaised, _raised_where, describe_origin

    c, d = setup.controller, setup.disturbance
    if c is None and d is None:
        run(k)
        return
    Z[:k, 0] = np.nan  # every row is written in full by a flight that ends
    try:
        run(k)
    except ControllerRaised:  # a Python controller's: it says its own time
        raise
    except Exception as e:
        left = np.flatnonzero(np.isnan(Z[:k, 0]))
        step = int(left[0]) if left.size else k - 1
        if d is None:
            who = describe_origin(c)
        else:
            who = (f"the controller ({c.name if c is not None else 'PID DP'}) or the disturbance "
                   f"({d.name})")
        raise ControllerRaised(who, float(setup.t[step]), e,
                               _raised_where(e, c.fn if c is not None else None)) from e


def fly_mission(setup: MissionSetup) -> MissionResult:
    """Fly the mission once; returns the time series and the summary."""
    from uuvid.core.checks import of_type

    s = of_type("setup", setup, MissionSetup, "a MissionSetup (setup_mission(vehicle, mission))")
    b = s.bank
    run, compiled, (Z, F, FD, TAU, SC, VOUT) = mission_runner(s)
    N = s.t.size
    # copies: the setup is flown again, and a result's arrays are the caller's to change
    ref_pos, ref_yaw = (np.array(s.ref[k], dtype=float, order="C") for k in (0, 2))
    VCT = s.current_series[0] if s.current_series is not None else np.zeros((0, 3))
    BAT = s.battery_array if s.battery_array is not None else np.zeros(0)
    compile_s = 0.0
    if not compiled:  # first flight in this process: compile (or load) the kernel on one
        # step, timed apart, so the real-time factor measures flying, not compiling
        t0 = time.perf_counter()
        _fly_steps(run, min(N, 1), s, Z)
        compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    _fly_steps(run, N, s, Z)
    wall = time.perf_counter() - t0
    if not np.all(np.isfinite(Z)):
        k = int(np.flatnonzero(~np.all(np.isfinite(Z), axis=1))[0])
        raise ValueError(f"the simulation diverged at t = {s.t[k]:.3f} s; try a smaller dt or more "
                         "substeps")
    out = s.controller.output if s.controller is not None else "wrench"
    # what the controller outputs is what it gave non-finite: a thrust or command controller's
    # NaN reaches the wrench only through B (η ∘ f), and "wrench" sent its author to the wrong code
    checks = ((TAU, "wrench"), (FD, "thrust command")) if out == "wrench" else (
        (FD, f"{out} (output={out!r}, one per thruster)"), (TAU, "wrench"))
    for arr, what in checks:
        bad = ~np.all(np.isfinite(arr), axis=1)
        if bad.any():  # the allocator read NaN as no thrust: a silent stop of the vehicle
            k = int(np.flatnonzero(bad)[0])
            who = f"the controller ({s.controller.name})" if s.controller is not None else \
                "the controller"
            raise ValueError(f"{who} gave a non-finite {what} from t = {s.t[k]:.4g} s "
                             f"({int(bad.sum())} steps): a controller must output finite numbers")
    lim = s.vehicle.layout.limits
    if BAT.size:  # the limits follow the supply voltage: those at the start, per step for checks
        lo_t, hi_t = battery_limits(BAT, VOUT[:, 0])
        lim = np.column_stack([np.full(b.n, lo_t[0]), np.full(b.n, hi_t[0])])
    res = MissionResult(s.t.copy(), Z, F, FD, TAU, SC, ref_pos, ref_yaw,
                        tuple(th.name for th in s.vehicle.layout), lim)
    err = res.tracking_error
    if BAT.size:
        over = np.maximum(F - hi_t[:, None] * (1 + 1e-9), lo_t[:, None] * (1 + 1e-9) - F)
    else:
        over = np.maximum(F - lim[:, 1] * (1 + 1e-9), lim[:, 0] * (1 + 1e-9) - F)
    att = attitude_metrics(Z[:, 3:7], ref_yaw)
    tracked = bool(mission_completed(float(np.max(err)), float(err[-1]), 0.0))
    level = bool(att["max_tilt_deg"] <= MISSION_MAX_TILT_DEG)
    summary = {
        "vehicle": s.vehicle.name,
        "mission": s.mission.name,
        "speed_m_s": float(s.mission.speed),
        **({"mission_note": s.mission.note} if getattr(s.mission, "note", "") else {}),
        # tracked the path *and* stayed level, to the path's end, on charge (set below): a vehicle
        # that follows the waypoints pitched 40° (or upside down), or whose duration stops it
        # half-way, has not flown the mission a pilot asked for
        "completed": tracked and level,
        "completed_reason": "",  # why not, in short (the warnings say more)
        **att,
        "max_tracking_error_m": float(np.max(err)),
        "rms_tracking_error_m": float(np.sqrt(np.mean(err**2))),
        "final_position_error_m": float(err[-1]),
        "max_thrust_N": float(np.max(np.abs(F))),
        "thrust_limit_N": float(np.max(np.abs(lim))),
        "thrust_limits_N": [float(np.min(lim[:, 0])), float(np.max(lim[:, 1]))],
        "thrust_over_limit": bool(np.any(over > 0)),
        "saturated_fraction": float(np.mean(SC < 1.0)),
        "sim_time_s": float(s.t[-1] + s.dt),
        "wall_time_s": wall,
        "real_time_factor": float((s.t[-1] + s.dt) / wall) if wall > 0 else math.inf,
        "compile_time_s": compile_s,  # kernel compile/cache load, not part of wall_time_s
        "dt": s.dt,
        "substeps": s.substeps,
        "allocation": s.allocation,
        "current": getattr(s.current_model, "kind", "constant"),
        "controller": s.controller.name if s.controller is not None else "PID DP",
        "controller_output": s.controller.output if s.controller is not None else "wrench",
        "disturbance": s.disturbance.name if s.disturbance is not None else "none",
        "inflow": s.inflow,  # thrust against the advance speed, and who switched it so
        "inflow_source": s.inflow_source,
        **({"propeller_map": s.propeller_map} if s.propeller_map else {}),
        "current_max_speed_m_s": float(np.max(np.linalg.norm(VCT, axis=1))) if VCT.shape[0]
        else float(np.linalg.norm(s.current)),
    }
    warnings, why_not = [], []  # why_not: completed_reason's parts
    unallocated = unallocated_motion_warning(s)
    if unallocated:  # first: it explains the tracking error below
        warnings.append(unallocated)
    cur_max = summary["current_max_speed_m_s"]
    said = CANNOT_FLY in summary.get("mission_note", "")  # the cruising-speed note says it
    too_strong = "" if said else current_limit_warning(s.vehicle, cur_max, s.inflow)
    if too_strong:  # before the tracking error and tilt it explains
        warnings.append(too_strong)
    if not tracked:
        hint = "" if said or too_strong or not cur_max > 0 else (
            f"; the current reaches {cur_max:.2f} m/s — `uuvid vehicle hold "
            f"{vehicle_ref(s.vehicle)}` gives the current the vehicle holds")
        warnings.append(f"the vehicle did not follow the path (max tracking error "
                        f"{float(np.max(err)):.2f} m, final {float(err[-1]):.2f} m; completed needs "
                        f"< 1 m and < 0.25 m at the end){hint}")
        why_not.append("off the path")
    if not level:
        warnings.append(mission_tilt_warning(s, att))
        why_not.append(f"tilted {att['max_tilt_deg']:.2f}° (level limit {MISSION_MAX_TILT_DEG:g}°)")
    path_end = path_cut(s)
    summary["path_finished"] = path_end is None
    if path_end is not None:  # tracked over the part flown is not the mission flown
        warnings.append(f"the flight stops at t = {summary['sim_time_s']:.4g} s, before the path "
                        f"ends (t = {path_end:.4g} s): the duration cuts the mission short, so it "
                        "is not completed (path_finished: false) — give a duration (t_end) of at least "
                        f"{path_end:.4g} s, or none for the mission's own")
        why_not.append(f"the duration ends before the path (flight stops at "
                       f"{summary['sim_time_s']:.4g} s, path ends at {path_end:.4g} s)")
    if BAT.size and float(np.min(VOUT[:, 2])) <= 0.0:
        k = int(np.argmax(VOUT[:, 2] <= 0.0))
        warnings.append(f"the battery ({s.battery.name}) is empty from t = {float(res.t[k]):.4g} s "
                        f"(state of charge {float(VOUT[k, 2]):.3g}): past that the mission flew "
                        "on charge the battery does not hold — start fuller or fly shorter")
        why_not.append(f"the battery is empty from t = {float(res.t[k]):.4g} s")
    summary["completed"] = not why_not
    summary["completed_reason"] = "; ".join(why_not)
    summary["warnings"] = warnings
    if BAT.size:
        summary.update({"battery": s.battery.name, "supply_voltage_V": [float(VOUT[0, 0]),
                                                                          float(VOUT[-1, 0])],
                        "soc": [float(VOUT[0, 2]), float(VOUT[-1, 2])],
                        "max_battery_current_A": float(np.max(VOUT[:, 1])),
                        "thrust_limits_end_N": [float(lo_t[-1]), float(hi_t[-1])]})
    return MissionResult(res.t, res.state, res.thrust, res.thrust_cmd, res.tau_cmd, res.scale,
                         res.ref_pos, res.ref_yaw, res.thruster_names, lim, summary,
                         VOUT if BAT.size else None)


#: Columns of :func:`run_batch`'s rows (:func:`_summarise_run`).
RUN_COLUMNS = ("max_tracking_error_m", "rms_tracking_error_m", "max_thrust_N",
               "final_position_error_m", "min_allocation_scale", "max_tilt_deg")


def run_batch(setup: MissionSetup, vehicle_params: np.ndarray, thruster_params: np.ndarray | None = None,
              currents: np.ndarray | None = None) -> np.ndarray:
    """Fly ``len(vehicle_params)`` vehicles in parallel; returns ``(runs, 6)`` summary rows
    ``[max err, rms err, max |thrust|, final err, min allocation scale, max tilt (deg)]``
    (:data:`RUN_COLUMNS`).

    A setup with a user controller or a disturbance flies the loop that takes them as function
    pointers (:func:`compiled_loop`: one vehicle per thread, each from its own copy of the controller
    state; a plain Python controller flies the vehicles one after another).

    Inflow (the setup's ``inflow``, issue 21): every vehicle flies :func:`_fly_loop` with the
    setup's inflow arrays, so its thrust follows the advance speed of each RK4 stage exactly as
    in :func:`fly_mission` (the same compiled arithmetic; the propeller map and thruster
    geometry are the setup's, shared by the batch)."""
    s = setup
    require_constant_current(s)
    b = s.bank
    VP, TP, VC = batch_inputs(s, vehicle_params, thruster_params, currents)
    nrun = VP.shape[0]
    OUT = np.empty((nrun, len(RUN_COLUMNS)))
    ref_pos, ref_vel, ref_yaw, ref_rate = (np.ascontiguousarray(a) for a in s.ref)
    IPRM, IGEO = _inflow_or_empty(s.inflow_arrays)
    if s.controller is not None or s.disturbance is not None:
        _, batch, cpar, cstate0, dpar, use_d, okind = s.blocks()
        batch(cpar, cstate0, dpar, use_d, okind, s.z0(), VP, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs,
              b.kinds, b.poff, TP, b.soff, b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command,
              ref_pos, ref_vel, ref_yaw, ref_rate, VC, s.dt, s.substeps, OUT, IPRM, IGEO)
        return OUT
    fly_batch(s.z0(), VP, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs, b.kinds, b.poff, TP, b.soff,
              b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command, s.gains.to_array(), ref_pos,
              ref_vel, ref_yaw, ref_rate, VC, s.dt, s.substeps, OUT, (IPRM, IGEO))
    return OUT
