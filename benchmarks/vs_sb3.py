"""adaptsky's learners beside what users would pick instead (issue 39): Stable-Baselines3's PPO
and SAC and ours on the same adaptsky environment, with the same hyperparameters and the same
number of environment steps, one process per side and one thread each. Prints each side's
environment steps per second and their ratio, and each seed's final greedy objective (the last
policy's steady sum rate on the training layout, the last 100 of 1000 steps, as a percentage
of the lattice oracle), with the interquartile mean and its 95% bootstrap interval over the
seeds.

    .venv/bin/python benchmarks/vs_sb3.py [--algo ppo|sac] [--seeds 5] [--env-steps N]
        [--learning-starts N] [--preset cleanrl|tuned] [--scenario scenarios/nyc_mmwave.toml]
        [--out DIR]

Ours trains every seed as one stack (``adaptsky train --workers 1``, the code of the tree this
script is in); SB3 trains them one after another in one process, each on a ``DummyVecEnv`` of
E Gymnasium environments (``adaptsky/NomaUav-v0``), as its documentation shows. Both wall
times include the training's own overheads after the imports (ours: the session's wall time
the run file records, with the greedy evaluations during training off, ``train.eval_every =
0``; SB3: ``learn``, with its logger). PASS where ours takes at least 5 (PPO) or 3 (SAC) times
SB3's steps per second (issue 39), and where our objective is no worse: our interval's upper
end at least SB3's interquartile mean. A script, not a test: no time is asserted anywhere.
Needs the dev extra (``stable-baselines3``, ``scipy``).

PPO (``--algo ppo``, default 240,000 steps per seed): the scenario's own action kind (the
paper's dense set on ``nyc_mmwave.toml``), E = 8 environments per seed; ``PPO`` below maps
one to one onto SB3's arguments, and ``norm_reward`` onto SB3's ``VecNormalize(norm_obs=False,
norm_reward=True, clip_reward=10, gamma=gamma)`` (both divide each reward by a running
standard deviation of the discounted return, as CleanRL's continuous PPO does).

SAC (``--algo sac``, default 100,000 steps per seed, as many as the replay memory holds):
continuous controls (``uav.actions = "continuous"``: the env's ``Box([-1, 1]^D)``), one
environment per seed on both sides (ours: the SAC learner's ``envs_per_member`` is 1; SB3:
a ``DummyVecEnv`` of 1, ``train_freq`` 1, ``gradient_steps`` 1). ``SAC`` below is adaptsky's
defaults (CleanRL's, docs/agent.md#sac); on SB3's side:

- ``hidden_sizes`` -> ``policy_kwargs={"net_arch": [256, 256]}`` (actor and both critics, ReLU,
  SB3's default activation); ``memory_size`` -> ``buffer_size``; ``learning_starts``,
  ``batch_size``, ``tau``, ``gamma`` as they are; ``target_network_frequency`` ->
  ``target_update_interval``; ``autotune`` -> ``ent_coef="auto"`` (alpha from 1, as ours) and
  ``target_entropy="auto"`` (-D, as ours). Both act uniformly in the box before
  ``learning_starts`` and bootstrap at the time limit (a truncation).
- ``reward_scale`` (the tuned preset's 0.01; PPO's too where set) -> each SB3 environment
  wrapped in Gymnasium's ``TransformReward`` multiplying every reward by it, as ours scales
  the rewards it learns from; the objective is measured unscaled on both sides.
- ``q_lr`` and ``policy_lr``: SAC takes one ``learning_rate`` (a schedule of the progress),
  which ``train`` sets on the actor's, the critics' and the temperature's optimisers alike
  before every update; no ``policy_kwargs`` or optimiser argument splits them. SB3's side is
  therefore ``SAC`` with that one method (``_update_learning_rate``) overridden to set the
  actor's Adam at ``policy_lr`` (3e-4) and the critics' and the temperature's at ``q_lr``
  (1e-3), as ours; ``learning_rate=policy_lr`` is what SB3 logs. The update itself is SB3's.
- ``policy_frequency`` 2: SB3's SAC has no policy delay (its TD3 has ``policy_delay``); it
  updates the actor and the temperature once every step, ours twice every second step: the
  same number of updates of each, at other times.
- Left as SB3 has them (its SAC, not CleanRL's): the actor's log std clamped to [-20, 2] (ours
  squashes it into [-5, 2] with a tanh), the temperature loss taken on log alpha (ours on
  alpha), the temperature updated before the critics (ours after the actor); Adam eps 1e-8 on
  both sides.

The objective is a percentage of the oracle on the lattice (docs/evaluation.md, "Oracle"): a
ceiling for the dense moves PPO takes on ``nyc_mmwave.toml``, a reference but not a bound for
continuous controls, whose positions and shares also fall between the lattice's points (a
policy may pass 100%); the output says which.
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
       "vf_coef": 0.5, "max_grad_norm": 0.5, "norm_adv": True, "norm_reward": True}
# the SAC settings both sides train with (CleanRL's, docs/agent.md#sac), on continuous controls
SAC = {"algorithm": "sac", "hidden_sizes": [256, 256], "q_lr": 1e-3, "policy_lr": 3e-4,
       "gamma": 0.99, "tau": 0.005, "batch_size": 256, "memory_size": 100_000,
       "learning_starts": 5000, "policy_frequency": 2, "target_network_frequency": 1,
       "autotune": True}
AGENTS = {"ppo": PPO, "sac": SAC}
ENV_STEPS = {"ppo": 240_000, "sac": 100_000}
"""The default environment steps per seed."""


def envs_per_seed(algo: str) -> int:
    """E, the environments per seed of both sides: PPO's ``envs_per_seed``, 1 for SAC."""
    return int(AGENTS[algo].get("envs_per_seed", 1))


