"""Rollouts of trained policies and baselines."""
