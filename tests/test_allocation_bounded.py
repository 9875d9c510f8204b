"""Bounded allocation against scipy oracles (HiGHS LP for feasibility and the largest scaling,
``lsq_linear`` BVLS for the weighted least-error optimum).

Guarantees checked (Allocator docstring): a wrench the LP finds achievable is delivered to 1e-9 N
and reported achievable; one it finds infeasible is reported not achievable and its achieved
wrench is the oracle's least-error optimum to 1e-6 (relative to the request's size, in N / N·m);
``maxscale`` returns the LP's largest scaling to 1e-6.  Wrenches within 1e-9 (relative) of the
achievable set's boundary are skipped: there the LP and our exact check may round either way.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog, lsq_linear

from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.definition import load_vehicle

CASES = [("bluerov2", None, False), ("bluerov2-heavy", None, False), ("romeo", None, True),
         ("romeo", None, False), ("romeo", "surge_front", True), ("romeo", "yaw_fl_rr", True),
         ("romeo", ("surge_rear", "vertical_all_heave_only"), True)]


def _planned_bounds(al):
    ep, en = al.eta
    lo, hi = al.limits[:, 0].copy(), al.limits[:, 1].copy()
    return (lo * en, hi * ep) if al.compensate_eta else (lo, hi)


def _lp_scale(al, phi, most=2.0):
    """max s ∈ [0, ``most``] with s·φ achievable (HiGHS; ``most=None``: unbounded above)."""
    n, ctl = al.n, list(al.controlled)
    lo, hi = _planned_bounds(al)
    C = al.mode.constraint_rows(al.B) if al.mode is not None else np.zeros((0, n))
    Aeq = np.vstack([np.hstack([al.B[ctl], -phi[ctl, None]]), np.hstack([C, np.zeros((len(C), 1))])])
    c = np.zeros(n + 1)
    c[-1] = -1.0
    r = linprog(c, A_eq=Aeq, b_eq=np.zeros(len(Aeq)), bounds=list(zip(lo, hi)) + [(0, most)],
                method="highs", options={"primal_feasibility_tolerance": 1e-10})
    assert r.status == 0
    return float(r.x[-1])


def _lsq(al, phi):
    n, ctl = al.n, list(al.controlled)
    lo, hi = _planned_bounds(al)
    C = al.mode.constraint_rows(al.B) if al.mode is not None else np.zeros((0, n))
    sq = np.sqrt(al.priority[ctl])
    A = np.vstack([sq[:, None] * al.B[ctl], 1e6 * C])  # mode equalities as a stiff penalty
    b = np.concatenate([sq * phi[ctl], np.zeros(len(C))])
    x = lsq_linear(A, b, bounds=(lo, hi), method="bvls", tol=1e-14).x
    return al.B[ctl] @ x


def _check(name, modes, comp, N, seed):
    v = load_vehicle(name)
    al = v.allocator(modes, compensate_eta=comp)
    ctl = list(al.controlled)
    ep, en = al.eta
    a_pri, a_max = al.to_array("priority"), al.to_array("maxscale")
    lim = float(np.abs(al.limits).max())
    rng = np.random.default_rng(seed)
    tau = np.empty(al.n)
    stats = {"feasible": 0, "infeasible": 0, "boundary": 0}
    for _ in range(N):
        phi = np.zeros(6)
        phi[ctl] = rng.normal(size=len(ctl)) * lim * rng.uniform(0.1, 2.5)
        scale = max(1.0, float(np.abs(phi).max()))
        s_lp = _lp_scale(al, phi)
        if abs(s_lp - 1.0) < 1e-9:
            stats["boundary"] += 1
            continue
        f = allocate_compiled(a_pri, phi, tau)
        assert np.all(tau >= al.limits[:, 0] - 1e-12) and np.all(tau <= al.limits[:, 1] + 1e-12)
        d = np.where(tau >= 0, ep, en) * tau if comp else tau
        y = al.B[ctl] @ d
        if al.mode is not None:
            assert np.abs(al.mode.constraint_rows(al.B) @ d).max(initial=0.0) < 1e-9 * scale
        if s_lp > 1.0:
            stats["feasible"] += 1
            assert f == 1.0, (name, modes, phi)
            assert np.abs(y - phi[ctl]).max() <= 1e-9
        else:
            stats["infeasible"] += 1
            assert f < 1.0, (name, modes, phi)
            assert np.abs(y - _lsq(al, phi)).max() <= 1e-6 * scale
            fm = allocate_compiled(a_max, phi, tau)
            assert abs(fm - s_lp) <= 1e-6
            d = np.where(tau >= 0, ep, en) * tau if comp else tau
            assert np.abs(al.B[ctl] @ d - fm * phi[ctl]).max() <= 1e-9 * scale
    assert stats["feasible"] > N // 20 and stats["infeasible"] > N // 20  # both cases exercised
    return stats


@pytest.mark.slow
@pytest.mark.parametrize("name,modes,comp", CASES)
def test_bounded_allocation_matches_oracles(name, modes, comp):
    _check(name, modes, comp, 120, 7)


@pytest.mark.slow
@pytest.mark.parametrize("name,modes,comp", CASES)
def test_bounded_allocation_matches_oracles_1e4(name, modes, comp):
    _check(name, modes, comp, 10_000, 11)


@pytest.mark.slow
def test_feasible_wrench_that_uniform_scaling_gives_up_is_delivered():
    """The issue's finding: minimum-norm + uniform scaling reports feasible wrenches saturated."""
    al = load_vehicle("bluerov2").allocator()
    rng = np.random.default_rng(3)
    ctl = list(al.controlled)
    found = 0
    for _ in range(400):
        phi = np.zeros(6)
        phi[ctl] = rng.normal(size=len(ctl)) * 60
        if al.allocate(phi, "scale").achievable or _lp_scale(al, phi) <= 1.0 + 1e-9:
            continue
        r = al.allocate(phi, "priority")
        assert r.achievable and np.allclose(r.achieved[ctl], phi[ctl], atol=1e-9)
        found += 1
    assert found > 0


