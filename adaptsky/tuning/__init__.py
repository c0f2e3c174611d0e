"""Hyperparameter tuning with Optuna: ``adaptsky tune`` (docs/tuning.md)."""
