"""Files in and out: run directories written atomically, and the small CSV files users give.

Modules: :mod:`~nodesim.io.rundir` (atomic writes, JSON/CSV, manifest facts) and
:mod:`~nodesim.io.csv_input` (the checks every user-CSV reader shares).
"""
