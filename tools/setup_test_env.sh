#!/usr/bin/env bash
# Install everything the test suite needs on a fresh Debian machine of this kind:
# the Debian EGL/Mesa libraries for headless rendering and usdworld with all extras.
# Safe to run twice. Used by the README's test command and by .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."

apt_packages=(libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libgbm1)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
  else
    sudo apt-get update -qq && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
fi

# torch first, pinned: the pinned CPU build is on this machine's disk; an open
# requirement would pull a multi-GB CUDA build.
python3 -m pip install -q "torch==2.13.0"
python3 -m pip install -q -e ".[test,render,depth,segment,batch,serve]"
# The nuscenes extra (nuscenes-devkit, build --dataroot) without its numpy<2 requirement, and
# what the devkit's table reader imports.
python3 -m pip install -q --no-deps "nuscenes-devkit==1.2.0"
python3 -m pip install -q "pyquaternion>=0.9.5" "matplotlib>=3.6" scikit-learn cachetools
# The blender extra (bpy, Blender 4.5 LTS) without its numpy<2 requirement: resolving it would
# downgrade numpy and opencv-python-headless; its other requirements come explicitly.
python3 -m pip install -q --no-deps "bpy>=4.5,<4.6" zstandard cython
# Browser clients (Debian chromium, node packages pinned in web/package-lock.json), and the
# browser editor's build tools (webapp/), so the test that its committed page is current runs.
bash tools/setup_web.sh
bash tools/build_webapp.sh --check
