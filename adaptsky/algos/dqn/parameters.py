"""The Q-network's parameters by name and shape, as ``torch`` names them in ``QNetwork``
(``network.py``): the one definition the stacked trainer's checkpoints and the run-file layout
both use. No torch here, so a run file is validated without it."""

from __future__ import annotations

from collections.abc import Iterable
from itertools import pairwise

from adaptsky.algos.shared.set_layout import SetEncoder


def network_shapes(obs: int, actions: int, hidden_sizes: Iterable[int],
                   dueling: bool, values: int = 1, encoder: SetEncoder | None = None
                   ) -> dict[str, tuple[int, ...]]:
    """The Q-network's parameters in ``QNetwork.parameters()`` order (the optimizer state's
    order), named and shaped as torch names them ((out, in) weights); a dueling head has
    ``values`` value outputs (one, or one per reward part of the BDQ). With a set
    ``encoder`` the torso reads its output and its shared network ``set.*`` comes last."""
    sizes = [obs if encoder is None else encoder.width, *hidden_sizes]
    shapes: dict[str, tuple[int, ...]] = {}
    for index, (size_in, size_out) in enumerate(pairwise(sizes)):
        shapes[f"torso.{2 * index}.weight"] = (size_out, size_in)
        shapes[f"torso.{2 * index}.bias"] = (size_out,)
    heads = (("value", values), ("advantage", actions)) if dueling else (("q", actions),)
    for head, width in heads:
        shapes[f"{head}.weight"] = (width, sizes[-1])
        shapes[f"{head}.bias"] = (width,)
    return shapes if encoder is None else shapes | encoder.shapes("set")
