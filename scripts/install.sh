#!/usr/bin/env bash
# Create a virtual environment and install adaptsky with its test tools and the example
# channel plugin. Usage: scripts/install.sh [--cpu | --cuda] [--dry-run]   (docs/install.md)
#
#   --cpu      the CPU build of torch (about 200 MB, no CUDA packages): a +cpu wheel from pip's
#              find-links if one is there (as on the project's CI machines), else PyTorch's CPU
#              index https://download.pytorch.org/whl/cpu
#   --cuda     torch from your package index as usual (PyPI's Linux torch bundles CUDA: several GB)
#   --dry-run  print the commands instead of running them
#
# Without --cpu or --cuda: a +cpu wheel in pip's find-links if there is one, else --cuda where
# an NVIDIA driver is visible (nvidia-smi on PATH), else --cpu. torch is never pinned: the
# newest build that fits is installed. PYTHON (default python3) and VENV (default .venv)
# choose the interpreter and the environment's folder. Each of the four stages (the
# environment, torch, adaptsky with its test tools, the example plugin) says on stderr what it
# does and how long it took, and every INSTALL_HEARTBEAT_S seconds (default 15) while it runs
# the time so far and pip's latest step (from its log); pip itself is quiet.
set -euo pipefail
cd "$(dirname "$0")/.."
python=${PYTHON:-python3}
venv=${VENV:-.venv}
CPU_INDEX=https://download.pytorch.org/whl/cpu

usage() { sed -n '2,17s/^# \{0,1\}//p' "$0"; }
mode="" dry_run=""
for arg in "$@"; do
  case "$arg" in
    --cpu | --cuda)
      if [ -n "$mode" ] && [ "$mode" != "${arg#--}" ]; then
        echo "install.sh: --cpu and --cuda exclude each other; give one of them" >&2; exit 2
      fi
      mode=${arg#--} ;;
    --dry-run) dry_run=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "install.sh: unknown option '$arg'; allowed: --cpu, --cuda, --dry-run, --help" >&2
       exit 2 ;;
  esac
done

