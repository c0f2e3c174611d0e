"""scripts/install.sh's choice of torch build (checked with --dry-run) and the packaging:
``import adaptsky`` and what the wheel ships."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import adaptsky
import adaptsky_cli
from tests.conftest import ROOT

SCRIPT = ROOT / "scripts" / "install.sh"
CPU_INDEX = "https://download.pytorch.org/whl/cpu"
# a dry run must create nothing: the environment it names stays absent (checked after each)
VENV = Path("/nonexistent/adaptsky-dry-run-venv")
PIP = f"{VENV}/bin/python -m pip --disable-pip-version-check -q install"
PROJECT = [f"{PIP} -e .[dev]", f"{PIP} -e plugins/example_channel"]


def _path_without_nvidia_smi(extra: Path | None = None) -> str:
    folders = [folder for folder in os.environ["PATH"].split(os.pathsep)
               if not (Path(folder) / "nvidia-smi").exists()]
    return os.pathsep.join(([str(extra)] if extra else []) + folders)


def _install(*flags: str, find_links: Path | None = None, nvidia: Path | None = None,
             python: str = sys.executable) -> subprocess.CompletedProcess[str]:
    """install.sh --dry-run with only ``find_links`` as pip's find-links (no config files)."""
    env = dict(os.environ, PIP_CONFIG_FILE=os.devnull, PIP_FIND_LINKS=str(find_links or ""),
               PATH=_path_without_nvidia_smi(nvidia), PYTHON=python, VENV=str(VENV))
    result = subprocess.run(["bash", str(SCRIPT), "--dry-run", *flags], env=env, text=True,
                            capture_output=True, timeout=60)
    assert not VENV.exists()
    return result


def _commands(result: subprocess.CompletedProcess[str]) -> list[str]:
    assert result.returncode == 0, result.stderr
    return result.stdout.splitlines()


@pytest.fixture
def cpu_wheels(tmp_path: Path) -> Path:
    """A find-links folder with two CPU builds of torch (and one for another Python)."""
    tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    for name in (f"torch-2.9.1+cpu-{tag}-{tag}-manylinux_2_28_x86_64.whl",
                 f"torch-2.10.0+cpu-{tag}-{tag}-manylinux_2_28_x86_64.whl",
                 "torch-2.99.0+cpu-cp27-cp27-manylinux_2_28_x86_64.whl"):
        (tmp_path / name).touch()
    return tmp_path


def test_default_prefers_the_newest_cpu_wheel_in_find_links(cpu_wheels):
    # the CI path: the find-links build goes in first, so pip downloads no CUDA torch
    tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    wheel = cpu_wheels / f"torch-2.10.0+cpu-{tag}-{tag}-manylinux_2_28_x86_64.whl"
    assert _commands(_install(find_links=cpu_wheels)) == [
        f"{sys.executable} -m venv {VENV}", f"{PIP} {wheel}", *PROJECT]


def test_default_without_a_driver_installs_torch_from_pytorchs_cpu_index():
    result = _install()
    assert _commands(result)[1:] == [f"{PIP} torch --index-url {CPU_INDEX}", *PROJECT]
    assert "torch for CPU: no NVIDIA driver visible" in result.stderr


def test_default_with_a_driver_installs_torch_from_the_index(tmp_path):
    (tmp_path / "nvidia-smi").write_text("#!/bin/sh\n")
    (tmp_path / "nvidia-smi").chmod(0o755)
    result = _install(nvidia=tmp_path)
    assert _commands(result)[1:] == [f"{PIP} torch", *PROJECT]
    assert "torch for CUDA: nvidia-smi found an NVIDIA driver" in result.stderr


def test_cpu_flag_uses_the_cpu_index_where_find_links_has_no_wheel():
    assert _commands(_install("--cpu"))[1:] == [f"{PIP} torch --index-url {CPU_INDEX}",
                                                *PROJECT]


def test_cuda_flag_ignores_a_cpu_wheel_in_find_links(cpu_wheels):
    assert _commands(_install("--cuda", find_links=cpu_wheels))[1:] == [f"{PIP} torch",
                                                                        *PROJECT]


