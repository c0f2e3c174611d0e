"""The learning agent: network, replay memory, DQN update, schedules. No I/O."""
