"""The DQN of algorithm 1 for a stack of S independent members (seeds) at once.

Every member has its own weights, target weights and Adam moments; they live in flat buffers
with a leading member axis, (S, P) (:class:`~adaptsky.algos.shared.stacked.StackedParameters`,
the layers ``layer.<i>`` with the dueling head's V and A as one layer), so one batched matmul
serves every member and Adam (elementwise, the fused kernel) updates each member exactly as if
it were alone. The TD update of eq. 12 is written out by hand (forward, backward, per-member
gradient clipping, Adam): no autograd graph per step, a few dozen kernels, the same code on a
CPU and on a GPU, where :class:`adaptsky.algos.device_step.Graphed` records it once and
replays it.

Network (sec. IV-A): ReLU layers ``hidden_sizes``, then a dueling head Q = V + A - mean_a A
(the mean per sample, docs/model.md §4; computed as [V | A] times a fixed matrix) or a plain
linear head. Per-member checkpoints use the
names of :class:`adaptsky.algos.dqn.network.QNetwork` (``torso.0.weight`` ...), so run files
from every device and every stack size read alike.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np
import torch

from adaptsky.algos.dqn.forward import head_output
from adaptsky.algos.dqn.network import QNetwork
from adaptsky.algos.dqn.parameters import network_shapes
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.algos.shared.stacked import ADAM_BETAS, ADAM_EPS, StackedParameters
from adaptsky.scenario.agents import BdqAgent, DqnAgent


@dataclass
class SetKept:
    """What the set encoder's backward pass needs of its forward one: each shared layer's
    input and output (S, n slots, width) and where each unit's maximum over the users is
    (S, n, H)."""

    inputs: list[torch.Tensor] = field(default_factory=list)
    outputs: list[torch.Tensor] = field(default_factory=list)
    argmax: torch.Tensor | None = None


@dataclass(frozen=True)
class Layer:
    """Offsets of one linear layer's weight (in, out) and bias (out) in a flat parameter row."""

    size_in: int
    size_out: int
    weight_at: int

    @property
    def bias_at(self) -> int:
        return self.weight_at + self.size_in * self.size_out

    @property
    def end(self) -> int:
        return self.bias_at + self.size_out


def layer_plan(observation_size: int, num_actions: int, hidden_sizes: list[int],
               dueling: bool, values: int = 1) -> list[Layer]:
    """The layers of the network, the head last (width ``values`` + A when dueling)."""
    head = num_actions + values if dueling else num_actions
    sizes = [observation_size, *hidden_sizes, head]
    layers, offset = [], 0
    for size_in, size_out in pairwise(sizes):
        layers.append(Layer(size_in, size_out, offset))
        offset = layers[-1].end
    return layers