def test_each_stage_says_what_it_does_before_its_command(cpu_wheels):
    # two minutes of pip -q were three lines; now a line per stage, and its time when run
    tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    wheel = cpu_wheels / f"torch-2.10.0+cpu-{tag}-{tag}-manylinux_2_28_x86_64.whl"
    result = _install(find_links=cpu_wheels)
    assert _commands(result) == [f"{sys.executable} -m venv {VENV}", f"{PIP} {wheel}", *PROJECT]
    stages = [line for line in result.stderr.splitlines() if line.startswith("install: [")]
    assert stages == [
        f"install: [1/4] creating the virtual environment in {VENV}",
        f"install: [2/4] torch, the CPU build at {wheel}",
        "install: [3/4] adaptsky and its test tools (editable, with the dev extras)",
        "install: [4/4] the example channel plugin (plugins/example_channel, editable)"]
    assert "done in" not in result.stderr  # a dry run times nothing


def test_a_stage_run_says_its_time_and_a_failing_one_where_it_stopped(tmp_path):
    """A real run with a stand-in interpreter: every stage times itself, and the first that
    fails ends the install with its exit code and one line naming it."""
    python = tmp_path / "python"
    # a "python" whose venv and pip succeed, except the install of the example plugin
    python.write_text('#!/bin/bash\nif [ "$1" = -c ]; then echo "3.11.9 cp311"; exit 0; fi\n'
                      'if [ "$2" = venv ]; then mkdir -p "$3/bin" && ln -s "$0" "$3/bin/python";'
                      ' exit 0; fi\n'
                      'case "$*" in *plugins/example_channel*) echo "pip: no network" >&2;'
                      ' exit 3;; esac\nexit 0\n')
    python.chmod(0o755)
    env = dict(os.environ, PIP_CONFIG_FILE=os.devnull, PIP_FIND_LINKS="",
               PATH=_path_without_nvidia_smi(), PYTHON=str(python), VENV=str(tmp_path / "v"))
    result = subprocess.run(["bash", str(SCRIPT), "--cpu"], env=env, text=True,
                            capture_output=True, timeout=60)
    assert (result.returncode, result.stdout) == (3, "")
    # a stage of a stand-in takes milliseconds: 0 s, or 1 s where a second's tick falls in it
    assert re.sub(r"(done in|failed after) [01] s", r"\1 0 s", result.stderr).splitlines() == [
        f"install: [1/4] creating the virtual environment in {tmp_path / 'v'}",
        "install: [1/4] done in 0 s",
        f"install: [2/4] torch, the CPU build from {CPU_INDEX}",
        "install: [2/4] done in 0 s",
        "install: [3/4] adaptsky and its test tools (editable, with the dev extras)",
        "install: [3/4] done in 0 s",
        "install: [4/4] the example channel plugin (plugins/example_channel, editable)",
        "pip: no network",
        "install: [4/4] failed after 0 s (exit code 3; the reason is above)"]


def test_a_long_stage_says_every_few_seconds_how_long_so_far_and_what_pip_does(tmp_path):
    """Stage 3 printed nothing for 89 s (issue 52): a heartbeat line every
    INSTALL_HEARTBEAT_S seconds with pip's latest step from its log; no line left behind."""
    python = tmp_path / "python"
    # a "python" whose pip install of .[dev] takes 4 s and logs its steps as pip does
    python.write_text('#!/bin/bash\nif [ "$1" = -c ]; then echo "3.11.9 cp311"; exit 0; fi\n'
                      'if [ "$2" = venv ]; then mkdir -p "$3/bin" && ln -s "$0" "$3/bin/python";'
                      ' exit 0; fi\n'
                      'case "$*" in *dev*) echo "2026-01-01T00:00:00,000 Collecting h5py>=3.10"'
                      ' >> "$PIP_LOG"; sleep 2; echo "2026-01-01T00:00:02,000 Installing '
                      'collected packages: h5py, numpy, rich" >> "$PIP_LOG"; sleep 2;; esac\n'
                      'exit 0\n')
    python.chmod(0o755)
    env = dict(os.environ, PIP_CONFIG_FILE=os.devnull, PIP_FIND_LINKS="",
               PATH=_path_without_nvidia_smi(), PYTHON=str(python), VENV=str(tmp_path / "v"),
               INSTALL_HEARTBEAT_S="1", TMPDIR=str(tmp_path))
    result = subprocess.run(["bash", str(SCRIPT), "--cpu"], env=env, text=True,
                            capture_output=True, timeout=60)
    assert result.returncode == 0, result.stderr
    beats = [line for line in result.stderr.splitlines() if "so far" in line]
    assert beats, result.stderr
    assert all(re.fullmatch(r"install: \[3/4\] [1-9] s so far: (Collecting h5py>=3\.10|"
                            r"Installing 3 collected packages)", line) for line in beats), beats
    assert beats[-1].endswith("Installing 3 collected packages")  # a list: how long it is
    lines = result.stderr.splitlines()
    assert lines.index(beats[0]) > lines.index(
        "install: [3/4] adaptsky and its test tools (editable, with the dev extras)")
    assert not list(tmp_path.glob("adaptsky-install-pip.*"))  # its log is removed


