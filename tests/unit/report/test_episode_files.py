"""``adaptsky show`` on a small run file and a small eval file made here: PNG, PDF, SVG, GIF
and MP4 files opened and measured (pixel sizes, pages, the SVG root, frame counts), the
episode drawn being eval's rollout of the policy, and every mistake one line, exit code 1 and
no file written; an eval file of two UAVs."""

from __future__ import annotations

import math
import re
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import h5py
import numpy as np
import pytest
from PIL import Image

from adaptsky.drawing.episode_figure import BLOCK_IN, EpisodeFigure
from adaptsky.evaluation.api import baseline
from adaptsky.evaluation.show import run_episode
from adaptsky.report.episodes import episode_of, eval_episodes
from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.scenario.variants import eval_scenario
from adaptsky.store.eval_file import write_eval
from adaptsky_cli.cli.main import main
from tests.helpers.evaluation import small_two_uavs

DPI = 40
WIDTH, HEIGHT = int(BLOCK_IN[0] * DPI), int(BLOCK_IN[1] * DPI)
EVAL_STEPS = 12


def _lines(capsys: pytest.CaptureFixture[str]) -> list[str]:
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return captured.err.strip().splitlines()


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    lines = _lines(capsys)
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture(scope="module")
def eval_file(tiny_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """eval of the tiny run's policy beside SoA and random, 12 steps on its layout."""
    path = tmp_path_factory.mktemp("show") / "eval.h5"
    assert main(["eval", str(tiny_run), "--steps", str(EVAL_STEPS), "--compare", "soa,random",
                 "--out", str(path), "--json"]) == 0
    return path


def _pdf_pages(data: bytes) -> int:
    return len(re.findall(rb"/Type\s*/Page\b", data))


def _check_files(folder: Path, blocks: int, frames: int) -> None:
    """The figure in three formats and the GIF, opened and measured."""
    with Image.open(folder / "fig.png") as png:
        assert png.format == "PNG" and png.size == (WIDTH, blocks * HEIGHT)
    pdf = (folder / "fig.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and _pdf_pages(pdf) == 1
    root = ElementTree.parse(folder / "fig.svg").getroot()
    assert root.tag.endswith("svg")
    with Image.open(folder / "episode.gif") as gif:
        assert gif.format == "GIF" and gif.size == (WIDTH, blocks * HEIGHT)
        assert gif.n_frames == frames


def _show(source: Path, folder: Path, *extra: str) -> list[list[str]]:
    calls = [["--out", str(folder / "fig.png"), "--animate", str(folder / "episode.gif")],
             ["--out", str(folder / "fig.pdf")], ["--out", str(folder / "fig.svg")]]
    return [["show", str(source), *call, "--dpi", str(DPI), "--quiet", *extra]
            for call in calls]


def test_show_a_run_file_in_every_format(tiny_run, tmp_path, capsys):
    for argv in _show(tiny_run, tmp_path, "--every", "2"):
        assert main(argv) == 0
    lines = _lines(capsys)
    # the tiny run evaluated nothing during training: its last policy, said once per call
    assert lines[:3] == [
        f"{tiny_run}: seed 0 has no best policy (no greedy evaluation during training); "
        "showing its last policy (episode 2)", f"figure: {tmp_path / 'fig.png'}",
        f"animation: {tmp_path / 'episode.gif'} (3 frames)"]
    _check_files(tmp_path, blocks=1, frames=math.ceil(5 / 2))  # train.steps 5, every 2


def test_show_an_eval_file_in_every_format(eval_file, tmp_path, capsys):
    for argv in _show(eval_file, tmp_path, "--every", "5", "--method", "random"):
        assert main(argv) == 0
    assert _lines(capsys)[:2] == [f"figure: {tmp_path / 'fig.png'}",
                                  f"animation: {tmp_path / 'episode.gif'} (3 frames)"]
    _check_files(tmp_path, blocks=2, frames=math.ceil(EVAL_STEPS / 5))  # policy over random


def test_a_run_file_s_episode_is_eval_s_rollout_of_the_policy(tiny_run, eval_file):
    scenario, episode, _ = run_episode(tiny_run, steps=EVAL_STEPS)
    with h5py.File(eval_file, "r") as file:
        stored = {name: file[f"methods/policy/trajectory/{name}"][:, 0]
                  for name in ("uav_m", "alpha", "rate_bps", "energy_j")}
    assert episode.uav_m.shape == (EVAL_STEPS, 1, 3)
    assert np.array_equal(episode.uav_m[:, 0], stored["uav_m"])
    assert np.array_equal(episode.alpha, stored["alpha"])
    assert np.array_equal(episode.rate_bps, stored["rate_bps"])
    # the power panel: each step's energy over its duration (docs/model.md §10)
    assert np.array_equal(episode.power_w[:, 0], stored["energy_j"] / scenario.uav.step_s)
    assert episode.pairs() == [(0, 0, [0, 1]), (0, 1, [2, 3])]  # the paper's listed pairs
    assert episode.los is None and scenario.channel.los == "always"


def test_an_eval_file_gives_the_policy_over_the_first_baseline(eval_file):
    _, (policy, soa) = eval_episodes(eval_file)
    assert policy.label == "policy of seed 0: last (episode 2), layout 0"
    assert soa.label == "soa, layout 0" and soa.held and not policy.held
    with h5py.File(eval_file, "r") as file:
        energy_j = file["methods/policy/trajectory/energy_j"][:, 0]
    assert np.array_equal(policy.power_w[:, 0], energy_j)   # steps of 1 s: W = J
    assert soa.power_w is not None and np.all(soa.power_w > 168.0)  # SoA hovers
    _, (_, first_rows) = eval_episodes(eval_file, method="random", steps=4)
    assert first_rows.steps == 4 and first_rows.label == "random, layout 0"


def test_mp4_where_imageio_ffmpeg_is_installed(tiny_run, tmp_path, capsys):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="MP4 needs the video extra: "
                                                                  "pip install 'adaptsky[video]'")
    video = tmp_path / "episode.mp4"
    assert main(["show", str(tiny_run), "--animate", str(video), "--dpi", str(DPI),
                 "--quiet"]) == 0
    assert _lines(capsys)[-1] == f"animation: {video} (5 frames)"
    assert video.read_bytes()[4:8] == b"ftyp"
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(video))
    assert frames == 5
    assert [path.name for path in tmp_path.iterdir()] == ["episode.mp4"]  # no copy left


