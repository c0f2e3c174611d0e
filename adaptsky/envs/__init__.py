"""The Gymnasium environment and vector environment over the batched simulation."""
