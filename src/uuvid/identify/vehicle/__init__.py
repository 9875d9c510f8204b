"""Vehicle identification (Caccia et al. 2000): steady segments of a log (``segments``), least-squares
drag, installation and inertia fits with statistics (``fit``), identification from pool logs
(``logs``, ``procedures``), their reports (``reports``), optimal input design (``design``) and the
model of a whole piloted dive, closed loop included (``dive``)."""
