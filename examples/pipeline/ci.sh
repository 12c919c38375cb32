#!/usr/bin/env bash
# Sample CI job for a project whose pipeline is declared in an fts manifest
# and whose outputs (models, coefficient files) and lock file are committed.
#
#   examples/pipeline/ci.sh [MANIFEST...]   (default: fts.toml)
#
# The mixsyn example commits its outputs and lock, so it passes as is:
#
#   examples/pipeline/ci.sh examples/mixsyn/fts.toml
#
# 1. `fts build --check` fails (exit 1), naming each stale output and why,
#    when a committed output no longer matches its inputs or settings:
#    someone changed a record or a setting and forgot to rebuild.
# 2. A from-scratch rebuild in a copy must reproduce every committed output
#    byte for byte: the pipeline is deterministic, so any difference is a
#    hand edit or a tool change.
set -euo pipefail

fts=${FTS:-fts}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

for manifest in "${@:-fts.toml}"; do
    dir=$(dirname "$manifest")
    name=$(basename "$manifest")
    if ! "$fts" build -f "$manifest" --check; then
        echo "stale outputs: run '$fts build -f $manifest' and commit the result" >&2
        exit 1
    fi
    copy=$(mktemp -d "$tmp/copy.XXXXXX")
    cp -R "$dir"/. "$copy"/
    "$fts" build -f "$copy/$name" --force >/dev/null
    if ! diff -r -x .git "$dir" "$copy"; then
        echo "$manifest: a from-scratch rebuild differs from the committed outputs" >&2
        exit 1
    fi
done
echo "all outputs up to date and reproducible"
