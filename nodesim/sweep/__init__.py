"""Sweeps and Monte Carlo campaigns: sweep files, executors (local pool, Dask), Parquet campaign store.

``nodesim sweep SWEEP.toml --out DIR`` plans every (point, seed) run of a sweep file
(:mod:`nodesim.sweep.spec`), runs them on an executor (:mod:`nodesim.sweep.executors`) with bounded retries
(:mod:`nodesim.sweep.tasks`), and stores each finished run at once (:mod:`nodesim.sweep.store`).
Load the results with ``pandas.read_parquet("DIR/results.parquet")``.
"""
