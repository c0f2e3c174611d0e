"""The ``[agent]`` section: one model per algorithm, told apart by ``algorithm`` (a tagged
union; docs/scenario-format.md). A file without ``algorithm`` gets ``"dqn"``, the paper's
agent family, so every scenario written before the key existed reads as it did.

A new algorithm adds its model here and an entry in :data:`AGENT_MODELS`; its learner lives in
``adaptsky.algos`` (docs/architecture.md).
"""

from __future__ import annotations

from copy import copy
from typing import Annotated, Any, ClassVar, Literal

from pydantic import Discriminator, Field, Tag, model_validator

from adaptsky.scenario.sections import MAX_COUNT, MAX_MEMORY, LayerSize, Section

DEFAULT_ALGORITHM = "dqn"
UNKNOWN_ALGORITHM = "unknown_algorithm"  # the error type of an algorithm no model has


class DqnAgent(Section):
    """The dueling DQN of sec. IV and V-A; extensions are off by default.

    ``preset`` names a set of values (``agent.presets``) for the keys a file does not give;
    ``"paper"`` is the paper's agent, every key at its default (docs/agent.md).
    """

    algorithm: Literal["dqn"] = Field(DEFAULT_ALGORITHM, description="the learning "
                                      "algorithm: 'dqn' (the dueling or plain DQN)")
    preset: str = Field("paper", description="named recipe for the keys not given "
                        "(docs/agent.md): 'paper' or 'tuned'")
    hidden_sizes: list[LayerSize] = Field([128, 128], min_length=1, max_length=100,
                                          description="hidden ReLU layers")
    dueling: bool = Field(True, description="dueling head; false gives the paper's plain 'DRL'")
    double_dqn: bool = Field(False, description="double-DQN target (extension)")
    loss: Literal["mse", "huber"] = Field("mse", description="TD loss; the paper uses MSE (eq. 12)")
    grad_clip_norm: float = Field(0.0, ge=0, le=1e6, description="gradient-norm clip; 0 disables")
    gamma: float = Field(0.999, ge=0, le=1, description="discount factor")
    lr: float = Field(1e-3, ge=1e-10, le=1.0, description="Adam learning rate l_r")
    batch_size: int = Field(128, ge=1, le=MAX_COUNT, description="mini-batch size B")
    memory_size: int = Field(15000, ge=1, le=MAX_MEMORY, description="replay memory capacity M")
    epsilon_start: float = Field(0.9, ge=0, le=1, description="epsilon_s")
    epsilon_end: float = Field(0.1, ge=0, le=1, description="epsilon_e")
    epsilon_decay_steps: float = Field(200.0, gt=0, le=1e15,
                                       description="chi, decay constant in steps")
    target_update_episodes: int = Field(10, ge=1, le=MAX_COUNT,
                                        description="hard target copy period")
    observation: Literal["scaled", "raw"] = Field(
        "scaled", description="observation scaling, see docs/environment.md"
    )
    user_order: Literal["listed", "clusters"] = Field(
        "listed", description="users in the observation: as the layout lists them, or cluster "
        "by cluster (first and second user of cluster 1, then cluster 2...)")
    network: Literal["mlp", "set"] = Field(
        "mlp", description="what reads the observation: 'mlp' the whole vector, 'set' a "
        "network shared by the users, pooled by mean and max, beside the rest "
        "(docs/agent.md, 'The set encoder')")
    set_sizes: list[LayerSize] = Field([64], min_length=1, max_length=100, description="'set':"
                                       " the layers of the network each user's features go "
                                       "through, the activation after each")
    observe: list[Literal["los", "heights", "velocity"]] = Field(
        [], max_length=3, description="observations of the world appended to the agent's "
        "(docs/environment.md): 'los' each user's serving link's LoS state, 'heights' a "
        "raster of building heights around each UAV, 'velocity' the users' velocities")
    raster_cells: int = Field(5, ge=1, le=31, description="'heights': the raster's cells "
                              "per side (odd: the UAV above the middle cell)")
    raster_cell_m: float = Field(10.0, gt=0, le=1000.0, description="'heights': a raster "
                                 "cell's side, m")
    reward_scale: float = Field(1.0, gt=0, le=1e6, description="rewards are multiplied by "
                                "this before they are stored for learning (extension)")
    n_step: int = Field(1, ge=1, le=100, description="n-step returns (extension); 1 is "
                        "eq. 12's one-step target")
    target_tau: float = Field(0.0, ge=0, le=1, description="soft target update theta' <- "
                              "theta' + tau (theta - theta') after every update (extension); "
                              "0 keeps the hard copies of target_update_episodes")
    lr_end: float | None = Field(None, ge=1e-12, le=1.0, description="learning rate reached "
                                 "after lr_decay_steps steps, linearly (extension); unset: "
                                 "constant lr")
    lr_decay_steps: float = Field(300_000.0, gt=0, le=1e15, description="steps over which lr "
                                  "falls to lr_end")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """A preset's values under the keys given explicitly."""
        return with_preset(cls, data, "dqn")

    @model_validator(mode="after")
    def _memory_holds_a_batch(self) -> DqnAgent:
        _check_memory_holds_a_batch(self.memory_size, self.batch_size)
        return self


