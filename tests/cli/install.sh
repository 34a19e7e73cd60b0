#!/usr/bin/env bash
# cmake --install puts the tools, their man pages and the docs in place, and
# CPack makes a .deb that depends on the Debian packages the tools use.
# Usage: install.sh BUILD_DIR
set -u
build=$1
source "$(dirname "$0")/lib.sh"
check "cmake --install" 0 "" -- cmake --install "$build" --prefix "$tmp/usr"
check "tools installed" 0 "0.1" -- "$tmp/usr/bin/mr-pipeline" --version
for t in mr-render mr-pipeline mr-register mr-fuse; do
  check "man page $t" 0 "" -- test -s "$tmp/usr/share/man/man1/$t.1"
done
check "docs installed" 0 "" -- test -s "$tmp/usr/share/doc/mr/tutorial.md"
check "cluster recipes installed" 0 "" -- test -x "$tmp/usr/share/doc/mr/examples/cluster/render-parallel.sh"
if command -v dpkg-shlibdeps > /dev/null; then
  check "cpack .deb" 0 "generated" -- cpack --config "$build/CPackConfig.cmake" -B "$tmp/pkg"
  deb=$(ls "$tmp"/pkg/mr_*.deb 2>/dev/null | head -1)
  check "deb depends on colmap" 0 "colmap" -- dpkg-deb -f "$deb" Depends
  check "deb depends on Embree" 0 "libembree3" -- dpkg-deb -f "$deb" Depends
  check "deb holds the tools" 0 "./usr/bin/mr-render" -- dpkg-deb -c "$deb"
else
  echo "skip cpack: dpkg-shlibdeps (dpkg-dev) is not installed"
fi
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
