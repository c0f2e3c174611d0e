"""Time a benchmark with a git revision's code and with the working tree, in turn, on this
machine, so that a restructuring is measured against what it replaced (machine load shifts
both alike).

    .venv/bin/python scripts/side_by_side.py REV --rounds 3 -- benchmarks/env_throughput.py

Each round runs the benchmark script of REV with REV's code first on PYTHONPATH (and its
built-in channel models) and the working tree's script with the working tree's code, both in
this environment; REV first in odd rounds, the working tree first in even ones. Prints every
output under its label, then the figures side by side: for every line that both outputs
share but for its numbers (a table row, by its first number), the other numbers of each
round.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NUMBER = re.compile(r"[-+]?\d[\d,]*\.?\d*(?:e[-+]?\d+)?")


def run(tree: Path, argv: list[str]) -> str:
    """The benchmark ``argv`` (a script path relative to the tree, then its options) with
    ``tree``'s code; its output without colour."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), str(tree / "plugins" /
                                                                      "builtin")]),
           "COLUMNS": "200", "NO_COLOR": "1", "TERM": "dumb"}
    done = subprocess.run([sys.executable, str(tree / argv[0]), *argv[1:]], cwd=tree, env=env,
                          capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"{tree}: {' '.join(argv)} failed: {done.stderr.strip()[-2000:]}")
    return done.stdout


def rows(output: str) -> dict[str, list[str]]:
    """Lines that hold two or more numbers, keyed by their text with every number but the
    first (a table row's label, such as B) taken out; the numbers after the first."""
    found = {}
    for line in output.splitlines():
        numbers = NUMBER.findall(line)
        if len(numbers) > 1:
            first = NUMBER.search(line)
            assert first is not None
            key = line[:first.end()] + NUMBER.sub("#", line[first.end():])
            found[" ".join(key.split())] = numbers[1:]
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rev")
    parser.add_argument("--rounds", type=int, default=3)
    words = sys.argv[1:]
    split = words.index("--") if "--" in words else len(words)
    args = parser.parse_args(words[:split])
    argv = words[split + 1:]
    if not argv:
        parser.error("name the benchmark after --: its script and its options")
    table: dict[str, dict[str, list[list[str]]]] = {}
    with tempfile.TemporaryDirectory() as scratch:
        tree = Path(scratch) / "tree"
        subprocess.run(["git", "worktree", "add", "-q", "--detach", str(tree), args.rev],
                       cwd=ROOT, check=True)
        try:
            sides = [(args.rev, tree), ("working tree", ROOT)]
            for round_ in range(1, args.rounds + 1):
                # ABBA: the side that runs first alternates, so a drift of the machine's
                # speed during the rounds hits both alike
                for label, code in sides if round_ % 2 else sides[::-1]:
                    output = run(code, argv)
                    print(f"--- round {round_}, {label} ---\n{output.rstrip()}\n", flush=True)
                    for key, numbers in rows(output).items():
                        table.setdefault(key, {}).setdefault(label, []).append(numbers)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           check=True)
    print("--- side by side (each round's numbers) ---")
    for key, sides in table.items():
        if len(sides) == 2:
            print(key)
            for label, found in sides.items():
                print(f"  {label:>14}: " + " | ".join(" ".join(n) for n in found))
    return 0


if __name__ == "__main__":
    sys.exit(main())
