"""Registers ``adaptsky/NomaUav-v0`` with Gymnasium (done on ``import adaptsky`` or
``import adaptsky.envs.gym_env``); without a ``scenario`` argument it uses the shipped
default."""

ENV_ID = "adaptsky/NomaUav-v0"


def register_envs() -> None:
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID,
            entry_point="adaptsky.envs.gym_env:NomaUavEnv",
            vector_entry_point="adaptsky.envs.gym_env:NomaUavVectorEnv",
        )
