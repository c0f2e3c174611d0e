"""Action distributions over an actor's head (docs/agent.md; PPO's and MAPPO's, and SAC's
Gaussian): a Categorical over the dense action set, one Categorical per branch (the
components' directions, MultiDiscrete), or a diagonal Gaussian with a state-independent log
standard deviation (continuous controls).

Sampling draws from each member's numpy generator (the same numbers alone, in a stack and
resumed); log-probabilities and entropies are torch (they carry the gradient). The greedy
action is the mode: the argmax, every branch's argmax, or the Gaussian's mean (clipped to the
box, as the environment takes it).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.shared.shapes import HeadShape

LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)


def _categorical_draw(logits: np.ndarray, uniform: np.ndarray) -> NDArray[np.int64]:
    """Inverse-CDF draws (..., ) from logits (..., A) with uniforms (...,) in [0, 1)."""
    shifted = logits.astype(np.float64) - logits.max(axis=-1, keepdims=True)
    cdf = np.cumsum(np.exp(shifted), axis=-1)
    cdf /= cdf[..., -1:]
    drawn = (cdf <= uniform[..., None]).sum(axis=-1)
    return np.minimum(drawn, logits.shape[-1] - 1).astype(np.int64)


class ActionHead:
    """The distribution of one head kind (module docstring). Stored actions: the dense index
    (S, n), the branch choices (S, n, D) or the Gaussian's sample (S, n, D), float32."""

    def __init__(self, head: HeadShape) -> None:
        self.head = head

    @property
    def stored_shape(self) -> tuple[int, ...]:
        """The trailing shape of one stored action."""
        return () if self.head.kind == "dense" else (len(self.head.branches) or
                                                     self.head.components,)

    def _split(self, out: torch.Tensor) -> list[torch.Tensor]:
        return list(torch.split(out, list(self.head.branches), dim=-1))

    # ---- numpy: sampling and modes --------------------------------------------------------

    def sample(self, out: np.ndarray, log_std: np.ndarray | None,
               rngs: list[np.random.Generator]) -> np.ndarray:
        """Stored actions for head outputs ``out`` (S, n, width); member s draws from
        ``rngs[s]`` (n uniforms per branch, or n x D normals), each member on its own (numpy's
        vector loops then round every member as they round it alone)."""
        log_stds = [None] * len(rngs) if log_std is None else list(log_std)
        return np.stack([self._sample_one(member_out, member_log_std, rng)
                         for member_out, member_log_std, rng in zip(out, log_stds, rngs,
                                                                     strict=True)])

    def _sample_one(self, out: np.ndarray, log_std: np.ndarray | None,
                    rng: np.random.Generator) -> np.ndarray:
        """One member's stored actions for its outputs (n, width)."""
        n, kind = len(out), self.head.kind
        if kind == "dense":
            return _categorical_draw(out, rng.random(n))
        if kind == "branches":
            uniform = rng.random((n, len(self.head.branches)))
            parts = np.split(out, np.cumsum(self.head.branches)[:-1], axis=-1)
            return np.stack([_categorical_draw(part, uniform[:, j])
                             for j, part in enumerate(parts)], axis=-1)
        assert log_std is not None
        normal = rng.standard_normal((n, self.head.components))
        return (out + np.exp(log_std) * normal).astype(np.float32)

    def mode(self, out: np.ndarray) -> np.ndarray:
        """The greedy stored actions for head outputs (S, n, width)."""
        kind = self.head.kind
        if kind == "dense":
            return out.argmax(axis=-1)
        if kind == "branches":
            parts = np.split(out, np.cumsum(self.head.branches)[:-1], axis=-1)
            return np.stack([part.argmax(axis=-1) for part in parts], axis=-1)
        return out.astype(np.float32)

    def env_actions(self, stored: np.ndarray) -> np.ndarray:
        """What the environment takes for stored actions (..., ...): the dense index, the
        branches' directions encoded as the dense index, or the sample clipped to [-1, 1]."""
        kind = self.head.kind
        if kind == "dense":
            return stored.astype(np.int64)
        if kind == "branches":
            # choice c of a branch is the digit of its component in the dense index
            # (ActionSet.decode: direction 2c - 1 of two, c - 1 of three)
            base = self.head.branches[0]
            powers = base ** np.arange(len(self.head.branches), dtype=np.int64)
            return (stored.astype(np.int64) * powers).sum(axis=-1)
        return np.clip(stored, -1.0, 1.0)

    # ---- torch: log-probabilities and entropy ---------------------------------------------

    def log_prob_entropy(self, out: torch.Tensor, log_std: torch.Tensor | None,
                         stored: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """log pi(a|s) and the entropy (S, n) of stored actions under head outputs (S, n,
        width)."""
        kind = self.head.kind
        if kind == "dense":
            log_p = torch.log_softmax(out, dim=-1)
            chosen = log_p.gather(-1, stored.long().unsqueeze(-1))[..., 0]
            return chosen, -(log_p.exp() * log_p).sum(dim=-1)
        if kind == "branches":
            log_prob = torch.zeros(out.shape[:2], dtype=out.dtype, device=out.device)
            entropy = torch.zeros_like(log_prob)
            for j, part in enumerate(self._split(out)):
                log_p = torch.log_softmax(part, dim=-1)
                log_prob = log_prob + log_p.gather(-1, stored[..., j:j + 1].long())[..., 0]
                entropy = entropy - (log_p.exp() * log_p).sum(dim=-1)
            return log_prob, entropy
        assert log_std is not None
        # log sigma broadcast to (S, n, D) before exp: every member's block then has the
        # same size as alone (module learner: vector loops round alike)
        log_std = log_std + torch.zeros_like(out)
        z = (stored - out) / log_std.exp()
        log_prob = (-0.5 * z * z - log_std - LOG_SQRT_2PI).sum(dim=-1)
        entropy = (0.5 + LOG_SQRT_2PI + log_std).sum(dim=-1)
        return log_prob, entropy
