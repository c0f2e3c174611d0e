#!/usr/bin/env bash
# The GPU checks of adaptsky in one command, for a machine with an NVIDIA GPU (an H100 or H200:
# about 8 minutes), its results as a markdown table in a file.
# Usage: scripts/gpu_check.sh [--dry-run] [--out FILE] [--only N[,N...]]
#
#   --dry-run  list the steps and what they run; run and write nothing
#   --out      the markdown file to write (default: docs/results/gpu-check-<UTC date>.md)
#   --only     run only these steps (numbers from --dry-run)
#
# The steps: the GPU tests; the stacked-training throughput at 1 to 1024 seeds; 64 seeds of
# the paper's full-length training against one; E2 at full length (48 runs in one stack).
# PYTHON (default: .venv/bin/python if there is one, else python3) runs them. adaptsky needs
# no install: the repository and its built-in channel models go on PYTHONPATH, with their entry
# points declared beside them. Missing Python packages (pydantic, gymnasium, tomli-w,
# distributed, ...) are installed from wheels in .whl/ (an ignored folder) where they are
# there, and named where they are not.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
dry_run="" only="" out="docs/results/gpu-check-$(date -u +%Y-%m-%d).md"
while [ $# -gt 0 ]; do
  case "$1" in
    --dry-run) dry_run=1 ;;
    --out) out=${2:?--out needs a file}; shift ;;
    --only) only=",${2:?--only needs step numbers},"; shift ;;
    -h | --help) sed -n '2,17s/^# \{0,1\}//p' "$0"; exit 0 ;;
    *) echo "gpu_check.sh: unknown option '$1'; allowed: --dry-run, --out FILE, --only N,..." >&2
       exit 2 ;;
  esac
  shift
done
python=${PYTHON:-}
if [ -z "$python" ]; then
  if [ -x .venv/bin/python ]; then python=.venv/bin/python; else python=python3; fi
fi
seeds64=$(seq -s, 0 63)
steps=(
  "GPU tests|$python -m pytest -q -p no:cacheprovider -m 'not slow' $(find tests -name test_gpu.py | head -n 1)"
  "stacked training throughput|$python benchmarks/train_throughput.py --device cuda --seeds 1,8,64,256,1024"
  "one paper-length seed (1000 x 300)|$python -m adaptsky_cli train scenarios/nyc_mmwave.toml --device cuda --seeds 0 --workers 1 --quiet --out /tmp/gpu-check/one.h5"
  "64 paper-length seeds in one stack|$python -m adaptsky_cli train scenarios/nyc_mmwave.toml --device cuda --seeds $seeds64 --quiet --out /tmp/gpu-check/sixty-four.h5"
  "E2 at full length (48 runs, one stack)|$python -m adaptsky_cli reproduce e2 --device cuda --quiet --out /tmp/gpu-check/e2"
  "PPO, 64 seeds in one stack (100 episodes)|$python -m adaptsky_cli train scenarios/nyc_mmwave.toml --device cuda --seeds $seeds64 --episodes 100 --set 'agent={algorithm=\"ppo\"}' --quiet --out /tmp/gpu-check/ppo.h5"
  "SAC on continuous controls, 64 seeds in one stack (50 episodes)|$python -m adaptsky_cli train scenarios/nyc_mmwave.toml --device cuda --seeds $seeds64 --episodes 50 --set 'uav.actions=\"continuous\"' --set 'agent={algorithm=\"sac\"}' --quiet --out /tmp/gpu-check/sac.h5"
  "MAPPO on two UAVs, 64 seeds in one stack (100 episodes)|$python -m adaptsky_cli train scenarios/two_uavs_mmwave.toml --device cuda --seeds $seeds64 --episodes 100 --set 'agent={algorithm=\"mappo\"}' --quiet --out /tmp/gpu-check/mappo.h5"
)

if [ -n "$dry_run" ]; then
  echo "gpu_check: would write $out with these steps (PYTHON=$python):"
  for index in "${!steps[@]}"; do
    number=$((index + 1))
    [ -n "$only" ] && [[ "$only" != *",$number,"* ]] && continue
    echo "  $number. ${steps[$index]%%|*}: ${steps[$index]#*|}"
  done
  exit 0