def world_observation_size(agent: Section, num_users: int, num_uavs: int) -> int:
    """The components ``agent.observe`` appends to the agent's observation (docs/
    environment.md, "Observations of the world"): N for 'los', 2 N for 'velocity', U R^2 for
    'heights' (R = ``raster_cells``); 0 for an agent that observes none."""
    observe = set(getattr(agent, "observe", ()))
    return (num_users * ("los" in observe) + 2 * num_users * ("velocity" in observe)
            + num_uavs * int(getattr(agent, "raster_cells", 0)) ** 2 * ("heights" in observe))


def check_world_keys(agent: Section) -> None:
    """``agent.observe`` lists each observation of the world once; the raster's keys set
    other than their defaults go with 'heights' (a setting silently ignored is a bug), its
    cells odd."""
    observe = list(getattr(agent, "observe", []))
    if len(set(observe)) != len(observe):
        raise ValueError(f"agent.observe: {observe} lists an observation twice; list each "
                         "once")
    given = [key for key in ("raster_cells", "raster_cell_m")    # (a resolved file lists
             if getattr(agent, key) != type(agent).model_fields[key].default]   # defaults)
    if given and "heights" not in observe:
        raise ValueError(f"agent.{', agent.'.join(given)} given without 'heights' in "
                         f"agent.observe, which "
                         f"{'reads it' if len(given) == 1 else 'read them'}; add 'heights' "
                         "or remove it")
    if getattr(agent, "raster_cells", 1) % 2 == 0:
        raise ValueError(f"agent.raster_cells: {agent.raster_cells} is even; the raster is "
                         "centred "
                         "on the UAV, give an odd number")


def check_network_keys(agent: Section) -> None:
    """``agent.set_sizes`` other than its default goes with ``network = "set"``; the set
    encoder reads the whole network's observation (MAPPO's and IPPO's per-UAV actors do not
    take it yet)."""
    network = getattr(agent, "network", "mlp")
    sizes = getattr(agent, "set_sizes", None)
    if sizes is not None and network != "set" and sizes != type(agent).model_fields[
            "set_sizes"].default:
        raise ValueError("agent.set_sizes given with agent.network = 'mlp', which reads no "
                         "set; set agent.network = 'set' or remove it")
    if network == "set" and getattr(agent, "local_view", False):
        raise ValueError(f"agent.network: 'set' is not built for '{agent.algorithm}' yet "
                         "(its actor acts on each UAV's local observation); use 'mlp', or "
                         "'ppo' with one actor for the whole network")


def with_preset(model: type[Section], data: Any, family: str) -> Any:
    """``data`` (an ``[agent]`` table) with the values of its ``preset`` (or the family's
    default preset) under the keys it gives, for the keys ``model`` has."""
    if not isinstance(data, dict):
        return data
    from adaptsky.scenario.presets import DEFAULT_PRESET, preset_values

    name = data.get("preset", DEFAULT_PRESET[family])
    if not isinstance(name, str):
        return data
    values = {key: value for key, value in preset_values(name, family).items()
              if key in model.model_fields}
    return {**values, **data}