@pytest.mark.parametrize(("flags", "message"), [
    (("--cpu", "--cuda"), "install.sh: --cpu and --cuda exclude each other; give one of them"),
    (("--gpu",), "install.sh: unknown option '--gpu'; allowed: --cpu, --cuda, --dry-run, "
                 "--help"),
])
def test_bad_options_are_one_line_and_exit_2(flags, message):
    result = _install(*flags)
    assert (result.returncode, result.stderr, result.stdout) == (2, message + "\n", "")


def test_a_python_older_than_3_11_is_refused_in_one_line():
    result = _install(python="false")
    assert result.returncode == 1 and result.stdout == ""
    assert result.stderr == ("install.sh: PYTHON=false: adaptsky needs Python 3.11 or newer; "
                             "set PYTHON to one\n")


def test_import_adaptsky_reexports_the_public_api():
    # `import adaptsky` failed: the distribution is adaptsky, the code is in adaptsky_cli
    from adaptsky.envs.gym_env import NomaUavEnv
    from adaptsky.training.api import train

    assert adaptsky.NomaUavEnv is NomaUavEnv and adaptsky.train is train
    assert adaptsky.__version__ == adaptsky_cli.__version__
    aliases = {"NomaUavBatch", "MultiUavBatch"}    # deprecated: they warn on every use
    for name in adaptsky.__all__:
        if name in aliases:
            with pytest.warns(DeprecationWarning, match="use adaptsky.NetworkBatch"):
                assert getattr(adaptsky, name) is adaptsky.NetworkBatch, name
        else:
            assert getattr(adaptsky, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'make'; it exports ENV_ID"):
        adaptsky.make  # noqa: B018


def _fresh_python(code: str) -> str:
    """What ``code`` prints in a new interpreter (imports start from nothing there)."""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=ROOT, timeout=60)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_import_adaptsky_registers_the_env_without_importing_torch():
    assert _fresh_python("import sys, gymnasium, adaptsky; assert 'torch' not in sys.modules; "
                         "assert adaptsky.ENV_ID in gymnasium.registry; print('ok')") == "ok\n"


def test_import_adaptsky_before_gymnasium_registers_the_env_when_gymnasium_comes():
    # import adaptsky no longer imports Gymnasium (0.2 s for every command): the env is
    # registered the moment Gymnasium is imported, and make() works as before
    assert _fresh_python(
        "import sys, adaptsky; assert 'gymnasium' not in sys.modules; import gymnasium; "
        "assert adaptsky.ENV_ID in gymnasium.registry; "
        "print(gymnasium.make(adaptsky.ENV_ID).reset(seed=0)[0].shape)") == "(17,)\n"


def test_the_command_line_starts_without_the_library_s_heavy_imports():
    # adaptsky --help took 0.65-0.9 s here, most of it importing what no help text needs;
    # a command imports the library when it runs
    assert _fresh_python(
        "import sys, adaptsky_cli.cli.main; print(sorted(m for m in ('numpy', 'h5py', "
        "'pydantic', 'gymnasium', 'torch', 'matplotlib') if m in sys.modules))") == "[]\n"


def test_the_wheel_ships_both_packages_and_the_default_scenario():
    wheel = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["hatch"]["build"][
        "targets"]["wheel"]
    assert {"adaptsky_cli", "adaptsky"} <= set(wheel["packages"])
    assert wheel["force-include"]["scenarios"] == "adaptsky/shipped/scenarios"
    assert (ROOT / "scenarios" / "nyc_mmwave.toml").is_file()
