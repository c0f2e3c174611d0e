"""Every stored dataset carries a checksum verified on reading (docs/file-format.md "Checks on
reading"): one bit flipped on disk in a weight, an optimizer state, a replay block or a curve
is refused by ``inspect``, ``eval`` and ``train --resume`` in one line naming the dataset, exit
1; what is read back is what was written; files without checksums read as before."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.store import checksums
from adaptsky.store.checksums import CRC_ATTR, MISMATCH, crc32_of, first_damage
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.store.tree import read_tree, write_tree
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.cli import one_line
from tests.helpers.run_files import LEGACY, check_all_refuse

CHECKPOINT = "/seeds/0/checkpoint"
# one of each kind of damage the issue names, and the Adam step count (a number of shape ())
DAMAGED = {
    "best_weight": f"{CHECKPOINT}/best/policy/torso.2.weight",
    "optimizer_moment": f"{CHECKPOINT}/agent/optimizer/state/2/exp_avg_sq",
    "optimizer_step": f"{CHECKPOINT}/agent/optimizer/state/2/step",
    "replay_block": f"{CHECKPOINT}/replay/observations",
    "curve": "/seeds/0/episodes/sum_rate_bps",
    "evaluation": "/seeds/0/evaluations/score",
}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """nyc_mmwave, seed 0, 2 episodes of 5 steps, a greedy evaluation after each (a best
    policy), trained once for this module. Read only: tests damage copies."""
    path = tmp_path_factory.mktemp("checksums") / "run.h5"
    assert main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--seeds", "0", "--episodes",
                 "2", "--steps", "5", "--workers", "1", "--quiet", "--set",
                 "train.eval_every=1", "--out", str(path)]) == 0
    return path


def flip_bit(path: Path, name: str, byte: int = 3, bit: int = 2, chunk: int = 0) -> None:
    """Flip one bit of ``name``'s stored bytes on disk (in its ``chunk``-th stored chunk, or
    its contiguous data), behind HDF5's back: as a disk or a copy would damage it."""
    with h5py.File(path, "r") as file:
        dataset = file[name]
        offset = (dataset.id.get_chunk_info(chunk).byte_offset if dataset.chunks
                  else dataset.id.get_offset())
    with open(path, "r+b") as handle:
        handle.seek(offset + byte)
        value = handle.read(1)[0]
        handle.seek(offset + byte)
        handle.write(bytes([value ^ (1 << bit)]))


def damaged_copy(run: Path, tmp_path: Path, name: str) -> Path:
    path = Path(shutil.copyfile(run, tmp_path / "damaged.h5"))
    flip_bit(path, name)
    return path


@pytest.mark.parametrize("case", sorted(DAMAGED))
def test_one_flipped_bit_is_refused_in_one_line_naming_the_dataset(case, run, tmp_path,
                                                                    capsys):
    path = damaged_copy(run, tmp_path, DAMAGED[case])
    with h5py.File(path, "r") as file:  # (it has stored bytes, which the flip changed)
        assert file[DAMAGED[case]].id.get_storage_size() > 0
    check_all_refuse(path, tmp_path, capsys,
                     f"damaged run file: {DAMAGED[case]}: {MISMATCH}")


def test_the_flipped_bit_would_otherwise_change_the_numbers(run, tmp_path):
    """Without its checksum the same flip reads as other finite numbers: what the check
    stops (the issue's weights evaluated silently)."""
    name = DAMAGED["best_weight"]
    path = damaged_copy(run, tmp_path, name)
    with h5py.File(run, "r") as file:
        rows, columns = file[name].chunks
        intact = file[name][:rows, :columns]  # the first chunk
        chunk = file[name].id.get_chunk_info(0)
        raw = path.read_bytes()[chunk.byte_offset:chunk.byte_offset + chunk.size]
    stored = np.frombuffer(raw[:-4], dtype="<f4")  # the chunk less its Fletcher32
    assert np.all(np.isfinite(stored))
    assert np.count_nonzero(stored != intact.reshape(-1)) == 1