def _check_memory_holds_a_batch(memory_size: int, batch_size: int) -> None:
    if memory_size < batch_size:
        raise ValueError(f"memory_size ({memory_size}) must hold at least one batch "
                         f"({batch_size})")


def _as_dqn(key: str) -> Any:
    """The DQN's field ``key`` (range, default and description): a key that means the same
    for another algorithm is declared once."""
    return copy(DqnAgent.model_fields[key])


class BdqAgent(Section):
    """The branching dueling Q-network (Tavakoli et al., AAAI 2018; docs/agent.md): one
    advantage branch per action component, every key that it shares with the DQN at the DQN's
    default. Its target is always the double-DQN one, averaged over the branches."""

    algorithm: Literal["bdq"] = Field(description="the learning algorithm: 'bdq' (the "
                                      "branching dueling Q-network)")
    preset: str = _as_dqn("preset")
    hidden_sizes: list[LayerSize] = _as_dqn("hidden_sizes")
    loss: Literal["mse", "huber"] = Field("mse", description="TD loss per branch, averaged "
                                          "over the branches and the batch")
    grad_clip_norm: float = _as_dqn("grad_clip_norm")
    gamma: float = _as_dqn("gamma")
    lr: float = _as_dqn("lr")
    batch_size: int = _as_dqn("batch_size")
    memory_size: int = _as_dqn("memory_size")
    epsilon_start: float = _as_dqn("epsilon_start")
    epsilon_end: float = _as_dqn("epsilon_end")
    epsilon_decay_steps: float = _as_dqn("epsilon_decay_steps")
    target_update_episodes: int = _as_dqn("target_update_episodes")
    observation: Literal["scaled", "raw"] = _as_dqn("observation")
    user_order: Literal["listed", "clusters"] = _as_dqn("user_order")
    network: Literal["mlp", "set"] = _as_dqn("network")
    set_sizes: list[LayerSize] = _as_dqn("set_sizes")
    observe: list[Literal["los", "heights", "velocity"]] = _as_dqn("observe")
    raster_cells: int = _as_dqn("raster_cells")
    raster_cell_m: float = _as_dqn("raster_cell_m")
    reward_scale: float = _as_dqn("reward_scale")
    n_step: int = _as_dqn("n_step")
    target_tau: float = _as_dqn("target_tau")
    lr_end: float | None = _as_dqn("lr_end")
    lr_decay_steps: float = _as_dqn("lr_decay_steps")
    reward_split: Literal["team", "per-uav", "difference"] = Field(
        "team", description="what the branches learn from: 'team', eq. 13's one reward for "
        "every branch; 'per-uav', each UAV's branches the part of eq. 13 from its own users; "
        "'difference', that part minus what its interference costs the other UAVs' users "
        "(a value per UAV; docs/agent.md)")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """A DQN preset's values for the BDQ's keys (its target is always the double one)
        under the keys given explicitly."""
        return with_preset(cls, data, "dqn")

    @model_validator(mode="after")
    def _memory_holds_a_batch(self) -> BdqAgent:
        _check_memory_holds_a_batch(self.memory_size, self.batch_size)
        return self


