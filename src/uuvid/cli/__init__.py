"""The ``uuvid`` command (typer): ``app.py`` holds the app and the thruster/reproduce commands;
``vehicle_cmds.py`` (simulate, vehicle), ``fit_cmd.py`` (thruster fit), ``identify_cmds.py``
(vehicle identification, reproduce caccia2000), ``uncertainty_cmds.py`` (sweep, montecarlo),
``demo.py`` and ``bench.py`` register onto it."""
