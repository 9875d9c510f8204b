"""Tests for uuvid.core.metrics."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uuvid.core.metrics import (
    DECAY_FRACTION,
    RISE_FRACTION,
    StepMetrics,
    mean_abs_error,
    nrmse,
    peak,
    response_direction,
    rmse,
    steady_value,
    step_response_metrics,
    time_constant_decay,
    time_constant_rise,
    time_to_fraction,
)

TAU = 0.35


def first_order(t, tau=TAU, final=1.0):
    return final * (1.0 - np.exp(-t / tau))


def peak_then_decay(t, s=20.0, h=10.0, tau=TAU, t_rise=0.05):
    """Linear rise to s + h over t_rise, then s + h·exp(-(t - t_rise)/tau)."""
    rise = (s + h) * t / t_rise
    decay = s + h * np.exp(-(t - t_rise) / tau)
    return np.where(t < t_rise, rise, decay)


def test_fractions():
    assert RISE_FRACTION == pytest.approx(0.6321205588)
    assert DECAY_FRACTION == pytest.approx(0.3678794412)


# ----------------------------------------------------------------------------- building blocks


def test_steady_value_uses_last_fraction_of_time_span():
    t = np.arange(11.0)  # 0..10
    y = np.arange(11.0)
    assert steady_value(t, y, 0.1) == pytest.approx(9.5)  # samples at t = 9, 10
    assert steady_value(t, y, 1.0) == pytest.approx(5.0)
    assert steady_value(t, y, 0.01) == pytest.approx(10.0)  # last sample always included


def test_response_direction_and_peak():
    assert response_direction([0, 1, 3, 2]) == 1.0
    assert response_direction([0, -1, -3, -2]) == -1.0
    assert response_direction([0, 5, -1], steady=-1.0) == -1.0
    assert response_direction([0, 0, 0]) == 1.0
    t = np.array([1.0, 1.1, 1.2, 1.3])
    assert peak(t, [0.0, 4.0, 4.0, 3.0]) == (4.0, pytest.approx(0.1))  # first on a plateau
    assert peak(t, [0.0, -4.0, -5.0, -3.0]) == (-5.0, pytest.approx(0.2))
    assert peak(t, [0.0, 4.0, -5.0, 3.0], direction=1) == (4.0, pytest.approx(0.1))


def test_time_to_fraction_interpolates():
    t = np.array([0.0, 1.0, 2.0])
    assert time_to_fraction(t, [0.0, 0.4, 1.0], 0.7, final=1.0) == pytest.approx(1.5)
    assert time_to_fraction(t, [0.0, -0.4, -1.0], 0.7, final=-1.0) == pytest.approx(1.5)
    assert time_to_fraction(t, [1.0, 1.4, 2.0], 0.7, final=2.0, initial=1.0) == pytest.approx(1.5)
    assert time_to_fraction(t, [0.9, 1.0, 1.0], 0.7, final=1.0) == 0.0
    assert math.isnan(time_to_fraction(t, [0.0, 0.1, 0.2], 0.7, final=1.0))
    assert math.isnan(time_to_fraction(t, [0.0, 0.1, 0.2], 0.7, final=0.0))


@pytest.mark.parametrize("t_start", [0.0, 3.0])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_time_constant_rise_of_first_order(t_start, sign):
    t = np.linspace(0.0, 10 * TAU, 4001)
    y = sign * first_order(t, final=150.0)
    assert time_constant_rise(t + t_start, y) == pytest.approx(TAU, rel=5e-3)


def test_time_constant_rise_coarse_sampling_interpolates():
    # 20 samples per tau: still within 0.5 % thanks to interpolation
    t = np.arange(0.0, 12 * TAU, TAU / 20)
    assert time_constant_rise(t, first_order(t)) == pytest.approx(TAU, rel=5e-3)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_time_constant_decay_of_pure_decay(sign):
    t = np.linspace(0.0, 10 * TAU, 4001)
    y = sign * (20.0 + 10.0 * np.exp(-t / TAU))
    assert time_constant_decay(t, y) == pytest.approx(TAU, rel=5e-3)


def test_time_constant_decay_measured_from_peak():
    t = np.linspace(0.0, 0.05 + 10 * TAU, 6001)
    assert time_constant_decay(t, peak_then_decay(t)) == pytest.approx(TAU, rel=5e-3)


def test_time_constant_decay_nan_without_overshoot():
    t = np.linspace(0.0, 10 * TAU, 2001)
    assert math.isnan(time_constant_decay(t, first_order(t)))  # peak is in the steady window
    assert math.isnan(time_constant_decay(t, np.full_like(t, 3.0)))
    # record ends before the peak has decayed to 37 %
    short = np.linspace(0.0, 0.5 * TAU, 200)
    assert math.isnan(time_constant_decay(short, 20.0 + 10 * np.exp(-short / TAU), steady=20.0))


# ------------------------------------------------------------------------ step_response_metrics


def test_step_response_metrics_hand_values():
    t = np.linspace(0.0, 0.05 + 10 * TAU, 6001) + 2.0  # t[0] != 0
    true = peak_then_decay(t - 2.0)
    speed = first_order(t - 2.0, tau=0.2, final=300.0)
    m = step_response_metrics(t, true, speed=speed)
    assert isinstance(m, StepMetrics)
    assert m.peak_output_thrust == pytest.approx(30.0, rel=1e-3)
    assert m.max_true_thrust == m.peak_output_thrust
    assert m.steady_thrust == pytest.approx(20.0, rel=1e-3)
    assert m.steady_speed == pytest.approx(300.0, rel=1e-3)
    assert m.time_to_peak == pytest.approx(0.05, abs=1e-3)
    assert m.time_constant_speed == pytest.approx(0.2, rel=5e-3)
    assert m.time_constant_decay == pytest.approx(TAU, rel=5e-3)


def test_step_response_metrics_uses_measured_as_output():
    t = np.linspace(0.0, 4.0, 4001)
    true = peak_then_decay(t)
    measured = 0.5 * peak_then_decay(t, tau=0.2)
    m = step_response_metrics(t, true, thrust_measured=measured)
    assert m.peak_output_thrust == pytest.approx(15.0, rel=1e-3)
    assert m.max_true_thrust == pytest.approx(30.0, rel=1e-3)
    assert m.steady_thrust == pytest.approx(10.0, rel=1e-3)
    assert m.time_constant_decay == pytest.approx(0.2, rel=5e-3)
    assert math.isnan(m.steady_speed) and math.isnan(m.time_constant_speed)


def test_step_response_metrics_negative_step_mirrors_positive():
    t = np.linspace(0.0, 4.0, 4001)
    pos = step_response_metrics(t, peak_then_decay(t), speed=first_order(t, final=200.0))
    neg = step_response_metrics(t, -peak_then_decay(t), speed=-first_order(t, final=200.0))
    assert neg.peak_output_thrust == pytest.approx(-pos.peak_output_thrust)
    assert neg.max_true_thrust == pytest.approx(-pos.max_true_thrust)
    assert neg.steady_thrust == pytest.approx(-pos.steady_thrust)
    assert neg.steady_speed == pytest.approx(-pos.steady_speed)
    for name in ("time_to_peak", "time_constant_speed", "time_constant_decay"):
        assert getattr(neg, name) == pytest.approx(getattr(pos, name)) and getattr(pos, name) > 0


def test_as_dict():
    t = np.linspace(0.0, 4.0, 401)
    m = step_response_metrics(t, first_order(t))
    d = m.as_dict()
    assert list(d) == [
        "peak_output_thrust",
        "max_true_thrust",
        "steady_thrust",
        "steady_speed",
        "time_to_peak",
        "time_constant_speed",
        "time_constant_decay",
    ]
    assert math.isnan(d["steady_speed"]) and math.isnan(d["time_constant_decay"])
    strict = m.as_dict(nan_as_none=True)
    assert strict["steady_speed"] is None and strict["steady_thrust"] == d["steady_thrust"]
    json.dumps(strict, allow_nan=False)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t": [0, 1], "thrust_true": [0, 1]}, "at least 3 samples"),
        ({"t": [0, 1, 2], "thrust_true": [0, 1]}, "thrust_true has length 2, expected 3"),
        ({"t": [0, 1, 2], "thrust_true": [0, 1, 2], "speed": [0, 1]}, "speed has length 2"),
        (
            {"t": [0, 1, 2], "thrust_true": [0, 1, 2], "thrust_measured": [0, 1, 2, 3]},
            "thrust_measured has length 4",
        ),
        ({"t": [0, 1, 1, 2], "thrust_true": [0, 1, 2, 3]}, r"t\[2\] = 1.0 <= t\[1\] = 1.0"),
        ({"t": [0, 2, 1, 3], "thrust_true": [0, 1, 2, 3]}, r"strictly increasing, but t\[2\]"),
        ({"t": [0, np.nan, 2], "thrust_true": [0, 1, 2]}, r"t has a non-finite value at index 1"),
        ({"t": [0, 1, 2], "thrust_true": [0, 1, np.nan]}, r"thrust_true .* index 2"),
        (
            {"t": [0, 1, 2], "thrust_true": [0, 1, 2], "speed": [np.nan, 1, 2]},
            r"speed has a non-finite value at index 0",
        ),
        (
            {"t": [0, 1, 2], "thrust_true": [0, 1, 2], "thrust_measured": [0, np.inf, 2]},
            r"thrust_measured has a non-finite value at index 1",
        ),
        ({"t": [[0, 1, 2]], "thrust_true": [0, 1, 2]}, "one-dimensional"),
        ({"t": [0, 1, 2], "thrust_true": [0, 1, 2], "steady_window": 0.0}, "steady_window"),
        ({"t": [0, 1, 2], "thrust_true": [0, 1, 2], "steady_window": 1.5}, "steady_window"),
    ],
)
def test_step_response_metrics_invalid(kwargs, match):
    with pytest.raises(ValueError, match=match):
        step_response_metrics(**kwargs)


# ------------------------------------------------------------------------------ error measures


def test_error_measures_hand_values():
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = np.array([1.0, 0.0, 3.0, 6.0])
    assert rmse(a, b) == pytest.approx(math.sqrt(2.0))
    assert mean_abs_error(a, b) == pytest.approx(1.0)
    assert nrmse(a, b) == pytest.approx(math.sqrt(2.0) / 6.0)
    assert nrmse(a, b, by="rms") == pytest.approx(math.sqrt(2.0) / math.sqrt(46.0 / 4.0))
    assert nrmse(a, b, by="std") == pytest.approx(math.sqrt(2.0) / np.std(b))
    assert rmse(a, a) == 0.0


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: rmse([1, 2], [1, 2, 3]), "same shape"),
        (lambda: mean_abs_error([], []), "must not be empty"),
        (lambda: rmse([1, np.nan], [1, 2]), "a has a non-finite value at index 1"),
        (lambda: mean_abs_error([1, 2], [np.inf, 2]), "b has a non-finite value at index 0"),
        (lambda: nrmse([1, 2], [3, 3]), "zero range"),
        (lambda: nrmse([1, 2], [3, 4], by="max"), "by must be"),
    ],
)
def test_error_measures_invalid(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.slow
@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=30).flatmap(
        lambda xs: st.tuples(
            st.just(xs), st.lists(st.floats(-1e3, 1e3), min_size=len(xs), max_size=len(xs))
        )
    )
)
def test_mae_le_rmse_and_symmetric(pair):
    a, b = pair
    assert mean_abs_error(a, b) <= rmse(a, b) * (1 + 1e-12) + 1e-12
    assert rmse(a, b) == pytest.approx(rmse(b, a))
