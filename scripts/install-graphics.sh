#!/usr/bin/env bash
# Installs what the bevy example's smoke run needs (issue 40): an X server
# without a display (Xvfb, with xvfb-run and xauth), Mesa's Vulkan driver
# (lavapipe, a CPU rasterizer: no GPU needed) and the X11 libraries winit
# loads at run time. Debian packages, through apt-get (root). Idempotent:
# prints nothing and changes nothing when they are there.
set -euo pipefail

packages=(xvfb xauth mesa-vulkan-drivers libvulkan1 libx11-6 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
    exit 0
fi
if [[ $(id -u) != 0 ]]; then
    echo "install-graphics: needs root to install ${missing[*]} (apt-get install)" >&2
    exit 1
fi
export DEBIAN_FRONTEND=noninteractive
if ! apt-get install -y --no-install-recommends "${missing[@]}" >&2; then
    echo "install-graphics: 'apt-get install' failed; trying 'apt-get update' first" >&2
    apt-get update >&2
    apt-get install -y --no-install-recommends "${missing[@]}" >&2
fi
