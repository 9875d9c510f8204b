"""Controllers of the mission loop, in one room: the block interface (``blocks.Controller``), the
PID dynamic-positioning controller (``pid``), the LQI on the linearised vehicle (``lqr``) and
controllers from user files (``files``).  Import from the submodules (this package imports none of
them, so using one controller does not load the others)."""
