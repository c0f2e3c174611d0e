"""PPO's actor and critic for a stack of S members, in one flat buffer (S, W).

Each member's parameters are one row of ``params``, named and laid out as
:mod:`adaptsky.algos.ppo.parameters` declares them (weights stored transposed, (in, out), for a
batched matmul); rows are padded to whole vectors so that elementwise kernels treat every
member alike, whatever S. Autograd runs through views of the buffer; Adam and the per-member
gradient-norm clip are written out (as ``torch.optim.Adam`` and ``clip_grad_norm_`` compute
them, each member alone). Initial weights are those of ``torch.nn.Linear`` layers under
``torch.manual_seed(seed)``, then orthogonal with gains sqrt(2) (hidden layers), 0.01 (the
actor's head) and 1 (the critic's head), biases 0 (CleanRL's ``layer_init``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from adaptsky.algos.ppo.parameters import HeadShape, critic_shapes, policy_shapes

ROW_MULTIPLE = 64
ADAM_BETAS = (0.9, 0.999)
ADAM_EPS = 1e-5  # CleanRL's PPO
CLIP_EPS = 1e-6  # as torch.nn.utils.clip_grad_norm_


@dataclass(frozen=True)
class Slot:
    """Where a named parameter lives in a row: offset, torch shape (out, in) and whether it
    is stored transposed (a weight)."""

    name: str
    at: int
    shape: tuple[int, ...]

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    @property
    def end(self) -> int:
        return self.at + self.size

    @property
    def transposed(self) -> bool:
        return len(self.shape) == 2


def _activation(name: str) -> tuple[object, object]:
    """(torch function, numpy function) of ``agent.activation``."""
    if name == "tanh":
        return torch.tanh, np.tanh
    return torch.relu, lambda x: np.maximum(x, 0.0)


class StackedActorCritic:
    """Actor and critic of S members on ``device`` (module docstring)."""

    def __init__(self, observation_size: int, hidden_sizes: list[int], head: HeadShape,
                 seeds: list[int], activation: str = "tanh", init_log_std: float = 0.0,
                 device: str | torch.device = "cpu") -> None:
        self.observation_size, self.hidden_sizes, self.head = (observation_size,
                                                               list(hidden_sizes), head)
        self.size = len(seeds)
        self.device = torch.device(device)
        self.policy_names = list(policy_shapes(observation_size, hidden_sizes, head))
        shapes = {**policy_shapes(observation_size, hidden_sizes, head),
                  **critic_shapes(observation_size, hidden_sizes)}
        self.slots: dict[str, Slot] = {}
        offset = 0
        for name, shape in shapes.items():
            self.slots[name] = Slot(name, offset, shape)
            offset = self.slots[name].end
        self.used = offset
        self.width = -(-offset // ROW_MULTIPLE) * ROW_MULTIPLE
        rows = [self._initial_row(seed, init_log_std) for seed in seeds]
        # torch's own (aligned) memory: numpy's may start anywhere within a vector, and which
        # elements an elementwise kernel takes in its vector loop or its tail (fused or not)
        # would then differ from one process to the next
        self.params = torch.tensor(np.stack(rows), device=self.device).requires_grad_(True)
        self.exp_avg = torch.zeros_like(self.params, requires_grad=False)
        self.exp_avg_sq = torch.zeros_like(self.params, requires_grad=False)
        self.step = 0  # Adam's step count: members update in lockstep
        self._act, self._act_host = _activation(activation)

    # ---- rows and names -----------------------------------------------------------------

    def _layers(self, prefix: str) -> list[tuple[Slot, Slot]]:
        weights = [slot for name, slot in self.slots.items()
                   if name.startswith(prefix + ".") and name.endswith(".weight")]
        return [(w, self.slots[w.name.removesuffix("weight") + "bias"]) for w in weights]

    def _initial_row(self, seed: int, init_log_std: float) -> np.ndarray:
        torch.manual_seed(seed)
        named: dict[str, np.ndarray] = {}
        for prefix, last_gain in (("actor", 0.01), ("critic", 1.0)):
            pairs = self._layers(prefix)
            for index, (weight, bias) in enumerate(pairs):
                layer = nn.Linear(weight.shape[1], weight.shape[0])
                gain = last_gain if index == len(pairs) - 1 else math.sqrt(2.0)
                nn.init.orthogonal_(layer.weight, gain)
                named[weight.name] = layer.weight.detach().numpy().copy()
                named[bias.name] = np.zeros(bias.shape, dtype=np.float32)
        if "log_std" in self.slots:
            named["log_std"] = np.full(self.slots["log_std"].shape, init_log_std, np.float32)
        row = np.zeros(self.width, dtype=np.float32)
        row[:self.used] = self.row_from_named(named)
        return row

    def row_from_named(self, named: dict[str, np.ndarray], names: list[str] | None = None
                       ) -> np.ndarray:
        """A row (its used part) from torch-named arrays ((out, in) weights); ``names``: only
        those (the rest 0)."""
        row = np.zeros(self.used, dtype=np.float32)
        for name in names or list(self.slots):
            slot = self.slots[name]
            value = np.asarray(named[name], dtype=np.float32)
            row[slot.at:slot.end] = (value.T if slot.transposed else value).ravel()
        return row

    def named_from_row(self, row: np.ndarray, names: list[str] | None = None
                       ) -> dict[str, np.ndarray]:
        """Torch-named arrays (copies) of ``names`` (default every one) from a row."""
        named = {}
        for name in names or list(self.slots):
            slot = self.slots[name]
            value = np.array(row[slot.at:slot.end], dtype=np.float32)
            if slot.transposed:
                value = value.reshape(slot.shape[1], slot.shape[0]).T.copy()
            named[name] = value.reshape(slot.shape)
        return named

    # ---- forward --------------------------------------------------------------------------

    def _views(self, prefix: str, flat: torch.Tensor) -> list[tuple[torch.Tensor, torch.Tensor]]:
        stack = flat.shape[0]
        return [(flat[:, w.at:w.end].view(stack, w.shape[1], w.shape[0]),
                 flat[:, b.at:b.end].view(stack, 1, b.shape[0]))
                for w, b in self._layers(prefix)]

    def _mlp(self, prefix: str, x: torch.Tensor) -> torch.Tensor:
        layers = self._views(prefix, self.params)
        for index, (weight, bias) in enumerate(layers):
            if weight.shape[-1] == 1:
                # a layer of one output (the critic's) as two, the second 0 and dropped:
                # torch's batched matrix-vector product rounds apart for one member and for
                # several (measured), its matrix product does not
                zero = torch.zeros_like(weight)
                x = torch.baddbmm(torch.cat([bias, zero[:, :1]], dim=2), x,
                                  torch.cat([weight, zero], dim=2))[..., :1]
            else:
                x = torch.baddbmm(bias, x, weight)
            if index < len(layers) - 1:
                x = self._act(x)  # type: ignore[operator]
        return x

    def actor(self, observations: torch.Tensor) -> torch.Tensor:
        """The head's outputs (S, n, width) for observations (S, n, obs)."""
        return self._mlp("actor", observations)

    def critic(self, observations: torch.Tensor) -> torch.Tensor:
        """V(s) (S, n) for observations (S, n, obs)."""
        return self._mlp("critic", observations)[..., 0]

    def log_std(self) -> torch.Tensor:
        """The Gaussian's log standard deviation (S, 1, D)."""
        slot = self.slots["log_std"]
        return self.params[:, slot.at:slot.end].view(self.size, 1, slot.size)

    def host_actor(self, observations: np.ndarray) -> np.ndarray:
        """The head's outputs (S, n, width) in numpy over the weights' memory (CPU)."""
        flat = self.params.detach().cpu().numpy()
        x = observations
        layers = self._layers("actor")
        for index, (w, b) in enumerate(layers):
            weight = flat[:, w.at:w.end].reshape(self.size, w.shape[1], w.shape[0])
            x = np.matmul(x, weight) + flat[:, None, b.at:b.end]
            if index < len(layers) - 1:
                x = self._act_host(x)  # type: ignore[operator]
        return x

    # ---- learning -------------------------------------------------------------------------

    def apply_gradients(self, lr: float, max_grad_norm: float) -> None:
        """Clip each member's gradient to ``max_grad_norm`` (its global norm; 0: no clip),
        then one Adam step of every member (``torch.optim.Adam``'s arithmetic)."""
        grad = self.params.grad
        assert grad is not None
        with torch.no_grad():
            if max_grad_norm > 0:
                norms = torch.linalg.vector_norm(grad, dim=1, keepdim=True)
                grad.mul_(torch.clamp(max_grad_norm / (norms + CLIP_EPS), max=1.0))
            self.step += 1
            beta1, beta2 = ADAM_BETAS
            self.exp_avg.lerp_(grad, 1 - beta1)
            self.exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
            correction1 = 1 - beta1 ** self.step
            correction2 = 1 - beta2 ** self.step
            denom = (self.exp_avg_sq.sqrt() / math.sqrt(correction2)).add_(ADAM_EPS)
            self.params.addcdiv_(self.exp_avg, denom, value=-lr / correction1)
        self.params.grad = None

    # ---- checkpoints ----------------------------------------------------------------------

    def _row(self, buffer: torch.Tensor, member: int) -> np.ndarray:
        return buffer[member, :self.used].detach().cpu().numpy()

    def policy_arrays(self, member: int) -> dict[str, np.ndarray]:
        """One member's greedy policy (actor, and log_std), torch-named (copies)."""
        return self.named_from_row(self._row(self.params, member), self.policy_names)

    def load_policy(self, member: int, policy: dict[str, np.ndarray]) -> None:
        """Put a stored policy into member ``member`` (greedy evaluation)."""
        row = self.row_from_named(policy, self.policy_names)
        with torch.no_grad():
            self.params[member, :self.used] = torch.from_numpy(row)

    def state_arrays(self, member: int) -> dict[str, object]:
        """Everything of one member: its policy, critic and Adam state, torch-named."""
        critic = [name for name in self.slots if name.startswith("critic.")]
        params = self._row(self.params, member)
        return {"policy": self.named_from_row(params, self.policy_names),
                "critic": self.named_from_row(params, critic),
                "optimizer": {"step": np.array(self.step, dtype=np.int64),
                              "exp_avg": self.named_from_row(self._row(self.exp_avg, member)),
                              "exp_avg_sq": self.named_from_row(
                                  self._row(self.exp_avg_sq, member))}}

    def load_state_arrays(self, member: int, state: dict[str, object]) -> None:
        """Inverse of :meth:`state_arrays`."""
        params = {**state["policy"], **state["critic"]}  # type: ignore[dict-item]
        optimizer = state["optimizer"]
        with torch.no_grad():
            for buffer, named in ((self.params, params),
                                  (self.exp_avg, optimizer["exp_avg"]),  # type: ignore[index]
                                  (self.exp_avg_sq, optimizer["exp_avg_sq"])):  # type: ignore[index]
                buffer[member, :self.used] = torch.from_numpy(self.row_from_named(named))
        self.step = int(np.asarray(optimizer["step"]))  # type: ignore[index]