def test_mp4_without_imageio_ffmpeg_is_one_line_and_no_file(tiny_run, tmp_path, capsys,
                                                           monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if not installed
    video, figure = tmp_path / "episode.mp4", tmp_path / "fig.png"
    assert main(["show", str(tiny_run), "--out", str(figure), "--animate", str(video)]) == 1
    assert one_line(capsys) == (f"--animate {video}: an MP4 needs imageio-ffmpeg, which is "
                                "not installed; install it with pip install 'adaptsky[video]', "
                                "or write a .gif")
    assert list(tmp_path.iterdir()) == []  # refused before any work: not even the figure


@pytest.mark.parametrize(("option", "name", "expected"), [
    ("--out", "fig.jpg", "a figure file must end in .png, .pdf or .svg (it has '.jpg')"),
    ("--out", "fig", "a figure file must end in .png, .pdf or .svg (it has no suffix)"),
    ("--animate", "episode.webm", "an animation file must end in .gif or .mp4 (it has "
                                  "'.webm')"),
])
def test_a_bad_suffix_is_one_line_and_no_file(tiny_run, tmp_path, capsys, option, name,
                                              expected):
    path = tmp_path / name
    assert main(["show", str(tiny_run), option, str(path)]) == 1
    assert one_line(capsys) == f"{option} {path}: {expected}"
    assert list(tmp_path.iterdir()) == []


def test_bad_choices_name_what_exists(tiny_run, eval_file, tmp_path, capsys):
    figure = tmp_path / "fig.png"
    cases = [
        ([str(tiny_run), "--seed", "7"], f"{tiny_run}: has no seed 7; it has 0, 1"),
        ([str(tiny_run), "--layout", "1"], f"--layout: {tiny_run} is a run file; --layout and "
                                           "--method choose what an eval file holds"),
        ([str(eval_file), "--layout", "3"], f"--layout 3: {eval_file} holds 1 layout: 0"),
        ([str(eval_file), "--method", "oracle"],
         f"--method oracle: not in it; {eval_file} holds soa, random"),
        ([str(eval_file), "--method", "policy"],
         f"--method policy: the policy itself; {eval_file} holds soa, random"),
        ([str(eval_file), "--seed", "0"],
         f"--seed: {eval_file} is an eval file; --seed and --policy choose a run file's policy "
         "(an eval file holds one)"),
        ([str(tmp_path / "missing.h5")], f"{tmp_path / 'missing.h5'}: no such run file"),
    ]
    for argv, expected in cases:
        assert main(["show", *argv, "--out", str(figure), "--quiet"]) == 1, argv
        assert one_line(capsys) == expected
        assert not figure.exists()
    # what the command line alone gets wrong is a usage error (exit 2, issue 52)
    assert main(["show", str(tiny_run), "--policy", "worst", "--out", str(figure)]) == 2
    assert one_line(capsys) == ("adaptsky show: --policy: unknown policy 'worst'; choose from "
                                "best, last; see 'adaptsky show --help'")
    assert main(["show", str(tiny_run)]) == 2
    assert one_line(capsys) == ("adaptsky show: nothing to write: give --out FIG.png (.pdf, "
                                ".svg), --animate FILE.gif (.mp4), or both; see 'adaptsky show "
                                "--help'")


def test_an_eval_file_of_two_uavs_draws_both_and_their_users(tmp_path, capsys):
    """An eval file of SoA per UAV alone (written here, no policy): every UAV's position as
    stored (T, L, U, 3), each user's serving UAV from the association on the layout."""
    scenario = small_two_uavs(tmp_path)
    results, methods = baseline(scenario_path=scenario, method="soa", layouts=2, steps=6)
    evaluated = eval_scenario(load_scenario(scenario), 2, 0)  # as eval stores it
    results["scenario_toml"] = dumps(evaluated.model_dump(mode="json"))
    path = tmp_path / "soa.h5"
    write_eval(path, results, methods)
    _, (episode,) = eval_episodes(path, layout=1)
    assert episode.label == "soa, layout 1" and episode.held
    assert np.array_equal(episode.uav_m, methods[0].trace.uav_m[:, 1])
    assert sorted(np.bincount(episode.serving_uav).tolist()) == [2, 2]  # two users per UAV
    figure = tmp_path / "soa.png"
    assert main(["show", str(path), "--layout", "1", "--out", str(figure), "--dpi",
                 str(DPI)]) == 0
    assert _lines(capsys) == [f"figure: {figure}"]
    with Image.open(figure) as png:
        assert png.size == (WIDTH, HEIGHT)


def test_a_propulsion_power_goes_into_the_episode_and_its_panel(tiny_run, tmp_path):
    """The hook for a propulsion-energy model: a (T, U) power in W, a synthetic one here."""
    scenario, episode, _ = run_episode(tiny_run, steps=6)
    power_w = np.linspace(100.0, 160.0, 6)[:, None]
    powered = episode_of(scenario, episode.users_m, episode.uav_m, episode.alpha,
                         episode.rate_bps, power_w=power_w)
    figure = EpisodeFigure([powered], side_m=scenario.area.side_m, dpi=DPI)
    png = tmp_path / "powered.png"
    png.write_bytes(figure.save("png"))
    panel = figure.blocks[0].panels[-1]
    assert panel.axes.get_ylabel() == "propulsion\npower $P$ (W)"
    assert np.array_equal(panel.line(0)[1], power_w[:, 0])
    with Image.open(png) as image:
        assert image.size == (WIDTH, HEIGHT)


def test_files_made_before_the_energy_are_shown_without_a_power_panel(eval_file, tmp_path,
                                                                      capsys):
    """A run file of format 2 (tests/data/legacy) and an eval file without the energy (as
    eval files were before it) give every picture; only the power panel is left out."""
    from tests.helpers.run_files import LEGACY

    legacy = tmp_path / "format2.h5"
    legacy.write_bytes((LEGACY / "format2-4b487ea.h5").read_bytes())
    _, episode, _ = run_episode(legacy, steps=6)
    # a legacy run is rolled out by today's code: the episode has its power
    assert episode.power_w is not None and episode.power_w.shape == (6, 1)
    old_eval = tmp_path / "old-eval.h5"
    old_eval.write_bytes(eval_file.read_bytes())
    with h5py.File(old_eval, "a") as file:
        for group in file["methods"].values():
            del group["trajectory/energy_j"]
            for name in ("energy_j", "steady_power_w", "energy_efficiency_bpj",
                         "steady_energy_efficiency_bpj", "steady_still_share",
                         "steady_vertical_share"):
                del group[name]
    _, (policy, soa) = eval_episodes(old_eval)
    assert policy.power_w is None and soa.power_w is None
    for source, folder in ((legacy, tmp_path / "run"), (old_eval, tmp_path / "eval")):
        folder.mkdir()
        for argv in _show(source, folder, "--every", "5", "--steps", "10"):
            assert main(argv) == 0
        _check_files(folder, blocks=1 if source == legacy else 2, frames=2)
    capsys.readouterr()
