"""Do two versions of adaptsky compute the same numbers? A fixed set of small trainings,
inspections, evaluations and one reproduction, run with the code of a git revision and with
the working tree, compared bit for bit (every array of every run and eval file, the JSON that
inspect and eval print, the CSV and figure data of reproduce).

    .venv/bin/python scripts/same_numbers.py [REV] [--wide] [--all]     (default REV: HEAD)

``--wide`` adds three and four UAVs, two UAVs on sub-6, the energy term on for one and two
UAVs, moving users (with and without fading), a city of one and of two UAVs, two moving UAVs,
evaluations against the oracle, best response, OMA, tracking, the per-step oracles (best
response at every step for two moving UAVs) and the static ceiling under fading, and a small
``reproduce e4`` (an hour or more); ``--all`` lists every difference, not the first 40;
``--parallel`` runs the revision and the working tree at once (one process each).

Both run in this environment on this machine; the revision's code is checked out into a
temporary worktree and put first on PYTHONPATH (with its built-in channel models). Prints one
line per compared output and a summary; exits 1 at the first difference it lists (a name a
newer version adds, listed in ADDED_NAMES, is compared only where both have it). Meant for
changes that restructure: they must not change a number (floats are only comparable bit for
bit on one machine, so this compares two versions here rather than a stored fingerprint).
"""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RUN = ["--seeds", "0,1", "--episodes", "4", "--steps", "30", "--checkpoint-every", "2",
       "--workers", "1", "--quiet"]
# (name, scenario, --set overrides): the paper's agent, the tuned preset, sampled LoS, fresh
# layouts, the plain DQN, the BDQ of two UAVs
TRAININGS = [
    ("paper", "nyc_mmwave.toml", []),
    ("tuned", "nyc_mmwave_tuned.toml", []),
    ("sampled-los", "sub6_al_hourani.toml", ["channel.los=sampled"]),
    ("fresh-layouts", "nyc_mmwave_any_layout.toml", ["train.eval_layouts=2"]),
    ("plain-dqn", "nyc_mmwave.toml", ["agent.dueling=false"]),
    ("two-uavs", "two_uavs_mmwave.toml", ["train.eval_every=0"]),
]
# --wide: more scenarios, every baseline, E4
WIDE_TRAININGS = [
    ("three-uavs", "three_uavs_mmwave.toml", ["train.eval_every=0"]),
    ("four-uavs", "four_uavs_mmwave.toml", ["train.eval_every=0"]),
    ("two-uavs-sub6", "two_uavs_sub6.toml", ["train.eval_every=0"]),
    ("energy", "nyc_mmwave.toml", ["reward.w_energy=10"]),
    ("two-uavs-energy", "two_uavs_mmwave.toml", ["reward.w_energy=10", "train.eval_every=0"]),
    ("moving", "moving_users_sub6.toml", []),
    ("moving-fading", "moving_users_fading_sub6.toml", []),
    ("city", "city_sub6.toml", []),
    ("city-two-uavs", "city_two_uavs_mmwave.toml", ["train.eval_every=0"]),
    ("two-uavs-moving", "two_uavs_moving_mmwave.toml", ["train.eval_every=0"]),
]
# runs evaluated on their scenario's own layout, not on uniform ones (users that move: the
# uniform layouts of an evaluation keep their mobility since issue 53, a fix)
OWN_LAYOUT = {"moving", "moving-fading", "two-uavs-moving"}
# (run, baselines, --set of the evaluation, steps): every baseline where the run's scenario
# has it
WIDE_EVALS = [
    ("paper", "soa,oracle,oma", [], 30),
    ("sampled-los", "oracle", ["channel.los=expected"], 30),
    ("two-uavs", "best-response,oma", [], 30),
    ("three-uavs", "soa,best-response,oma", [], 30),
    ("four-uavs", "soa,best-response,oma", [], 30),
    ("two-uavs-sub6", "soa,best-response,oma", [], 30),
    ("two-uavs-energy", "soa,best-response,oma", [], 30),
    ("moving", "oracle,tracking,soa", [], 30),          # the per-step oracle
    ("moving-fading", "oracle,tracking", [], 30),       # the per-step oracle under fading
    ("city", "oracle,soa,oma", [], 30),                 # the static ceiling under fading
    ("city-two-uavs", "best-response,oma", [], 30),
    ("two-uavs-moving", "best-response,tracking", [], 10),  # best response at every step
]
CODE = ("import sys; from adaptsky_cli.cli.main import main; sys.exit(main(sys.argv[1:]))")


