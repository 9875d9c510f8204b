"""Simulation: input signals, the compiled chain kernel (``kernels``), step metrics, the one
``TimeResponse`` type, DP control and mission references, the compiled mission loop
(``vehicle_sim``), the batched vehicle kernel (``batch``), scenario files and envelope checks."""
