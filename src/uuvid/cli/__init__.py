"""The ``uuvid`` command (typer): ``app.py`` holds the app and the thruster/reproduce commands;
``vehicle_cmds.py`` (simulate, vehicle), ``fit_cmd.py`` (thruster fit), ``identify_cmds.py``
(vehicle identify steady, registration), ``inertia_cmd.py`` (vehicle identify inertia),
``log_options.py`` (their shared log options), ``design_cmds.py`` (design-input, reproduce
caccia2000), ``uncertainty_cmds.py`` (sweep, montecarlo),
``demo.py`` and ``bench.py`` register onto it."""
