"""Batches: ``labsim sweep`` runs behaviour files over a grid of parameters and seeds.

``grid`` (the runs a sweep makes and one run's row), ``pool`` and ``dask_pool`` (the two
executors; ``isolated``, a Dask run's own process), ``ending`` (how a sweep and its workers
end), ``stats`` (the comparison per setting, with ``student_t``), ``output`` (the rows and the
table), ``plot`` (its chart) and ``driver`` (from the command line's options to an exit code).
"""
