"""Thruster identification: steady maps and degree selection (``steady``, ``regions``), the
voltage-aware physical model (``physical``), dynamic models and their selection (``dynamic``,
``dynamic_select``), the McLean test rig (``rig``), the T200 preset refit (``t200_preset``) and the
bench-file workflow behind ``uuvid thruster fit`` (``workflow``)."""
