"""Test-rig helpers (uuvid.identify.thruster.rig) against McLean 1991, Ch. III–IV: the tap test of the load
cell, undoing the load cell, and the lesson of averaging eight runs without aligning them."""

import json
import math

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.identify.thruster import rig
from uuvid.thruster.blocks import LoadCell
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import auv2_rig_chain, mclean_load_cell

WN = math.sqrt(1935.0)  # block 9: 1935/(s² + 14.1 s + 1935)
ZETA = 14.1 / (2 * WN)


def _tap_record(fs, noise_frac, seed, duration=2.0, t_tap=0.2, offset=0.5):
    """Impulse response of 1935/(s² + 14.1s + 1935) sampled at ``fs``, on an offset, with noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * fs)) / fs
    tau = np.clip(t - t_tap, 0, None)
    wd = WN * math.sqrt(1 - ZETA**2)
    h = np.where(t >= t_tap, WN / math.sqrt(1 - ZETA**2) * np.exp(-ZETA * WN * tau)
                 * np.sin(wd * tau), 0.0)
    return t, h + offset + rng.normal(0, noise_frac * h.max(), t.size)


@pytest.mark.parametrize("fs", [75.0, 1000.0])
def test_tap_test_recovers_mcleans_load_cell(fs):
    """The thesis's tap test: ω_n ≈ 44 rad/s (7 Hz), ζ ≈ 0.16, at its 75 Hz and at 1 kHz."""
    t, y = _tap_record(fs, 0.02, seed=int(fs))
    tap = rig.load_cell_from_tap(t, y)
    assert tap.method == "ringdown_fit"
    assert tap.natural_frequency == pytest.approx(WN, rel=0.01)
    assert tap.damping_ratio == pytest.approx(ZETA, rel=0.08)
    assert tap.frequency_hz == pytest.approx(7.0, abs=0.05)
    fit = tap.fit
    for name, true in (("natural_frequency", WN), ("damping_ratio", ZETA)):
        assert abs(fit[name].value - true) < 3 * fit[name].stderr
    assert fit["damping_ratio"].stderr < 0.01
    # the other two estimates agree too (less precisely at 75 Hz: ~11 samples per period)
    tol = 0.2 if fs < 100 else 0.1
    fft, logdec = tap.estimates["fft"], tap.estimates["log_decrement"]
    assert fft["natural_frequency"] == pytest.approx(WN, rel=0.05)
    assert fft["damping_ratio"] == pytest.approx(ZETA, rel=tol)
    assert fft["resonant_frequency_hz"] == pytest.approx(WN * math.sqrt(1 - 2 * ZETA**2)
                                                         / (2 * math.pi), rel=0.05)
    assert logdec["natural_frequency"] == pytest.approx(WN, rel=0.05)
    assert logdec["damping_ratio"] == pytest.approx(ZETA, rel=tol)
    assert logdec["log_decrement"] == pytest.approx(2 * math.pi * ZETA / math.sqrt(1 - ZETA**2),
                                                    rel=tol)
    lc = tap.load_cell
    assert isinstance(lc, LoadCell) and lc.natural_frequency == tap.natural_frequency
    json.dumps(tap.as_dict())


def test_tap_record_errors():
    t, y = _tap_record(75.0, 0.0, 0)
    with pytest.raises(ValueError, match="uniformly sampled"):
        rig.load_cell_from_tap(np.concatenate([t[:10], t[10:] + 0.003]), y)
    with pytest.raises(ValueError, match="samples"):
        rig.load_cell_from_tap(t, y[:-1])
    with pytest.raises(ValueError, match="no oscillation"):
        rig.load_cell_from_tap(t, np.exp(-t))  # a decay, no ringing


def _load_cell_filter(F, dt):
    """Pass a true thrust through McLean's load cell (fine grid, exact first sample)."""
    cell = ThrusterChain((mclean_load_cell(),), input_kind="thrust")
    return cell.simulate(F, dt * (F.size - 1), dt=dt, substeps=1)["measured_thrust"]


@pytest.mark.parametrize("method", ["fourier", "savgol"])
@pytest.mark.parametrize("fs", [75.0, 1000.0])
def test_remove_load_cell_recovers_a_known_thrust(method, fs):
    """A spike-and-decay thrust (rise 30 ms, decay 120 ms, like McLean's) through the load cell,
    0.05 N noise: inverting the filter gets far closer to the true thrust than the raw record."""
    rng = np.random.default_rng(7)
    fine = 2.5e-4
    tf = np.arange(0, 1.5, fine)
    tau = np.clip(tf - 0.1, 0, None)
    F = np.where(tf >= 0.1, 16 * (1 - np.exp(-tau / 0.03)) * np.exp(-tau / 0.12)
                 + 2.2 * (1 - np.exp(-tau / 0.12)) ** 2, 0.0)
    y_fine = _load_cell_filter(F, fine)
    step = round(1 / fs / fine)
    t, Ft = tf[::step], F[::step]
    y = y_fine[::step] + rng.normal(0, 0.05, t.size)
    Fh = rig.remove_load_cell(t, y, mclean_load_cell(), method=method)
    rms_raw = np.sqrt(np.mean((y - Ft) ** 2))
    rms = np.sqrt(np.mean((Fh - Ft) ** 2))
    assert rms < 0.25 * rms_raw, (rms, rms_raw)
    assert Fh.max() == pytest.approx(Ft.max(), rel=0.06)
    assert y.max() > 1.3 * Ft.max()  # the load cell overshoots (McLean: 5.4 lb out of 3.8 lb)


