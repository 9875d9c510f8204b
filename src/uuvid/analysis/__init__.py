"""Analyses that fly the vehicle model to answer a question: the current a vehicle can hold and its
endurance (``hold``), the speed envelope confirmed by simulation (``envelope_check``).  Analyses that
need only the model itself (static stability, the allocation-based speed envelope, linearisation)
stay in :mod:`uuvid.vehicle`."""