def run(tree: Path, out: Path, *args: str) -> str:
    """One adaptsky command with the code of ``tree`` (searches cached in ``out``'s own
    cache, never a cache the other side filled); its stdout."""
    path = [str(tree), str(tree / "plugins" / "builtin")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path), "COLUMNS": "200",
           "ADAPTSKY_CACHE_DIR": str(out.parent / f"{out.name}-cache")}
    done = subprocess.run([sys.executable, "-c", CODE, *args], capture_output=True, text=True,
                          cwd=out, env=env, check=False)
    if done.returncode != 0:
        sys.exit(f"{tree}: adaptsky {' '.join(args)} failed: {done.stderr.strip()}")
    return done.stdout


def outputs(tree: Path, out: Path, wide: bool = False) -> dict[str, str]:
    """Run the fixed set (``wide``: the wide one) with ``tree``'s code in ``out``; the printed
    JSON by name."""
    printed = {}
    for name, scenario, overrides in TRAININGS + (WIDE_TRAININGS if wide else []):
        sets = [word for item in overrides for word in ("--set", item)]
        run(tree, out, "train", str(ROOT / "scenarios" / scenario), *RUN, *sets,
            "--out", f"{name}.h5")
        printed[f"inspect {name}"] = run(tree, out, "inspect", f"{name}.h5", "--json")
        layouts = [] if name in OWN_LAYOUT else ["--layouts", "2"]
        printed[f"eval {name}"] = run(tree, out, "eval", "--checkpoint", f"{name}.h5",
                                      "--steps", "50", *layouts,
                                      "--compare", "soa,random", "--out", f"{name}-eval.h5",
                                      "--json")
    run(tree, out, "reproduce", "e1a", *two_runs(tree), "--episodes", "3", "--steps", "20",
        "--workers", "1", "--out", "e1a", "--quiet")
    if wide:
        for name, baselines, overrides, steps in WIDE_EVALS:
            sets = [word for item in overrides for word in ("--set", item)]
            label = f"eval {name} {baselines}"
            layouts = [] if name in OWN_LAYOUT else ["--layouts", "1"]
            printed[label] = run(tree, out, "eval", "--checkpoint", f"{name}.h5", "--steps",
                                 str(steps), *layouts, "--compare", baselines, *sets,
                                 "--out", f"{name}-{baselines.replace(',', '-')}-eval.h5",
                                 "--json")
        run(tree, out, "reproduce", "e4", *two_runs(tree), "--episodes", "2", "--steps",
            "20", "--workers", "1", "--out", "e4", "--quiet")
    return printed


def two_runs(tree: Path) -> list[str]:
    """Two runs of every group: ``--runs 2`` since it exists, ``--seeds 2`` (then a count)
    in older trees."""
    command = (tree / "adaptsky_cli" / "cli" / "reproduce_cmd.py").read_text()
    has_runs = re.search(r"^\s+runs: Annotated", command, re.MULTILINE) is not None
    return ["--runs", "2"] if has_runs else ["--seeds", "2"]


def arrays(path: Path) -> dict[str, np.ndarray]:
    """Every dataset and attribute of an HDF5 file (times and versions left out)."""
    found: dict[str, np.ndarray] = {}
    skip = {"created_utc", "sessions", "command_line", "adaptsky_version", "platform",
            "python_version", "torch_version", "numpy_version", "h5py_version",
            "wall_time_s", "format_version", "seconds_per_layout", "seconds_per_step",
            "crc32"}  # a dataset's checksum (store.checksums): its data is compared

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Dataset) and name.rsplit("/", 1)[-1] not in skip:
            found[name] = np.asarray(item[()])
        for key, value in item.attrs.items():
            if key not in skip:
                found[f"{name}@{key}"] = np.asarray(value)

    with h5py.File(path, "r") as file:
        visit("/", file)
        file.visititems(visit)
    return found


def same(a: np.ndarray, b: np.ndarray, a_dir: Path, b_dir: Path) -> bool:
    """Equal bit for bit; text equal once each side's output folder is named alike."""
    if a.dtype.kind in "fc" and b.dtype.kind in "fc":
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    if a.dtype.kind in "OSU" and a.shape == b.shape == ():
        old = _text(a.item(), a_dir)
        return old == without_added(old, _text(b.item(), b_dir))
    return a.shape == b.shape and bool(np.all(a == b))


def _text(value: object, folder: Path) -> object:
    """Text as compared: JSON or TOML (a written scenario) as the data it holds, without
    times and added defaults, the output folder named alike."""
    text = value.decode() if isinstance(value, bytes) else value
    if not isinstance(text, str):
        return text
    text = text.replace(str(folder), "OUT")
    for parse in (json.loads, tomllib.loads):
        try:
            return without_times(parse(text))
        except ValueError:
            pass
    return text


