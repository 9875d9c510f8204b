"""Simulation: input signals, the compiled mission loop (``vehicle_sim``) and batched vehicle
kernel (``batch``), controllers (``control``: block interface, PID, LQI, user files), mission
references, currents and disturbances, scenario files, station keeping, the Gymnasium environment
and mission reports.  The chain kernels live with the thrusters (:mod:`uuvid.thruster.kernels`),
the ``TimeResponse`` type and step metrics in :mod:`uuvid.core`."""
