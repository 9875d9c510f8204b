"""Thrusters: blocks (ESC, motors, McLean tunnel thruster, steady maps, UUV Simulator dynamics,
load cell), their composition into chains, presets built from the papers, load matching."""
