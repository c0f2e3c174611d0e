"""What a greedy evaluation during training costs next to training (one seed, one thread):
median seconds of a training episode and of one evaluation (train.eval_steps = 1000) on
scenarios/nyc_mmwave.toml, without and with 16 held-out layouts, alternated over 5 rounds.

    python benchmarks/evaluation_cost.py
"""

import time

import numpy as np

from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.training.evaluation import GreedyEvaluator, evaluation_set
from adaptsky.training.runner import pin_threads
from adaptsky.training.stack_run import Member, StackRun

pin_threads()
for layouts in (0, 16):
    data = load_scenario("scenarios/nyc_mmwave.toml").model_dump(mode="json")
    data["train"] |= {"eval_layouts": layouts}
    sc = parse_scenario(data)
    ev = evaluation_set(sc)
    run = StackRun([Member(sc, 0)])
    for _ in range(3):
        run.run_episode()  # fill the memory past a batch
    train_s, eval_s = [], []
    assert ev is not None
    evaluator = GreedyEvaluator([ev], sc.train.eval_steps)
    for _ in range(5):
        start = time.perf_counter()
        run.run_episode()
        train_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        evaluator.run(run.algorithm.greedy)
        eval_s.append(time.perf_counter() - start)
    tr, evs = np.median(train_s), np.median(eval_s)
    print(f"held-out layouts {layouts}: training episode {tr:.3f} s, evaluation (1000 steps, "
          f"{1 + layouts} layouts) {evs:.3f} s; every 10 episodes: "
          f"{100 * evs / (10 * tr):.1f}% of training")
