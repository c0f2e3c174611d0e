"""The search cache (adaptsky/store/search_cache.py, docs/training.md): best response, the
oracle and the best OMA configuration of a scenario's layouts are searched once per machine,
found again by another process bit for bit (for the greedy evaluations' reference and for the
baselines), searched anew when the method, the physics, the layouts or the model change, and
a broken file or an unwritable folder never stops a run."""

from __future__ import annotations

import numpy as np
import pytest

from adaptsky.references import searches
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.several_uavs import SearchResult
from adaptsky.scenario import load_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.store import search_cache
from adaptsky.store.run_file import RunReader
from adaptsky.training import evaluation
from adaptsky_cli.cli.main import main
from tests.helpers.training import three

FIELDS = ("objective_bps", "uav_m", "alpha_first", "rate_bps", "rounds", "converged",
          "seconds_per_layout")


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """The cache in a folder of the test's; no reference in this process's memory."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(search_cache.CACHE_ENV, str(folder))
    monkeypatch.setattr(evaluation, "_REFERENCES", {})
    return folder


def _counting(monkeypatch) -> list[str]:
    """Count the searches (the real ones still run)."""
    calls: list[str] = []
    for name in ("best_response", "best_oma"):
        real = getattr(several_uavs, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            calls.append(_name)
            return _real(*args, **kwargs)

        monkeypatch.setattr(several_uavs, name, counted)
    return calls


def _same(one: SearchResult, two: SearchResult) -> bool:
    return all(np.asarray(getattr(one, name)).tobytes() == np.asarray(getattr(two, name)).tobytes()
               for name in FIELDS)


def test_a_second_process_finds_the_reference_bit_for_bit_without_searching(
        cache, tmp_path, monkeypatch):
    scenario = load_scenario(three(tmp_path))
    layouts_m = user_layouts(scenario, 2)
    calls = _counting(monkeypatch)
    first = evaluation.reference_bps(scenario, layouts_m)
    assert calls == ["best_response"] and len(list((cache / "searches").glob("*.npz"))) == 1
    monkeypatch.setattr(evaluation, "_REFERENCES", {})      # another process
    again = evaluation.reference_bps(scenario, layouts_m)
    assert calls == ["best_response"]
    assert again.tobytes() == first.tobytes() and again.shape == (2,)
    # the baseline's search is the same search: found, whole
    found = searches.search(scenario, "best-response", layouts_m)
    assert calls == ["best_response"] and found.objective_bps.tobytes() == first.tobytes()
    # another name, agent or training shares it; other physics, layouts or method do not
    renamed = scenario.model_copy(update={"name": "renamed", "agent": scenario.agent.model_copy(
        update={"lr": 0.5})})
    evaluation.reference_bps(renamed, layouts_m)
    assert calls == ["best_response"]
    louder = scenario.model_copy(update={"radio": scenario.radio.model_copy(
        update={"tx_power_dbm": scenario.radio.tx_power_dbm + 3.0})})
    assert evaluation.reference_bps(louder, layouts_m)[0] > first[0]
    evaluation.reference_bps(scenario, layouts_m[:1])
    assert calls == ["best_response"] * 3
    searches.search(scenario, "oma", layouts_m)
    assert calls == ["best_response"] * 3 + ["best_oma"]


def test_a_baseline_search_is_stored_whole_and_found_bit_for_bit(cache, tmp_path, monkeypatch):
    scenario = load_scenario(three(tmp_path))
    layouts_m = user_layouts(scenario, 2)
    calls = _counting(monkeypatch)
    for method in ("best-response", "oma"):
        searched = searches.search(scenario, method, layouts_m)
        found = searches.search(scenario, method, layouts_m)
        assert _same(searched, found)
    assert calls == ["best_response", "best_oma"]


def test_the_key_follows_method_physics_layouts_model_and_the_search_source(monkeypatch):
    layouts_m = np.zeros((1, 4, 2))
    key = search_cache.search_key('{"a": 1}', "mmwave-nyc", layouts_m)
    assert key == search_cache.search_key('{"a": 1}', "mmwave-nyc", layouts_m.copy())
    assert key != search_cache.search_key('{"a": 1}', "mmwave-nyc", layouts_m, "oma")
    assert key != search_cache.search_key('{"a": 2}', "mmwave-nyc", layouts_m)
    assert key != search_cache.search_key('{"a": 1}', "mmwave-nyc", layouts_m + 1.0)
    assert key != search_cache.search_key('{"a": 1}', "sub6-al-hourani", layouts_m)
    monkeypatch.setattr(search_cache, "_source_digest", lambda: "changed code")
    assert key != search_cache.search_key('{"a": 1}', "mmwave-nyc", layouts_m)


def _search(layouts: int = 2, uavs: int = 1, users: int = 4) -> SearchResult:
    return SearchResult(np.arange(layouts, dtype=np.float64), np.ones((layouts, uavs, 3)),
                        np.full((layouts, uavs, 2), 0.25), np.ones((layouts, users)),
                        np.ones(layouts, dtype=np.int64), np.ones(layouts, dtype=bool), 1.5)


@pytest.mark.parametrize("content", ["garbage", "other shape", "other dtype", "pickled"])
def test_a_broken_file_is_searched_again_and_rewritten(cache, content):
    key = "k" * 64
    path = cache / "searches" / f"{key}.npz"
    path.parent.mkdir(parents=True)
    arrays = {name: np.asarray(getattr(_search(), name)) for name in FIELDS}
    if content == "garbage":
        path.write_bytes(b"not an npz file")
    elif content == "pickled":     # an object array loads only through pickle: refused
        np.savez(path, **(arrays | {"rate_bps": np.array([{"x": 1}, None], dtype=object)}))
    else:
        changed = (np.zeros((3, 4)) if content == "other shape"
                   else np.zeros((2, 4), dtype=np.float32))
        np.savez(path, **(arrays | {"rate_bps": changed}))
    assert search_cache.read_search(key, 2, 1, 4) is None
    assert search_cache.write_search(key, _search()) == path
    assert _same(search_cache.read_search(key, 2, 1, 4), _search())
    assert search_cache.read_search(key, 2, 2, 4) is None        # not of two UAVs


def test_off_or_unwritable_the_search_runs_as_before(tmp_path, monkeypatch):
    monkeypatch.setenv(search_cache.CACHE_ENV, "off")
    assert search_cache.cache_folder() is None
    assert search_cache.write_search("k", _search()) is None
    blocked = tmp_path / "a file"
    blocked.write_text("not a folder")
    monkeypatch.setenv(search_cache.CACHE_ENV, str(blocked))
    assert search_cache.write_search("k", _search()) is None
    assert search_cache.read_search("k", 2, 1, 4) is None
    assert list(tmp_path.iterdir()) == [blocked]


def test_default_folder_is_xdg_cache_home(tmp_path, monkeypatch):
    monkeypatch.delenv(search_cache.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert search_cache.cache_folder() == tmp_path / "adaptsky"


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
