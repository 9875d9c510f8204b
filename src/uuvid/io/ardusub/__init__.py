"""ArduSub logs read right: the vehicle as its parameters describe it, depth and attitude from
the right sensors on one clock, flight modes, and thrust/forces from PWM at the logged voltage.

In a few lines::

    from uuvid.io.ardusub import load_dive, inspect_log
    print(inspect_log("dive.tlog").summary())
    dive = load_dive("dive.tlog")                  # or vehicle="bluerov2-heavy"
    dive.table[["t_s", "depth_m", "Z_N"]]          # pandas DataFrame, SI units
    mask, why = dive.open_loop(min_duration=5.0)   # MANUAL & armed stretches
    dive.export("dive.parquet")
"""

from uuvid.io.ardusub.dive import BASE_COLUMNS, DiveLog, load_dive
from uuvid.io.ardusub.export import check_export_path, shared_log_dir, sidecar_path
from uuvid.io.ardusub.frames import (
    DOF_COLUMNS,
    FRAME_NAMES,
    MODE_NAMES,
    VehicleConfig,
    check_vehicle,
    config_from_params,
    factor_matrix,
)
from uuvid.io.ardusub.inspect import LogInspection, inspect_log
from uuvid.io.ardusub.thrust import default_t200, load_thrust_model

__all__ = ["load_dive", "DiveLog", "inspect_log", "LogInspection", "VehicleConfig",
           "config_from_params", "check_vehicle", "factor_matrix", "default_t200",
           "load_thrust_model", "shared_log_dir", "check_export_path", "sidecar_path",
           "BASE_COLUMNS", "DOF_COLUMNS", "FRAME_NAMES", "MODE_NAMES"]