class PpoAgent(Section):
    """PPO (Schulman et al. 2017) with CleanRL's details (docs/agent.md): GAE(lambda), the
    clipped surrogate and value loss, an entropy bonus, advantages normalised per minibatch,
    epochs of minibatches, orthogonal initialisation, a global gradient-norm clip per seed and
    a linearly annealed learning rate; it collects a rollout of T steps (one episode) from
    ``envs_per_seed`` copies of the layout per seed, then updates."""

    preset_family: ClassVar[str] = "ppo"
    algorithm: Literal["ppo"] = Field(description="the learning algorithm: 'ppo'")
    preset: str = Field("cleanrl", description="named recipe for the keys not given "
                        "(docs/agent.md): 'cleanrl' (the defaults) or 'tuned'")
    hidden_sizes: list[LayerSize] = Field([64, 64], min_length=1, max_length=100,
                                          description="hidden layers of actor and critic")
    activation: Literal["tanh", "relu"] = Field("tanh", description="hidden activation")
    action_head: Literal["auto", "dense", "branches", "gaussian"] = Field(
        "auto", description="the policy's distribution: 'dense' (one Categorical over the "
        "dense action set), 'branches' (one per component), 'gaussian' (continuous "
        "controls); 'auto': dense for uav.actions 'paper'/'with-hover', gaussian for "
        "'continuous'")
    envs_per_seed: int = Field(8, ge=1, le=4096, description="E, environments per seed "
                               "collecting each rollout")
    lr: float = Field(3e-4, ge=1e-10, le=1.0, description="Adam learning rate")
    anneal_lr: bool = Field(True, description="anneal the learning rate linearly to 0 over "
                            "train.episodes")
    gamma: float = Field(0.99, ge=0, le=1, description="discount factor")
    gae_lambda: float = Field(0.95, ge=0, le=1, description="GAE lambda")
    epochs: int = Field(4, ge=1, le=1000, description="epochs over each rollout")
    minibatches: int = Field(4, ge=1, le=MAX_COUNT, description="minibatches per epoch")
    clip_coef: float = Field(0.2, gt=0, le=10, description="surrogate clipping epsilon")
    clip_vloss: bool = Field(True, description="clip the value loss as the surrogate")
    ent_coef: float = Field(0.01, ge=0, le=100, description="entropy bonus coefficient")
    vf_coef: float = Field(0.5, ge=0, le=100, description="value loss coefficient")
    max_grad_norm: float = Field(0.5, ge=0, le=1e6, description="global gradient-norm clip "
                                 "per seed; 0 disables")
    norm_adv: bool = Field(True, description="normalise advantages per minibatch")
    norm_reward: bool = Field(True, description="divide rewards by a running standard "
                              "deviation of the discounted return, per seed, and clip them "
                              "to [-10, 10] (CleanRL's continuous PPO)")
    init_log_std: float = Field(0.0, ge=-20, le=2, description="initial log standard "
                                "deviation of the Gaussian head")
    network: Literal["mlp", "set"] = _as_dqn("network")
    set_sizes: list[LayerSize] = _as_dqn("set_sizes")
    observation: Literal["scaled", "raw"] = _as_dqn("observation")
    user_order: Literal["listed", "clusters"] = _as_dqn("user_order")
    observe: list[Literal["los", "heights", "velocity"]] = _as_dqn("observe")
    raster_cells: int = _as_dqn("raster_cells")
    raster_cell_m: float = _as_dqn("raster_cell_m")
    reward_scale: float = _as_dqn("reward_scale")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """A preset's values (of PPO's, or MAPPO's for MAPPO and IPPO) under the keys given
        explicitly."""
        return with_preset(cls, data, cls.preset_family)


