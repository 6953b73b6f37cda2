"""Campaigns: many runs of scenarios over drawn plant overrides (``wheelleg campaign``).

sampling (what each run is), execution (one run, and the Dask engine),
journal (results.jsonl and resuming), analysis and report (report.md, the PNG),
progress (the bar); margins (robustness margins: the bisection per key and
side, the table) and margin_runs (their runs on the engine).
"""
