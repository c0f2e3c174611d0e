"""The documented run-file layout (``docs/file-format.md``) as data, and its validator.

Every name, dtype and shape a run file may hold is listed once below, with shapes written in
terms of what the stored ``/config`` implies (users N, observation size O, actions A, steps T,
memory rows R, the network's layers). :func:`validate_run` walks the layout on the file's
metadata only (declared shapes, dtypes, attributes, link types): no array is read, so a dataset
declared as (2**36, O) is refused without reading it, and the walk is bounded by the layout
(every group's member count is checked before its members are listed). Links inside the file
are refused, never followed. The first problem raises :class:`RunFileError`, one line:
``<file>: damaged run file: <hdf5 path>: <what is wrong> (expected ...)``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NoReturn

import h5py
import numpy as np

from adaptsky import __version__
from adaptsky.algos.protocol import AlgorithmSpec
from adaptsky.algos.registry import ALGORITHMS, algorithm_of
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.arrays import Field
from adaptsky.channels.registry import get_model_class
from adaptsky.errors import AdaptskyError, PluginError
from adaptsky.scenario import Scenario, parse_scenario
from adaptsky.scenario.agents import algorithm_tag
from adaptsky.sim.controls import controls_of

KIND = "adaptsky-run"
# what this adaptsky writes (2: greedy evaluations and the best policy; 3: energy; 4: the
# service metrics of every episode and every user's position at every step)
FORMAT_VERSION = 5
SUPPORTED_VERSIONS = (1, 2, 3, 4, 5)  # what it reads
ENERGY_VERSION = 3  # the first format with the energy of every episode and step
SERVICE_VERSION = 4  # the first with the service metrics and the users' positions
LEARNER_VERSION = 5  # the first with the policy's entropy (learners beyond the DQN family)
MAX_PLUGINS = 64

Needs = Literal["curves", "all"]


class RunFileError(AdaptskyError):
    """A run file that is missing, unreadable, not HDF5, damaged, too new, or lacks what is
    asked of it."""


# /seeds/<S>/episodes/: one row per episode ("E": rows, at least episodes_done)
EPISODES = (
    Field("sum_rate_bps", "float", ("E",), "bit/s"),
    Field("fairness", "float", ("E",)),
    Field("reward", "float", ("E",)),
    Field("mean_height_m", "float", ("E",), "m"),
    Field("epsilon", "float", ("E",)),
    Field("loss", "float", ("E",)),  # NaN before the first update
    Field("mean_rate_bps", "float", ("E", "N"), "bit/s"),
    Field("mean_alpha", "float", ("E", "N")),
)
# format 3: the episode's propulsion and transmit energy of every UAV, and bit per joule
ENERGY_EPISODES = (
    Field("energy_j", "float", ("E",), "J"),
    Field("energy_efficiency_bpj", "float", ("E",), "bit/J"),
)
# format 4: the episode's service metrics (docs/model.md §14)
SERVICE_EPISODES = (
    Field("outage_share", "float", ("E",)),
    Field("mean_least_rate_bps", "float", ("E",), "bit/s"),
    Field("p5_rate_bps", "float", ("E",), "bit/s"),
)
# format 5: the policy's mean entropy in the episode's update (PPO; NaN for Q-learners)
LEARNER_EPISODES = (Field("entropy", "float", ("E",)),)
# /seeds/<S>/evaluations/ (format 2): one row per greedy evaluation ("V" rows), NaN where a
# column does not apply (adaptsky.training.evaluation)
EVALUATIONS = (
    Field("episode", "int", ("V",)),
    Field("sum_rate_bps", "float", ("V",), "bit/s"),
    Field("fairness", "float", ("V",)),
    Field("pct_oracle", "float", ("V",), "%"),
    Field("heldout_sum_rate_bps", "float", ("V",), "bit/s"),
    Field("heldout_fairness", "float", ("V",)),
    Field("heldout_pct_oracle", "float", ("V",), "%"),
    Field("heldout_pct_oracle_median", "float", ("V",), "%"),
    Field("score", "float", ("V",)),
)
# format 4 (optional: files of format 4 made before them lack both): the tracking baseline's
# steady sum rate on the same draws, where users move
TRACKING_EVALUATIONS = (
    Field("tracking_bps", "float", ("V",), "bit/s"),
    Field("heldout_tracking_bps", "float", ("V",), "bit/s"),
)
# /evaluation/ (format 2, when the run evaluates): the layouts and their oracle sum rates
EVALUATION_SET = {"training": "the training layout", "heldout": "the held-out layouts"}
# /seeds/<S>/trajectory/ and /seeds/<S>/trajectories/<e>/: time-major, attr episode
TRAJECTORY = (
    Field("uav_m", "float", ("T", 3), "m"),
    Field("alpha", "float", ("T", "N")),
    Field("gain", "float", ("T", "N")),
    Field("los", "bool", ("T", "N")),
    Field("rate_bps", "float", ("T", "N"), "bit/s"),
    Field("reward", "float", ("T",)),
    Field("action", "int", ("T",)),
)
# format 3: each step's energy (docs/model.md §10), of every UAV for several
STEP_ENERGY = Field("energy_j", "float", ("T",), "J")
SEVERAL_UAVS_STEP_ENERGY = Field("energy_j", "float", ("T", "U"), "J")
# format 4: every user's position at every step (docs/model.md §3: users that move)
USERS_TRAJECTORY = Field("users_m", "float", ("T", "N", 2), "m")
# continuous controls (docs/model.md §3): each step's action in [-1, 1]^D, as the env took it
CONTINUOUS_ACTIONS = Field("action", "float", ("T", "D"))
# several UAVs (docs/model.md §9): every UAV's position per step
SEVERAL_UAVS_POSITIONS = Field("uav_m", "float", ("T", "U", 3), "m")
# attributes: name -> type ("int", "str", "json", "rng": a numpy bit generator's state as JSON)
ROOT_ATTRS = {"kind": "str", "format_version": "int", "adaptsky_version": "str",
              "created_utc": "str", "scenario_name": "str"}
PROVENANCE_ATTRS = {"python_version": "str", "numpy_version": "str", "torch_version": "str",
                    "h5py_version": "str", "platform": "str", "command_line": "json"}
ATTR_KINDS = {"int": "an integer", "float": "a number", "str": "text", "json": "JSON text",
              "rng": "a numpy generator state (or a list of them) as JSON text"}
SEED_ATTRS = {"seed": "int", "episodes_done": "int", "episodes_planned": "int"}
CHECKPOINT_ATTRS = {"episode": "int", "global_step": "int", "seed": "int"}
CHECKPOINT_OPTIONAL_ATTRS = {"device": "str"}  # since the stacked trainer; older files lack it
RNG_ATTRS = {"numpy_agent_json": "rng", "numpy_env_json": "rng"}
# sections whose absence would silently give defaults (a missing [train] means 1000 x 300)
CONFIG_SECTIONS = ("area", "users", "uav", "radio", "channel", "reward", "agent", "train")
CONFIG_KEYS = {"train": ("episodes", "steps", "seeds", "checkpoint_every"),
               "users": ("count",), "uav": ("actions",), "channel": ("model",)}

UNITS = {field.name: field.units for field in (*EPISODES, *ENERGY_EPISODES, *SERVICE_EPISODES,
                                               *LEARNER_EPISODES,
                                               *TRAJECTORY, STEP_ENERGY, USERS_TRAJECTORY,
                                               *EVALUATIONS, *TRACKING_EVALUATIONS)}
UNITS |= {field.name: field.units for spec in ALGORITHMS.values() for field in spec.fields}
UNITS |= {"training_layouts_m": "m", "heldout_layouts_m": "m", "training_oracle_bps": "bit/s",
          "heldout_oracle_bps": "bit/s"}


def episode_fields(version: int) -> tuple[Field, ...]:
    """The learning curves' datasets of a file of format ``version``."""
    fields = EPISODES
    if version >= ENERGY_VERSION:
        fields += ENERGY_EPISODES
    if version >= SERVICE_VERSION:
        fields += SERVICE_EPISODES
    if version >= LEARNER_VERSION:
        fields += LEARNER_EPISODES
    return fields