# "3.11.9 cp311": the version, and the wheel tag of a torch build for it
if ! version=$("$python" -c 'import platform, sys; v = sys.version_info
print(platform.python_version(), f"cp{v[0]}{v[1]}"); sys.exit(v < (3, 11))' 2>/dev/null); then
  echo "install.sh: PYTHON=$python${version:+ is Python ${version% *}}: adaptsky needs Python" \
       "3.11 or newer; set PYTHON to one" >&2
  exit 1
fi
tag=${version#* }

run() {  # run a command, or only print it with --dry-run
  if [ -n "$dry_run" ]; then printf '%s\n' "$*"; else "$@"; fi
}

stages=4 stage=0 started=$SECONDS
heartbeat_s=${INSTALL_HEARTBEAT_S:-15}
took() {  # seconds as "42 s" or "2 min 5 s"
  if (($1 < 60)); then echo "$1 s"; else echo "$(($1 / 60)) min $(($1 % 60)) s"; fi
}
steps='Collecting|Processing|Obtaining|Downloading|Building|Preparing|Installing|Getting requirements'
latest_step() {  # pip's latest step in its verbose log: "Collecting h5py>=3.10", ...
  local line commas
  line=$(grep -E "^[^ ]+ ($steps)" "$1" 2>/dev/null | tail -n 1 | cut -d' ' -f2-) || true
  case $line in
    "Installing collected packages: "*)  # a list of dozens: how many
      commas=${line//[^,]/}
      line="Installing $((${#commas} + 1)) collected package"
      [ -z "$commas" ] || line+="s" ;;
  esac
  printf '%s\n' "${line:0:100}"
}
heartbeat() {  # heartbeat START LOG: every heartbeat_s seconds, the time so far and pip's step
  local sleeper="" step
  trap '[ -z "$sleeper" ] || kill "$sleeper" 2>/dev/null; exit 0' TERM
  while :; do
    sleep "$heartbeat_s" & sleeper=$!
    wait "$sleeper"
    step=$(latest_step "$2")
    echo "install: [$stage/$stages] $(took $((SECONDS - $1))) so far${step:+: $step}" >&2
  done
}
# run a command with a heartbeat on stderr and pip's verbose log (PIP_LOG; with a log pip would
# draw its download bars even with -q: off)
run_beating() {
  local log status=0 beat
  log=$(mktemp "${TMPDIR:-/tmp}/adaptsky-install-pip.XXXXXX")
  heartbeat "$SECONDS" "$log" &
  beat=$!
  PIP_LOG=$log PIP_PROGRESS_BAR=off "$@" || status=$?
  kill "$beat" 2>/dev/null || true
  wait "$beat" 2>/dev/null || true
  rm -f "$log"
  return "$status"
}
stage() {  # stage WHAT COMMAND...: a line saying WHAT, the command, a line with its time
  local what=$1 start=$SECONDS status=0
  shift
  stage=$((stage + 1))
  echo "install: [$stage/$stages] $what" >&2
  if [ -n "$dry_run" ]; then run "$@"; else run_beating "$@" || status=$?; fi
  if [ "$status" -ne 0 ]; then
    echo "install: [$stage/$stages] failed after $(took $((SECONDS - start))) (exit code" \
         "$status; the reason is above)" >&2
    exit "$status"
  fi
  [ -n "$dry_run" ] || echo "install: [$stage/$stages] done in $(took $((SECONDS - start)))" >&2
}

stage "creating the virtual environment in $venv" "$python" -m venv "$venv"
# with --dry-run the environment does not exist: ask the interpreter it would be made from
probe=$venv/bin/python
[ -n "$dry_run" ] && probe=$python
pip=("$venv/bin/python" -m pip --disable-pip-version-check -q)

# the newest CPU wheel of torch for this interpreter in pip's find-links, if any
find_links="${PIP_FIND_LINKS:-} $("$probe" -m pip config get global.find-links 2>/dev/null || true)"
cpu_wheel=""
for dir in $find_links; do
  dir=${dir#file://}
  [ -d "$dir" ] || continue
  cand=$(ls "$dir"/torch-*+cpu-"$tag"-*.whl 2>/dev/null | sort -V | tail -n 1 || true)
  [ -n "$cand" ] && cpu_wheel=$cand
done

if [ -z "$mode" ]; then
  if [ -n "$cpu_wheel" ]; then
    mode=cpu reason="a CPU build of torch is in pip's find-links"
  elif command -v nvidia-smi >/dev/null 2>&1; then
    mode=cuda reason="nvidia-smi found an NVIDIA driver"
  else
    mode=cpu reason="no NVIDIA driver visible (no nvidia-smi)"
  fi
  echo "install: torch for ${mode^^}: $reason (choose with --cpu or --cuda)" >&2
fi

if [ "$mode" = cpu ] && [ -n "$cpu_wheel" ]; then
  stage "torch, the CPU build at $cpu_wheel" "${pip[@]}" install "$cpu_wheel"
elif [ "$mode" = cpu ]; then
  stage "torch, the CPU build from $CPU_INDEX" "${pip[@]}" install torch --index-url "$CPU_INDEX"
else
  stage "torch from your package index (with CUDA: several GB)" "${pip[@]}" install torch
fi
# torch is installed already, so its requirement is met and pip installs no other build
stage "adaptsky and its test tools (editable, with the dev extras)" \
  "${pip[@]}" install -e ".[dev]"
stage "the example channel plugin (plugins/example_channel, editable)" \
  "${pip[@]}" install -e plugins/example_channel
if [ -z "$dry_run" ]; then
  echo "install: done in $(took $((SECONDS - started))); activate with 'source" \
       "$venv/bin/activate', then run 'adaptsky --help' (or run $venv/bin/adaptsky directly)"
fi