def test_a_replay_chunk_zeroed_whole_with_its_checksum_is_refused(run, tmp_path, capsys):
    """Fletcher32 of zeros is 0: a chunk zeroed with its checksum (a lost disk block) passes
    HDF5's own check; the CRC-32 of the whole dataset does not."""
    name = DAMAGED["replay_block"]
    path = Path(shutil.copyfile(run, tmp_path / "zeroed.h5"))
    with h5py.File(path, "r") as file:
        chunk = file[name].id.get_chunk_info(0)
    data = bytearray(path.read_bytes())
    data[chunk.byte_offset:chunk.byte_offset + chunk.size] = bytes(chunk.size)
    path.write_bytes(bytes(data))
    with h5py.File(path, "r") as file:
        assert not file[name][()].any()  # HDF5 reads the zeros without complaint
    check_all_refuse(path, tmp_path, capsys, f"damaged run file: {name}: {MISMATCH}")


@pytest.mark.parametrize(("case", "value"), [("best_weight", 0.01), ("replay_block", 0.0)])
def test_other_numbers_written_through_hdf5_are_refused(case, value, run, tmp_path, capsys):
    """The issue's cases: the first chunk of a best-policy weight overwritten with other
    finite numbers, a replay block zeroed, by h5py, which computes a new Fletcher32 for them:
    the dataset's CRC-32 no longer matches."""
    path = Path(shutil.copyfile(run, tmp_path / "overwritten.h5"))
    name = DAMAGED[case]
    with h5py.File(path, "r+") as file:
        first_chunk = tuple(slice(0, size) for size in file[name].chunks)
        assert np.all(file[name][first_chunk] != value)
        file[name][first_chunk] = value
    check_all_refuse(path, tmp_path, capsys, f"damaged run file: {name}: {MISMATCH}")


def test_a_curves_reader_checks_what_it_reads_and_only_that(run, tmp_path):
    replay = damaged_copy(run, tmp_path, DAMAGED["replay_block"])
    with RunReader(replay, needs="curves") as reader:  # (plot, tune: no checkpoint read)
        assert len(reader.episodes(0)["sum_rate_bps"]) == 2
    curve = damaged_copy(run, tmp_path, DAMAGED["curve"])
    with pytest.raises(RunFileError, match=f"{DAMAGED['curve']}: checksum mismatch"):
        RunReader(curve, needs="curves")


def test_every_dataset_of_a_run_file_carries_a_checksum(run):
    """Fletcher32 and a CRC-32 of the whole on every array, the CRC-32 alone on numbers of
    shape () and texts (HDF5 cannot chunk them)."""
    found: dict[str, str] = {}
    scalars: set[str] = set()

    def visit(name: str, item: h5py.HLObject) -> None:
        if isinstance(item, h5py.Dataset):
            found[name] = " ".join(kind for kind, has in (
                ("fletcher32", item.fletcher32), ("crc32", CRC_ATTR in item.attrs)) if has)
            if item.shape == ():
                scalars.add(name)
    with h5py.File(run, "r") as file:
        file.visititems(visit)
        reward = file["seeds/0/episodes/reward"]  # (appended to at every checkpoint)
        assert reward.attrs[CRC_ATTR] == crc32_of(reward[()]) and len(reward) == 2
        assert first_damage(file) is None
    assert {kind for name, kind in found.items() if name not in scalars} == {"fletcher32 crc32"}
    assert {kind for name, kind in found.items() if name in scalars} == {"crc32"}
    assert {"config", "seeds/0/checkpoint/agent/optimizer/state/2/step"} <= scalars


def test_checksums_change_nothing_read_back(tmp_path):
    """Shapes, dtypes and values read back are those written (bit for bit), also after an
    overwrite in place, whose numbers of shape () get their new CRC."""
    tree = {"w": np.arange(12, dtype=np.float32).reshape(3, 4) / 7, "empty": np.zeros((0, 4)),
            "step": np.array(3.0, dtype=np.float32), "flags": np.array([True, False]),
            "count": np.array(7), "inner": {"rows": np.arange(5, dtype=np.int64)}}
    path = tmp_path / "tree.h5"
    with h5py.File(path, "w") as file:
        write_tree(file, tree)
        write_tree(file, {"step": np.array(4.0, dtype=np.float32)})
    expected = tree | {"step": np.array(4.0, dtype=np.float32)}
    with h5py.File(path, "r") as file:
        got = read_tree(file)
        assert first_damage(file) is None
        assert file["step"].attrs[CRC_ATTR] != 0 and file["w"].fletcher32
    for key in ("w", "empty", "step", "flags", "count"):
        value = np.asarray(got[key])
        assert value.shape == expected[key].shape and value.dtype == expected[key].dtype, key
        assert value.tobytes() == expected[key].tobytes(), key
    assert np.array_equal(got["inner"]["rows"], np.arange(5))


