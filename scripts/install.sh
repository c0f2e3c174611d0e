#!/usr/bin/env bash
# Create .venv and install adaptsky with its test tools and the example channel plugin.
#
# Where pip's find-links hold a CPU build of torch (as on the project's CI machines), that
# build is installed first, so the unpinned `torch` requirement is already met and no CUDA
# packages are downloaded. Elsewhere torch comes from your index as usual: nothing is pinned.
set -euo pipefail
cd "$(dirname "$0")/.."
python=${PYTHON:-python3}
venv=${VENV:-.venv}

"$python" -m venv "$venv"
pip=("$venv/bin/python" -m pip --disable-pip-version-check -q)

find_links="${PIP_FIND_LINKS:-} $("$venv/bin/python" -m pip config get global.find-links 2>/dev/null || true)"
cpu_wheel=""
for dir in $find_links; do
  dir=${dir#file://}
  [ -d "$dir" ] || continue
  # newest CPU wheel for this interpreter, if any
  tag=$("$venv/bin/python" -c 'import sys; print(f"cp{sys.version_info[0]}{sys.version_info[1]}")')
  cand=$(ls "$dir"/torch-*+cpu-"$tag"-*.whl 2>/dev/null | sort -V | tail -n 1 || true)
  [ -n "$cand" ] && cpu_wheel=$cand
done
if [ -n "$cpu_wheel" ]; then
  echo "install: using the CPU build of torch at $cpu_wheel"
  "${pip[@]}" install "$cpu_wheel"
fi

"${pip[@]}" install -e ".[dev]" -e plugins/example_channel
echo "install: done; the command is $venv/bin/adaptsky"