class SacAgent(Section):
    """Soft actor-critic (Haarnoja et al. 2018) with CleanRL's details (docs/agent.md): twin Q
    networks and their Polyak-averaged targets, a tanh-squashed Gaussian actor updated every
    ``policy_frequency`` steps, and a learned temperature; for continuous controls. It acts
    uniformly at random for ``learning_starts`` steps, then stores every step and updates."""

    algorithm: Literal["sac"] = Field(description="the learning algorithm: 'sac'")
    preset: str = Field("cleanrl", description="named recipe for the keys not given "
                        "(docs/agent.md): 'cleanrl' (the defaults) or 'tuned'")
    hidden_sizes: list[LayerSize] = Field([256, 256], min_length=1, max_length=100,
                                          description="hidden ReLU layers of the actor and "
                                          "of each Q network")
    q_lr: float = Field(1e-3, ge=1e-10, le=1.0, description="Adam learning rate of the Q "
                        "networks and of the temperature")
    policy_lr: float = Field(3e-4, ge=1e-10, le=1.0, description="Adam learning rate of the "
                             "actor")
    gamma: float = Field(0.99, ge=0, le=1, description="discount factor")
    tau: float = Field(0.005, gt=0, le=1, description="target smoothing: theta' <- tau theta "
                       "+ (1 - tau) theta'")
    batch_size: int = Field(256, ge=1, le=MAX_COUNT, description="mini-batch size, drawn "
                            "with replacement")
    memory_size: int = Field(100_000, ge=1, le=MAX_MEMORY, description="replay memory "
                             "capacity")
    learning_starts: int = Field(5000, ge=0, le=MAX_COUNT, description="steps of uniform "
                                 "random actions before the first update")
    policy_frequency: int = Field(2, ge=1, le=MAX_COUNT, description="every this many steps, "
                                  "this many actor (and temperature) updates (delayed)")
    target_network_frequency: int = Field(1, ge=1, le=MAX_COUNT, description="steps between "
                                          "target updates")
    autotune: bool = Field(True, description="learn the temperature alpha towards the target "
                           "entropy -D (from alpha 1); false keeps alpha fixed")
    alpha: float = Field(0.2, gt=0, le=1e6, description="the fixed temperature where "
                         "autotune is false")
    observation: Literal["scaled", "raw"] = _as_dqn("observation")
    user_order: Literal["listed", "clusters"] = _as_dqn("user_order")
    observe: list[Literal["los", "heights", "velocity"]] = _as_dqn("observe")
    raster_cells: int = _as_dqn("raster_cells")
    raster_cell_m: float = _as_dqn("raster_cell_m")
    network: Literal["mlp", "set"] = _as_dqn("network")
    set_sizes: list[LayerSize] = _as_dqn("set_sizes")
    reward_scale: float = _as_dqn("reward_scale")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """A preset's values under the keys given explicitly."""
        return with_preset(cls, data, "sac")


class MappoAgent(PpoAgent):
    """MAPPO and IPPO (Yu et al. 2022) for several UAVs (docs/agent.md): PPO's details and
    keys, with one actor shared by the UAVs, each acting on its local observation and a
    one-hot UAV id; the critic reads every UAV's local observation and the id (``"mappo"``:
    centralised) or the UAV's own and the id (``"ippo"``: local). ``action_head`` is each
    UAV's: 'dense' one Categorical over its own 2^(3 + K) (or 3^(3 + K)) moves, 'branches'
    one per component, 'gaussian' its continuous controls."""

    local_view: ClassVar[bool] = True  # the environment gives every UAV's local observation
    preset_family: ClassVar[str] = "mappo"
    algorithm: Literal["mappo", "ippo"] = Field(description="the learning algorithm: 'mappo' "
                                                "(centralised critic) or 'ippo' (local critic)")
    reward_split: Literal["team", "per-uav", "difference"] = Field(
        "team", description="what each UAV learns from: 'team', eq. 13's one reward; "
        "'per-uav', the part of eq. 13 from its own users; 'difference', that part minus "
        "what its interference costs the other UAVs' users (docs/agent.md)")


AGENT_MODELS: dict[str, type[Section]] = {"dqn": DqnAgent, "bdq": BdqAgent, "ppo": PpoAgent,
                                          "sac": SacAgent, "mappo": MappoAgent,
                                          "ippo": MappoAgent}


def algorithm_tag(value: Any) -> str | None:
    """The algorithm an ``[agent]`` value names (``"dqn"`` where it names none); None for
    a name no model has, which pydantic reports as :data:`UNKNOWN_ALGORITHM`."""
    name = (value.get("algorithm", DEFAULT_ALGORITHM) if isinstance(value, dict)
            else getattr(value, "algorithm", None))
    return name if isinstance(name, str) and name in AGENT_MODELS else None


AgentConfig = Annotated[
    Annotated[DqnAgent, Tag("dqn")] | Annotated[BdqAgent, Tag("bdq")]
    | Annotated[PpoAgent, Tag("ppo")] | Annotated[SacAgent, Tag("sac")]
    | Annotated[MappoAgent, Tag("mappo")] | Annotated[MappoAgent, Tag("ippo")],
    Discriminator(algorithm_tag, custom_error_type=UNKNOWN_ALGORITHM,
                  custom_error_message="unknown algorithm")]
"""The ``[agent]`` section: the model its ``algorithm`` names."""
