"""Experiments as data: experiment files, their plans, sweeps of runs, evaluation."""
