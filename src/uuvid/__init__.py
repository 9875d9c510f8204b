"""uuvid — model, simulate and identify underwater vehicles and their thrusters.

Everything inside is SI (N, m, s, rad, V, A, kg).  Papers that print other units are converted at
the edge in :mod:`uuvid.units`.

Domains:
    thruster   blocks of a thruster (ESC, motors, propeller maps, dynamics, McLean tunnel, rig)
    simulate   input signals, compiled chain integration, response metrics
    identify   estimation with statistics (later issues)
    io         model files (YAML/TOML), atomic writes, bench data
    report     plots and self-contained HTML reports
    papers     reproductions of the papers' tables, as clients of the public API
    cli        the ``uuvid`` command
"""

__version__ = "0.1.0"