@pytest.mark.parametrize("name", sorted(p.name for p in LEGACY.glob("*.h5")))
def test_files_written_before_checksums_read_as_before(name, tmp_path, capsys):
    path = Path(shutil.copyfile(LEGACY / name, tmp_path / name))
    with RunReader(path) as reader:
        assert reader.checkpoint(3)["episode"] == 2
    with h5py.File(path, "r") as file:
        assert not file["seeds/3/checkpoint/agent/policy/torso.0.weight"].fletcher32
    assert main(["inspect", str(path)]) == 0
    version = name.split("-")[0].removeprefix("format")
    assert f"format {version}" in capsys.readouterr().out


def test_a_changed_letter_in_the_stored_scenario_text_is_refused(run, tmp_path, capsys):
    """Texts (and numbers of shape ()) cannot be chunked: their CRC-32 attribute is checked."""
    path = Path(shutil.copyfile(run, tmp_path / "text.h5"))
    with h5py.File(path, "r") as file:
        text = file["scenario"][()]
    piece = text[len(text) // 2:len(text) // 2 + 40]
    data = bytearray(path.read_bytes())
    assert data.count(piece) == 1
    data[data.index(piece)] ^= 0x20  # one letter's case, or a space made a "\0"
    path.write_bytes(bytes(data))
    check_all_refuse(path, tmp_path, capsys, f"damaged run file: /scenario: {MISMATCH}")


@pytest.mark.parametrize("name", ["methods/policy/steady_sum_rate_bps",
                                  "methods/policy/trajectory/rate_bps", "layouts_m"])
def test_a_damaged_eval_file_is_refused_naming_the_dataset(name, run, tmp_path, capsys):
    out = tmp_path / "eval.h5"
    assert main(["eval", str(run), "--steps", "5", "--compare", "", "--out", str(out),
                 "--json"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(out)]) == 0
    capsys.readouterr()
    assert read_eval_metrics(out)[1]["policy"]["steady_sum_rate_bps"].shape == (1,)
    flip_bit(out, name)
    assert main(["inspect", str(out)]) == 1
    line = f"{out}: damaged eval file: /{name}: {MISMATCH}"
    assert one_line(capsys) == line
    with pytest.raises(AdaptskyError) as refused:  # what reproduce's reports read
        read_eval_metrics(out)
    assert str(refused.value) == line


def test_large_datasets_are_verified_chunk_by_chunk_as_stored(tmp_path, monkeypatch):
    """Above the size read whole, every stored chunk is read (a damaged fourth chunk is
    found), and a dataset declared far larger than the file (2^36 rows: 4.7 TB) is read only
    where it stores something."""
    monkeypatch.setattr(checksums, "_WHOLE_BYTES", 1000)
    path = tmp_path / "large.h5"
    with h5py.File(path, "w") as file:
        file.create_dataset("huge", shape=(2**36, 17), dtype="f4", chunks=(1024, 17),
                            fletcher32=True)
        file["huge"][5:10] = 1.0
        file.create_dataset("w", data=np.arange(40000.0).reshape(200, 200), chunks=(64, 64),
                            fletcher32=True)
        file.create_dataset("plain", data=np.arange(40000.0).reshape(200, 200))
        assert file["w"].id.get_num_chunks() == 16 and file["huge"].id.get_num_chunks() == 1
    with h5py.File(path, "r") as file:
        assert first_damage(file) is None
    flip_bit(path, "w", byte=100, chunk=3)
    with h5py.File(path, "r") as file:
        assert first_damage(file) == ("/w", MISMATCH)
        assert file["w"][:64, :64].sum() == np.arange(40000.0).reshape(200, 200)[:64, :64].sum()


def test_a_checksum_attribute_that_is_not_a_number_is_a_mismatch(run, tmp_path, capsys):
    path = Path(shutil.copyfile(run, tmp_path / "attribute.h5"))
    with h5py.File(path, "r+") as file:
        file["seeds/0/episodes/reward"].attrs[CRC_ATTR] = "not a checksum"
    check_all_refuse(path, tmp_path, capsys,
                     f"damaged run file: /seeds/0/episodes/reward: {MISMATCH}")
