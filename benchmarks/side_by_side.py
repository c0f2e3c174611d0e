"""This tree against another checkout (the commit before a change), side by side in one run:
training throughput of the dueling DQN, PPO and SAC, the simulator's steps, best response of
four UAVs and the per-step oracle (issue 53's bars of speed).

Each measurement is a child process that imports one tree's ``adaptsky`` (``PYTHONPATH`` the
other checkout and its built-in plugins, or nothing for this tree), on one thread, and prints
its units per CPU second (the process's CPU time: on a shared machine, time spent waiting for
a core is not the code's): a learner trains one seed until every timed step learns, then
whole episodes are timed (environment step, action, replay or rollout, updates; the median
episode's steps); ``env`` steps 64 environments of nyc_mmwave with random actions;
``best-response`` searches four_uavs_mmwave.toml's layout (on a lattice of ``--search-step-m``,
default 4 m: the same search, minutes less); ``per-step-oracle`` searches 10 steps of
moving_users_sub6.toml. Every round runs the two trees' children at once, so that the
machine's load hits both alike; the ratio is this tree's median over the other's (>= 1: not
slower).

    .venv/bin/python benchmarks/side_by_side.py --base /tmp/base67 [--rounds 5] [--what dqn,env]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "scenarios/nyc_mmwave.toml"
LEARNERS = {
    "dqn": ["agent.algorithm=dqn", "agent.dueling=true"],
    "ppo": ["agent.algorithm=ppo"],
    "sac": ["agent.algorithm=sac", "uav.actions=continuous", "agent.learning_starts=64",
            "agent.batch_size=64"],
}

WHAT = (*LEARNERS, "env", "best-response", "per-step-oracle")
UNITS = {"env": "env steps", "best-response": "searches", "per-step-oracle": "steps"}


def child(name: str, steps: int, episodes: int, search_step_m: float) -> None:
    """One tree's units per CPU second of ``name``."""
    from adaptsky.training.host import pin_threads

    pin_threads()
    measure = (_learner if name in LEARNERS else
               {"env": _env, "best-response": _best_response,
                "per-step-oracle": _per_step_oracle}[name])
    print(json.dumps({"per_s": measure(name, steps, episodes, search_step_m)}))


def _learner(name: str, steps: int, episodes: int, _: float) -> float:
    """Training steps per CPU second (median over ``episodes`` timed episodes)."""
    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.training.stack_run import Member, StackRun

    scenario, _ = load_scenario_with_overrides(ROOT / SCENARIO,
                                               [*LEARNERS[name], f"train.steps={steps}"])
    run = StackRun([Member(scenario, 0)])
    for _ in range(2):  # the memory holds a batch, SAC is past learning_starts
        run.run_episode()
    seconds = []
    for _ in range(episodes):
        start = time.process_time()
        run.run_episode()
        seconds.append(time.process_time() - start)
    return steps / statistics.median(seconds)


def _env(_name: str, steps: int, episodes: int, _: float) -> float:
    """Environment steps (64 environments a batched step) per CPU second."""
    import numpy as np

    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.sim.network import NetworkBatch

    scenario, _ = load_scenario_with_overrides(ROOT / SCENARIO, ["train.steps=1000000000"])
    env = NetworkBatch(scenario, num_envs=64, seed=0)
    env.reset()
    actions = np.random.default_rng(0).integers(0, env.actions.count, size=(steps, 64))
    for row in actions[:20]:   # warm up
        env.step(row)
    start = time.process_time()
    for _ in range(episodes):
        for row in actions:
            env.step(row)
    return 64 * steps * episodes / (time.process_time() - start)


def _best_response(_name: str, _steps: int, _episodes: int, step_m: float) -> float:
    """Searches of best response of four UAVs (its layout) per CPU second."""
    from adaptsky.rollouts.several_uavs import best_response
    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.sim.layout import user_layouts

    scenario, _ = load_scenario_with_overrides(
        ROOT / "scenarios/four_uavs_mmwave.toml", [f"uav.step_m=[{step_m},{step_m},{step_m}]"])
    start = time.process_time()
    best_response(scenario, user_layouts(scenario, 1))
    return 1 / (time.process_time() - start)


def _per_step_oracle(_name: str, _steps: int, _episodes: int, _: float) -> float:
    """Steps of the per-step oracle (moving_users_sub6.toml, 10 steps) per CPU second."""
    from adaptsky.rollouts.genie import per_step_oracle
    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.sim.layout import user_layouts

    scenario, _ = load_scenario_with_overrides(ROOT / "scenarios/moving_users_sub6.toml", [])
    start = time.process_time()
    per_step_oracle(scenario, user_layouts(scenario, 1), 10)
    return 10 / (time.process_time() - start)


def start(name: str, base: str | None, steps: int, episodes: int, search_step_m: float
          ) -> subprocess.Popen[str]:
    """A child measuring ``name`` with the tree at ``base`` (None: this one)."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if base is not None:
        env["PYTHONPATH"] = f"{base}:{base}/plugins/builtin"
    return subprocess.Popen([sys.executable, __file__, "--child", name, "--steps", str(steps),
                             "--episodes", str(episodes), "--search-step-m",
                             str(search_step_m)], env=env, cwd=ROOT,
                            stdout=subprocess.PIPE, text=True)


def result(child: subprocess.Popen[str]) -> float:
    out, _ = child.communicate()
    if child.returncode:
        raise SystemExit(f"a child failed ({child.returncode})")
    return float(json.loads(out.strip().splitlines()[-1])["per_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="the other checkout (the commit before)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=100, help="steps per episode")
    parser.add_argument("--episodes", type=int, default=3, help="timed episodes per child")
    parser.add_argument("--what", default=",".join(WHAT))
    parser.add_argument("--search-step-m", type=float, default=4.0,
                        help="best response's lattice step (the scenario's is 1 m)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.steps, args.episodes, args.search_step_m)
        return
    if not args.base:
        parser.error("--base: the other checkout to compare with")
    for name in args.what.split(","):
        rates: dict[str, list[float]] = {"before": [], "now": []}
        for _ in range(args.rounds):
            children = {label: start(name, base, args.steps, args.episodes,
                                     args.search_step_m)
                        for label, base in (("before", args.base), ("now", None))}
            for label, running in children.items():
                rates[label].append(result(running))
        before, now = (statistics.median(rates[k]) for k in ("before", "now"))
        print(f"{name}: before {before:,.3f} {UNITS.get(name, 'steps')}/CPU s, now {now:,.3f}, "
              f"ratio {now / before:.3f} (medians of {args.rounds} rounds; per round "
              + ", ".join(f"{n / b:.3f}" for b, n in zip(rates["before"], rates["now"],
                                                         strict=True)) + ")", flush=True)


if __name__ == "__main__":
    main()
