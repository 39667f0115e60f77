"""Virtual fleets through the real command path: the runner of the fleet benchmarks.

``runner`` calls `batlab` (``batlab.cli.main``) in this process and spreads bats over a
process pool; ``jobs`` draws, writes and inspects the bats of the false-alarm and detection
studies. Their scoring is pure and lives in ``updating.simulate.scoring``,
``updating.simulate.lab_methods`` and ``updating.simulate.detection``.
"""