# keys that a newer adaptsky writes into a stored scenario with the value every older file
# means (they hold no number): [agent] algorithm, "dqn" by default since it exists
ADDED_DEFAULTS = {"algorithm": "dqn"}
# the same, for keys whose names other tables use too: (table, key) -> the default. Several
# UAVs (issue 23, docs/model.md §9): at these values a scenario has one UAV, as before
ADDED_SECTION_DEFAULTS = {("uav", "count"): 1, ("uav", "start_positions_m"): None,
                          ("uav", "min_separation_m"): 10.0, ("users", "association"): "kmeans",
                          ("users", "uav"): None, ("radio", "reuse"): "full",
                          # the energy (docs/model.md §10) and the BDQ's reward per UAV
                          ("uav", "step_s"): 1.0, ("reward", "w_energy"): 0.0,
                          ("agent", "reward_split"): "team",
                          # exploring starts (docs/training.md)
                          ("train", "exploring_starts"): "none",
                          # what a cluster's action component does (continuous actions)
                          ("uav", "power"): "change",
                          # imperfect SIC (docs/model.md §13): 0, perfect, as before
                          ("radio", "sic_residual"): 0.0,
                          # buildings (docs/model.md §12): none
                          ("world", "buildings"): "none", ("world", "city"): None,
                          ("world", "built_up_ratio"): None,
                          ("world", "buildings_per_km2"): None,
                          ("world", "height_scale_m"): None, ("world", "seed"): 0,
                          ("world", "building"): [],
                          # the built-in small-scale fading (docs/model.md §11), off (its
                          # unset keys, null in JSON, left out)
                          ("channel", "fading"): {"model": "none"},
                          # users that move by a model (docs/model.md §3): static
                          ("users", "mobility"): {"model": "static"},
                          ("users", "hotspots"): None, ("users", "spread_m"): None,
                          ("users", "reassociate_every_s"): None,
                          # the service metrics' outage threshold (docs/model.md §14)
                          ("metrics", "outage_se"): 1.0,
                          # NOMA clusters of M users (docs/model.md §15): pairs; perfect
                          # channel knowledge (§16); the downlink (§17)
                          ("users", "cluster_size"): 2, ("channel", "csi"): {"model": "perfect"},
                          ("radio", "direction"): "downlink", ("users", "tx_power_dbm"): None,
                          # observations of the world (docs/environment.md): none
                          ("agent", "observe"): [], ("agent", "raster_cells"): 5,
                          ("agent", "raster_cell_m"): 10.0,
                          # the networks read the whole observation (docs/agent.md)
                          ("agent", "network"): "mlp", ("agent", "set_sizes"): [64]}
# tables a newer adaptsky adds: left out where every key in them is at its default
ADDED_TABLES = {"world", "metrics"}
# names a newer adaptsky adds beside the numbers it had (JSON keys, HDF5 datasets with their
# attributes): compared where both sides have them, left out where only the newer one does.
# Each user's steady-state rate of eval (steady_user_rate_bps) and last-episode rate of
# inspect (last_episode_user_rate_bps); the energy of docs/model.md §10 (the run file's
# format rose to 3 with it: the format version is left out, it is no number of a run)
ADDED_NAMES = {"steady_user_rate_bps", "last_episode_user_rate_bps", "energy_j",
               "energy_efficiency_bpj", "steady_power_w", "steady_energy_efficiency_bpj",
               "steady_still_share", "steady_vertical_share", "uav_energy_j",
               # the service metrics of every evaluation (docs/model.md §14)
               "outage_share", "mean_least_rate_bps", "p5_rate_bps",
               # run-file format 4: every user's position in the trajectories
               "users_m",
               # format 4: the tracking baseline beside the greedy evaluations of moving users
               "tracking_bps", "heldout_tracking_bps",
               # format 5: the policy's entropy (NaN for the Q-learners)
               "entropy"}


def without_added(old: object, new: object) -> object:
    """``new`` without the :data:`ADDED_NAMES` keys that ``old`` lacks (in dicts at the same
    place of both)."""
    if isinstance(old, dict) and isinstance(new, dict):
        return {k: without_added(old[k], v) if k in old else v for k, v in new.items()
                if k in old or k not in ADDED_NAMES}
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [without_added(a, b) for a, b in zip(old, new, strict=True)]
    return new


def _added(key: str) -> bool:
    """Whether an HDF5 name (``path/name`` or ``path/name@attribute``) is an added one."""
    return key.split("@")[0].rsplit("/", 1)[-1] in ADDED_NAMES