def evaluation_fields(version: int) -> tuple[Field, ...]:
    """The greedy evaluations' columns of a file of format ``version``."""
    return EVALUATIONS + (TRACKING_EVALUATIONS if version >= SERVICE_VERSION else ())


def added_after(version: int) -> frozenset[str]:
    """The names of episode, evaluation and trajectory datasets that formats after
    ``version`` add (a run continued by ``train --resume`` keeps its format: these are left
    out of it)."""
    names: set[str] = set()
    if version < ENERGY_VERSION:
        names |= {field.name for field in ENERGY_EPISODES} | {STEP_ENERGY.name}
    if version < SERVICE_VERSION:
        names |= {field.name for field in (*SERVICE_EPISODES, *TRACKING_EVALUATIONS)}
        names |= {USERS_TRAJECTORY.name}
    if version < LEARNER_VERSION:
        names |= {field.name for field in LEARNER_EPISODES}
    return frozenset(names)


@dataclass(frozen=True)
class Sizes:
    """What a stored scenario implies for the layout."""

    scenario: Scenario
    version: int = FORMAT_VERSION

    @property
    def episodes(self) -> tuple[Field, ...]:
        """The learning curves' datasets: with the energy from format 3, the service
        metrics from format 4."""
        return episode_fields(self.version)

    @property
    def symbols(self) -> dict[str, int]:
        s = self.scenario
        return {"N": s.num_users, "O": observation_size_of(s), "T": s.train.steps,
                "U": s.uav.count, "D": sum(3 + k for k in s.shares_of_uavs)}

    @property
    def trajectory(self) -> tuple[Field, ...]:
        """The trajectory's datasets: :data:`TRAJECTORY`, with every UAV's position
        (T, U, 3) for several UAVs, and from format 3 each step's energy."""
        several = self.scenario.uav.count > 1
        continuous = self.scenario.uav.actions == "continuous"
        replaced = {"uav_m": SEVERAL_UAVS_POSITIONS if several else None,
                    "action": CONTINUOUS_ACTIONS if continuous else None}
        fields = tuple(replaced.get(field.name) or field for field in TRAJECTORY)
        if self.version < ENERGY_VERSION:
            return fields
        fields = (*fields, SEVERAL_UAVS_STEP_ENERGY if several else STEP_ENERGY)
        return fields if self.version < SERVICE_VERSION else (*fields, USERS_TRAJECTORY)

    @property
    def algorithm(self) -> AlgorithmSpec:
        """The algorithm that checks its own part of every checkpoint."""
        return algorithm_of(self.scenario)