fi

# ---- Python packages: what is missing, from .whl/ where it is there --------------------------
missing=$("$python" - <<'PY'
import importlib.util
names = {"pydantic": "pydantic", "gymnasium": "gymnasium", "tomli_w": "tomli-w",
         "distributed": "distributed", "typer": "typer", "rich": "rich", "h5py": "h5py",
         "threadpoolctl": "threadpoolctl", "matplotlib": "matplotlib", "torch": "torch",
         "pettingzoo": "pettingzoo"}
print(" ".join(pkg for module, pkg in names.items() if importlib.util.find_spec(module) is None))
PY
)
site=/tmp/gpu-check/site
mkdir -p "$site"
if [ -n "$missing" ]; then
  if ls .whl/*.whl >/dev/null 2>&1; then
    echo "gpu_check: installing from .whl/ for the missing: $missing" >&2
    "$python" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
      --target "$site" .whl/*.whl || { echo "gpu_check: the wheels in .whl/ did not install" >&2; exit 1; }
  else
    echo "gpu_check: missing Python packages: $missing; put their wheels (and their" \
         "dependencies') for this Python in .whl/ (docs/training.md, GPU check)" >&2
    exit 1
  fi
fi
# adaptsky from this checkout: its entry points (the built-in channel models) as metadata
"$python" - "$site" <<'PY'
import pathlib, sys, tomllib
project = tomllib.loads(pathlib.Path("pyproject.toml").read_text())["project"]
info = pathlib.Path(sys.argv[1]) / f"adaptsky-{project['version']}.dist-info"
info.mkdir(parents=True, exist_ok=True)
(info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: adaptsky\nVersion: {project['version']}\n")
groups = project.get("entry-points", {})
(info / "entry_points.txt").write_text("".join(
    f"[{group}]\n" + "".join(f"{name} = {target}\n" for name, target in points.items()) + "\n"
    for group, points in groups.items()))
PY
export PYTHONPATH="$site:$root:$root/plugins/builtin${PYTHONPATH:+:$PYTHONPATH}"
export PYTHONUNBUFFERED=1

mkdir -p "$(dirname "$out")" /tmp/gpu-check
log=/tmp/gpu-check/log.txt
: > "$log"
rows=()
for index in "${!steps[@]}"; do
  number=$((index + 1))
  [ -n "$only" ] && [[ "$only" != *",$number,"* ]] && continue
  name=${steps[$index]%%|*} command=${steps[$index]#*|}
  echo "== $number. $name: $command" | tee -a "$log"
  start_ms=$(( $(date +%s%N) / 1000000 ))
  bash -c "$command" 2>&1 | tee -a "$log" | tail -n 40 > "/tmp/gpu-check/step-$number.txt"
  status=${PIPESTATUS[0]}
  elapsed_ms=$(( $(date +%s%N) / 1000000 - start_ms ))
  seconds=$(printf '%d.%d' $((elapsed_ms / 1000)) $((elapsed_ms % 1000 / 100)))
  rows+=("| $number | $name | $([ "$status" = 0 ] && echo ok || echo "failed ($status)") | $seconds |")
done

{
  echo "# GPU check, $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo
  gpu=$(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader \
        2>/dev/null | head -n 1)
  echo "Machine: ${gpu:-no NVIDIA GPU seen by nvidia-smi}; Python" \
       "$("$python" -c 'import platform; print(platform.python_version())'), torch" \
       "$("$python" -c 'import torch; print(torch.__version__)' 2>/dev/null); commit" \
       "$(git rev-parse --short HEAD 2>/dev/null || echo unknown). Command:" \
       "\`scripts/gpu_check.sh${only:+ --only ${only:1:-1}}\`."
  echo
  echo "| step | what | result | wall time (s) |"
  echo "|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
  for file in /tmp/gpu-check/step-*.txt; do
    echo
    echo "## Step ${file##*step-}" | sed 's/\.txt$//'
    echo
    echo '```'
    cat "$file"
    echo '```'
  done
} > "$out"
echo "gpu_check: wrote $out (full log: $log)"
