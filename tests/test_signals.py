"""Tests for uuvid.simulate.signals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import chirp

from uuvid.simulate.signals import (
    SIGNAL_KINDS,
    Constant,
    Ramp,
    Sampled,
    Sawtooth,
    Signal,
    Sine,
    Square,
    Step,
    Sweep,
    signal_from_spec,
)

ALL_EXAMPLES: list[Signal] = [
    Constant(3.5),
    Step(24.0, t0=0.5, baseline=-1.0),
    Square(-2.0, 5.0, period=0.4, duty=0.25, t0=0.1),
    Sawtooth(0.0, 10.0, period=2.0, t0=1.0),
    Sine(1.0, 2.0, period=0.5, phase=0.3),
    Ramp(0.0, 12.0, t0=1.0, t1=3.0),
    Sweep(0.5, 2.0, f0=0.1, f1=5.0, t1=10.0),
    Sweep(0.0, 1.0, f0=0.1, f1=5.0, t1=10.0, method="logarithmic"),
    Sampled([0.0, 1.0, 2.5], [1.0, -3.0, 4.0], hold="linear"),
]


# ------------------------------------------------------------------------------ common behaviour


@pytest.mark.parametrize("sig", ALL_EXAMPLES, ids=lambda s: s.kind)
def test_shape_dtype_and_nan_propagation(sig):
    t = np.linspace(-1.0, 12.0, 53).reshape(53)
    u = sig(t)
    assert u.shape == t.shape and u.dtype == np.float64
    assert np.all(np.isfinite(u))
    grid = np.linspace(0.0, 3.0, 12).reshape(3, 4)
    assert sig(grid).shape == (3, 4)
    assert np.asarray(sig(0.7)).shape == ()
    out = sig(np.array([0.2, np.nan, 0.9]))
    assert np.isnan(out[1]) and np.isfinite(out[[0, 2]]).all()


@pytest.mark.parametrize("sig", ALL_EXAMPLES, ids=lambda s: s.kind)
def test_describe_round_trips_and_is_json(sig):
    d = sig.describe()
    assert d["kind"] == sig.kind
    again = signal_from_spec(json.loads(json.dumps(d)))
    assert again == sig
    assert hash(again) == hash(sig)
    t = np.linspace(0.0, 5.0, 101)
    np.testing.assert_array_equal(again(t), sig(t))


def test_registry_covers_all_kinds():
    assert set(SIGNAL_KINDS) == {
        "constant",
        "step",
        "square",
        "sawtooth",
        "sine",
        "ramp",
        "sweep",
        "sampled",
    }


def test_frozen():
    s = Step(1.0)
    with pytest.raises(AttributeError):
        s.amplitude = 2.0  # type: ignore[misc]


# ------------------------------------------------------------------------------------ values


def test_constant():
    np.testing.assert_array_equal(Constant(2)(np.arange(4.0)), [2.0, 2.0, 2.0, 2.0])
    assert Constant(2).value == 2.0 and isinstance(Constant(2).value, float)


def test_step_values():
    s = Step(24.0, t0=1.0, baseline=-2.0)
    np.testing.assert_array_equal(s(np.array([0.0, 0.999, 1.0, 5.0])), [-2.0, -2.0, 24.0, 24.0])
    np.testing.assert_array_equal(Step(3.0)(np.array([-1e-9, 0.0])), [0.0, 3.0])


def test_square_values_and_before_t0():
    s = Square(0.0, 1.0, period=1.0, duty=0.25, t0=2.0)
    t = np.array([0.0, 1.99, 2.0, 2.2, 2.25, 2.3, 2.99, 3.0, 3.1])
    np.testing.assert_array_equal(s(t), [0, 0, 1, 1, 0, 0, 0, 1, 1])


@pytest.mark.parametrize("duty", [0.1, 0.25, 0.5, 0.8])
def test_square_duty_cycle_mean(duty):
    low, high, period = -3.0, 7.0, 0.2
    s = Square(low, high, period=period, duty=duty)
    t = np.arange(0, 50 * 2000) * (period / 2000)  # 50 whole periods, 2000 samples each
    assert s(t).mean() == pytest.approx(low + duty * (high - low), abs=1e-3)


def test_sawtooth_known_phases():
    s = Sawtooth(2.0, 6.0, period=0.1, t0=0.0)
    t = np.array([0.0, 0.025, 0.05, 0.075, 0.1, 0.125, 0.3, 0.7, -0.05])
    np.testing.assert_allclose(s(t), [2.0, 3.0, 4.0, 5.0, 2.0, 3.0, 2.0, 2.0, 2.0], atol=1e-9)
    # just before a reset it is (almost) high
    assert s(np.array([0.1 - 1e-9]))[0] == pytest.approx(6.0, abs=1e-6)


def test_sawtooth_with_t0():
    s = Sawtooth(0.0, 1.0, period=2.0, t0=1.0)
    np.testing.assert_allclose(
        s(np.array([0.0, 1.0, 1.5, 2.0, 3.0, 4.5])), [0, 0, 0.25, 0.5, 0, 0.75]
    )


def test_sine_values():
    s = Sine(1.0, 2.0, period=4.0)
    np.testing.assert_allclose(s(np.array([0.0, 1.0, 2.0, 3.0])), [1.0, 3.0, 1.0, -1.0], atol=1e-12)
    assert s.frequency_hz == 0.25 and s.omega == pytest.approx(math.pi / 2)
    c = Sine(0.0, 1.0, period=1.0, phase=math.pi / 2)
    assert c(np.array([0.0]))[0] == pytest.approx(1.0)


def test_ramp_values():
    r = Ramp(10.0, 20.0, t0=1.0, t1=3.0)
    np.testing.assert_allclose(
        r(np.array([0.0, 1.0, 1.5, 2.0, 3.0, 9.0])), [10, 10, 12.5, 15, 20, 20]
    )
    down = Ramp(5.0, -5.0, t0=0.0, t1=1.0)
    assert down(np.array([0.5]))[0] == pytest.approx(0.0)


def _local_frequencies(sig: Sweep) -> tuple[np.ndarray, np.ndarray]:
    """(midpoint time, 1 / interval) of consecutive upward zero crossings of the waveform."""
    t = np.linspace(0.0, sig.t1, 400_001)
    u = sig(t) - sig.offset
    up = np.flatnonzero((u[:-1] <= 0) & (u[1:] > 0))  # includes the start, u(0) = 0
    tc = t[up] - u[up] * (t[up + 1] - t[up]) / (u[up + 1] - u[up])
    return 0.5 * (tc[1:] + tc[:-1]), 1.0 / np.diff(tc)


@pytest.mark.parametrize("method", ["linear", "logarithmic"])
def test_sweep_matches_scipy_and_frequency_endpoints(method):
    s = Sweep(0.0, 1.0, f0=5.0, f1=50.0, t1=4.0, method=method)
    t = np.linspace(0.0, 4.0, 10_001)
    np.testing.assert_allclose(s(t), chirp(t, 5.0, 4.0, 50.0, method=method, phi=-90), atol=1e-8)
    assert s.instantaneous_frequency(0.0) == pytest.approx(5.0)
    assert s.instantaneous_frequency(4.0) == pytest.approx(50.0)
    assert s.instantaneous_frequency(99.0) == pytest.approx(50.0)  # clamped
    assert s.instantaneous_frequency(-1.0) == pytest.approx(5.0)
    # measured from the waveform itself: local frequency of the first and last whole cycles
    t_mid, f_loc = _local_frequencies(s)
    np.testing.assert_allclose(f_loc, s.instantaneous_frequency(t_mid), rtol=0.02)
    # roughly the endpoint frequencies (the first/last whole cycles are centred near 0 and t1)
    assert t_mid[0] < 0.15 and t_mid[-1] > 3.97
    assert f_loc[0] == pytest.approx(5.0, rel=0.25) and f_loc[-1] == pytest.approx(50.0, rel=0.03)


def test_sweep_starts_at_offset_and_is_off_outside():
    s = Sweep(3.0, 2.0, f0=0.5, f1=4.0, t1=5.0)
    np.testing.assert_allclose(s(np.array([-1.0, 0.0, 5.0 + 1e-9, 100.0])), 3.0, atol=1e-12)
    t = np.linspace(0, 5, 5001)
    assert s(t).max() == pytest.approx(5.0, abs=1e-3) and s(t).min() == pytest.approx(1.0, abs=1e-3)


def test_log_sweep_with_equal_frequencies_is_a_sine():
    s = Sweep(0.0, 1.0, f0=2.0, f1=2.0, t1=3.0, method="logarithmic")
    t = np.linspace(0, 3, 301)
    np.testing.assert_allclose(s(t), np.sin(2 * np.pi * 2.0 * t), atol=1e-12)


def test_sampled_zoh():
    s = Sampled([1.0, 2.0, 4.0], [10.0, 20.0, 40.0])
    t = np.array([0.0, 1.0, 1.5, 1.999, 2.0, 3.9, 4.0, 10.0])
    np.testing.assert_array_equal(s(t), [10, 10, 10, 10, 20, 20, 40, 40])


def test_sampled_linear():
    s = Sampled(np.array([1.0, 2.0, 4.0]), np.array([10.0, 20.0, 40.0]), hold="linear")
    t = np.array([0.0, 1.0, 1.5, 3.0, 4.0, 10.0])
    np.testing.assert_allclose(s(t), [10, 10, 15, 30, 40, 40])


@pytest.mark.parametrize("hold", ["zoh", "linear"])
def test_sampled_single_sample_is_constant(hold):
    s = Sampled([2.0], [7.0], hold=hold)
    np.testing.assert_array_equal(s(np.array([-5.0, 2.0, 9.0])), [7.0, 7.0, 7.0])


def test_sampled_stores_tuples_and_is_hashable():
    s = Sampled(np.array([0.0, 1.0]), [1, 2])
    assert s.t_data == (0.0, 1.0) and s.u_data == (1.0, 2.0)
    assert {s: 1}[Sampled([0, 1], [1.0, 2.0])] == 1


# ------------------------------------------------------------------------------ invalid input


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: Square(0, 1, period=0.0), "'period' must be > 0"),
        (lambda: Square(0, 1, period=-1.0), "'period' must be > 0"),
        (lambda: Square(0, 1, period=1.0, duty=0.0), "0 < duty < 1"),
        (lambda: Square(0, 1, period=1.0, duty=1.0), "0 < duty < 1"),
        (lambda: Sawtooth(0, 1, period=0.0), "sawtooth: 'period' must be > 0"),
        (lambda: Sine(0, 1, period=0.0), "sine: 'period' must be > 0"),
        (lambda: Ramp(0, 1, t0=2.0, t1=2.0), "'t1' must be > 't0'"),
        (lambda: Ramp(0, 1, t0=2.0, t1=1.0), "'t1' must be > 't0'"),
        (lambda: Sweep(0, 1, 1.0, 2.0, t1=0.0), "'t1' must be > 0"),
        (lambda: Sweep(0, 1, -1.0, 2.0, t1=1.0), "'f0' must be >= 0"),
        (lambda: Sweep(0, 1, 0.0, 2.0, 1.0, method="logarithmic"), "'f0' must be > 0"),
        (lambda: Sweep(0, 1, 1.0, 2.0, 1.0, method="cubic"), "'method' must be one of"),
        (lambda: Step(math.nan), "'amplitude' must be finite"),
        (lambda: Step(math.inf), "'amplitude' must be finite"),
        (lambda: Step("24"), "'amplitude' must be a real number"),  # type: ignore[arg-type]
        (lambda: Step(True), "'amplitude' must be a real number"),
        (lambda: Constant(None), "'value' must be a real number"),  # type: ignore[arg-type]
        (lambda: Sampled([], []), "at least 1 sample"),
        (lambda: Sampled([0, 1], [1, 2, 3]), "same length, got 2 and 3"),
        (lambda: Sampled([0, 1, 1], [1, 2, 3]), r"strictly increasing, but t_data\[2\]"),
        (lambda: Sampled([0, 2, 1], [1, 2, 3]), r"t_data\[2\] = 1.0 <= t_data\[1\] = 2.0"),
        (lambda: Sampled([0, np.nan], [1, 2]), r"'t_data' has a non-finite value at index 1"),
        (lambda: Sampled([0, 1], [1, np.inf]), r"'u_data' has a non-finite value at index 1"),
        (lambda: Sampled([[0, 1]], [[1, 2]]), "one-dimensional"),
        (lambda: Sampled(["a"], [1]), "sequence of numbers"),
        (lambda: Sampled([0, 1], [1, 2], hold="cubic"), "'hold' must be one of"),
    ],
)
def test_invalid_parameters(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ({"amplitude": 1.0}, "missing the key 'kind'"),
        ({"kind": "pulse"}, "unknown signal kind 'pulse'"),
        ({"kind": 3}, "unknown signal kind 3"),
        ({"kind": "step"}, "step: missing required key 'amplitude'"),
        ({"kind": "step", "amplitude": 1.0, "t_0": 1.0}, "step: unknown key 't_0'"),
        ({"kind": "ramp", "start": 0, "end": 1, "t0": 0}, "missing required key 't1'"),
        ({"kind": "square", "low": 0, "high": 1, "period": 1, "duty": 2}, "0 < duty < 1"),
        (
            {"kind": "sine", "offset": 0, "amplitude": "x", "period": 1},
            "'amplitude' must be a real",
        ),
        ({"kind": "sampled", "t_data": [0, 1]}, "missing required key 'u_data'"),
    ],
)
def test_signal_from_spec_errors(spec, match):
    with pytest.raises(ValueError, match=match):
        signal_from_spec(spec)


def test_signal_from_spec_builds_with_defaults():
    s = signal_from_spec({"kind": "step", "amplitude": 24})
    assert s == Step(24.0, t0=0.0, baseline=0.0)
    with pytest.raises(TypeError, match="mapping"):
        signal_from_spec([("kind", "step")])  # type: ignore[arg-type]


# ------------------------------------------------------------------------------- properties

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
positive = st.floats(min_value=1e-3, max_value=1e3)
times = st.lists(st.floats(min_value=-1e4, max_value=1e4), min_size=1, max_size=50)


@settings(max_examples=75, deadline=None)
@given(finite, finite, positive, st.floats(min_value=0.01, max_value=0.99), finite, times)
def test_square_only_takes_low_or_high(low, high, period, duty, t0, ts):
    u = Square(low, high, period, duty, t0)(np.array(ts))
    assert np.all((u == low) | (u == high))


@settings(max_examples=75, deadline=None)
@given(finite, finite, positive, finite, times)
def test_sawtooth_stays_between_low_and_high(low, high, period, t0, ts):
    u = Sawtooth(low, high, period, t0)(np.array(ts))
    lo, hi = min(low, high), max(low, high)
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    assert np.all((u >= lo - tol) & (u <= hi + tol))


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=20, unique=True),
    st.data(),
)
def test_sampled_zoh_returns_data_values(t_list, data):
    t_data = sorted(t_list)
    u_data = data.draw(st.lists(finite, min_size=len(t_data), max_size=len(t_data)))
    s = Sampled(t_data, u_data)
    u = s(np.array(data.draw(times)))
    assert set(u.tolist()) <= set(s.u_data)
    np.testing.assert_array_equal(s(np.array(t_data)), s.u_data)
