#!/usr/bin/env bash
# Checks that the C++ sources follow .clang-format (Debian 12's clang-format 14).
#   scripts/check-format.sh          lists the files that differ; exit 1 if any
#   scripts/check-format.sh --fix    reformats them in place
# Exit 77 (the `format` test's skip) when clang-format is not installed.
set -euo pipefail
cd "$(dirname "$0")/.."
cf=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$cf" ]; then
  echo "check-format: clang-format is not installed (apt-get install clang-format): skipped"
  exit 77
fi
mapfile -t files < <(git ls-files -- 'libmr/*.h' 'libmr/*.cpp' 'tools/*.cpp' 'tools/*.h' 'tests/*.h' 'tests/*.cpp' \
                                    'bench/*.cpp' 'bench/*.h' 'fuzz/*.cpp' 2>/dev/null ||
                     find libmr tools tests bench fuzz -name '*.h' -o -name '*.cpp')
if [ "${1:-}" = "--fix" ]; then
  "$cf" -i "${files[@]}"
  exit 0
fi
bad=0
for f in "${files[@]}"; do
  if ! "$cf" --dry-run -Werror "$f" >/dev/null 2>&1; then
    echo "$f: not formatted (scripts/check-format.sh --fix)"
    bad=$((bad + 1))
  fi
done
echo "check-format: ${#files[@]} files, $bad not formatted"
[ "$bad" -eq 0 ]
