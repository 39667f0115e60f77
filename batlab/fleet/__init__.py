"""Fleet work on a Dask cluster, and the fleet benchmarks' virtual bats.

``cluster`` opens a client (a local cluster sized to the machine, or a running scheduler)
and maps work over it in order; ``inspect_fleet`` is `batlab fleet inspect` (workers judge,
the client stores); ``calibrate`` and ``clean_retests`` are `batlab fleet calibrate` (clean
re-tests of one bat, its registration cached per worker). ``runner`` calls `batlab`
(``batlab.cli.main``) in a worker and maps the benchmarks' bats over the cluster
(``fleet_map``); ``jobs`` draws, writes and inspects the bats of the false-alarm and
detection studies, ``cache`` those of the field fleet. Their scoring is pure and lives in
``updating.simulate.scoring``, ``updating.simulate.lab_methods`` and
``updating.simulate.detection``.
"""
