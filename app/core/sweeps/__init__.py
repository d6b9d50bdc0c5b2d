"""Design sweeps: many gait solves over robot and gait parameters, and their Pareto front.

spec (the sweep file, checked), robot_variants (built-in robots with lengths and masses
changed), sampling (grid, random, Latin hypercube → points), evaluate (one point → metrics, with
a per-process cache of built NLPs), pareto (the front), results (CSV, summary). The engine that
runs points on Dask workers is app.sweep_engine.
"""
