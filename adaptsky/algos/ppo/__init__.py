"""PPO (Schulman et al. 2017) stacked over seeds, for dense, branching and continuous actions
(docs/agent.md)."""
