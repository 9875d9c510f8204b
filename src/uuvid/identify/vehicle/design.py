"""Input design for the inertia experiment (Caccia, Indiveri & Veruggio 2000, §III-B/C).

With the drag known, eq. 3 linearised about the regime velocity ξ* is first order::

    m δξ̇ = −k_L δξ + η δφ,   k_L = k + 2 k_q |ξ*|,   τ_c = m/k_L      (eq. 13)

i.e. ``G(s) = b/(s + a)`` with ``a = k_L/m = 1/τ_c`` and ``b = η/m``.  A single sine
``φ = φ₀ + Δφ sin(ωt)`` is applied (no thrust reversal: ``Δφ < φ₀``; φ₀ sets ξ*).  The D-optimal
frequency maximises ``det M`` of the Fisher information of (a, b) from the steady-state response;
the paper's numbers imply ``ω_opt = 1/(√3 τ_c)`` (eq. 14).  This module **verifies that
numerically**: :func:`fisher_information` (``method="numeric"``) samples the steady-state
response ``y(t; θ) = Δφ·Im(G(jω; θ) e^{jωt})`` over one period, differentiates it by central
differences in θ and averages ``s sᵀ``; :func:`d_optimal_frequency` maximises ``log det M`` over
``log ω`` (grid + bounded Brent) without using the closed form.  The closed form
(``det M ∝ b² ω²/(a² + ω²)⁴``, maximal at ``ω = a/√3``) is :func:`fisher_information` with
``method="analytic"``.  The optimum does not depend on the parametrisation: (m, k) is a
frequency-independent reparametrisation of (a, b).

τ_c is known only within bounds: the inertia is the in-air inertia plus 10 … 100 % added mass.
:func:`robust_frequency` picks the frequency that maximises the *worst* normalised D-efficiency
``(det M(ω; a)/det M(a/√3; a))^{1/2}`` over that range (maximin).

:func:`design_sine_experiment` puts it together: offset φ₀ for the regime speed, the largest
amplitude that avoids thrust reversal (``Δφ ≤ (1 − margin) φ₀``), keeps the speed within a range
(linearised steady-state response at ω, or quasi-static if asked) and within the force limit, the
experiment length (settling + ``n_periods`` periods) and, when a maneuvering space is given, the
frequency raised so that the periods fit (the paper's surge test used a 26 s period instead of the
35 s optimum for this reason).  :meth:`SineDesign.command` returns the generalized-force time
series at a sample time; :meth:`SineDesign.thruster_commands` allocates it to the thrusters of a
:class:`~uuvid.vehicle.definition.Vehicle` in a thrust-mapping mode (and to voltages for
``T = c_V V|V|`` thrusters).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uuvid.simulate.signals import Sine

__all__ = [
    "SineDesign",
    "check_command_request",
    "command_column",
    "command_columns",
    "d_efficiency",
    "d_optimal_frequency",
    "design_sine_experiment",
    "fisher_information",
    "linearised_drag",
    "robust_frequency",
    "sine_levels",
    "time_constant",
]

SQRT3 = math.sqrt(3.0)


def _pos(name: str, v) -> float:
    v = float(v)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive finite number, got {v!r}")
    return v


def linearised_drag(k: float, k_q: float, speed: float) -> float:
    """``k_L = k + 2 k_q |ξ*|`` (eq. 13)."""
    if not (math.isfinite(k) and math.isfinite(k_q) and k >= 0 and k_q >= 0):
        raise ValueError(f"drag coefficients must be finite and >= 0, got k={k!r}, k_q={k_q!r}")
    kl = k + 2.0 * k_q * abs(float(speed))
    if kl <= 0:
        raise ValueError("linearised drag k_L is zero (no linear drag at zero speed)")
    return kl


def time_constant(mass: float, k_L: float) -> float:
    """``τ_c = m/k_L``."""
    return _pos("mass", mass) / _pos("k_L", k_L)


# ---------------------------------------------------------------------------------------------
# Fisher information of b/(s + a) under a sine
# ---------------------------------------------------------------------------------------------
def _response(theta, omega, amplitude, tt):
    a, b = theta
    G = b / (1j * omega + a)
    return amplitude * np.imag(G * np.exp(1j * omega * tt))


def fisher_information(omega: float, a: float, b: float = 1.0, *, amplitude: float = 1.0,
                       noise_var: float = 1.0, method: str = "numeric", n: int = 256,
                       rel_step: float = 1e-5) -> np.ndarray:
    """Fisher information (per sample, averaged over a period) of θ = (a, b) from the steady-state
    response of ``b/(s + a)`` to ``amplitude·sin(ωt)`` in white noise of variance ``noise_var``.

    ``method="numeric"``: sampled response + central-difference sensitivities (no closed form);
    ``"analytic"``: ``½ Re(S Sᴴ)`` with ``S = amplitude·[∂G/∂a, ∂G/∂b]``.
    """
    omega = _pos("omega", omega)
    a = _pos("a", a)
    b = _pos("b", b)
    if method == "analytic":
        z = 1j * omega + a
        S = amplitude * np.array([-b / z**2, 1.0 / z])
        return 0.5 * np.real(np.outer(S, np.conj(S))) / noise_var
    if method != "numeric":
        raise ValueError(f"method must be 'numeric' or 'analytic', got {method!r}")
    tt = np.arange(n) * (2 * math.pi / omega) / n
    th = np.array([a, b])
    sens = np.empty((2, n))
    for i in range(2):
        h = rel_step * th[i]
        tp, tm = th.copy(), th.copy()
        tp[i] += h
        tm[i] -= h
        sens[i] = (_response(tp, omega, amplitude, tt) - _response(tm, omega, amplitude, tt)) / (2 * h)
    return sens @ sens.T / n / noise_var


def _logdet(omega, a, method):
    M = fisher_information(omega, a, 1.0, method=method)
    s, ld = np.linalg.slogdet(M)
    return ld if s > 0 else -np.inf


def _logdet_grid(omegas, a, method, n: int = 256, rel_step: float = 1e-5):
    """``log det M(ω)`` at every ω of a grid at once (the numeric :func:`fisher_information`'s
    arithmetic with ω along a batch axis; −inf where M is not positive definite)."""
    if method != "numeric":
        return np.array([_logdet(w, a, method) for w in omegas])
    w = np.asarray(omegas, float)[:, None]
    tt = np.arange(n) * (2 * math.pi / w) / n
    th = np.array([a, 1.0])
    sens = np.empty((w.shape[0], 2, n))
    for i in range(2):
        h = rel_step * th[i]
        tp, tm = th.copy(), th.copy()
        tp[i] += h
        tm[i] -= h
        sens[:, i] = (_response(tp, w, 1.0, tt) - _response(tm, w, 1.0, tt)) / (2 * h)
    M = np.einsum("gin,gjn->gij", sens, sens) / n
    sgn, ld = np.linalg.slogdet(M)
    return np.where(sgn > 0, ld, -np.inf)


def d_optimal_frequency(a: float, *, method: str = "numeric", span: float = 100.0,
                        n_grid: int = 241, xtol: float = 1e-10) -> float:
    """ω maximising ``det M(ω)`` for ``b/(s + a)``, found numerically over ``[a/span, a·span]``
    (log grid, then bounded Brent on ``log ω``).  Analytically ``a/√3``."""
    from scipy.optimize import minimize_scalar

    a = _pos("a", a)
    lw = np.linspace(math.log(a / span), math.log(a * span), n_grid)
    vals = _logdet_grid(np.array([math.exp(x) for x in lw]), a, method)
    i = int(np.argmax(vals))
    lo, hi = lw[max(i - 1, 0)], lw[min(i + 1, n_grid - 1)]
    res = minimize_scalar(lambda x: -_logdet(math.exp(x), a, method), bounds=(lo, hi),
                          method="bounded", options={"xatol": xtol})
    return float(math.exp(res.x))


def d_efficiency(omega, a: float) -> np.ndarray | float:
    """Normalised D-efficiency ``(det M(ω)/det M(a/√3))^{1/2}`` of a sine at ω for ``b/(s + a)``
    (closed form ``det ∝ ω²/(a² + ω²)⁴``); 1 at the optimum."""
    a = _pos("a", a)
    w = np.asarray(omega, dtype=float)
    w0 = a / SQRT3
    r = (w**2 / (a**2 + w**2) ** 4) / (w0**2 / (a**2 + w0**2) ** 4)
    out = np.sqrt(r)
    return float(out) if out.ndim == 0 else out


def robust_frequency(k_L: float, mass_range: tuple[float, float], *, n_masses: int = 41,
                     n_grid: int = 4001) -> dict:
    """Maximin-D-efficiency frequency over inertias in ``mass_range`` (``a = k_L/m``).

    Returns ``{"omega", "min_efficiency", "omega_opt_range", "efficiency_at_ends"}``.
    """
    k_L = _pos("k_L", k_L)
    m_lo, m_hi = (float(v) for v in mass_range)
    _pos("mass_range[0]", m_lo)
    if not m_hi >= m_lo:
        raise ValueError(f"mass_range must be (low, high) with high >= low, got {mass_range}")
    a_vals = k_L / np.linspace(m_lo, m_hi, n_masses)
    w_lo, w_hi = a_vals.min() / SQRT3, a_vals.max() / SQRT3
    if w_hi <= w_lo * (1 + 1e-12):
        return {"omega": w_lo, "min_efficiency": 1.0, "omega_opt_range": (w_lo, w_hi),
                "efficiency_at_ends": (1.0, 1.0)}
    grid = np.geomspace(w_lo, w_hi, n_grid)
    eff = np.min(np.array([d_efficiency(grid, a) for a in a_vals]), axis=0)
    j = int(np.argmax(eff))
    w = float(grid[j])
    return {"omega": w, "min_efficiency": float(eff[j]), "omega_opt_range": (float(w_lo), float(w_hi)),
            "efficiency_at_ends": (float(d_efficiency(w, k_L / m_lo)),
                                   float(d_efficiency(w, k_L / m_hi)))}


# ---------------------------------------------------------------------------------------------
# levels and the complete design
# ---------------------------------------------------------------------------------------------
def _steady_force(k, k_q, xi, w, eta):
    return (k * xi + k_q * xi * abs(xi) - w) / eta


def sine_levels(k: float, k_q: float, speed: float, *, speed_range: tuple[float, float] | None = None,
                eta: float = 1.0, w: float = 0.0, reversal_margin: float = 0.1,
                force_limit: float | None = None, omega: float | None = None,
                mass: float | None = None) -> dict:
    """Offset and amplitude of ``φ₀ + Δφ sin ωt`` for the regime speed ``speed`` (ξ*).

    φ₀ holds ξ* steady (``(k ξ* + k_q ξ*|ξ*| − w)/η``); Δφ is the largest amplitude with
    (i) ``Δφ ≤ (1 − reversal_margin)|φ₀|`` (no thrust reversal), (ii) ``|φ₀| + Δφ ≤ force_limit``,
    (iii) the speed within ``speed_range``: the linearised steady-state speed amplitude
    ``η Δφ/(k_L √(1 + (ωτ_c)²))`` when ``omega`` and ``mass`` are given, else quasi-statically
    (steady speeds at φ₀ ± Δφ).  Returns the levels, the bound that limited Δφ and the speed range
    reached.
    """
    from uuvid.vehicle.model import steady_speed

    if not 0 <= reversal_margin < 1:
        raise ValueError(f"reversal_margin must be in [0, 1), got {reversal_margin!r}")
    eta = _pos("eta", eta)
    if speed == 0:
        raise ValueError("the regime speed must be non-zero (a sine about zero reverses thrust)")
    phi0 = _steady_force(k, k_q, speed, w, eta)
    if phi0 * speed <= 0:
        raise ValueError(f"the offset force {phi0:.4g} does not push towards the regime speed "
                         "(the disturbance w dominates)")
    bounds = {"no_reversal": (1 - reversal_margin) * abs(phi0)}
    if force_limit is not None:
        fl = _pos("force_limit", force_limit)
        if abs(phi0) >= fl:
            raise ValueError(f"offset |φ₀| = {abs(phi0):.4g} already exceeds the force limit {fl}")
        bounds["force_limit"] = fl - abs(phi0)
    kL = linearised_drag(k, k_q, speed)
    dyn = omega is not None and mass is not None
    gain = eta / kL / (math.sqrt(1 + (omega * mass / kL) ** 2) if dyn else 1.0)

    def speeds(dphi):
        if dyn:
            dv = gain * dphi
            return speed - dv, speed + dv
        s = np.sign(phi0)
        a = steady_speed(k, k_q, eta * (phi0 - s * dphi) + w)
        b = steady_speed(k, k_q, eta * (phi0 + s * dphi) + w)
        return min(a, b), max(a, b)

    if speed_range is not None:
        lo, hi = sorted(float(v) for v in speed_range)
        if not lo <= speed <= hi:
            raise ValueError(f"regime speed {speed} is outside speed_range {speed_range}")
        top = max(bounds.values())
        a_, b_ = 0.0, top
        for _ in range(80):  # bisection on Δφ
            mid = 0.5 * (a_ + b_)
            s0, s1 = speeds(mid)
            if s0 >= lo - 1e-12 and s1 <= hi + 1e-12:
                a_ = mid
            else:
                b_ = mid
        bounds["speed_range"] = a_
    limit = min(bounds, key=bounds.get)
    dphi = bounds[limit]
    return {"offset": phi0, "amplitude": dphi, "limited_by": limit, "bounds": bounds,
            "speed_min": speeds(dphi)[0], "speed_max": speeds(dphi)[1], "k_L": kL,
            "speed_model": "linearised dynamic" if dyn else "quasi-static"}


@dataclass(frozen=True)
class SineDesign:
    """A designed inertia experiment ``φ(t) = offset + amplitude·sin(ω t)`` (after ``lead_in``).

    ``omega`` is the frequency to apply; ``omega_opt`` the D-optimal one for the nominal inertia
    (analytic ``1/(√3 τ_c)``) and ``omega_numeric`` the numeric optimum of the Fisher information;
    ``robust`` the maximin choice over the inertia range; ``efficiency`` the D-efficiency of
    ``omega`` for the nominal inertia.
    """

    dof: str
    mass: float
    k: float
    k_q: float
    speed: float
    k_L: float
    tau_c: float
    omega_opt: float
    omega_numeric: float
    omega: float
    offset: float
    amplitude: float
    n_periods: float
    settle: float
    duration: float
    sample_time: float
    efficiency: float
    distance: float
    eta: float = 1.0
    lead_in: float = 0.0
    choice: str = "nominal"
    robust: dict = field(default_factory=dict)
    levels: dict = field(default_factory=dict)
    messages: tuple[str, ...] = ()

    @property
    def period(self) -> float:
        return 2 * math.pi / self.omega

    def signal(self) -> Sine:
        """The sine as a :class:`uuvid.simulate.signals.Sine` (time from the start of the sine)."""
        return Sine(self.offset, self.amplitude, self.period)

    def command(self, sample_time: float | None = None) -> dict:
        """``{"t", "force"}``: the generalized force sampled every ``sample_time`` s over the
        experiment (``offset`` during ``lead_in``, then the sine)."""
        dt = self.sample_time if sample_time is None else _pos("sample_time", sample_time)
        _check_command_size(self.lead_in + self.duration, dt)
        n = int(math.floor((self.lead_in + self.duration) / dt + 1e-9)) + 1
        t = np.arange(n) * dt
        ts = t - self.lead_in
        f = np.where(ts < 0, self.offset, self.offset + self.amplitude * np.sin(self.omega * ts))
        return {"t": t, "force": f, "sample_time": dt, "dof": self.dof}

    def thruster_commands(self, vehicle, mode, *, sample_time: float | None = None,
                          voltage: tuple[float, float] | None = None) -> dict:
        """Allocate :meth:`command` to the thrusters of ``vehicle`` in thrust-mapping ``mode``.

        Returns ``t``, the 6-component generalized force, the nominal thrust per thruster
        (n × N, the allocator's ``T φ``; the mode's constraints hold on these commanded thrusts),
        ``mode`` (``"default"`` when none is given), ``saturated``, ``messages`` (a warning naming
        the thrusters whose commands exceed their limits: the vehicle would clip them and not
        deliver the designed force) and, with ``voltage=(c_pos, c_neg)`` of ``T = c_V V|V|``, the
        voltages.  ``ValueError`` naming the DOF and the vehicle when its thrusters cannot produce
        the designed force along the DOF in that mode (``B · thrust`` must reproduce it: BlueROV2
        allocates surge, sway, heave and yaw only, so a pitch command came out all zeros).
        """
        from uuvid.vehicle.layout import dof_index
        from uuvid.vehicle.model import DOF_NAMES

        if voltage is not None:
            voltage = tuple(_pos("c_V", v) for v in voltage)
        c = self.command(sample_time)
        al = vehicle.allocator(mode)
        mode_name = al.mode.name if al.mode is not None else (str(mode) if mode else "default")
        i = dof_index(self.dof)
        phi = np.zeros((6, c["t"].size))
        phi[i] = c["force"]
        thrust = al.T @ phi
        thrust[np.abs(thrust) < 1e-9 * max(1.0, float(np.abs(thrust).max()))] = 0.0
        got = (al.B @ thrust)[i]
        scale = float(np.max(np.abs(c["force"])))
        if scale > 0 and float(np.max(np.abs(got - c["force"]))) > 1e-6 * scale:
            allocated = ", ".join(DOF_NAMES[d] for d in al.controlled) or "no DOF"
            raise ValueError(
                f"{vehicle.name} cannot produce the designed {self.dof} command with its thrusters "
                f"in mode {mode_name}: its allocation drives {allocated}, and the thrusts it gives "
                f"for {self.dof} deliver at most {float(np.max(np.abs(got))):.3g} of the designed "
                f"{scale:.3g} {'N·m' if i >= 3 else 'N'}; pick a DOF the vehicle allocates (or a "
                "mode that drives this one), or drive it by other means")
        lim = al.limits
        over = (thrust > lim[:, 1:2] + 1e-9) | (thrust < lim[:, 0:1] - 1e-9)
        names = list(vehicle.layout.names)
        messages = []
        if np.any(over):
            bad = [names[j] for j in np.flatnonzero(over.any(axis=1))]
            peak = float(np.max(np.abs(thrust)))
            messages.append(
                f"the {self.dof} command needs up to {peak:.3g} N from thruster(s) "
                f"{', '.join(bad)}, beyond their thrust limits on {int(over.any(axis=0).sum())} of "
                f"{thrust.shape[1]} samples: the vehicle would clip them and not deliver the "
                "designed force (lower the amplitude or give the force limit)")
        out = {"t": c["t"], "generalized_force": phi, "thrust": thrust,
               "thrusters": names, "mode": mode_name,
               "sample_time": c["sample_time"], "saturated": bool(np.any(over)),
               "messages": messages}
        if voltage is not None:
            cp, cn = voltage
            out["voltage"] = np.where(thrust >= 0, np.sqrt(np.abs(thrust) / cp),
                                      -np.sqrt(np.abs(thrust) / cn))
        return out

    def as_dict(self) -> dict:
        d = {k: getattr(self, k) for k in (
            "dof", "mass", "k", "k_q", "speed", "k_L", "tau_c", "omega_opt", "omega_numeric",
            "omega", "offset", "amplitude", "n_periods", "settle", "duration", "sample_time",
            "efficiency", "distance", "eta", "lead_in", "choice")}
        d["period"] = self.period
        d["robust"] = self.robust
        d["levels"] = self.levels
        d["messages"] = list(self.messages)
        return d


def command_column(dof: str) -> str:
    """The command file's force column, named with its unit: ``force_N`` for surge, sway and
    heave, ``torque_Nm`` for roll, pitch and yaw (a yaw file's ``force`` column held N·m)."""
    from uuvid.vehicle.layout import dof_index

    return "torque_Nm" if dof_index(dof) >= 3 else "force_N"


def check_command_request(*, dof: str | None, vehicle, voltage, out) -> list[str]:
    """What a request for the designed command's outputs asks that cannot be done: ``ValueError``
    for ``voltage`` (the ``c_V`` pair) without a ``vehicle`` (the voltages are per thruster),
    a ``vehicle`` or an ``out`` file without the ``dof`` (the allocation and the column's unit,
    N or N·m, depend on it).  Returns notes: a ``vehicle`` without an ``out`` file computes the
    thruster commands but writes them nowhere (only their peak and saturation are reported)."""
    from uuvid.core.checks import arg

    if voltage is not None and vehicle is None:
        raise ValueError(f"{arg('voltage_cv')}: the voltages are per thruster; give "
                         f"{arg('vehicle')} (and {arg('out_file')}) to write them, or leave "
                         f"{arg('voltage_cv')} out")
    if vehicle is not None and not dof:
        raise ValueError(f"{arg('vehicle')} needs {arg('dof')} (the DOF the command drives)")
    if out is not None and not dof:
        raise ValueError(f"{arg('out_file')} needs {arg('dof')}: the command column is a force "
                         "[N] for surge, sway and heave and a torque [N·m] for roll, pitch and yaw")
    if vehicle is not None and out is None:
        return [f"{arg('vehicle')}: the per-thruster commands are not written anywhere without "
                f"{arg('out_file')} (only their peak thrust and saturation are reported)"]
    return []


def command_columns(design: SineDesign, sample_time: float | None = None,
                    thrusters: dict | None = None) -> dict[str, np.ndarray]:
    """The command file's columns: ``time``, the force column (:func:`command_column`), then
    ``thrust_<name>`` and ``voltage_<name>`` per thruster from :meth:`SineDesign.thruster_commands`
    when given."""
    cmd = design.command(sample_time)
    cols = {"time": cmd["t"], command_column(design.dof): cmd["force"]}
    if thrusters is not None:
        for key in ("thrust", "voltage"):
            if key in thrusters:
                for j, nm in enumerate(thrusters["thrusters"]):
                    cols[f"{key}_{nm}"] = thrusters[key][j]
    return cols


#: Most samples a designed command may hold (:meth:`SineDesign.command`, the thruster commands
#: and the CSV written from them take ≈ :data:`COMMAND_SAMPLE_BYTES` each): 2 million samples is
#: 55 hours at the default 0.1 s.
MAX_COMMAND_SAMPLES = 2_000_000
COMMAND_SAMPLE_BYTES = 400


def _check_command_size(length: float, sample_time: float) -> None:
    """``ValueError`` before anything is allocated when an experiment of ``length`` seconds
    sampled every ``sample_time`` s is more than :data:`MAX_COMMAND_SAMPLES` samples."""
    n = length / sample_time + 1
    if not math.isfinite(n) or n > MAX_COMMAND_SAMPLES:
        raise ValueError(
            f"the experiment lasts {length:.3g} s: sampled every {sample_time:g} s "
            f"(`sample_time=`) its command is {n:.3g} samples (≈ "
            f"{n * COMMAND_SAMPLE_BYTES / 1e9:.3g} GB with the thruster commands and the CSV), "
            f"more than the {MAX_COMMAND_SAMPLES:,} a command may hold; raise `sample_time=` or "
            "shorten the experiment (`n_periods=`, `settle_tau=`, `lead_in=`, or the inertia "
            "and drag behind τ_c)")


def design_sine_experiment(k: float, k_q: float = 0.0, *, mass: float, speed: float,
                           mass_range: tuple[float, float] | None = None,
                           mass_air: float | None = None,
                           added_fraction: tuple[float, float] = (0.1, 1.0),
                           speed_range: tuple[float, float] | None = None, eta: float = 1.0,
                           w: float = 0.0, n_periods: float = 3.0, settle_tau: float = 4.0,
                           lead_in: float = 0.0, max_distance: float | None = None,
                           force_limit: float | None = None, reversal_margin: float = 0.1,
                           amplitude: float | None = None, sample_time: float = 0.1,
                           choice: str = "nominal", dynamic_speed_check: bool = True,
                           dof: str = "") -> SineDesign:
    """Design the sine inertia experiment (see the module docstring).

    ``mass``: the nominal inertia used for τ_c (the paper: 675 kg for surge = 450 kg + 50 %;
    93.75 kg·m² for yaw, the in-air box inertia); ``mass_range`` or ``mass_air`` with
    ``added_fraction`` (default 10 … 100 %) bounds it for the robust choice; ``speed``: regime
    speed ξ* (its sign sets the offset's); ``choice``: ``"nominal"`` (``1/(√3 τ_c)``) or
    ``"robust"`` (maximin D-efficiency over the range); ``amplitude``: impose Δφ (checked against
    reversal) instead of the largest admissible one; ``max_distance``: maneuvering space (m) —
    the frequency is raised if ``settle + n_periods`` periods at ``|ξ*|`` would not fit.
    """
    from uuvid.core.checks import finite, non_negative

    if choice not in ("nominal", "robust"):
        raise ValueError(f"choice must be 'nominal' or 'robust', got {choice!r}")
    k, k_q = non_negative("k", k), non_negative("k_q", k_q)
    speed, w = finite("speed", speed), finite("w", w)
    mass = _pos("mass", mass)
    n_periods = _pos("n_periods", n_periods)
    sample_time = _pos("sample_time", sample_time)
    settle_tau = non_negative("settle_tau", settle_tau, "multiples of τ_c")
    lead_in = non_negative("lead_in", lead_in, "s")
    kL = linearised_drag(k, k_q, speed)
    tau = mass / kL
    a = 1.0 / tau
    w_opt = a / SQRT3
    w_num = d_optimal_frequency(a)
    if mass_range is None and mass_air is not None:
        ma = _pos("mass_air", mass_air)
        mass_range = (ma * (1 + added_fraction[0]), ma * (1 + added_fraction[1]))
    robust = robust_frequency(kL, mass_range) if mass_range is not None else {}
    if choice == "robust" and not robust:
        raise ValueError("choice='robust' needs mass_range or mass_air")
    omega = robust["omega"] if choice == "robust" else w_opt
    msgs = []
    if mass_range is not None and not (mass_range[0] * (1 - 1e-12) <= mass <= mass_range[1] * (1 + 1e-12)):
        # the paper's yaw design takes the in-air inertia, which lies below the a-priori range
        # (in-air + 10…100 % added mass): say so instead of printing a nominal outside its range
        msgs.append(f"the nominal inertia {mass:.4g} (τ_c = {tau:.4g} s, ω_opt = {w_opt:.4g} rad/s) "
                    f"lies outside the a-priori inertia range {mass_range[0]:.4g} … "
                    f"{mass_range[1]:.4g} (τ_c {mass_range[0] / kL:.4g} … {mass_range[1] / kL:.4g} s); "
                    + ("it is the in-air value, without added mass (the paper's yaw choice); "
                       if mass_air is not None and mass == mass_air else "")
                    + "give --mass for another nominal or --choice robust for the ω that covers "
                    "the range"
                    + (f" ({robust['omega']:.4g} rad/s)" if robust else ""))
    tau_hi = (mass_range[1] / kL) if mass_range is not None else tau
    settle = settle_tau * tau_hi
    if max_distance is not None:
        md = _pos("max_distance", max_distance)
        t_avail = md / abs(speed) - settle - lead_in
        if t_avail <= 0:
            raise ValueError(f"the maneuvering space {md} m is used up by the settling time "
                             f"({settle:.3g} s at {abs(speed)} m/s)")
        period_max = t_avail / n_periods
        if 2 * math.pi / omega > period_max:
            w_new = 2 * math.pi / period_max
            msgs.append(f"{n_periods:g} periods of {2 * math.pi / omega:.3g} s do not fit in "
                        f"{md:g} m at {abs(speed):g} m/s after {settle:.3g} s of settling: "
                        f"frequency raised from {omega:.4g} to {w_new:.4g} rad/s (period "
                        f"{period_max:.3g} s, D-efficiency {d_efficiency(w_new, a):.3f})")
            omega = w_new
    lv = sine_levels(k, k_q, speed, speed_range=speed_range, eta=eta, w=w,
                     reversal_margin=reversal_margin, force_limit=force_limit,
                     omega=omega if dynamic_speed_check else None,
                     mass=mass if dynamic_speed_check else None)
    amp = lv["amplitude"]
    if amplitude is not None:
        amp = _pos("amplitude", amplitude)
        if amp >= abs(lv["offset"]):
            raise ValueError(f"amplitude {amp} >= |offset| {abs(lv['offset']):.4g}: the thrust "
                             "would reverse")
        if amp > lv["amplitude"] * (1 + 1e-9):
            msgs.append(f"imposed amplitude {amp:.4g} exceeds the admissible {lv['amplitude']:.4g} "
                        f"(limited by {lv['limited_by']})")
    duration = settle + n_periods * 2 * math.pi / omega
    if sample_time > math.pi / omega:
        raise ValueError(f"sample_time = {sample_time:g} s: more than half the sine's period "
                         f"({2 * math.pi / omega:.4g} s), so the command cannot carry the sine "
                         f"(Nyquist); expected at most {math.pi / omega:.4g} s")
    _check_command_size(lead_in + duration, sample_time)
    return SineDesign(dof, mass, float(k), float(k_q), float(speed), kL, tau, w_opt, w_num, omega,
                      lv["offset"], amp, n_periods, settle, duration, sample_time,
                      float(d_efficiency(omega, a)), abs(speed) * (duration + lead_in), eta,
                      lead_in, choice, robust, lv, tuple(msgs))
