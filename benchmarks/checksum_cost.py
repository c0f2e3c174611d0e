"""What the checksums of stored arrays cost (docs/file-format.md "Checks on reading"): the
time of writing a checkpoint of nyc_mmwave.toml's DQN with a full replay memory (15000 rows)
into its run file, with the checksums (Fletcher32 on every array, the CRC-32 of every
dataset) and without, the file's size either way, the time of reading the checkpoint, and
that of the verification ``RunReader`` adds on opening (every dataset read once).

    .venv/bin/python benchmarks/checksum_cost.py [--rounds 5]

The checkpoint is a real one (a run of 1 episode of 5 steps trained here), its replay filled
up to agent.memory_size with random rows of the real dtypes. A checkpoint write is what
``train`` does at each checkpoint: read the file, rewrite the checkpoint in an in-memory image
(in place after the first), write the image to a copy, fsync, rename. Verifying is timed as
the reading of every dataset with a checksum once (``store.checksums.first_damage``, what
``RunReader`` adds to its validation on opening); reading the checkpoint whole (``eval``,
``--resume``) is timed with and without. Both sides run in this process, alternated, best of
``--rounds`` (wall time). A script, not a test.
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stdout
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import h5py  # noqa: E402

from adaptsky.store import tree  # noqa: E402
from adaptsky.store.atomic import rewrite  # noqa: E402
from adaptsky.store.checksums import first_damage  # noqa: E402
from adaptsky.store.layout import UNITS  # noqa: E402
from adaptsky.store.run_file import RunReader  # noqa: E402
from adaptsky_cli.cli.main import main as cli  # noqa: E402

SCENARIO = ROOT / "scenarios" / "nyc_mmwave.toml"
MEMORY = 15000  # nyc_mmwave's agent.memory_size


@contextmanager
def checksums(on: bool) -> Iterator[None]:
    """Datasets written with the checksums (as adaptsky writes them) or without."""
    options, seal = tree.CHECKED_ARRAY, tree.seal
    if not on:
        tree.CHECKED_ARRAY, tree.seal = {"chunks": True}, lambda *args: None
    try:
        yield
    finally:
        tree.CHECKED_ARRAY, tree.seal = options, seal


def full_checkpoint(run: Path) -> dict:
    with RunReader(run) as reader:
        checkpoint = reader.checkpoint(0)
    replay = checkpoint["replay"]
    rng = np.random.default_rng(0)
    for name, value in list(replay.items()):
        if isinstance(value, np.ndarray):
            shape = (MEMORY, *value.shape[1:])
            replay[name] = (rng.random(shape) < 0.5 if value.dtype == bool else
                            rng.integers(0, 32, shape) if value.dtype.kind == "i" else
                            rng.standard_normal(shape)).astype(value.dtype)
    replay["position"] = 0
    return checkpoint


def write_checkpoint(path: Path, checkpoint: dict) -> float:
    start = time.perf_counter()
    with rewrite(path) as file:
        tree.write_tree(file.require_group("seeds/0/checkpoint"), checkpoint, units=UNITS)
    return time.perf_counter() - start


def read_time(path: Path) -> float:
    """Reading the checkpoint whole (as eval and --resume do; HDF5 verifies Fletcher32)."""
    with h5py.File(path, "r") as file:
        start = time.perf_counter()
        tree.read_tree(file["seeds/0/checkpoint"])
        return time.perf_counter() - start


def verify_time(path: Path) -> float:
    """The pass RunReader adds on opening: every dataset with a checksum read once."""
    with h5py.File(path, "r") as file:
        start = time.perf_counter()
        assert first_damage(file) is None
        return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="checksum-cost-"))
    try:
        run = folder / "run.h5"
        with redirect_stdout(io.StringIO()):  # (its summary table)
            assert cli(["train", str(SCENARIO), "--seeds", "0", "--episodes", "1", "--steps",
                        "5", "--workers", "1", "--quiet", "--out", str(run)]) == 0
        checkpoint = full_checkpoint(run)
        with h5py.File(run, "a") as file:  # written anew by the first write below
            del file["seeds/0/checkpoint"]
        times: dict[bool, dict[str, list[float]]] = {
            on: {"first": [], "again": [], "read": [], "verify": []} for on in (False, True)}
        sizes: dict[bool, int] = {}
        for _ in range(args.rounds):
            for on in (False, True, True, False):
                path = folder / f"run-{on}.h5"
                shutil.copyfile(run, path)
                with checksums(on):
                    times[on]["first"].append(write_checkpoint(path, checkpoint))
                    times[on]["again"].append(write_checkpoint(path, checkpoint))  # in place
                times[on]["read"].append(read_time(path))
                times[on]["verify"].append(verify_time(path))
                sizes[on] = os.path.getsize(path)
        print(f"load average: {os.getloadavg()[0]:.2f}; best of {args.rounds} rounds")
        print("| | without checksums | with checksums | ratio |")
        print("|---|---|---|---|")
        for key, what in (("first", "first checkpoint write (datasets created), s"),
                          ("again", "later checkpoint write (in place), s"),
                          ("read", "reading the checkpoint whole, s")):
            without, with_ = min(times[False][key]), min(times[True][key])
            print(f"| {what} | {without:.4f} | {with_:.4f} | {with_ / without:.3f} |")
        print(f"| verifying every checksum on opening, s | | {min(times[True]['verify']):.4f} "
              "| |")
        print(f"| file size, bytes | {sizes[False]} | {sizes[True]} | "
              f"{sizes[True] / sizes[False]:.4f} |")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
