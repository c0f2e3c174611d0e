"""One simulator against two (issue 36): the code of git revision REV and the working tree,
side by side in one run, with PASS / FAIL against the issue's thresholds.

(a) Environment steps per second of one UAV (scenarios/nyc_mmwave.toml) at B = 1024 batched
    environments: new >= 0.95 x old.
(b) A training step: seed-steps per second of a stack of ``--seeds`` seeds of
    scenarios/nyc_mmwave.toml (the paper's DQN), whole episodes after a warm-up, so that every
    timed step makes an update (as benchmarks/train_throughput.py): new >= 0.95 x old, the
    5% allowing for noise (HEAD against itself shows how much there is).
(c) Links stepped per second (B x U x N) at B = 256: eight UAVs x 64 users
    (scenarios/eight_uavs_mmwave.toml) at least those of one UAV x 4 users
    (scenarios/one_uav_200m_mmwave.toml), both on the new code; the old code's are printed
    beside (a revision that refuses eight UAVs says so in its column).

    .venv/bin/python benchmarks/one_simulator.py [REV] [--seconds 2] [--rounds 3]
        [--seeds 4] [--steps 300] [--items a,b,c]

REV (default HEAD) is checked out into a temporary git worktree. Each side runs in a process
of its own, this file with ``--serve`` and its tree first on PYTHONPATH (with its built-in
channel models), as scripts/same_numbers.py runs a revision; both read the working tree's
scenario files, which REV may lack. The environments are built through
``adaptsky.sim.multi_batch.network_batch`` and the stacks through
``adaptsky.training.stack_run.StackRun``, which both revisions have. The two sides' timed
blocks alternate (old, new, new, old, ...), so that drift in the machine's speed (it may be
shared) and going first hit both alike; every figure is the best of ``--rounds`` blocks (3)
of the side's CPU time (``time.process_time``, one torch and BLAS thread). Beside each
new/old it prints the spread of the blocks (1 - slowest / fastest, the larger side's): a
quotient off 1 by about that much may be the machine, not the code. Prints the load average
before and after; exits 1 where a verdict is FAIL. A script, not a
test: no time is asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

# the step benchmarks' shared pieces, beside this file (also when a test loads it by path)
sys.path.insert(0, str(Path(__file__).resolve().parent))
from stepping import pin_one_thread, random_steps

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
ONE_UAV = SCENARIOS / "nyc_mmwave.toml"              # (a) and (b)
FEW_LINKS = SCENARIOS / "one_uav_200m_mmwave.toml"   # (c): 1 UAV x 4 users
MANY_LINKS = SCENARIOS / "eight_uavs_mmwave.toml"    # (c): 8 UAVs x 64 users
ENV_ENVS = 1024      # B of (a)
LINK_ENVS = 256      # B of (c)
SPEED_THRESHOLD = 0.95   # (a) and (b): new over old
LINK_THRESHOLD = 1.0     # (c): links/s of 8 x 64 over those of 1 x 4, new code
ERROR_WIDTH = 64         # characters of a side's error shown in the table
ONE_THREAD = {var: "1" for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


# ---- one side: the measurements, in the process whose tree is first on PYTHONPATH ----------

def endless(path: str | Path, steps: int = 10**9) -> Any:
    """The scenario at ``path`` with ``steps`` steps per episode (by default a time limit
    that never ends a benchmark episode)."""
    from adaptsky.scenario import load_scenario

    scenario = load_scenario(path)
    return scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"steps": steps})})


@dataclass
class Stepping:
    """``num_envs`` environments of a scenario (per-environment seeds, as training makes
    them) and random dense actions; ``steps_per_block`` steps fill about ``seconds``."""

    step: Callable[[int], None]
    links_per_env: int      # U x N
    steps_per_s: float      # the calibration's batched steps per CPU second


def stepping(path: str | Path, num_envs: int) -> Stepping:
    """Environments of the scenario at ``path``, warmed up and calibrated."""
    import numpy as np

    from adaptsky.sim.multi_batch import network_batch

    scenario = endless(path)
    with warnings.catch_warnings():  # network_batch is a deprecated alias once merged
        warnings.simplefilter("ignore", DeprecationWarning)
        env = network_batch(scenario, num_envs,
                            seed=[np.random.SeedSequence([s, 0]) for s in range(num_envs)])
    step, steps_per_s = random_steps(env, num_envs)
    return Stepping(step, scenario.uav.count * scenario.num_users, steps_per_s)


def env_block(stepper: Stepping, seconds: float) -> float:
    """Batched steps per CPU second over one block of about ``seconds``."""
    count = max(1, round(stepper.steps_per_s * seconds))
    start = time.process_time()
    stepper.step(count)
    return count / (time.process_time() - start)


def training(path: str | Path, seeds: int, steps: int) -> Any:
    """A stack of ``seeds`` seeds of the scenario at ``path`` (``steps`` steps per episode)
    on this CPU thread whose memories hold a batch, so every timed step makes an update."""
    import torch

    from adaptsky.training.stack_run import Member, StackRun

    scenario = endless(path, steps)
    run = StackRun([Member(scenario, seed) for seed in range(seeds)], torch.device("cpu"))
    while run.algorithm.memory.size < scenario.agent.batch_size + 1 or run.episodes_done < 1:
        run.run_episode()
    return run


def train_block(run: Any) -> float:
    """Seed-steps per CPU second of one whole episode of the stack ``run``."""
    start = time.process_time()
    run.run_episode()
    return len(run.members) * run.scenario.train.steps / (time.process_time() - start)


class Side:
    """The measurements of one side, answering one timed block per request; environments
    and stacks are built (warmed, calibrated) at their first request and kept."""

    def __init__(self) -> None:
        self._built: dict[str, Any] = {}

    def block(self, request: dict[str, Any]) -> dict[str, Any]:
        """``{"kind": "env", "scenario", "num_envs", "seconds"}``: batched steps per second
        and U x N; ``{"kind": "train", "scenario", "seeds", "steps"}``: seed-steps per
        second."""
        key = json.dumps({k: v for k, v in request.items() if k != "seconds"}, sort_keys=True)
        if request["kind"] == "env":
            if key not in self._built:
                self._built[key] = stepping(request["scenario"], request["num_envs"])
            stepper = self._built[key]
            return {"rate": env_block(stepper, request["seconds"]),
                    "links_per_env": stepper.links_per_env}
        if key not in self._built:
            self._built[key] = training(request["scenario"], request["seeds"],
                                        request["steps"])
        return {"rate": train_block(self._built[key])}


def serve(requests: IO[str], replies: IO[str]) -> None:
    """Answer JSON requests, one a line: first where adaptsky came from, then a timed block
    per request, or the one-line error of a side that cannot run it."""
    pin_one_thread()
    import torch

    import adaptsky

    version = getattr(adaptsky, "__version__", "?")
    replies.write(json.dumps({"adaptsky": str(Path(adaptsky.__file__).resolve().parent),
                              "version": version, "torch": torch.__version__,
                              "threads": torch.get_num_threads()}) + "\n")
    replies.flush()
    side = Side()
    for line in requests:
        request = json.loads(line)
        try:
            reply = side.block(request)
        except Exception as error:
            text = (str(error).strip().splitlines() or [""])[0]
            text = text.replace(request["scenario"], Path(request["scenario"]).name)
            reply = {"error": f"{type(error).__name__}: {text}"}
        replies.write(json.dumps(reply) + "\n")
        replies.flush()


# ---- the parent: two sides, alternated blocks, the table -------------------------------------

class Remote:
    """A side in a process of its own with ``tree`` first on PYTHONPATH."""

    def __init__(self, tree: Path) -> None:
        path = [str(tree), str(tree / "plugins" / "builtin")]
        env = {**os.environ, **ONE_THREAD, "PYTHONPATH": os.pathsep.join(path)}
        self.process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--serve"], cwd=tree, env=env,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.hello = self._reply()
        found = Path(self.hello["adaptsky"])
        if not found.is_relative_to(tree.resolve()):
            self.close()
            sys.exit(f"{tree}: its process imported adaptsky from {found}, not from the tree")

    def _reply(self) -> dict[str, Any]:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        if not line:
            sys.exit(f"a side's process ended (exit code {self.process.wait()})")
        return json.loads(line)

    def block(self, request: dict[str, Any]) -> dict[str, Any]:
        assert self.process.stdin is not None
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        return self._reply()

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        self.process.wait(timeout=60)


@dataclass
class Figure:
    """The best of a side's blocks of one item (``rate`` None with ``error`` where the side
    could not run it), and every block's rate."""

    rate: float | None = None
    links_per_env: int = 0
    error: str = ""
    rates: list[float] = field(default_factory=list)

    def add(self, reply: dict[str, Any]) -> None:
        if "error" in reply:
            self.error = reply["error"]
            return
        self.rates.append(reply["rate"])
        if self.rate is None or reply["rate"] > self.rate:
            self.rate, self.links_per_env = reply["rate"], reply.get("links_per_env", 0)

    @property
    def spread(self) -> float:
        """1 - slowest / fastest block: how much the machine's speed moved meanwhile."""
        return 1.0 - min(self.rates) / max(self.rates) if self.rates else 0.0


