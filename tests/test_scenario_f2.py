"""Scenario keys and files a new user got silently wrong (fix-f2, items 2-4): controller gains
that did nothing, a current CSV whose typo'd or duplicated columns were dropped, implausible
vertical currents and depths accepted without a word."""


import pytest

from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

GAINS = [1.0, 1.0, 1.0, 1.0]


@pytest.mark.parametrize("controller, said", [
    ({"kd": [1000, 1000, 1000, 1000]}, r"controller: kd: given without kp.*ki/kd need kp"),
    ({"ki": GAINS}, r"controller: ki: given without kp.*ki/kd need kp"),
    ({"kind": "lqr", "bandwidth": GAINS}, r"controller: bandwidth: only with kind: pid"),
    ({"kind": "lqr", "kp": GAINS}, r"controller: kp: only with kind: pid"),
    ({"kind": "lqr", "kp": GAINS, "kd": GAINS}, r"controller: kp, kd: only with kind: pid"),
    ({"kp": GAINS, "bandwidth": GAINS}, r"controller: bandwidth and kp are exclusive"),
])
def test_controller_gains_that_would_do_nothing_are_refused(controller, said):
    """`{kd: [1000]*4}` flew exactly as `{kd: [0]*4}` (no kp: the bandwidth's gains); an lqr with
    bandwidth or kp flew the LQI unchanged; kp beside bandwidth dropped the bandwidth."""
    with pytest.raises(ScenarioError, match=said):
        scenario_from_dict({"controller": controller}, where="s.yaml")


@pytest.mark.parametrize("controller", [
    {"kp": GAINS, "kd": GAINS}, {"kp": GAINS}, {"bandwidth": GAINS}, {"kind": "lqr"},
    {"kind": "pid", "kp": GAINS, "ki": GAINS, "kd": GAINS},
])
def test_controller_gains_that_fly_are_still_taken(controller):
    scenario_from_dict({"controller": controller}, where="s.yaml")