def test_remove_load_cell_mclean_step_response():
    """McLean's baseline: the true thrust jumps to 3.78 lb; away from the jump it is recovered."""
    rng = np.random.default_rng(8)
    dt = 1e-3
    t = np.arange(1501) * dt
    r = auv2_rig_chain().simulate(np.where(t >= 0.1, 24.0, 0.0), t[-1], dt=dt)
    F = U.to_lbf(r["thrust"])
    y = U.to_lbf(r["measured_thrust"]) + rng.normal(0, 0.02, t.size)
    Fh = rig.remove_load_cell(t, y, mclean_load_cell())
    after = t >= 0.13
    assert np.sqrt(np.mean((Fh - F)[after] ** 2)) < 0.05  # lb
    assert np.sqrt(np.mean((y - F)[after] ** 2)) > 0.4  # the raw record rings by ~0.5 lb


def test_remove_load_cell_errors():
    t = np.arange(100) * 0.01
    with pytest.raises(ValueError, match="method"):
        rig.remove_load_cell(t, np.zeros(100), mclean_load_cell(), method="magic")
    with pytest.raises(ValueError, match="polyorder"):
        rig.remove_load_cell(t, np.zeros(100), mclean_load_cell(), method="savgol", polyorder=1)
    with pytest.raises(TypeError, match="LoadCell"):
        rig.remove_load_cell(t, np.zeros(100), (44.0, 0.16))


# ------------------------------------------------------------------------------------------------
# aligning and averaging: the thesis's 5.3 → 3.5 lb lesson
# ------------------------------------------------------------------------------------------------
JITTER = 0.065  # s, ± uniform trigger jitter


@pytest.fixture(scope="module")
def eight_runs():
    """Eight 24 V runs at 75 Hz of a 5.3-lb peaked (load-cell) response, each starting at
    0.1 s ± 65 ms; the recorded command rises over 10 ms at the same instant."""
    r = auv2_rig_chain().simulate(24.0, 2.0, dt=2.5e-4, substeps=1)
    s = U.to_lbf(r["measured_thrust"])
    s *= 5.3 / s.max()
    t = np.arange(0, 1.5, 1 / 75)
    rng = np.random.default_rng(2)
    starts = 0.1 + rng.uniform(-JITTER, JITTER, 8)
    Y = np.array([np.interp(t - d, r.t, s, left=0.0) for d in starts])
    C = np.array([24.0 * np.clip((t - d) / 0.01, 0, 1) for d in starts])
    return t, Y, C, starts


def test_misaligned_average_cuts_the_peak_by_a_third(eight_runs):
    t, Y, _, _ = eight_runs
    assert Y.max(axis=1).min() > 5.1  # every run peaks near 5.3 lb (sampled at 75 Hz)
    naive = rig.average_runs(t, Y, align=False)
    assert naive.peak == pytest.approx(3.5, abs=0.3)  # Table II: 5.30 → 3.50 lb


@pytest.mark.parametrize("trigger", ["threshold", "command"])
def test_aligned_average_keeps_the_peak(eight_runs, trigger):
    t, Y, C, starts = eight_runs
    avg = rig.average_runs(t, Y, trigger=trigger, commands=C if trigger == "command" else None)
    assert avg.peak == pytest.approx(5.3, rel=0.03)
    # the recovered shifts match the jitter to within a fraction of the 13.3 ms sample period
    shifts = avg.aligned.shifts
    assert np.max(np.abs((shifts - shifts.mean()) - (starts - starts.mean()))) < 0.004
    assert np.all(avg.count[np.isfinite(avg.mean)] == 8)


def test_trigger_time_is_sub_sample():
    t = np.arange(20) * 0.1
    y = np.clip((t - 0.537) * 10, 0, 5)  # ramp from 0 at 0.537 s to 5 at 1.037 s
    assert rig.trigger_time(t, y, level=0.5) == pytest.approx(0.787, abs=1e-9)
    assert rig.trigger_time(t, y, absolute=1.0) == pytest.approx(0.637, abs=1e-9)
    assert rig.trigger_time(t, -y, level=0.5) == pytest.approx(0.787, abs=1e-9)  # falling


def test_align_errors():
    t = np.arange(10) * 0.1
    with pytest.raises(ValueError, match="as long as t"):
        rig.align_runs(t, [np.zeros(9)])
    with pytest.raises(ValueError, match="trigger must be"):
        rig.align_runs(t, [np.arange(10.0)], trigger="psychic")
    with pytest.raises(ValueError, match="needs the commands"):
        rig.align_runs(t, [np.arange(10.0)], trigger="command")
    with pytest.raises(ValueError, match="never crosses"):
        rig.align_runs(t, [np.arange(10.0)], trigger="threshold", absolute=100.0)