def scenario_file(base: Path, out: Path, algo: str, episodes: int, seeds: int,
                  learning_starts: int | None = None, preset: str = "cleanrl") -> Path:
    """The benchmark's scenario: ``base`` with the algorithm's settings and those of our
    ``preset`` over them (SAC: on continuous controls, ``learning_starts`` where given),
    ``episodes`` episodes, no greedy evaluations during training."""
    from adaptsky.scenario import load_scenario
    from adaptsky.scenario.presets import preset_values
    from adaptsky.scenario.toml_writer import dumps

    data = load_scenario(base).model_dump(mode="json")
    data["agent"] = {**AGENTS[algo], **preset_values(preset, algo), "preset": preset}
    if algo == "sac":
        data["uav"]["actions"] = "continuous"
        if learning_starts is not None:
            data["agent"]["learning_starts"] = learning_starts
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
                   stdout=subprocess.DEVNULL, env=_env())
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
            check=True, capture_output=True, text=True, env=_env())
        scores.append(_pct_of_oracle(json.loads(result.stdout)))
    return wall, scores


def _env() -> dict[str, str]:
    """The environment of both sides' processes: this tree's adaptsky first on the path (the
    ``adaptsky`` command and ``python -c`` would otherwise import the installed one)."""
    path = os.environ.get("PYTHONPATH")
    return os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT), *([path] if path else [])])}


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
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecNormalize
from stable_baselines3.common.utils import update_learning_rate
register_envs()
path, seeds, out = Path(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
scenario = load_scenario(path)
agent, train = scenario.agent, scenario.train
envs = getattr(agent, "envs_per_seed", 1)
total = train.episodes * train.steps * envs


class TwoRateSAC(SAC):
    """SB3's SAC with the actor's Adam at policy_lr and the critics' and the temperature's
    at q_lr (SAC's one learning_rate would set all three alike before every update)."""

    def _update_learning_rate(self, optimizers):
        self.logger.record("train/learning_rate", agent.policy_lr)
        for optimizer in optimizers:
            update_learning_rate(optimizer, agent.policy_lr if optimizer is self.actor.optimizer
                                 else agent.q_lr)


def model_of(seed, env):
    if agent.algorithm == "sac":
        return TwoRateSAC(
            "MlpPolicy", env, learning_rate=agent.policy_lr, buffer_size=agent.memory_size,
            learning_starts=agent.learning_starts, batch_size=agent.batch_size, tau=agent.tau,
            gamma=agent.gamma, train_freq=1, gradient_steps=1,
            ent_coef="auto" if agent.autotune else agent.alpha,
            target_update_interval=agent.target_network_frequency, target_entropy="auto",
            policy_kwargs={"net_arch": list(agent.hidden_sizes)},
            seed=seed, device="cpu", verbose=0)
    batch = train.steps * envs
    return PPO("MlpPolicy", env, learning_rate=lambda left: agent.lr * left,
               n_steps=train.steps, batch_size=batch // agent.minibatches,
               n_epochs=agent.epochs, gamma=agent.gamma, gae_lambda=agent.gae_lambda,
               clip_range=agent.clip_coef, clip_range_vf=agent.clip_coef,
               ent_coef=agent.ent_coef, vf_coef=agent.vf_coef,
               max_grad_norm=agent.max_grad_norm, normalize_advantage=agent.norm_adv,
               policy_kwargs={"net_arch": {"pi": list(agent.hidden_sizes),
                                           "vf": list(agent.hidden_sizes)},
                              "activation_fn": torch.nn.Tanh},
               seed=seed, device="cpu", verbose=0)


models, start = [], time.monotonic()
for seed in range(seeds):
    scaled = {} if agent.reward_scale == 1 else {  # ours: rewards x reward_scale, stored
        "wrapper_class": gymnasium.wrappers.TransformReward,
        "wrapper_kwargs": {"func": lambda reward: reward * agent.reward_scale}}
    env = make_vec_env(ENV_ID, n_envs=envs, seed=seed, env_kwargs={"scenario": scenario},
                       **scaled)
    if getattr(agent, "norm_reward", False):  # ours: reward / running std of the return
        env = VecNormalize(env, norm_obs=False, norm_reward=True, clip_reward=10.0,
                           gamma=agent.gamma)
    model = model_of(seed, env)
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
                            capture_output=True, text=True, env=_env())
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
    parser.add_argument("--algo", default="ppo", choices=tuple(AGENTS))
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--env-steps", type=int, default=None,
                        help="environment steps per seed, rounded to whole episodes of E "
                        "environments (default: 240,000 for PPO, 100,000 for SAC)")
    parser.add_argument("--learning-starts", type=int, default=None,
                        help=f"SAC only: steps of uniform actions before the first update "
                        f"(default {SAC['learning_starts']}; lower for a short smoke run)")
    parser.add_argument("--preset", default="cleanrl", choices=("cleanrl", "tuned"),
                        help="our preset's values over the settings below, on both sides "
                        "(docs/agent.md; SAC's tuned: 64-64 networks)")
    parser.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "nyc_mmwave.toml")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    if args.learning_starts is not None and args.algo != "sac":
        parser.error("--learning-starts is SAC's (--algo sac)")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    out = args.out or Path(tempfile.mkdtemp(prefix="vs_sb3-"))
    out.mkdir(parents=True, exist_ok=True)
    from adaptsky.scenario import load_scenario

    steps = load_scenario(args.scenario).train.steps
    envs = envs_per_seed(args.algo)
    env_steps = ENV_STEPS[args.algo] if args.env_steps is None else args.env_steps
    episodes = max(1, round(env_steps / (steps * envs)))
    path = scenario_file(args.scenario, out, args.algo, episodes, args.seeds,
                         args.learning_starts, args.preset)
    agent = load_scenario(path).agent
    per_seed = episodes * steps * envs
    shape = (f"{episodes} rollouts of {steps} steps x {envs} envs" if args.algo == "ppo" else
             f"{episodes} episodes of {steps} steps, 1 env, continuous controls, "
             f"learning_starts {agent.learning_starts}")
    print(f"{args.algo.upper()}: {args.seeds} seeds x {per_seed:,} environment steps "
          f"({shape}) on {args.scenario.name}, preset {args.preset} (hidden "
          f"{agent.hidden_sizes}); load {os.getloadavg()[0]:.1f}; files in {out}")
    our_wall, our_scores = ours(path, out)
    their_wall, their_scores = sb3(path, args.seeds)
    total = per_seed * args.seeds
    ours_rate, theirs_rate = total / our_wall, total / their_wall
    ratio = ours_rate / theirs_rate
    if load_scenario(path).uav.actions == "continuous":
        print("objective: % of the lattice oracle, a reference, not a bound (continuous "
              "positions and shares fall between its points; above 100% is possible)")
    else:
        print("objective: % of the lattice oracle, a ceiling for these moves")
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
