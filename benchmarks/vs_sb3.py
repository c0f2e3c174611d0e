"""adaptsky's learners beside what users would pick instead (issue 39): Stable-Baselines3's PPO
(and SAC, once adaptsky has it) and ours on the same adaptsky environment, with the same
hyperparameters and the same number of environment steps, one process per side and one thread
each. Prints each side's environment steps per second and their ratio, and each seed's final
greedy objective (the last policy's steady sum rate on the training layout, the last 100 of
1000 steps, as a percentage of the oracle), with the interquartile mean and its 95% bootstrap
interval over the seeds.

    .venv/bin/python benchmarks/vs_sb3.py [--algo ppo] [--seeds 5] [--env-steps 240000]
        [--scenario scenarios/nyc_mmwave.toml] [--out DIR]

Ours trains every seed as one stack (``adaptsky train --workers 1``); SB3 trains them one after
another in one process, each on a ``DummyVecEnv`` of E Gymnasium environments
(``adaptsky/NomaUav-v0``), as its documentation shows. Both wall times include the training's
own overheads after the imports (ours: the session's wall time the run file records, with the
greedy evaluations during training off, ``train.eval_every = 0``; SB3: ``learn``, with its
logger). PASS where ours takes at least ``--ratio`` (5 for PPO, issue 39) times SB3's
steps per second, and where our objective is no worse: our interval's upper end at least
SB3's interquartile mean. A script, not a test: no time is asserted anywhere. Needs the dev
extra (``stable-baselines3``, ``scipy``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RATIO = {"ppo": 5.0, "sac": 3.0}
ADAPTSKY = str(Path(sys.executable).with_name("adaptsky"))
# the PPO settings both sides train with (CleanRL's, docs/agent.md#ppo)
PPO = {"algorithm": "ppo", "hidden_sizes": [64, 64], "activation": "tanh", "envs_per_seed": 8,
       "lr": 3e-4, "anneal_lr": True, "gamma": 0.99, "gae_lambda": 0.95, "epochs": 4,
       "minibatches": 4, "clip_coef": 0.2, "clip_vloss": True, "ent_coef": 0.01,
       "vf_coef": 0.5, "max_grad_norm": 0.5, "norm_adv": True}


def scenario_file(base: Path, out: Path, episodes: int, seeds: int) -> Path:
    """The benchmark's scenario: ``base`` with PPO's settings, ``episodes`` episodes, no
    greedy evaluations during training."""
    from adaptsky.scenario import load_scenario
    from adaptsky.scenario.toml_writer import dumps

    data = load_scenario(base).model_dump(mode="json")
    data["agent"] = dict(PPO)
    data["train"] |= {"episodes": episodes, "seeds": list(range(seeds)), "eval_every": 0,
                      "checkpoint_every": episodes}
    path = out / "vs_sb3.toml"
    path.write_text(dumps(data))
    return path


def ours(path: Path, out: Path) -> tuple[float, list[float]]:
    """Train every seed as one stack in one process; (wall s, last policies' % of oracle)."""
    run = out / "ours.h5"
    subprocess.run([ADAPTSKY, "train", str(path),
                    "--workers", "1", "--out", str(run), "--quiet"], check=True,
                   stdout=subprocess.DEVNULL)
    scores = []
    from adaptsky.store.run_file import RunReader

    with RunReader(run) as reader:  # the training's wall time as the run file records it
        seeds = reader.seeds
        wall = float(json.loads(reader.file["sessions"][()])[-1]["wall_s"])
    for seed in seeds:
        result = subprocess.run(
            [ADAPTSKY, "eval", "--checkpoint", str(run),
             "--seed", str(seed), "--policy", "last", "--compare", "oracle", "--steps", "1000",
             "--json", "--out", str(out / f"ours-eval-{seed}.h5")],
            check=True, capture_output=True, text=True)
        scores.append(_pct_of_oracle(json.loads(result.stdout)))
    return wall, scores


def _pct_of_oracle(results: dict) -> float:
    """The policy's steady sum rate over the oracle's, % (eval's JSON)."""
    methods = results["methods"]
    policy = next(name for name in methods if name not in ("oracle",))
    steady = methods[policy]["summary"]["steady_sum_rate_bps"]
    return 100.0 * steady / methods["oracle"]["summary"]["mean_sum_rate_bps"]


SB3_SIDE = r'''
import json, sys, time
from pathlib import Path
import torch
from threadpoolctl import threadpool_limits
threadpool_limits(limits=1)
torch.set_num_threads(1)
import gymnasium
import adaptsky
from adaptsky.envs.registration import ENV_ID, register_envs
from adaptsky.scenario import load_scenario
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
register_envs()
path, seeds, out = Path(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
scenario = load_scenario(path)
agent, train = scenario.agent, scenario.train
total = train.episodes * train.steps * agent.envs_per_seed
models, start = [], time.monotonic()
for seed in range(seeds):
    env = make_vec_env(ENV_ID, n_envs=agent.envs_per_seed, seed=seed,
                       env_kwargs={"scenario": scenario})
    batch = train.steps * agent.envs_per_seed
    model = PPO("MlpPolicy", env, learning_rate=lambda left: agent.lr * left,
                n_steps=train.steps, batch_size=batch // agent.minibatches,
                n_epochs=agent.epochs, gamma=agent.gamma, gae_lambda=agent.gae_lambda,
                clip_range=agent.clip_coef, clip_range_vf=agent.clip_coef,
                ent_coef=agent.ent_coef, vf_coef=agent.vf_coef,
                max_grad_norm=agent.max_grad_norm, normalize_advantage=agent.norm_adv,
                policy_kwargs={"net_arch": {"pi": list(agent.hidden_sizes),
                                            "vf": list(agent.hidden_sizes)},
                               "activation_fn": torch.nn.Tanh},
                seed=seed, device="cpu", verbose=0)
    model.learn(total_timesteps=total)
    models.append(model)
wall = time.monotonic() - start
scores = []
for seed, model in enumerate(models):
    results, _ = adaptsky.evaluate_policy(
        lambda obs, model=model: model.predict(obs, deterministic=True)[0],
        scenario_path=path, compare_with=["oracle"], steps=1000, label="sb3")
    methods = results["methods"]
    scores.append(100.0 * methods["policy"]["summary"]["steady_sum_rate_bps"]
                  / methods["oracle"]["summary"]["mean_sum_rate_bps"])
print(json.dumps({"wall_s": wall, "scores": scores, "steps_per_seed": total}))
'''


def sb3(path: Path, seeds: int) -> tuple[float, list[float]]:
    """SB3's side in one process; (wall s of the training, last policies' % of oracle)."""
    result = subprocess.run([sys.executable, "-c", SB3_SIDE, str(path), str(seeds), "-"],
                            capture_output=True, text=True)
    if result.returncode:
        raise SystemExit(f"the SB3 side failed:\n{result.stderr[-3000:]}")
    found = json.loads(result.stdout.strip().splitlines()[-1])
    return float(found["wall_s"]), [float(s) for s in found["scores"]]


def iqm_interval(scores: list[float]) -> tuple[float, float, float]:
    """The interquartile mean and its 95% percentile-bootstrap interval (10,000 resamples,
    seed 0)."""
    from scipy import stats

    values = np.asarray(scores, dtype=np.float64)

    def iqm(sample: np.ndarray, axis: int = -1) -> np.ndarray:
        return stats.trim_mean(sample, 0.25, axis=axis)

    if len(values) < 2 or np.ptp(values) == 0:
        value = float(iqm(values))
        return value, value, value
    found = stats.bootstrap((values,), iqm, confidence_level=0.95, n_resamples=10_000,
                            method="percentile", random_state=np.random.default_rng(0))
    return (float(iqm(values)), float(found.confidence_interval.low),
            float(found.confidence_interval.high))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", default="ppo", choices=("ppo",))
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--env-steps", type=int, default=240_000,
                        help="environment steps per seed (rounded to whole episodes of E)")
    parser.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "nyc_mmwave.toml")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    out = args.out or Path(tempfile.mkdtemp(prefix="vs_sb3-"))
    out.mkdir(parents=True, exist_ok=True)
    from adaptsky.scenario import load_scenario

    steps = load_scenario(args.scenario).train.steps
    episodes = max(1, round(args.env_steps / (steps * PPO["envs_per_seed"])))
    path = scenario_file(args.scenario, out, episodes, args.seeds)
    per_seed = episodes * steps * PPO["envs_per_seed"]
    print(f"{args.algo.upper()}: {args.seeds} seeds x {per_seed:,} environment steps "
          f"({episodes} rollouts of {steps} steps x {PPO['envs_per_seed']} envs) on "
          f"{args.scenario.name}; load {os.getloadavg()[0]:.1f}; files in {out}")
    our_wall, our_scores = ours(path, out)
    their_wall, their_scores = sb3(path, args.seeds)
    total = per_seed * args.seeds
    ours_rate, theirs_rate = total / our_wall, total / their_wall
    ratio = ours_rate / theirs_rate
    print(f"{'':8} {'env steps/s':>12} {'wall':>9}   final greedy objective, % of oracle")
    for name, rate, wall, scores in (("adaptsky", ours_rate, our_wall, our_scores),
                                     ("SB3", theirs_rate, their_wall, their_scores)):
        iqm, low, high = iqm_interval(scores)
        seeds = ", ".join(f"{s:.1f}" for s in scores)
        print(f"{name:8} {rate:>12,.0f} {wall:>8.0f}s   IQM {iqm:.2f}% [{low:.2f}, {high:.2f}]"
              f" (seeds {seeds})")
    fast = ratio >= RATIO[args.algo]
    _, _, our_high = iqm_interval(our_scores)
    their_iqm, _, _ = iqm_interval(their_scores)
    good = our_high >= their_iqm
    print(f"speed: ours / SB3 = {ratio:.2f} (>= {RATIO[args.algo]:g}): "
          f"{'PASS' if fast else 'FAIL'}; objective no worse: {'PASS' if good else 'FAIL'}; "
          f"load {os.getloadavg()[0]:.1f}")
    return 0 if fast and good else 1


if __name__ == "__main__":
    raise SystemExit(main())
