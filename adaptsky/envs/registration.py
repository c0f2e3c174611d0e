"""Registers ``adaptsky/NomaUav-v0`` with Gymnasium (done on ``import adaptsky`` or
``import adaptsky.envs.gym_env``); without a ``scenario`` argument it uses the shipped
default. The one id serves scenarios of one UAV and of several (``uav.count > 1``: a
MultiDiscrete action space by default, docs/environment.md, "Several UAVs"). The envs take
their time limit as ``max_episode_steps`` (default ``train.steps``): ``gymnasium.make_vec``
passes it on, while ``gymnasium.make`` keeps that name for its own ``TimeLimit`` wrapper, which
can end an episode earlier than the env's limit, never later (docs/environment.md,
"Episodes").

``import adaptsky`` does not import Gymnasium for this (it takes about 0.2 s, which every
``adaptsky`` command would pay): where Gymnasium is not imported yet, the registration runs
the moment it is, so ``gymnasium.make(ENV_ID)`` works whichever is imported first."""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from importlib.machinery import ModuleSpec
from types import ModuleType
from typing import Any

ENV_ID = "adaptsky/NomaUav-v0"


def register_envs() -> None:
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID,
            entry_point="adaptsky.envs.gym_env:NomaUavEnv",
            vector_entry_point="adaptsky.envs.gym_env:NomaUavVectorEnv",
        )


def register_when_gymnasium_is_imported() -> None:
    """:func:`register_envs` now if Gymnasium is imported, else right after it is."""
    if "gymnasium" in sys.modules:
        register_envs()
    elif not any(isinstance(finder, _OnGymnasiumImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _OnGymnasiumImport())


class _OnGymnasiumImport(importlib.abc.MetaPathFinder):
    """Finds ``gymnasium`` as usual, once, and registers the environments after its module
    has run."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> ModuleSpec | None:
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def exec_and_register(module: ModuleType) -> None:
            exec_module(module)
            register_envs()

        spec.loader.exec_module = exec_and_register  # type: ignore[method-assign]
        return spec