def alternated(sides: list[Remote], request: dict[str, Any], rounds: int) -> list[Figure]:
    """The best of ``rounds`` blocks of ``request`` per side, the sides alternated and each
    round in the other order (old, new, new, old, ...)."""
    figures = [Figure() for _ in sides]
    for round_index in range(rounds):
        order = range(len(sides)) if round_index % 2 == 0 else reversed(range(len(sides)))
        for index in order:
            if not figures[index].error:
                figures[index].add(sides[index].block(request))
    return figures


def ratio_cell(ratio: float | None, figures: list[Figure]) -> str:
    """new/old, with the larger of the two sides' block spreads beside it."""
    if ratio is None:
        return "-"
    return f"{ratio:.3f} (spread {max(f.spread for f in figures):.0%})"


def verdict(ratio: float | None, threshold: float) -> str:
    return "n/a" if ratio is None else "PASS" if ratio >= threshold else "FAIL"


def quotient(new: float | None, old: float | None) -> float | None:
    return None if new is None or old is None else new / old


Row = tuple[str, str, str, str, str, str, str]
"""A row of the table: item, measure, old, new, new/old, threshold, verdict."""


def shown(value: float | None, error: str = "") -> str:
    """A figure with thousands separators, or why there is none."""
    if value is None:
        short = error if len(error) <= ERROR_WIDTH else error[:ERROR_WIDTH - 3] + "..."
        return f"n/a ({short})" if error else "n/a"
    return f"{value:,.0f}"


