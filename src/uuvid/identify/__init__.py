"""Identification with statistics.

fit.py          one result type (``Fit``): σ, percentile error, 51.02 % significance, covariance,
                condition number, identifiability warnings; linear and nonlinear least squares
regions.py      dead zone and saturation of a steady map
steady.py       thruster steady maps per direction (K_T, c_V, polynomial + degree selection,
                dead-zone curve, table) from bench data
physical.py     voltage-aware physical thruster model (ESC duty × supply → DC motor → propeller)
t200_preset.py  the vehicles' ``t200`` preset chain fitted to the T200 sheets; its errors per sheet
dynamic.py      dynamic thruster models fitted over simulated responses (first-order, Yoerger,
                Bessa, DC motor, McLean tunnel)
rig.py          test-rig helpers: load cell from a tap test, its inversion, trigger alignment
segments.py     steady segments and robust velocities from pool logs, Savitzky–Golay velocity
vehicle_fit.py  drag + installation coefficients, model reduction, inertia (Caccia et al. 2000)
design.py       D-optimal sine experiments for the inertia
vehicle_logs.py one DOF's command/position from CSV/Parquet, ROS bags, ArduSub logs (LogSpec →
                LogData): signs/scales, duplicates, clocks, PWM → force, magnitude warnings
procedures.py   identify_steady / identify_inertia on a log: result objects with summary(),
                to_dict(), report(folder), plot(); η maps, drag sources, uniform position grid
log_reports.py  their report folders (plots, tables, summary.json, index.html)
"""
