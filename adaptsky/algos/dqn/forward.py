"""The Q-network's forward pass (sec. IV-A), written once for every array library that runs it:
torch batched over a stack (training and device greedy), numpy over host memory (greedy actions
on a CPU) and the torch module ``QNetwork`` (initial weights, the reference in tests)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

X = TypeVar("X")


def head_output(layers: Sequence[tuple[Any, Any]], x: X, affine: Callable[[X, Any, Any], X],
                relu: Callable[[X], X], keep: list[X] | None = None) -> X:
    """The head's output for inputs ``x``: ``relu(affine(x, W, b))`` through every hidden
    layer of ``layers`` [(W, b) ...], then the last layer's ``affine`` (Q for a plain head;
    [V | A] for a dueling head, which the caller turns into Q = V + A - mean_a A). ``keep``
    collects each layer's input (for a hand-written backward pass)."""
    for weight, bias in layers[:-1]:
        if keep is not None:
            keep.append(x)
        x = relu(affine(x, weight, bias))
    if keep is not None:
        keep.append(x)
    weight, bias = layers[-1]
    return affine(x, weight, bias)
