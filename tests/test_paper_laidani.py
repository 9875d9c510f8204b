"""Laidani et al.: the PWM → ESC → A2212 → degree-5 polynomial chain."""

import pytest

from uuvid.papers import laidani


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("laidani")
    return laidani.reproduce(out_dir=out), out


def test_full_command_thrusts_table2(result):
    r, _ = result
    assert r["omega_full_rad_s"] == pytest.approx(131.3016 * 12)
    assert r["full_forward_N"] == pytest.approx(12.0, rel=0.01)
    assert r["full_reverse_N"] == pytest.approx(10.79, rel=0.01)


def test_forward_polynomial_peaks_near_12_4N(result):
    r, _ = result
    assert r["peak_forward_N"] == pytest.approx(12.4, abs=0.1)
    assert 1300 < r["peak_forward_omega_rad_s"] < 1500


def test_dead_zone_and_saturation_detected_from_the_chain(result):
    r, _ = result
    lo, hi = r["dead_zone_us"]
    assert hi - lo == pytest.approx(50.0, abs=2.0)
    assert lo < 1500 < hi
    assert r["saturation_us"] == pytest.approx(1800.0, abs=2.0)


def test_fig10_plot_written(result):
    r, out = result
    assert (out / "laidani_fig10_sine_response.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert r["fig10"]["max_thrust_N"] == pytest.approx(r["peak_forward_N"], rel=0.01)
    assert r["fig10"]["min_thrust_N"] == pytest.approx(-10.79, rel=0.01)
