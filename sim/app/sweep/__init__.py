"""``vo-testbed sweep``: grids of any ``--set`` keys x seeds x estimators, run on Dask distributed.

Modules: :mod:`~sim.app.sweep.grid` (spec, axes, seeds -> cells), :mod:`~sim.app.sweep.cell` (one
generate-then-run on a worker, its atomic record), :mod:`~sim.app.sweep.fingerprint` (the code
fingerprint each record carries, so that a resume re-runs the records of other code),
:mod:`~sim.app.sweep.table` (tidy and aggregate tables), :mod:`~sim.app.sweep.plots` (heatmaps, lines,
the baseline model) and :mod:`~sim.app.sweep.driver` (the Dask client, resume, report). Dask is
imported only by the driver.
"""
