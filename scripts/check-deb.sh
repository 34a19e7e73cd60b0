#!/usr/bin/env bash
# Installs the .deb that CPack built into a fresh Debian 12 (debootstrap
# minbase; needs root and the Debian mirror) and runs the tools there: apt
# resolves every dependency from the package's Depends, and a synthetic
# capture renders.  About 4 minutes; not part of the test suite.
# Usage: scripts/check-deb.sh [BUILD_DIR (default build)] [ROOT (default /tmp/mr-deb12)]
set -euo pipefail
build=${1:-build}
root=${2:-/tmp/mr-deb12}
(cd "$build" && cpack -G DEB > /dev/null)
deb=$(ls "$build"/mr_*_amd64.deb | head -1)
command -v debootstrap > /dev/null || apt-get install -y -qq debootstrap
rm -rf "$root"
debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian > "$root.log"
cp "$deb" "$root/tmp/mr.deb"
cp /etc/resolv.conf "$root/etc/resolv.conf"
mount --bind /proc "$root/proc"
trap 'umount "$root/proc"' EXIT
chroot "$root" /bin/bash -euc '
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends /tmp/mr.deb > /tmp/install.log
  cd /tmp && mr-synth --preset small --out cap -q && mr-render cap/scene.json --spp 2 --out r -q
  test -s r/00001.png && colmap -h > /dev/null && test -s /usr/share/man/man1/mr-pipeline.1
  echo "check-deb: $(mr-info --version) installs on a fresh Debian 12 and renders"'