def measure(sides: list[Remote], seconds: float, seeds: int, steps: int, rounds: int,
            items: str = "abc") -> list[Row]:
    """The table's rows for ``items`` (of "a", "b", "c"): item, measure, old, new, new/old,
    threshold, verdict."""
    rows: list[Row] = []
    env = {"kind": "env", "seconds": seconds}
    if "a" in items:
        rows.append(speed_row(sides, env, rounds))
    if "b" in items:
        rows.append(training_row(sides, seeds, steps, rounds))
    if "c" in items:
        rows.extend(link_rows(sides, env, rounds))
    return rows


def speed_row(sides: list[Remote], env: dict[str, Any], rounds: int
              ) -> Row:
    """(a): environment steps per second of one UAV at B = ENV_ENVS."""
    old, new = alternated(sides, {**env, "scenario": str(ONE_UAV), "num_envs": ENV_ENVS}, rounds)
    steps_old, steps_new = (None if f.rate is None else f.rate * ENV_ENVS for f in (old, new))
    ratio = quotient(steps_new, steps_old)
    return ("(a)", f"env steps/s, {ONE_UAV.name}, B = {ENV_ENVS}",
            shown(steps_old, old.error), shown(steps_new, new.error),
            ratio_cell(ratio, [old, new]), f">= {SPEED_THRESHOLD:g}",
            verdict(ratio, SPEED_THRESHOLD))


def training_row(sides: list[Remote], seeds: int, steps: int, rounds: int) -> Row:
    """(b): seed-steps per second of a stack of ``seeds`` seeds of one UAV, whole episodes
    of ``steps`` steps."""
    request = {"kind": "train", "scenario": str(ONE_UAV), "seeds": seeds, "steps": steps}
    old, new = alternated(sides, request, rounds)
    ratio = quotient(new.rate, old.rate)
    return ("(b)", f"seed-steps/s, {seeds} seeds x {steps} steps, {ONE_UAV.name}",
            shown(old.rate, old.error), shown(new.rate, new.error),
            ratio_cell(ratio, [old, new]), f">= {SPEED_THRESHOLD:g}",
            verdict(ratio, SPEED_THRESHOLD))