def _baddbmm(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    return torch.baddbmm(bias, x, weight)


def _relu_(x: torch.Tensor) -> torch.Tensor:
    return x.clamp_(min=0.0)


def _matmul_add(x: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    out = np.matmul(x, weight)
    out += bias
    return out


def _relu_host(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0, out=x)


class StackedDqn:
    """Policy and target networks and Adam for S members on ``device``.

    Members share the network shape and ``config`` (gamma, lr, loss, options); each keeps its
    own numbers. Arguments: ``seeds`` (one per member; initial weights are those of
    ``QNetwork`` under ``torch.manual_seed(seed)``), ``observation_size``, ``num_actions``.
    """

    action_width = 1
    """Replay columns of one action (the action index)."""
    values = 1
    """Value outputs of a dueling head, and reward columns of a replay row."""

    def __init__(self, config: DqnAgent | BdqAgent, observation_size: int, num_actions: int,
                 seeds: list[int], device: str | torch.device = "cpu",
                 encoder: SetEncoder | None = None) -> None:
        self.config = config
        self.dueling = self._dueling_head(config)
        self.num_actions = num_actions
        self.observation_size = observation_size
        self.encoder = encoder
        self.size = len(seeds)
        self.device = torch.device(device)
        self.layers = layer_plan(observation_size if encoder is None else encoder.width,
                                 num_actions, config.hidden_sizes, self.dueling, self.values)
        self.names = list(network_shapes(observation_size, num_actions, config.hidden_sizes,
                                         self.dueling, self.values, encoder))
        shapes = {f"layer.{index}.{kind}": shape for index, layer in enumerate(self.layers)
                  for kind, shape in (("weight", (layer.size_out, layer.size_in)),
                                      ("bias", (layer.size_out,)))}
        if encoder is not None:     # the users' shared network, after the layers in a row
            shapes |= encoder.shapes("set")
        self.net = StackedParameters(shapes, [self._initial_layers(seed) for seed in seeds],
                                     ADAM_EPS, device, fused=True)
        self.params, self.exp_avg, self.exp_avg_sq = (self.net.params, self.net.exp_avg,
                                                      self.net.exp_avg_sq)
        assert isinstance(self.net.step, torch.Tensor)
        self.step = self.net.step  # Adam's, a device tensor: members are in lockstep
        self.target = self.params.clone()
        self.grads = torch.zeros_like(self.params)
        self._grad_padding = torch.zeros(self.size, self.net.width - self.net.used,
                                         device=self.device)
        self._lr: float | torch.Tensor = (config.lr if config.lr_end is None else
                                          torch.tensor(config.lr, device=self.device))
        self._discount = config.gamma ** config.n_step  # an n-step row bootstraps after n
        # each member's summed loss, added by every update (learner.RunningMeans takes it)
        self.loss_sum = torch.zeros(self.size, dtype=torch.float64, device=self.device)
        self._policy = self.net.views("layer", self.params)
        self._target = self.net.views("layer", self.target)
        self._set_kept: SetKept | None = None    # the last update's set encoder forward
        self._policy_set = self.net.views("set", self.params)      # (empty without one)
        self._target_set = self.net.views("set", self.target)
        if encoder is not None:
            self._per_user = torch.as_tensor(encoder.layout.per_user, device=self.device)
            self._rest = torch.as_tensor(encoder.layout.rest, device=self.device)
        # Q = [V | A] @ M: M[0, j] = 1, M[1 + k, j] = [k = j] - 1 / A (the dueling head as one
        # small matmul; its transpose carries the gradient back)
        self._dueling = self._head_matrix().to(self.device)
        self._dueling_stack = self._dueling.expand(self.size, -1, -1)
        self._dueling_back = self._dueling.T.expand(self.size, -1, -1)
        self._host = ([(weight.numpy(), bias.numpy()) for weight, bias in self._policy]
                      if self.device.type == "cpu" else None)

    @staticmethod
    def _dueling_head(config: DqnAgent | BdqAgent) -> bool:
        """Whether the head is [V | A] (a dueling head) or Q itself."""
        assert isinstance(config, DqnAgent)
        return config.dueling

    def _head_matrix(self) -> torch.Tensor:
        """The dueling head's M: Q = [V | A] @ M."""
        count = self.num_actions
        return torch.cat([torch.ones(1, count), torch.eye(count) - 1.0 / count])

    def _initial_layers(self, seed: int) -> dict[str, np.ndarray]:
        """The layers of ``QNetwork`` under ``torch.manual_seed(seed)``."""
        torch.manual_seed(seed)
        net = QNetwork(self.observation_size, self.num_actions, self.config.hidden_sizes,
                       self.dueling, self.values, self.encoder)
        return self._layer_arrays({k: v.numpy() for k, v in net.state_dict().items()})

    # ---- forward and greedy action ------------------------------------------------------

    def _forward(self, views: list[tuple[torch.Tensor, torch.Tensor]], x: torch.Tensor,
                 keep: list[torch.Tensor] | None = None,
                 set_views: list[tuple[torch.Tensor, torch.Tensor]] | None = None,
                 set_keep: SetKept | None = None) -> torch.Tensor:
        """Q (S, n, A) for observations x (S, n, obs); ``keep`` collects each layer's input;
        with a set encoder (its layers ``set_views``) x is encoded first, ``set_keep``
        collecting what its backward pass needs."""
        if self.encoder is not None:    # the target's encoder with the target's layers
            if set_views is None:
                set_views = self._target_set if views is self._target else self._policy_set
            x = self._encoded(set_views, x, set_keep)
        return self._head(head_output(views, x, _baddbmm, _relu_, keep))

    def _encoded(self, views: list[tuple[torch.Tensor, torch.Tensor]], x: torch.Tensor,
                 keep: SetKept | None = None) -> torch.Tensor:
        """The set encoding (S, n, 2 H + G) of observations x (S, n, obs) (docs/agent.md,
        "The set encoder"): each user's features through the shared ReLU layers ``views``,
        their mean and maximum over the users, then the rest of x."""
        assert self.encoder is not None
        stack, rows = x.shape[:2]
        slots, features = self._per_user.shape
        h = x[..., self._per_user].reshape(stack, rows * slots, features)
        for weight, bias in views:
            if keep is not None:
                keep.inputs.append(h)
            h = _relu_(torch.baddbmm(bias, h, weight))
            if keep is not None:
                keep.outputs.append(h)
        users = h.view(stack, rows, slots, -1)
        largest, where = users.max(dim=2)
        if keep is not None:
            keep.argmax = where
        return torch.cat([users.mean(dim=2), largest, x[..., self._rest]], dim=-1)

    def _head(self, out: torch.Tensor) -> torch.Tensor:
        """Q from the head's output: itself, or V + A - mean_a A (per sample) if dueling."""
        return torch.bmm(out, self._dueling_stack) if self.dueling else out

    def q_values(self, observations: torch.Tensor) -> torch.Tensor:
        """Q (S, n, A) of the policy network for observations (S, n, obs) on the device."""
        with torch.no_grad():
            return self._forward(self._policy, observations, set_views=self._policy_set)

    def greedy(self, observations: np.ndarray) -> np.ndarray:
        """argmax_a Q(s, a) per member for host observations (S, n, obs) -> (S, n).

        On a CPU this is numpy over the weights' memory (no torch dispatch for a handful of
        rows); elsewhere a forward on the device.
        """
        if self._host is None:
            x = torch.from_numpy(observations).to(self.device)
            return self.device_greedy(x).cpu().numpy()
        if self.encoder is not None:
            layout = self.encoder.layout
            observations = self.net.host_set_encoded("set", observations, layout.per_user,
                                                     layout.rest, _relu_host)
        return self._host_greedy(head_output(self._host, observations, _matmul_add,
                                             _relu_host))

    def device_greedy(self, observations: torch.Tensor) -> torch.Tensor:
        """Greedy actions (S, n) for observations (S, n, obs) on the device."""
        return self.q_values(observations).argmax(dim=-1)

    def _host_greedy(self, out: np.ndarray) -> np.ndarray:
        """Greedy actions from the head's output on the host."""
        if self.dueling:  # the constant V and mean(A) do not change the argmax
            out = out[..., self.values:]
        return out.argmax(axis=-1)

    def stored_actions(self, actions: np.ndarray) -> np.ndarray:
        """Actions (S,) as the replay memory stores them (:attr:`action_width` columns)."""
        return actions

    # ---- the TD update of eq. 12 ----------------------------------------------------------

    def update(self, observations: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor,
               next_observations: torch.Tensor, not_terminal: torch.Tensor) -> None:
        """One Adam step per member on its batch: observations (S, B, obs), actions (S, B)
        int64, rewards and not_terminal (S, B). Adds each member's loss to ``loss_sum``.

        Every operation has a fixed shape and no host synchronisation, so it can be recorded
        as one CUDA graph.
        """
        config = self.config
        with torch.no_grad():
            next_q = self._forward(self._target, next_observations, set_views=self._target_set)
            if config.double_dqn:
                best = self._forward(self._policy, next_observations,
                                     set_views=self._policy_set).argmax(dim=-1, keepdim=True)
                next_value = next_q.gather(-1, best).squeeze(-1)
            else:
                next_value = next_q.amax(dim=-1)
            target = rewards + self._discount * not_terminal * next_value
            inputs: list[torch.Tensor] = []
            self._set_kept = kept = SetKept() if self.encoder is not None else None
            q = self._forward(self._policy, observations, inputs, self._policy_set, kept)
            chosen = actions.unsqueeze(-1)
            error = q.gather(-1, chosen).squeeze(-1) - target
            d_chosen = self._loss_gradient(error)
            self._learn(inputs, self._d_head(chosen, d_chosen.unsqueeze(-1)))

    def _loss_gradient(self, error: torch.Tensor) -> torch.Tensor:
        """dLoss / d(error) of the mean loss over the errors (S, n) of each member; adds each
        member's loss to ``loss_sum``."""
        count = error.shape[1]
        if self.config.loss == "mse":
            loss = error.square().mean(dim=1)
            d_error = error * (2.0 / count)
        else:  # Huber with delta 1 (torch's SmoothL1Loss)
            magnitude = error.abs()
            loss = torch.where(magnitude < 1.0, 0.5 * error.square(),
                               magnitude - 0.5).mean(dim=1)
            d_error = error.clamp(-1.0, 1.0) * (1.0 / count)
        self.loss_sum += loss
        return d_error

    def _learn(self, inputs: list[torch.Tensor], d_out: torch.Tensor) -> None:
        """Backward pass from dLoss / d(head output), Adam, and the soft target update."""
        self._backward(inputs, d_out)
        self._adam()
        if self.config.target_tau > 0:  # soft target update (extension)
            self.target.lerp_(self.params, self.config.target_tau)

    def _d_head(self, chosen: torch.Tensor, d_chosen: torch.Tensor) -> torch.Tensor:
        """dLoss / d(head output) (S, B, width) from dLoss / dQ of the chosen columns
        ``chosen`` (S, B, k), ``d_chosen`` of the same shape."""
        d_q = torch.zeros(*chosen.shape[:2], self.num_actions, device=self.device,
                          dtype=d_chosen.dtype).scatter_(-1, chosen, d_chosen)
        return torch.bmm(d_q, self._dueling_back) if self.dueling else d_q

    def _backward(self, inputs: list[torch.Tensor], d_out: torch.Tensor) -> None:
        """Gradients of every layer into the flat ``grads``; ``inputs[i]`` is layer i's input."""
        pieces: list[torch.Tensor] = []
        stack = d_out.shape[0]
        for index in range(len(self.layers) - 1, -1, -1):
            x = inputs[index]
            pieces += [d_out.sum(dim=1), torch.bmm(x.transpose(1, 2), d_out).view(stack, -1)]
            if index:
                weight, _ = self._policy[index]
                d_in = torch.bmm(d_out, weight.transpose(1, 2))
                d_out = torch.ops.aten.threshold_backward(d_in, x, 0.0)  # ReLU'
        encoder: list[torch.Tensor] = []
        if self.encoder is not None:     # on into the set encoder, from the torso's input
            weight, _ = self._policy[0]
            encoder = self._set_backward(torch.bmm(d_out, weight.transpose(1, 2)))
        torch.cat([*reversed(pieces), *encoder, self._grad_padding], dim=1, out=self.grads)

    def _set_backward(self, d_encoded: torch.Tensor) -> list[torch.Tensor]:
        """The set encoder's gradients (weight, bias of each layer, in order) from dLoss /
        d(its output) (S, B, 2 H + G): the mean's share to every user, the maximum's to the
        user that holds it, then back through the shared ReLU layers."""
        kept = self._set_kept
        assert kept is not None and kept.argmax is not None
        stack, rows, slots, width = (*kept.argmax.shape[:2], self._per_user.shape[0],
                                     kept.argmax.shape[2])
        d_users = (d_encoded[..., :width] / slots).unsqueeze(2).expand(
            stack, rows, slots, width).contiguous()
        d_users.scatter_add_(2, kept.argmax.unsqueeze(2),
                             d_encoded[..., width:2 * width].unsqueeze(2))
        d_out = d_users.view(stack, rows * slots, width)
        pieces: list[torch.Tensor] = []
        for index in range(len(kept.inputs) - 1, -1, -1):
            d_out = torch.ops.aten.threshold_backward(d_out, kept.outputs[index], 0.0)
            x = kept.inputs[index]
            pieces += [d_out.sum(dim=1), torch.bmm(x.transpose(1, 2), d_out).view(stack, -1)]
            if index:
                weight, _ = self._policy_set[index]
                d_out = torch.bmm(d_out, weight.transpose(1, 2))
        return list(reversed(pieces))

    def _adam(self) -> None:
        """Per-member gradient-norm clipping, then Adam (the fused kernel)."""
        self.net.apply_fused(self.grads, self._lr, self.config.grad_clip_norm)

    def learning_rate(self) -> float:
        """The learning rate of the next update (Adam's ``lr``)."""
        return float(self._lr)

    def set_learning_rate(self, global_step: int) -> None:
        """lr at ``global_step``: linear from ``lr`` to ``lr_end`` over ``lr_decay_steps``,
        then ``lr_end`` (nothing to do without ``lr_end``)."""
        config = self.config
        if config.lr_end is None:
            return
        done = min(1.0, global_step / config.lr_decay_steps)
        assert isinstance(self._lr, torch.Tensor)
        self._lr.fill_(config.lr + (config.lr_end - config.lr) * done)

    def sync_target(self, members: np.ndarray | None = None) -> None:
        """Hard copy theta' <- theta (alg. 1), for every member or those flagged in a bool (S,)."""
        if members is None:
            self.target.copy_(self.params)
        elif members.any():
            index = torch.from_numpy(np.flatnonzero(members)).to(self.device)
            self.target.index_copy_(0, index, self.params.index_select(0, index))

    # ---- per-member state as plain arrays ------------------------------------------------

    def _layer_arrays(self, state: dict[str, Any]) -> dict[str, np.ndarray]:
        """The layers ``layer.<i>`` ((out, in) weights) from QNetwork-named arrays: the dueling
        head's value and advantage as one layer, V first."""
        names = [name for name in self.names if not name.startswith("set.")]
        pairs = [(state[w], state[b]) for w, b in zip(names[0::2], names[1::2], strict=True)]
        if self.dueling:
            (value_w, value_b), (adv_w, adv_b) = pairs[-2:]
            pairs[-2:] = [(np.concatenate([value_w, adv_w]), np.concatenate([value_b, adv_b]))]
        return {**{f"layer.{index}.{kind}": array for index, pair in enumerate(pairs)
                   for kind, array in zip(("weight", "bias"), pair, strict=True)},
                **{name: state[name] for name in self.names if name.startswith("set.")}}

    def row_from_state(self, state: dict[str, Any]) -> np.ndarray:
        """A flat row from QNetwork-named arrays ((out, in) weights)."""
        return self.net.row_from_named(self._layer_arrays(state))

    def state_from_row(self, row: np.ndarray) -> dict[str, np.ndarray]:
        """QNetwork-named arrays from a flat row (inverse of :meth:`row_from_state`)."""
        named = self.net.named_from_row(row)
        arrays = [array for name, array in named.items() if name.startswith("layer.")]
        if self.dueling:
            head_w, head_b = arrays[-2:]
            v = self.values
            arrays[-2:] = [head_w[:v], head_b[:v], head_w[v:], head_b[v:]]
        names = [name for name in self.names if not name.startswith("set.")]
        return {**dict(zip(names, arrays, strict=True)),
                **{name: array for name, array in named.items() if name.startswith("set.")}}

    def state_arrays(self, member: int) -> dict[str, Any]:
        """One member's weights and Adam state, named as ``QNetwork`` and ``torch.optim.Adam``
        name them, as numpy arrays and JSON text (no pickle)."""
        rows = [buffer[member, :self.net.used].cpu().numpy() for buffer in
                (self.params, self.target, self.exp_avg, self.exp_avg_sq)]
        step = np.float32(self.step.item())
        moments = [self.state_from_row(row) for row in rows[2:]]
        return {
            "policy": self.state_from_row(rows[0]),
            "target": self.state_from_row(rows[1]),
            "optimizer": {
                "param_groups_json": json.dumps([{"lr": self.config.lr, "betas": ADAM_BETAS,
                                                  "eps": ADAM_EPS}]),
                "state": {str(i): {"step": np.array(step), "exp_avg": moments[0][name],
                                   "exp_avg_sq": moments[1][name]}
                          for i, name in enumerate(self.names)},
            },
        }

    def policy_arrays(self, member: int) -> dict[str, np.ndarray]:
        """One member's policy weights, named as ``QNetwork`` names them (a copy)."""
        return self.state_from_row(self.params[member, :self.net.used].cpu().numpy())

    def load_policy(self, member: int, policy: dict[str, Any]) -> None:
        """Put QNetwork-named policy weights into one member (greedy evaluation)."""
        self.params[member, :self.net.used] = torch.from_numpy(
            self.row_from_state(policy))

    def load_state_arrays(self, member: int, state: dict[str, Any]) -> None:
        """Inverse of :meth:`state_arrays` for one member."""
        optimizer = state["optimizer"]["state"]
        moments = [{name: optimizer[str(i)][key] for i, name in enumerate(self.names)}
                   for key in ("exp_avg", "exp_avg_sq")] if optimizer else None
        buffers = [(self.params, state["policy"]), (self.target, state["target"])]
        if moments is not None:
            buffers += [(self.exp_avg, moments[0]), (self.exp_avg_sq, moments[1])]
        used = self.net.used
        for buffer, named in buffers:
            buffer[member, :used] = torch.from_numpy(self.row_from_state(named))
        self.step.fill_(float(np.asarray(optimizer["0"]["step"])) if optimizer else 0.0)
        if moments is None:
            self.exp_avg[member] = 0.0
            self.exp_avg_sq[member] = 0.0
