"""Schedule optimiser (``nodesim optimize``): the cheapest update/timeout schedule that meets an accuracy target.

:mod:`~nodesim.optimization.problem` reads and validates the optimisation file (base scenario, decision
variables, objectives, constraints); :mod:`~nodesim.optimization.search` runs the Optuna study, one batched
Monte Carlo run per trial on the sweep executors; :mod:`~nodesim.optimization.outcome` builds the trial and
Pareto tables, the recommendation and the sensitivities.
"""