class Node:
    """A group or dataset of the file, opened through HDF5's low-level API (a fraction of the
    cost of h5py's objects: the walk opens every object of every checkpoint), named by its
    path in the file."""

    def __init__(self, oid: Any, name: str) -> None:
        self.id, self.name = oid, name

    @property
    def attrs(self) -> h5py.AttributeManager:
        return h5py.AttributeManager(self)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.id.shape)

    @property
    def dtype(self) -> np.dtype:
        return self.id.dtype

    def __len__(self) -> int:
        return int(self.id.get_num_objs())

    def keys(self) -> list[str]:
        return [name.decode("utf-8", "replace") for name in self.id]

    def read(self) -> Any:
        return h5py.Dataset(self.id)[()]


GROUP, DATASET = h5py.h5g.GroupID, h5py.h5d.DatasetID
DTYPE_CLASS = {"float": h5py.h5t.FLOAT, "int": h5py.h5t.INTEGER, "bool": h5py.h5t.ENUM}


class Validator:
    """Walks one open run file; :meth:`fail` raises the one-line error."""

    def __init__(self, file: h5py.File, path: Path) -> None:
        self.root, self.path = Node(file.id, ""), path
        self.version = FORMAT_VERSION  # set from the file by header()

    def fail(self, where: str, what: str, expected: str = "") -> NoReturn:
        raise RunFileError(f"{self.path}: damaged run file: {where or '/'}: {what}"
                           + (f" (expected {expected})" if expected else ""))

    # ---- nodes ------------------------------------------------------------------------

    def child(self, group: Node, name: str, kind: type, expected: str = "",
              optional: bool = False) -> Any:
        """``group``'s member ``name`` if it is a hard link to a ``kind`` (GROUP or
        DATASET)."""
        where, key, links = f"{group.name}/{name}", name.encode(), group.id.links
        if not links.exists(key):
            if optional:
                return None
            self.fail(where, "missing", expected)
        link = links.get_info(key).type
        if link == h5py.h5l.TYPE_SOFT:
            self.fail(where, f"is a soft link to {links.get_val(key).decode()} (links are not "
                      "followed)", "the object itself")
        if link != h5py.h5l.TYPE_HARD:
            self.fail(where, "is an external link (links are not followed)", "the object itself")
        item = h5py.h5o.open(group.id, key)
        if not isinstance(item, kind):
            what = "a group" if isinstance(item, GROUP) else "a dataset"
            self.fail(where, f"is {what}", f"a {'group' if kind is GROUP else 'dataset'}")
        return Node(item, where)

    def group(self, parent: Node, name: str, optional: bool = False) -> Any:
        """``parent``'s group ``name`` (None if absent and ``optional``)."""
        return self.child(parent, name, GROUP, optional=optional)

    def members(self, group: Node, allowed: int, expected: str) -> list[str]:
        """The member names of ``group``, refused beyond ``allowed`` before they are listed."""
        if len(group) > allowed:
            self.fail(group.name, f"holds {len(group)} members", expected)
        return group.keys()

    def exact_members(self, group: Node, names: Iterable[str],
                      extra_ok: tuple[str, ...] = ()) -> None:
        names = list(names)
        found = set(self.members(group, len(names) + len(extra_ok), ", ".join(names)))
        for name in names:
            if name not in found:
                self.fail(f"{group.name}/{name}", "missing", f"{len(names)} members: "
                          + ", ".join(names))
        unknown = sorted(found - set(names) - set(extra_ok))
        if unknown:
            self.fail(f"{group.name}/{unknown[0]}", "unknown member", ", ".join(names))

    # ---- attributes -------------------------------------------------------------------

    def attr(self, obj: Node, name: str, kind: str, optional: bool = False) -> Any:
        where = f"{obj.name}/@{name}"
        if name not in obj.attrs:
            if optional:
                return None
            self.fail(where, "missing", ATTR_KINDS[kind])
        value = obj.attrs[name]
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bytes):
            value = value.decode("utf-8", "replace")
        if kind == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                self.fail(where, f"is {value!r}", ATTR_KINDS[kind])
            return int(value)
        if kind == "float":
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    np.isfinite(value)):
                self.fail(where, f"is {value!r}", "a finite number")
            return float(value)
        if not isinstance(value, str):
            self.fail(where, f"is {value!r}", ATTR_KINDS[kind])
        if kind == "str":
            return value
        try:
            parsed = json.loads(value)
            if kind == "rng":  # one state, or a list of them (E environments per seed)
                for state in parsed if isinstance(parsed, list) and parsed else [parsed]:
                    np.random.PCG64().state = state
        except (ValueError, TypeError, KeyError, OverflowError) as error:
            reason = f"no {error}" if isinstance(error, KeyError) else str(error).splitlines()[0]
            self.fail(where, f"is not valid ({reason})", ATTR_KINDS[kind])
        return parsed

    def attrs(self, obj: Node, spec: dict[str, str],
              optional: bool = False) -> dict[str, Any]:
        return {name: self.attr(obj, name, kind, optional) for name, kind in spec.items()}

    # ---- datasets ---------------------------------------------------------------------

    def dataset(self, group: Node, field: Field, symbols: dict[str, int],
                shape: tuple[int, ...] | None = None) -> Node:
        """Check a dataset's dtype kind and declared shape (``shape`` overrides the field's)."""
        expected = shape if shape is not None else tuple(
            symbols[dim] if isinstance(dim, str) else dim for dim in field.shape)
        dataset = self.child(group, field.name, DATASET, f"{field.dtype} {expected}")
        if DTYPE_CLASS[field.dtype] != dataset.id.get_type().get_class() or (
                field.dtype == "bool" and dataset.dtype.kind != "b"):
            self.fail(dataset.name, f"dtype {dataset.dtype}", field.dtype)
        if dataset.shape != expected:
            self.fail(dataset.name, f"shape {dataset.shape}",
                      f"{expected} from the stored config")
        return dataset

    def text(self, name: str, optional: bool = False) -> Node | None:
        dataset = self.child(self.root, name, DATASET, "a text dataset", optional)
        if dataset is not None and (dataset.shape != () or h5py.check_string_dtype(
                dataset.dtype) is None):
            self.fail(dataset.name, f"is a {dataset.dtype} array of shape {dataset.shape}",
                      "one string")
        return dataset

    def json_text(self, name: str, kind: type, optional: bool = False) -> Any:
        dataset = self.text(name, optional)
        if dataset is None:
            return None
        try:
            value = json.loads(dataset.read().decode())
        except (ValueError, UnicodeDecodeError) as error:
            self.fail(dataset.name, f"is not JSON ({str(error).splitlines()[0]})", "JSON")
        if not isinstance(value, kind):
            self.fail(dataset.name, f"is JSON {type(value).__name__}", f"a JSON {kind.__name__}")
        return value

    # ---- the file ---------------------------------------------------------------------

    def header(self) -> Sizes:
        """Kind, format version, text datasets, plugins and the stored config."""
        attrs = self.root.attrs
        if attrs.get("kind") not in (KIND, KIND.encode()):
            raise RunFileError(f"{self.path}: not an adaptsky run file (its kind is "
                               f"{attrs.get('kind')!r}, expected '{KIND}')")
        version = self.attr(self.root, "format_version", "int")
        if version > max(SUPPORTED_VERSIONS):
            raise RunFileError(f"{self.path}: format version {version} is newer than this "
                               f"adaptsky ({__version__}) reads ({FORMAT_VERSION}); upgrade")
        if version not in SUPPORTED_VERSIONS:
            self.fail("/@format_version", f"is {version}",
                      " or ".join(map(str, SUPPORTED_VERSIONS)))
        self.attrs(self.root, ROOT_ATTRS)
        self.attrs(self.root, PROVENANCE_ATTRS, optional=True)
        self.text("scenario")
        overrides = self.json_text("overrides", list, optional=True)
        if overrides is not None and not all(isinstance(item, str) for item in overrides):
            self.fail("/overrides", "holds a non-text item", "a JSON list of section.key=value")
        sessions = self.json_text("sessions", list, optional=True)
        if sessions is not None and not all(isinstance(item, dict) for item in sessions):
            self.fail("/sessions", "holds a non-object item", "a JSON list of objects")
        plugins = self.child(self.root, "plugins", GROUP, optional=True)
        if plugins is not None:
            for name in self.members(plugins, MAX_PLUGINS, f"at most {MAX_PLUGINS} plugins"):
                self.attrs(self.child(plugins, name, GROUP),
                           {"package": "str", "version": "str", "target": "str"})
        self.version = version
        return Sizes(self.config(), version)

    def config(self) -> Scenario:
        config = self.json_text("config", dict)
        if self.version == 1 and isinstance(config.get("train"), dict):
            config["train"].setdefault("eval_every", 0)  # format 1 predates the evaluations
        for section in CONFIG_SECTIONS:
            if not isinstance(config.get(section), dict):
                self.fail("/config", f"section '{section}' is missing",
                          "the resolved scenario with every section")
            keys = CONFIG_KEYS.get(section, ())
            if section == "agent":  # an unknown algorithm is parse_scenario's one line
                name = algorithm_tag(config["agent"])
                keys = ALGORITHMS[name].config_keys if name is not None else ()
            for key in keys:
                if key not in config[section]:
                    self.fail("/config", f"{section}.{key} is missing",
                              "the resolved scenario with every key")
        model = config["channel"]["model"]
        try:
            get_model_class(model)
        except PluginError as error:
            raise RunFileError(f"{self.path}: the run's channel model is not usable here "
                               f"({error}); install the plugin named in /plugins/{model}") \
                from None
        try:
            scenario = parse_scenario(config, "")
            controls_of(scenario, 1)  # its actions exist (a dense set fits an int64)
        except (AdaptskyError, ValueError) as error:
            self.fail("/config", str(error).splitlines()[0].removeprefix(": "),
                      "a valid scenario")
        return scenario

    def evaluation_set(self, sizes: Sizes) -> None:
        """/evaluation: the layouts and oracle of the greedy evaluations (format 2, optional)."""
        group = self.child(self.root, "evaluation", GROUP, optional=True)
        if group is None:
            return
        names = [name for name in EVALUATION_SET
                 if self.child(group, f"{name}_oracle_bps", DATASET, optional=True) is not None]
        self.exact_members(group, [f"{name}_{key}" for name in names
                                   for key in ("layouts_m", "oracle_bps")])
        n = sizes.symbols["N"]
        for name in names:
            oracle = self.child(group, f"{name}_oracle_bps", DATASET)
            count = oracle.shape[0] if len(oracle.shape) == 1 else -1
            if not 1 <= count <= 1000:
                self.fail(oracle.name, f"shape {oracle.shape}", "one number per layout")
            self.dataset(group, Field(f"{name}_oracle_bps", "float", ()), {}, (count,))
            self.dataset(group, Field(f"{name}_layouts_m", "float", ()), {}, (count, n, 2))

    def evaluations(self, group: Node, sizes: Sizes, planned: int) -> None:
        """/seeds/<S>/evaluations: equal-length, extendible columns."""
        table = self.child(group, "evaluations", GROUP, optional=self.version == 1)
        if table is None:
            return
        optional = evaluation_fields(self.version)[len(EVALUATIONS):]
        names = [field.name for field in optional]
        self.exact_members(table, [field.name for field in EVALUATIONS], extra_ok=tuple(names))
        present = set(table.keys())
        found = [field for field in optional if field.name in present]
        if found and len(found) < len(optional):
            missing = next(name for name in names if name not in present)
            self.fail(f"{table.name}/{missing}", "missing", "both of " + " and ".join(names)
                      + " or neither")
        fields = EVALUATIONS + tuple(found)
        every = sizes.scenario.train.eval_every
        bound = planned // every if every else 0
        first = self.child(table, fields[0].name, DATASET)
        length = first.shape[0] if len(first.shape) == 1 else -1
        if not 0 <= length <= bound:
            self.fail(first.name, f"shape {first.shape}",
                      f"at most {bound} rows: one per {every} episodes")
        for field in fields:
            rows = self.dataset(table, field, {"V": length})
            if rows.id.get_space().get_simple_extent_dims(True)[0] != h5py.h5s.UNLIMITED:
                self.fail(rows.name, "cannot grow", "a table extendible along its first axis")

    def best(self, checkpoint: Node, sizes: Sizes, done: int) -> None:
        """/seeds/<S>/checkpoint/best: the best policy so far (optional)."""
        best = self.child(checkpoint, "best", GROUP, optional=True)
        if best is None:
            return
        episode = self.attr(best, "episode", "int")
        if not 1 <= episode <= done:
            self.fail(f"{best.name}/@episode", f"is {episode}", f"1 to {done}")
        self.attr(best, "score", "float")
        self.exact_members(best, ("policy",))
        sizes.algorithm.check_policy(self, self.group(best, "policy"), sizes.scenario)

    def seeds(self, sizes: Sizes, needs: Needs) -> None:
        expected = [str(seed) for seed in sizes.scenario.train.seeds]
        seeds = self.child(self.root, "seeds", GROUP)
        for name in expected:
            self.child(seeds, name, GROUP, "a group for every seed of /config "
                       f"train.seeds: {', '.join(expected)}")
        self.exact_members(seeds, expected)
        for name in expected:
            self.seed(self.child(seeds, name, GROUP), int(name), sizes, needs)

    def seed(self, group: Node, seed: int, sizes: Sizes, needs: Needs) -> None:
        attrs = self.attrs(group, SEED_ATTRS)
        done, planned = attrs["episodes_done"], attrs["episodes_planned"]
        if attrs["seed"] != seed:
            self.fail(f"{group.name}/@seed", f"is {attrs['seed']}", str(seed))
        if planned != sizes.scenario.train.episodes:
            self.fail(f"{group.name}/@episodes_planned", f"is {planned}",
                      f"{sizes.scenario.train.episodes}, /config train.episodes")
        if not 0 <= done <= planned:
            self.fail(f"{group.name}/@episodes_done", f"is {done}", f"0 to {planned}")
        episodes = self.child(group, "episodes", GROUP)
        for field in sizes.episodes:
            rows = self.child(episodes, field.name, DATASET,
                              f"a {field.dtype} table, one row per episode")
            length = rows.shape[0] if rows.shape else -1
            if not done <= length <= planned:
                self.fail(rows.name, f"has {length} rows",
                          f"{done} to {planned}: episodes_done to episodes_planned")
            self.dataset(episodes, field, {**sizes.symbols, "E": length})
            if rows.id.get_space().get_simple_extent_dims(True)[0] != h5py.h5s.UNLIMITED:
                self.fail(rows.name, "cannot grow", "a table extendible along its first axis, "
                          "as train writes it (chunked, maxshape None)")
        self.evaluations(group, sizes, planned)
        if needs == "curves":
            return
        checkpoint = self.child(group, "checkpoint", GROUP, optional=True)
        if checkpoint is None:
            if done:
                self.fail(f"{group.name}/checkpoint", f"missing, but episodes_done is {done}",
                          f"the checkpoint of episode {done}")
            return
        self.checkpoint(checkpoint, seed, done, sizes)
        self.trajectory(self.child(group, "trajectory", GROUP), sizes, done)
        every = sizes.scenario.train.trajectory_every
        stored = self.child(group, "trajectories", GROUP, optional=True)
        if stored is not None:
            bound = planned // every if every else 0
            for name in self.members(stored, bound, f"at most {bound} trajectories"):
                if not name.isdigit() or not 1 <= int(name) <= planned:
                    self.fail(f"{stored.name}/{name}", "is not an episode",
                              f"an episode 1 to {planned}")
                self.trajectory(self.child(stored, name, GROUP), sizes, planned)

    def trajectory(self, group: Node, sizes: Sizes, last: int) -> None:
        episode = self.attr(group, "episode", "int")
        if not 1 <= episode <= last:
            self.fail(f"{group.name}/@episode", f"is {episode}", f"1 to {last}")
        self.exact_members(group, [field.name for field in sizes.trajectory])
        for field in sizes.trajectory:
            self.dataset(group, field, sizes.symbols)

    def checkpoint(self, group: Node, seed: int, done: int, sizes: Sizes) -> None:
        attrs = self.attrs(group, CHECKPOINT_ATTRS)
        self.attrs(group, CHECKPOINT_OPTIONAL_ATTRS, optional=True)
        steps = sizes.scenario.train.steps
        for name, value in (("episode", done), ("seed", seed), ("global_step", done * steps)):
            if attrs[name] != value:
                self.fail(f"{group.name}/@{name}", f"is {attrs[name]}", f"{value}")
        algorithm = sizes.algorithm
        self.exact_members(group, (*algorithm.checkpoint_members, "rng"), extra_ok=("best",))
        self.best(group, sizes, done)
        algorithm.check_checkpoint(self, group, sizes.scenario, done)
        self.attrs(self.child(group, "rng", GROUP), RNG_ATTRS)


def validate_run(file: h5py.File, path: Path, needs: Needs = "all") -> Scenario:
    """Check ``file`` against the layout; the stored scenario. ``needs="curves"`` leaves out
    the checkpoints and trajectories (for readers of the learning curves only)."""
    validator = Validator(file, path)
    sizes = validator.header()
    validator.evaluation_set(sizes)
    validator.seeds(sizes, needs)
    return sizes.scenario


def require_finite(path: Path, where: str, values: np.ndarray, allow_nan: bool = False) -> None:
    """Refuse NaN or infinite numbers in float ``values`` read from ``where``."""
    if values.dtype.kind != "f":
        return
    bad = np.isinf(values) if allow_nan else ~np.isfinite(values)
    count = int(np.count_nonzero(bad))
    if count:
        what = "infinite" if allow_nan else "NaN or infinite"
        raise RunFileError(f"{path}: damaged run file: {where}: {count} value"
                           f"{'s are' if count > 1 else ' is'} {what} (expected finite "
                           "numbers)")
