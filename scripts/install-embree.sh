#!/usr/bin/env bash
# Installs Embree 3 (Debian's libembree-dev, 3.13.x) for the traversal comparison benchmark
# (`cargo bench -p geometry --bench embree --features embree`, see scripts/bench-traversal.sh).
# Nothing else in the project needs it. Needs root (or sudo) and apt.
set -euo pipefail
if ldconfig -p 2>/dev/null | grep -q 'libembree3\.so\b' && [[ -f /usr/include/embree3/rtcore.h ]]; then
  echo "Embree 3 already installed: $(dpkg-query -W -f='${Version}' libembree-dev 2>/dev/null || echo unknown)"
  exit 0
fi
sudo=""
[[ $(id -u) -eq 0 ]] || sudo="sudo"
$sudo apt-get update -q
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends libembree-dev
echo "Installed Embree $(dpkg-query -W -f='${Version}' libembree-dev)"
