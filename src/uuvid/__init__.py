"""uuvid — model, simulate and identify underwater vehicles and their thrusters.

Everything inside is SI (N, m, s, rad, V, A, kg).  Papers that print other units are converted at
the edge in :mod:`uuvid.core.units`.

Rooms, bottom layer first (every import runs down; see docs/architecture.md):
    core         units, TimeResponse and metrics, the Result surface, figures, HTML pages,
                 progress, atomic writes, the disk cache
    thruster     blocks of a thruster (ESC, motors, propeller maps, dynamics, McLean tunnel, rig),
                 chains and their compiled kernels, the physical model, presets, model files,
                 load matching
    vehicle      6-DOF and 1-DOF models, thruster layouts, allocation and mapping modes, vehicle
                 files and presets, battery, stability, speed envelope, linearisation
    io           bench data, logs (CSV/Parquet, ROS bags, ArduSub), export to UUV Simulator
    simulate     signals, the compiled mission loop and batch runners, controllers
                 (``simulate.control``), missions, scenarios, station keeping, Gymnasium env
    identify     estimation with statistics: ``identify.thruster`` (steady, physical, dynamic, rig)
                 and ``identify.vehicle`` (segments, drag and installation coefficients, inertia,
                 input design), sharing ``identify.fit``
    analysis     analyses that fly the vehicle: holding a current, endurance, envelope check
    uncertainty  sweeps, Monte Carlo, bootstrap, execution in-process / processes / Dask
    papers       reproductions of the papers' tables and studies, as clients of the public API
    cli          the ``uuvid`` command
"""

__version__ = "0.1.0"

# numba's cache=True stamps a function by its own file only: key uuvid's on all its compiled code
from uuvid.core import numba_cache  # noqa: E402

numba_cache.install()
