#!/usr/bin/env bash
# docs/tools/*.md are the tools' --help: fails when a page is stale.
# Usage: docs.sh BIN_DIR
set -u
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bash "$src/scripts/tool-docs.sh" "$1" "$tmp" || exit 1
if ! diff -ru "$src/docs/tools" "$tmp"; then
  echo "docs/tools is stale: run scripts/tool-docs.sh build/bin"
  exit 1
fi
echo "docs/tools matches every tool's --help"
