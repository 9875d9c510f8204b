"""uuvid — model, simulate and identify underwater vehicles and their thrusters.

Everything inside is SI (N, m, s, rad, V, A, kg).  Papers that print other units are converted at
the edge in :mod:`uuvid.units`.

Domains:
    thruster     blocks of a thruster (ESC, motors, propeller maps, dynamics, McLean tunnel, rig),
                 chains, presets, load matching
    vehicle      6-DOF and 1-DOF models, thruster layouts, allocation and mapping modes, vehicle
                 files and presets, speed envelope
    simulate     signals, compiled chain and mission loops, batch runners, DP control, missions,
                 response metrics
    identify     estimation with statistics: thruster (steady, physical, dynamic, rig) and vehicle
                 (segments, drag and installation coefficients, inertia, input design)
    uncertainty  sweeps, Monte Carlo, bootstrap, execution in-process / processes / Dask
    io           model files (YAML/TOML), bench data, logs (CSV/Parquet, ROS bags, ArduSub),
                 export to UUV Simulator, atomic writes
    report       plots and self-contained HTML reports, progress bars
    papers       reproductions of the papers' tables and studies, as clients of the public API
    cli          the ``uuvid`` command
"""

__version__ = "0.1.0"

# numba's cache=True stamps a function by its own file only: key uuvid's on all its compiled code
from uuvid import _numba_cache  # noqa: E402

_numba_cache.install()