def link_rows(sides: list[Remote], env: dict[str, Any], rounds: int
              ) -> list[Row]:
    """(c): links per second of FEW_LINKS and MANY_LINKS at B = LINK_ENVS on both sides,
    and the verdict on the new side's quotient."""
    rows = []
    links: list[list[float | None]] = []
    for path in (FEW_LINKS, MANY_LINKS):
        figures = alternated(sides, {**env, "scenario": str(path), "num_envs": LINK_ENVS},
                             rounds)
        per_side = [None if f.rate is None else f.rate * LINK_ENVS * f.links_per_env
                    for f in figures]
        links.append(per_side)
        uavs, users = size(path)
        ratio = quotient(per_side[1], per_side[0])
        rows.append(("(c)", f"links/s, U x N = {uavs} x {users}, {path.stem}, B = {LINK_ENVS}",
                     shown(per_side[0], figures[0].error), shown(per_side[1], figures[1].error),
                     ratio_cell(ratio, figures), "", ""))
    scale = [quotient(links[1][side], links[0][side]) for side in (0, 1)]
    (few_u, few_n), (many_u, many_n) = size(FEW_LINKS), size(MANY_LINKS)
    rows.append(("(c)", f"links/s of {many_u} x {many_n} over {few_u} x {few_n}, each side's "
                 "code",
                 "-" if scale[0] is None else f"{scale[0]:.2f}",
                 "-" if scale[1] is None else f"{scale[1]:.2f}", "",
                 f">= {LINK_THRESHOLD:g} (new)", verdict(scale[1], LINK_THRESHOLD)))
    return rows


def size(path: Path) -> tuple[int, int]:
    """U and N of the scenario file at ``path`` (read as TOML: the parent imports no
    adaptsky)."""
    import tomllib

    data = tomllib.loads(path.read_text())
    users = data.get("users", {})
    count = len(users["positions_m"]) if "positions_m" in users else int(users.get("count", 4))
    return int(data.get("uav", {}).get("count", 1)), count


def load_line() -> str:
    one, five, fifteen = os.getloadavg()
    return f"{one:.2f}, {five:.2f}, {fifteen:.2f} ({os.cpu_count()} CPUs)"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", nargs="?", default="HEAD", help="git revision (old side)")
    parser.add_argument("--seconds", type=float, default=2.0,
                        help="CPU seconds of each timed block of stepping")
    parser.add_argument("--rounds", type=int, default=3, help="timed blocks per side, best kept")
    parser.add_argument("--seeds", type=int, default=4, help="seeds in the stack of (b)")
    parser.add_argument("--steps", type=int, default=300, help="steps per episode of (b)")
    parser.add_argument("--items", default="a,b,c", help="which of a, b, c to measure")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve:
        replies = os.fdopen(os.dup(sys.stdout.fileno()), "w")
        sys.stdout = sys.stderr  # nothing the code prints can garble the replies
        serve(sys.stdin, replies)
        return 0
    from rich.console import Console
    from rich.table import Table

    rev = subprocess.run(["git", "rev-parse", "--short", args.rev], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                           check=True, capture_output=True, text=True).stdout.strip()
    print(f"load average before: {load_line()}")
    with tempfile.TemporaryDirectory() as scratch:
        tree = Path(scratch) / "tree"
        subprocess.run(["git", "worktree", "add", "-q", "--detach", str(tree), rev], cwd=ROOT,
                       check=True)
        sides: list[Remote] = []
        try:
            sides.append(Remote(tree))
            sides.append(Remote(ROOT))
            rows = measure(sides, args.seconds, args.seeds, args.steps, args.rounds,
                           args.items)
        finally:
            for side in sides:
                side.close()
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           check=True)
    new_label = "working tree" + (" (uncommitted changes)" if dirty else "")
    hello = sides[1].hello
    old_label = rev if args.rev.startswith(rev) else f"{args.rev} ({rev})"
    table = Table("item", "measure", f"old: {old_label}", f"new: {new_label}",
                  "new/old (spread of blocks)",
                  "threshold", "verdict",
                  title=f"one simulator: {old_label} against the working tree; best of "
                        f"{args.rounds} alternated blocks, CPU time, torch {hello['torch']}, "
                        f"{hello['threads']} thread")
    for row in rows:
        table.add_row(*row)
    Console(width=160).print(table)
    print(f"load average after: {load_line()}")
    return 1 if any(row[-1] == "FAIL" for row in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
