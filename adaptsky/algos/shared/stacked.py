"""Named parameters of a stack of S members in one flat buffer (S, W), their MLPs and the one
Adam: the machinery every stacked learner (the DQN, the BDQ, PPO, MAPPO, SAC) shares.

Each member's parameters are one row of ``params``, named (``actor.0.weight`` (out, in) ...;
weights stored transposed, (in, out), for a batched matmul); rows are padded to a multiple of
:data:`ROW_MULTIPLE` floats so that elementwise kernels treat every member alike, whatever S.
Adam's moments have the rows' layout; members are in lockstep, so its step count is one number.
The per-member gradient-norm clip is ``clip_grad_norm_``'s, each member alone. Adam's step is
one of two kernels, chosen when the parameters are built: torch's fused kernel (``fused``: a
fixed-shape step with its count in a device tensor, recorded in the DQN's CUDA graph) or
``torch.optim.Adam``'s arithmetic written out (autograd learners: PPO, SAC); the two round
apart, and each learner keeps the one its numbers were made with.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

ROW_MULTIPLE = 64
ADAM_BETAS = (0.9, 0.999)
ADAM_EPS = 1e-8  # torch.optim.Adam's default (the DQN's and SAC's; PPO takes CleanRL's 1e-5)
CLIP_EPS = 1e-6  # as torch.nn.utils.clip_grad_norm_
PAD = 32
"""Per-member row counts are padded to a multiple of this (the float32 lanes torch's unrolled
vector loop takes at once: 16 with AVX2, 32 with AVX-512):
elementwise kernels (exp, tanh) run a vector loop and a scalar tail that may round apart, so a
member's block of rows must take the same lanes alone and in a stack (a seed then learns the
same numbers alone, in a stack, and resumed in another stacking)."""

Shapes = dict[str, tuple[int, ...]]
Activation = Callable[[torch.Tensor], torch.Tensor]
HostActivation = Callable[[np.ndarray], np.ndarray]


def padded(rows: int) -> int:
    """``rows`` rounded up to a multiple of :data:`PAD`."""
    return -(-rows // PAD) * PAD


def padded_rows(rows: int) -> tuple[np.ndarray, torch.Tensor]:
    """Where the :func:`padded` rows of a batch of ``rows`` come from (its own rows, then its
    first row again) and the mask (padded,) of the real ones."""
    size = padded(rows)
    where = np.concatenate([np.arange(rows), np.zeros(size - rows, dtype=np.int64)])
    mask = torch.zeros(size)
    mask[:rows] = 1.0
    return where, mask


def activation(name: str) -> tuple[Activation, HostActivation]:
    """(torch function, numpy function) of a hidden activation, ``tanh`` or ``relu``."""
    if name == "tanh":
        return torch.tanh, np.tanh
    return torch.relu, lambda x: np.maximum(x, 0.0)


def linear_layers(shapes: Shapes, prefix: str) -> list[tuple[str, str]]:
    """(weight, bias) names of the linear layers ``<prefix>.<i>``, in order."""
    return [(name, name.removesuffix("weight") + "bias") for name in shapes
            if name.startswith(prefix + ".") and name.endswith(".weight")]


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


def clip_per_member_(grad: torch.Tensor, max_norm: float) -> None:
    """Scale each member's gradient row (S, W) to a global norm of at most ``max_norm``
    (``clip_grad_norm_``'s arithmetic, each member alone), in place."""
    norms = torch.linalg.vector_norm(grad, dim=1, keepdim=True)
    grad.mul_(torch.clamp(max_norm / (norms + CLIP_EPS), max=1.0))


class StackedParameters:
    """Parameters ``shapes`` of S members on ``device``, member s starting from ``rows[s]``
    (torch-named arrays), with Adam's state (module docstring). ``fused``: Adam is torch's
    fused kernel and the parameters carry no autograd (a hand-written backward fills a
    gradient buffer); else autograd runs through views of the buffer and Adam is written
    out."""

    def __init__(self, shapes: Shapes, rows: list[dict[str, np.ndarray]],
                 adam_eps: float = ADAM_EPS, device: str | torch.device = "cpu",
                 fused: bool = False) -> None:
        self.size, self.adam_eps, self.fused = len(rows), adam_eps, fused
        self.device = torch.device(device)
        self.shapes = dict(shapes)
        self.slots: dict[str, Slot] = {}
        offset = 0
        for name, shape in shapes.items():
            self.slots[name] = Slot(name, offset, shape)
            offset = self.slots[name].end
        self.used = offset
        self.width = -(-offset // ROW_MULTIPLE) * ROW_MULTIPLE
        initial = np.zeros((self.size, self.width), dtype=np.float32)
        for member, named in enumerate(rows):
            initial[member, :self.used] = self.row_from_named(named)
        # torch's own (aligned) memory: numpy's may start anywhere within a vector, and which
        # elements an elementwise kernel takes in its vector loop or its tail (fused or not)
        # would then differ from one process to the next
        self.params = torch.tensor(initial, device=self.device).requires_grad_(not fused)
        self.exp_avg = torch.zeros_like(self.params, requires_grad=False)
        self.exp_avg_sq = torch.zeros_like(self.params, requires_grad=False)
        # Adam's step count (members in lockstep): the fused kernel's is a device tensor
        self.step: int | torch.Tensor = (torch.zeros((), device=self.device) if fused else 0)

    # ---- rows and names -----------------------------------------------------------------

    def layers(self, prefix: str) -> list[tuple[Slot, Slot]]:
        """The (weight, bias) slots of the linear layers ``<prefix>.<i>``."""
        return [(self.slots[w], self.slots[b]) for w, b in linear_layers(self.shapes, prefix)]

    def names(self, prefix: str) -> list[str]:
        """The parameters named ``<prefix>.*``."""
        return [name for name in self.slots if name.startswith(prefix + ".")]

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

    def views(self, prefix: str, flat: torch.Tensor
              ) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(weight (S, in, out), bias (S, 1, out)) views of ``flat``'s layers ``prefix``."""
        stack = flat.shape[0]
        return [(flat[:, w.at:w.end].view(stack, w.shape[1], w.shape[0]),
                 flat[:, b.at:b.end].view(stack, 1, b.shape[0]))
                for w, b in self.layers(prefix)]

    def mlp(self, prefix: str, x: torch.Tensor, hidden: Activation,
            flat: torch.Tensor | None = None) -> torch.Tensor:
        """The MLP ``prefix`` (S, n, out) of x (S, n, in), ``hidden`` after every layer but
        the last, over ``flat`` (default :attr:`params`; a copy of its layout: a target)."""
        layers = self.views(prefix, self.params if flat is None else flat)
        for index, (weight, bias) in enumerate(layers):
            if weight.shape[-1] == 1:
                # a layer of one output (a critic's) as two, the second 0 and dropped:
                # torch's batched matrix-vector product rounds apart for one member and for
                # several (measured), its matrix product does not
                zero = torch.zeros_like(weight)
                x = torch.baddbmm(torch.cat([bias, zero[:, :1]], dim=2), x,
                                  torch.cat([weight, zero], dim=2))[..., :1]
            else:
                x = torch.baddbmm(bias, x, weight)
            if index < len(layers) - 1:
                x = hidden(x)
        return x

    def set_encoded(self, prefix: str, x: torch.Tensor, per_user: torch.Tensor,
                    rest: torch.Tensor, hidden: Activation, flat: torch.Tensor | None = None
                    ) -> torch.Tensor:
        """The set encoder ``prefix`` (docs/agent.md, "The set encoder") of x (S, n, obs):
        each user's features x[..., per_user] (slots, F) through the MLP ``prefix`` with
        ``hidden`` after every layer, pooled by mean and max over the users, beside
        x[..., rest]: (S, n, 2 H + G); over ``flat`` as :meth:`mlp`."""
        stack, rows = x.shape[:2]
        slots, features = per_user.shape
        users = x[..., per_user].reshape(stack, rows * slots, features)
        encoded = hidden(self.mlp(prefix, users, hidden, flat)).reshape(stack, rows, slots, -1)
        return torch.cat([encoded.mean(dim=2), encoded.amax(dim=2), x[..., rest]], dim=-1)

    def host_set_encoded(self, prefix: str, x: np.ndarray, per_user: np.ndarray,
                         rest: np.ndarray, hidden: HostActivation) -> np.ndarray:
        """:meth:`set_encoded` in numpy over the weights' memory (CPU)."""
        stack, rows = x.shape[:2]
        slots, features = per_user.shape
        users = x[..., per_user].reshape(stack, rows * slots, features)
        encoded = hidden(self.host_mlp(prefix, users, hidden)).reshape(stack, rows, slots, -1)
        return np.concatenate([encoded.mean(axis=2), encoded.max(axis=2), x[..., rest]],
                              axis=-1)

    def host_mlp(self, prefix: str, x: np.ndarray, hidden: HostActivation) -> np.ndarray:
        """:meth:`mlp` in numpy over the weights' memory (CPU)."""
        flat = self.params.detach().cpu().numpy()
        layers = self.layers(prefix)
        for index, (w, b) in enumerate(layers):
            weight = flat[:, w.at:w.end].reshape(self.size, w.shape[1], w.shape[0])
            x = np.matmul(x, weight) + flat[:, None, b.at:b.end]
            if index < len(layers) - 1:
                x = hidden(x)
        return x

    # ---- learning -------------------------------------------------------------------------

    def apply_gradients(self, lr: float, max_grad_norm: float = 0.0) -> None:
        """Clip each member's autograd gradient to ``max_grad_norm`` (0: no clip), then one
        Adam step of every member (``torch.optim.Adam``'s arithmetic, written out)."""
        grad = self.params.grad
        assert grad is not None and not self.fused
        with torch.no_grad():
            if max_grad_norm > 0:
                clip_per_member_(grad, max_grad_norm)
            self.step += 1
            beta1, beta2 = ADAM_BETAS
            self.exp_avg.lerp_(grad, 1 - beta1)
            self.exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
            correction1 = 1 - beta1 ** self.step
            correction2 = 1 - beta2 ** self.step
            denom = (self.exp_avg_sq.sqrt() / math.sqrt(correction2)).add_(self.adam_eps)
            self.params.addcdiv_(self.exp_avg, denom, value=-lr / correction1)
        self.params.grad = None

    def apply_fused(self, grad: torch.Tensor, lr: float | torch.Tensor,
                    max_grad_norm: float = 0.0) -> None:
        """:meth:`apply_gradients` from a gradient buffer (S, W) with torch's fused kernel
        (``lr`` a float or a device tensor): fixed shapes, no host synchronisation."""
        assert self.fused and isinstance(self.step, torch.Tensor)
        if max_grad_norm > 0:
            clip_per_member_(grad, max_grad_norm)
        self.step += 1
        torch._fused_adam_([self.params], [grad], [self.exp_avg], [self.exp_avg_sq], [],
                           [self.step], lr=lr, beta1=ADAM_BETAS[0], beta2=ADAM_BETAS[1],
                           weight_decay=0.0, eps=self.adam_eps, amsgrad=False,
                           maximize=False)

    # ---- checkpoints ----------------------------------------------------------------------

    def row(self, buffer: torch.Tensor, member: int) -> np.ndarray:
        """Member ``member``'s used part of ``buffer`` (the parameters, a moment, a target)."""
        return buffer[member, :self.used].detach().cpu().numpy()

    def named(self, member: int, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Member ``member``'s parameters ``names`` (default every one), torch-named."""
        return self.named_from_row(self.row(self.params, member), names)

    def load_named(self, member: int, named: dict[str, np.ndarray],
                   names: list[str] | None = None, buffer: torch.Tensor | None = None
                   ) -> None:
        """Put torch-named arrays ``names`` (default every one) into member ``member``'s row
        of ``buffer`` (default :attr:`params`; the rest of the row 0)."""
        row = self.row_from_named(named, names)
        with torch.no_grad():
            (self.params if buffer is None else buffer)[member, :self.used] = \
                torch.from_numpy(row)

    def optimizer_arrays(self, member: int) -> dict[str, object]:
        """Adam's state of one member: ``step``, ``exp_avg`` and ``exp_avg_sq``, torch-named."""
        return {"step": np.array(self.steps(), dtype=np.int64),
                "exp_avg": self.named_from_row(self.row(self.exp_avg, member)),
                "exp_avg_sq": self.named_from_row(self.row(self.exp_avg_sq, member))}

    def load_optimizer(self, member: int, optimizer: dict[str, object]) -> None:
        """Inverse of :meth:`optimizer_arrays`."""
        for name, buffer in (("exp_avg", self.exp_avg), ("exp_avg_sq", self.exp_avg_sq)):
            self.load_named(member, optimizer[name], buffer=buffer)  # type: ignore[arg-type]
        self.set_steps(int(np.asarray(optimizer["step"])))

    def steps(self) -> int:
        """Adam's step count."""
        return int(self.step.item()) if isinstance(self.step, torch.Tensor) else self.step

    def set_steps(self, steps: int) -> None:
        if isinstance(self.step, torch.Tensor):
            self.step.fill_(float(steps))
        else:
            self.step = steps