@pytest.mark.slow
def test_shortfall_names_the_lost_dofs_and_priority_keeps_heave():
    al = load_vehicle("bluerov2").allocator()
    phi = np.array([400.0, 0, 60.0, 0, 0, 0])  # far too much surge, achievable heave
    r = al.allocate(phi, "priority")
    assert not r.achievable and "surge" in r.shortfall
    assert abs(r.achieved[2] - 60.0) < 1e-6  # heave kept (priority 1000× surge)
    assert "lost: surge" in r.report()


def _lp_reach(al, phi):
    """max s >= 0 with s·φ achievable (HiGHS, s unbounded above)."""
    return _lp_scale(al, phi, most=None)


@pytest.mark.slow
@pytest.mark.parametrize("name, modes, comp", CASES[:4])
@pytest.mark.parametrize("one_way", [False, True])
def test_reach_is_the_lp_largest_force_along_a_direction(name, modes, comp, one_way):
    """Allocator.reach (the PID's output limits come from it) is the LP's largest s with s·φ
    achievable — also with a thruster limited to one direction, where the uniform allocation's
    max_along is 0 for every direction whose T φ needs that thruster the other way."""
    from uuvid.vehicle.allocation import Allocator

    v = load_vehicle(name)
    lim = np.array(v.layout.limits, float)
    if one_way:
        lim[0, 0] = 0.0  # the first thruster cannot reverse
    base = v.allocator(modes, compensate_eta=comp)
    al = Allocator(v.B, base.dofs, base.weights, base.mode, lim, comp)
    rng = np.random.default_rng(5)
    ctl = list(al.controlled)
    phis = [s * np.eye(6)[d] for d in ctl for s in (1.0, -1.0)]
    phis += [np.where(np.isin(np.arange(6), ctl), rng.normal(size=6), 0.0) for _ in range(20)]
    zero_uniform = 0
    for phi in phis:
        want = _lp_reach(al, phi)
        got = al.reach(phi)
        assert got == pytest.approx(want, rel=1e-6, abs=1e-6)
        assert got >= al.max_along(phi) * (1 - 1e-9)
        zero_uniform += al.max_along(phi) == 0.0 and want > 1.0
    assert (zero_uniform > 0) == one_way
