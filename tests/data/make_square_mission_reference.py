"""Regenerate ``square_mission_bluerov2.npz``: the BlueROV2 square mission (no current, ideal
supply, default priority allocation), state[:, :13] and thrust every 100th step.

Run from the worktree root: ``PYTHONPATH=src python tests/data/make_square_mission_reference.py``.
Regenerate only on a deliberate change of the flown physics (and say why in the commit); the
tests that read it guard against accidental ones.
"""

import subprocess
from pathlib import Path

import numpy as np

from uuvid.simulate.reference import square_mission
from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
from uuvid.vehicle.definition import load_vehicle

OUT = Path(__file__).with_name("square_mission_bluerov2.npz")


def main() -> None:
    r = fly_mission(setup_mission(load_vehicle("bluerov2"), square_mission()))
    rows = np.arange(0, r.state.shape[0], 100)
    base = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).parent).stdout.strip()
    np.savez_compressed(OUT, rows=rows, state=r.state[rows, :13], thrust=r.thrust[rows],
                        made_by=np.array(f"tests/data/make_square_mission_reference.py on {base}"))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
