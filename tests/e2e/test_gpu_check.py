"""scripts/gpu_check.sh: its dry run lists the GPU checks without running or writing
anything; a wrong option is one line. (The checks themselves need an NVIDIA GPU.)"""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import ROOT

SCRIPT = ROOT / "scripts" / "gpu_check.sh"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", str(SCRIPT), *args], capture_output=True, text=True,
                          cwd=ROOT, check=False, timeout=60)


def test_the_dry_run_lists_every_step_and_writes_nothing(tmp_path):
    out = tmp_path / "gpu.md"
    done = run("--dry-run", "--out", str(out))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[0].startswith(f"gpu_check: would write {out}")
    steps = lines[1:]
    assert [line.split(".")[0].strip() for line in steps] == [str(n) for n in range(1, 9)]
    text = "\n".join(steps)
    assert "test_gpu.py" in text
    assert "train_throughput.py --device cuda --seeds 1,8,64,256,1024" in text
    assert "--seeds 0 " in steps[2] and "--seeds 0,1,2," in steps[3] and ",63 " in steps[3]
    assert "reproduce e2 --device cuda" in steps[4]
    # the new learners' stacks (issue 39): PPO, SAC on continuous controls, MAPPO
    for step, learner in zip(steps[5:], ("ppo", "sac", "mappo"), strict=True):
        assert "--device cuda --seeds 0,1,2," in step and f'algorithm="{learner}"' in step
    assert 'uav.actions="continuous"' in steps[6] and "two_uavs_mmwave" in steps[7]
    assert not out.exists()


def test_only_keeps_the_named_steps():
    done = run("--dry-run", "--only", "2,5")
    assert [line.split(".")[0].strip() for line in done.stdout.splitlines()[1:]] == ["2", "5"]


def test_a_wrong_option_is_one_line_and_exit_2():
    done = run("--fast")
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip().splitlines() == [
        "gpu_check.sh: unknown option '--fast'; allowed: --dry-run, --out FILE, --only N,..."]


def test_python_m_adaptsky_cli_is_the_command():
    done = subprocess.run([sys.executable, "-m", "adaptsky_cli",
                           "scenario", "validate", str(ROOT / "scenarios" / "nyc_mmwave.toml")],
                          capture_output=True, text=True, check=False, timeout=120)
    assert done.returncode == 0 and done.stdout.startswith("ok")
