"""Training throughput of the dueling DQN, PPO and SAC, this tree against another checkout
(the commit before a change), side by side in one run.

Each measurement is a child process that imports one tree's ``adaptsky`` (``PYTHONPATH`` the
other checkout and its built-in plugins, or nothing for this tree), trains one seed on one
thread until every timed step learns, then times whole episodes (environment step, action,
replay or rollout, updates) and prints the median episode's steps per CPU second (the
process's CPU time: on a shared machine, time spent waiting for a core is not the code's).
Every round runs the two trees' children at once, so that the machine's load hits both alike;
the ratio is this tree's median over the other's (>= 1: not slower).

    .venv/bin/python benchmarks/learners_side_by_side.py --base /tmp/base67 [--rounds 5]
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


def child(name: str, steps: int, episodes: int) -> None:
    """One tree's steps per second of ``name`` (median over ``episodes`` timed episodes)."""
    from adaptsky.scenario.loading import load_scenario_with_overrides
    from adaptsky.training.host import pin_threads
    from adaptsky.training.stack_run import Member, StackRun

    pin_threads()
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
    print(json.dumps({"steps_per_s": steps / statistics.median(seconds)}))


def start(name: str, base: str | None, steps: int, episodes: int) -> subprocess.Popen[str]:
    """A child measuring ``name`` with the tree at ``base`` (None: this one)."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if base is not None:
        env["PYTHONPATH"] = f"{base}:{base}/plugins/builtin"
    return subprocess.Popen([sys.executable, __file__, "--child", name, "--steps", str(steps),
                             "--episodes", str(episodes)], env=env, cwd=ROOT,
                            stdout=subprocess.PIPE, text=True)


def result(child: subprocess.Popen[str]) -> float:
    out, _ = child.communicate()
    if child.returncode:
        raise SystemExit(f"a child failed ({child.returncode})")
    return float(json.loads(out.strip().splitlines()[-1])["steps_per_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="the other checkout (the commit before)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=100, help="steps per episode")
    parser.add_argument("--episodes", type=int, default=3, help="timed episodes per child")
    parser.add_argument("--learners", default=",".join(LEARNERS))
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.steps, args.episodes)
        return
    if not args.base:
        parser.error("--base: the other checkout to compare with")
    for name in args.learners.split(","):
        rates: dict[str, list[float]] = {"before": [], "now": []}
        for _ in range(args.rounds):
            children = {label: start(name, base, args.steps, args.episodes)
                        for label, base in (("before", args.base), ("now", None))}
            for label, running in children.items():
                rates[label].append(result(running))
        before, now = (statistics.median(rates[k]) for k in ("before", "now"))
        print(f"{name}: before {before:,.0f} steps/CPU s, now {now:,.0f} steps/CPU s, "
              f"ratio {now / before:.3f} (medians of {args.rounds} rounds; per round "
              + ", ".join(f"{n / b:.3f}" for b, n in zip(rates["before"], rates["now"],
                                                         strict=True)) + ")", flush=True)


if __name__ == "__main__":
    main()
