"""MAPPO and IPPO (Yu et al. 2022) stacked over seeds: one PPO actor shared by the UAVs, each
acting on its local observation with a one-hot UAV id, and a centralised or local critic
(docs/agent.md)."""