def without_times(value: object, table: str = "") -> object:
    """JSON without the keys that hold a wall time or a moment, and without the
    :data:`ADDED_DEFAULTS` and :data:`ADDED_SECTION_DEFAULTS` (in their ``table``, the key
    of the enclosing dict) at their default."""
    if isinstance(value, str) and "\n[" in value:  # TOML text inside JSON
        try:
            return without_times(tomllib.loads(value))
        except ValueError:
            return value
    if isinstance(value, dict):
        kept = {k: without_times(v, k) for k, v in value.items()
                if "wall" not in k and "seconds" not in k and k != "format_version"
                and k not in {"created_utc", "started_utc"}
                and not (k in ADDED_DEFAULTS and v == ADDED_DEFAULTS[k])
                and not ((table, k) in ADDED_SECTION_DEFAULTS
                         and _without_none(v) == ADDED_SECTION_DEFAULTS[table, k])}
        return {k: v for k, v in kept.items() if not (k in ADDED_TABLES and v == {})}
    if isinstance(value, list):
        return [without_times(v) for v in value]
    return value


def _without_none(value: object) -> object:
    """``value`` without the None entries of its dicts (JSON keeps the unset keys of a
    table, as null, that TOML leaves out)."""
    if isinstance(value, dict):
        return {k: _without_none(v) for k, v in value.items() if v is not None}
    return value


def relative_difference(a: np.ndarray | None, b: np.ndarray | None) -> str:
    """`` (largest relative difference ...)`` of two float arrays of one shape, else ''."""
    if a is None or b is None or a.shape != b.shape or a.dtype.kind != "f" or (
            b.dtype.kind != "f"):
        return ""
    scale = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(invalid="ignore", divide="ignore"):
        relative = np.where(scale > 0, np.abs(a - b) / scale, 0.0)
    return f" (largest relative difference {np.nanmax(relative):.1e})"


def _csv_rows(text: str, old_header: list[str] | None = None) -> list[list[str]]:
    """A CSV's rows, without the :data:`ADDED_NAMES` columns that ``old_header`` lacks."""
    rows = list(csv.reader(text.splitlines()))
    if old_header is None or not rows:
        return rows
    kept = [i for i, name in enumerate(rows[0]) if name in old_header or name not in ADDED_NAMES]
    return [[row[i] for i in kept] for row in rows]


def compare(old: Path, new: Path, printed_old: dict[str, str],
            printed_new: dict[str, str]) -> list[str]:
    differences, compared = [], 0
    for name in printed_old:
        compared += 1
        before = _text(printed_old[name], old)
        if before != without_added(before, _text(printed_new[name], new)):
            differences.append(f"{name}: the printed JSON differs")
    for path in sorted(old.rglob("*.h5")):
        other = new / path.relative_to(old)
        a, b = arrays(path), arrays(other)
        for key in sorted(set(a) | set(b)):
            if key not in a and _added(key):
                continue
            compared += 1
            if key not in a or key not in b or not same(a[key], b[key], old, new):
                differences.append(f"{path.relative_to(old)}: {key} differs"
                                   + relative_difference(a.get(key), b.get(key)))
    for path in sorted(old.rglob("*.csv")):
        compared += 1
        if _csv_rows(path.read_text()) != _csv_rows((new / path.relative_to(old)).read_text(),
                                                    _csv_rows(path.read_text())[0]):
            differences.append(f"{path.relative_to(old)} differs")
    print(f"compared {compared} outputs")
    return differences


def main() -> int:
    if {"-h", "--help"} & set(sys.argv[1:]):
        print(__doc__)
        return 0
    wide = "--wide" in sys.argv[1:]
    positional = [arg for arg in sys.argv[1:] if arg not in ("--wide", "--all", "--parallel")]
    rev = positional[0] if positional else "HEAD"
    with tempfile.TemporaryDirectory() as scratch:
        base = Path(scratch)
        tree = base / "tree"
        subprocess.run(["git", "worktree", "add", "-q", "--detach", str(tree), rev],
                       cwd=ROOT, check=True)
        try:
            for side in ("old", "new"):
                (base / side).mkdir()
            jobs = 2 if "--parallel" in sys.argv[1:] else 1
            with ThreadPoolExecutor(jobs) as pool:
                old_side = pool.submit(outputs, tree, base / "old", wide)
                new_side = pool.submit(outputs, ROOT, base / "new", wide)
                printed_old, printed_new = old_side.result(), new_side.result()
            differences = compare(base / "old", base / "new", printed_old, printed_new)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           check=True)
    for line in differences if "--all" in sys.argv[1:] else differences[:40]:
        print(line)
    print(f"{rev} and the working tree: " + ("the same numbers, bit for bit" if not differences
                                             else f"{len(differences)} differences"))
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
