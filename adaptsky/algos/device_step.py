"""The device work of one training step of a stack: greedy actions, then the TD update.

On a CPU both are plain calls. On CUDA each is recorded once as a CUDA graph and replayed
every step (one launch instead of dozens of kernel launches: a small DQN is bound by launch
latency, not arithmetic). Per step only the observations (S x obs floats) and the sampled
indices (S x B) go to the device and the greedy actions (S) come back.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np
import torch

from adaptsky.algos.replay import StackedReplay
from adaptsky.algos.stacked import StackedDqn


def resolve_device(name: str) -> torch.device:
    """``cpu``, ``cuda`` (or ``cuda:N``) or ``auto`` (cuda when available) as a torch device."""
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    try:
        device = torch.device(name)
    except RuntimeError:
        raise ValueError(f"--device {name}: expected cpu, cuda, cuda:N or auto") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError("--device cuda: torch sees no CUDA device here "
                         f"(torch {torch.__version__}); use --device cpu or auto")
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"--device {name}: expected cpu, cuda or auto")
    if device.type == "cuda":  # cuBLAS repeats its products only with a fixed workspace
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    return device


def describe(device: torch.device) -> str:
    """The device as recorded in checkpoints, e.g. ``cpu`` or ``cuda (NVIDIA H100 80GB HBM3)``."""
    if device.type != "cuda":
        return device.type
    return f"cuda ({torch.cuda.get_device_name(device)})"


class Graphed:
    """``body()`` recorded as one CUDA graph; calling replays it and returns its output.

    Warm-up runs on a side stream (as CUDA graphs require) change ``state``, so it is saved
    before and put back after: recording has no effect on training.
    """

    def __init__(self, body: Callable[[], torch.Tensor | None], state: list[torch.Tensor]
                 ) -> None:
        saved = [tensor.clone() for tensor in state]
        side = torch.cuda.Stream()
        side.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(side):
            for _ in range(2):
                body()
        torch.cuda.current_stream().wait_stream(side)
        for tensor, value in zip(state, saved, strict=True):
            tensor.copy_(value)
        self.graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(self.graph):
            self.output = body()

    def __call__(self) -> torch.Tensor | None:
        self.graph.replay()
        return self.output


class DeviceStep:
    """Greedy actions and TD updates of ``agent`` over ``memory``, graphed on CUDA."""

    def __init__(self, agent: StackedDqn, memory: StackedReplay, batch_size: int,
                 graphs: bool | None = None) -> None:
        self.agent, self.memory = agent, memory
        device = agent.device
        self.graphs = device.type == "cuda" if graphs is None else graphs
        self.index = torch.zeros(agent.size, batch_size, dtype=torch.long, device=device)
        self.observations = torch.zeros(agent.size, 1, agent.observation_size, device=device)
        self._act: Graphed | None = None
        self._update: Graphed | None = None
        if self.graphs:
            self._host_index = torch.zeros(agent.size, batch_size, dtype=torch.long,
                                           pin_memory=True)
            self._host_obs = torch.zeros(agent.size, 1, agent.observation_size,
                                         pin_memory=True)

    def _greedy_body(self) -> torch.Tensor:
        return self.agent.q_values(self.observations).argmax(dim=-1).squeeze(-1)

    def _update_body(self) -> None:
        self.agent.update(*self.memory.gather(self.index))

    def greedy(self, observations: np.ndarray) -> np.ndarray:
        """argmax_a Q(s, a) of every member for one observation each, (S, obs) -> (S,)."""
        if not self.graphs:
            return self.agent.greedy(observations[:, None, :])[:, 0]
        if self._act is None:
            self._act = Graphed(self._greedy_body, [])
        self._host_obs.numpy()[:, 0] = observations
        self.observations.copy_(self._host_obs, non_blocking=True)
        actions = self._act()
        assert actions is not None
        return actions.cpu().numpy()

    def update(self, index: np.ndarray) -> None:
        """One update of every member on the memory rows at ``index`` (S, B)."""
        self.agent.updates += 1
        if not self.graphs:
            self.index.copy_(torch.from_numpy(index))
            self._update_body()
            return
        if self._update is None:
            agent = self.agent
            self._update = Graphed(self._update_body, [
                agent.params, agent.grads, agent.exp_avg, agent.exp_avg_sq, agent.step,
                agent.loss_sum])
        self._host_index.numpy()[:] = index
        self.index.copy_(self._host_index, non_blocking=True)
        self._update()
