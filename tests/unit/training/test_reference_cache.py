"""The reference cache (adaptsky/store/reference_cache.py, docs/training.md): the oracle or
best response of the evaluation layouts is searched once per machine, found again by another
process bit for bit, searched anew when the physics, the layouts or the model change, and a
broken file or an unwritable folder never stops a run."""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.rollouts import several_uavs
from adaptsky.scenario import load_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.store import reference_cache
from adaptsky.store.run_file import RunReader
from adaptsky.training import evaluation
from adaptsky_cli.cli.main import main
from tests.helpers.training import three


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """The cache in a folder of the test's; no reference in this process's memory."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(reference_cache.CACHE_ENV, str(folder))
    monkeypatch.setattr(evaluation, "_REFERENCES", {})
    return folder


def _counting(monkeypatch) -> list[int]:
    """Count the searches of evaluation.best_response (the real search still runs)."""
    calls: list[int] = []
    real = several_uavs.best_response

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(evaluation, "best_response", counted)
    return calls


def test_a_second_process_reads_the_reference_bit_for_bit_without_searching(
        cache, tmp_path, monkeypatch):
    scenario = load_scenario(three(tmp_path))
    layouts_m = user_layouts(scenario, 2)
    calls = _counting(monkeypatch)
    first = evaluation.reference_bps(scenario, layouts_m)
    assert len(calls) == 1 and len(list((cache / "references").glob("*.npy"))) == 1
    monkeypatch.setattr(evaluation, "_REFERENCES", {})      # another process
    again = evaluation.reference_bps(scenario, layouts_m)
    assert len(calls) == 1
    assert again.tobytes() == first.tobytes() and again.shape == (2,)
    # the same layouts under another agent or training share it; other physics does not
    other_agent = scenario.model_copy(update={"name": "renamed"})
    evaluation.reference_bps(other_agent, layouts_m)
    assert len(calls) == 1
    louder = scenario.model_copy(update={"radio": scenario.radio.model_copy(
        update={"tx_power_dbm": scenario.radio.tx_power_dbm + 3.0})})
    assert evaluation.reference_bps(louder, layouts_m)[0] > first[0]
    assert len(calls) == 2
    evaluation.reference_bps(scenario, layouts_m[:1])       # other layouts
    assert len(calls) == 3


def test_the_key_follows_physics_layouts_and_the_search_source(monkeypatch):
    layouts_m = np.zeros((1, 4, 2))
    key = reference_cache.reference_key('{"a": 1}', "mmwave-nyc", layouts_m)
    assert key == reference_cache.reference_key('{"a": 1}', "mmwave-nyc", layouts_m.copy())
    assert key != reference_cache.reference_key('{"a": 2}', "mmwave-nyc", layouts_m)
    assert key != reference_cache.reference_key('{"a": 1}', "mmwave-nyc", layouts_m + 1.0)
    assert key != reference_cache.reference_key('{"a": 1}', "sub6-al-hourani", layouts_m)
    monkeypatch.setattr(reference_cache, "_source_digest", lambda: "changed code")
    assert key != reference_cache.reference_key('{"a": 1}', "mmwave-nyc", layouts_m)


@pytest.mark.parametrize("content", ["garbage", "wrong shape", "wrong dtype", "pickled"])
def test_a_broken_file_is_searched_again_and_rewritten(cache, content):
    key = "k" * 64
    path = cache / "references" / f"{key}.npy"
    path.parent.mkdir(parents=True)
    if content == "garbage":
        path.write_bytes(b"not an npy file")
    elif content == "pickled":                 # an object array would need pickle to load
        np.save(path, np.array([{"x": 1}, None], dtype=object), allow_pickle=True)
    else:
        np.save(path, np.zeros(3) if content == "wrong shape" else np.zeros(2, np.float32))
    assert reference_cache.read_reference(key, 2) is None
    assert reference_cache.write_reference(key, np.array([1.5, 2.5])) == path
    assert reference_cache.read_reference(key, 2).tolist() == [1.5, 2.5]


def test_off_or_unwritable_the_reference_is_searched_as_before(tmp_path, monkeypatch):
    monkeypatch.setenv(reference_cache.CACHE_ENV, "off")
    assert reference_cache.cache_folder() is None
    assert reference_cache.write_reference("k", np.ones(1)) is None
    blocked = tmp_path / "a file"
    blocked.write_text("not a folder")
    monkeypatch.setenv(reference_cache.CACHE_ENV, str(blocked))
    assert reference_cache.write_reference("k", np.ones(1)) is None
    assert reference_cache.read_reference("k", 1) is None
    assert list(tmp_path.iterdir()) == [blocked]


def test_default_folder_is_xdg_cache_home(tmp_path, monkeypatch):
    monkeypatch.delenv(reference_cache.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert reference_cache.cache_folder() == tmp_path / "adaptsky"


def test_a_second_training_says_it_found_best_response_in_the_cache(cache, tmp_path, capsys):
    scenario = three(tmp_path)
    for name in ("one", "two"):
        evaluation._REFERENCES.clear()
        assert main(["train", str(scenario), "--seeds", "0", "--workers", "1",
                     "--out", str(tmp_path / f"{name}.h5")]) == 0
    err = capsys.readouterr().err
    assert err.count("computing best response on the training layout and 2 held-out "
                     "layouts") == 1
    assert err.count("best response on the training layout and 2 held-out layouts from the "
                     f"cache ({cache}; docs/training.md)") == 1
    with RunReader(tmp_path / "one.h5") as one, RunReader(tmp_path / "two.h5") as two:
        stored = [(a.tobytes(), b.tobytes()) for a, b in
                  zip(one.evaluation_oracle(), two.evaluation_oracle(), strict=True)]
    assert len(stored) == 2 and all(a == b for a, b in stored)
