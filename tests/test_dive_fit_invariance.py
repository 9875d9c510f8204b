"""The dive output-error fit works on time and position relative to each window's start: a heading
written as (−π, π], as [0, 2π) or unwrapped + 2πk, and stamps in Unix time (1.7e9 s, where one
step of a double is 2.4e-7 s) give the same numbers."""

import numpy as np

from uuvid.simulate.dive_replay import WindowProblem


class _Channels:
    name = "synthetic"

    def __init__(self, channels):
        self.channels = channels


def _yaw_problem(t0: float, heading_offset: float):
    # stamps on a 1/64 s grid: t0 + t is exact for t0 = 1.7e9, so any difference is the fit's
    t = np.arange(0.0, 40.0, 1 / 64) + t0
    rng = np.random.default_rng(0)
    s = t - t0
    psi = 0.8 * np.sin(0.3 * s) + 0.2 * np.sin(1.1 * s) + rng.normal(0, 0.005, s.size)
    torque = 2.0 * np.cos(0.3 * s) + np.sign(np.sin(0.7 * s))
    ch = {"yaw_rad": (t, psi + heading_offset), "N_Nm": (t[::32], torque[::32])}
    wins = [(t0 + a, t0 + a + 4.0) for a in np.arange(1.0, 37.0, 4.0)]
    return WindowProblem(_Channels(ch), "yaw", wins)


def test_window_problem_works_on_time_and_heading_relative_to_each_window():
    """The RK4 half steps' force, each window's samples and its measured start rate are the same
    numbers with the time offset by 1.7e9 s and the heading by 20π (built on absolute stamps,
    the half steps of a Unix-time log were rounded to its 2.4e-7 s grid)."""
    ref = _yaw_problem(0.0, 0.0)
    for t0, off in ((1.7e9, 0.0), (0.0, 20 * np.pi), (1.7e9, -6 * np.pi)):
        p = _yaw_problem(t0, off)
        assert np.array_equal(p.Fh, ref.Fh), (t0, off, np.max(np.abs(p.Fh - ref.Fh)))
        np.testing.assert_allclose(p.y_rel, ref.y_rel, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p.v0_meas, ref.v0_meas, rtol=0, atol=1e-10)
        np.testing.assert_allclose(p.v0_weight, ref.v0_weight, rtol=1e-12)
        theta = np.array([0.3, 0.5, 2.0, 0.01])
        np.testing.assert_allclose(p.predict(theta, np.zeros(p.W), p.v0_meas) - p.y_rel,
                                   ref.predict(theta, np.zeros(p.W), ref.v0_meas) - ref.y_rel,
                                   rtol=0, atol=1e-12)
