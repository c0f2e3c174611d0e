"""The training device: choosing it (``--device``), naming it in checkpoints, and
:class:`Graphed`, a piece of device work recorded once as a CUDA graph and replayed (a small
network is bound by kernel-launch latency, not arithmetic)."""

from __future__ import annotations

import os
from collections.abc import Callable

import torch


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
