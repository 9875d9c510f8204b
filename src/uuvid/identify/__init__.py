"""Identification with statistics, in two rooms sharing one result type.

fit.py      one result type (``Fit``): σ, percentile error, 51.02 % significance, covariance,
            condition number, identifiability warnings; linear and nonlinear least squares
thruster/   thruster identification: steady maps and degree selection (``steady``), dead zone and
            saturation (``regions``), the voltage-aware physical model (``physical``), the T200
            preset refit (``t200_preset``), dynamic models and their selection (``dynamic``,
            ``dynamic_select``), the test rig (``rig``), the bench workflow (``workflow``)
vehicle/    vehicle identification (Caccia et al. 2000): steady segments (``segments``), drag,
            installation and inertia fits (``fit``), one DOF from a log (``logs``), identify_steady /
            identify_inertia (``procedures``), their report folders (``reports``), D-optimal input
            design (``design``), identification from a whole piloted dive (``dive``)
"""
