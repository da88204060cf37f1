#!/usr/bin/env bash
# The golden set of a restructure: every command block of README.md and docs/ run by
# `cargo xtask docs-check --keep`, its whole output and every file it wrote (JSON, CSV, TOML,
# Markdown, HTML, text; not images), collected into OUTDIR with what changes from run to run
# masked (the commit, the date and time, elapsed seconds, the working copy's path). Two such
# directories, one before and one after a change, are compared with `diff -r`.
#
#   scripts/golden.sh /tmp/golden-before     # on the commit before
#   scripts/golden.sh /tmp/golden-after      # on the commit after
#   diff -r /tmp/golden-before /tmp/golden-after
#
# The outputs are named by document and the block's ordinal in it (not its line), so editing a
# document's prose leaves the names alone.
set -euo pipefail
out=${1:?usage: scripts/golden.sh OUTDIR}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
log=$(mktemp)
(cd "$root" && cargo xtask docs-check --keep) >"$log" 2>&1 || { tail -20 "$log"; echo "golden: docs-check failed (log $log)"; exit 1; }
work=$(sed -n 's/^working copies kept in //p' "$log")
[ -d "$work" ] || { echo "golden: no working copies in $log"; exit 1; }
tracked=$(mktemp)
(cd "$root" && git ls-files) | sort >"$tracked"
mask() {
  sed -E -e "s#$work/[0-9]+#WORK#g" \
    -e 's/\b[0-9a-f]{40}\b/COMMIT/g' -e 's/\b[0-9a-f]{7,12}(-dirty)?\b/COMMIT/g' \
    -e 's/[0-9]{4}-[0-9]{2}-[0-9]{2}[T ][0-9]{2}:[0-9]{2}(:[0-9]{2}(\.[0-9]+)?)?(Z|[+-][0-9:]+| UTC)?/DATETIME/g' \
    -e 's/\(?[0-9]+(\.[0-9]+)? ?(s|ms)\)? ?(elapsed|wall|CPU)/ELAPSED/g' \
    -e 's/(ran|took|in) [0-9]+(\.[0-9]+)? ?s\b/\1 ELAPSED/g'
}
for copy in "$work"/*/; do
  for o in "$copy"docs-check-*.out; do
    [ -e "$o" ] || continue
    base=$(basename "$o" .out)          # docs-check-docs-verdict.md-123
    doc=${base#docs-check-}; doc=${doc%-*}
    line=${base##*-}
    printf '%s %08d %s\n' "$doc" "$line" "$o"
  done
done | sort | awk '{k[$1]++; printf "%s %s-%02d.out\n", $3, $1, k[$1]}' | while read -r src name; do
  mask <"$src" >"$out/$name"
done
# Files the blocks wrote inside their working copies.
for copy in "$work"/*/; do
  (cd "$copy" && find . -type f -not -path './target/*' -not -name 'docs-check-*.out' \
     \( -name '*.json' -o -name '*.csv' -o -name '*.toml' -o -name '*.md' -o -name '*.html' -o -name '*.txt' \) \
     | sed 's#^\./##' | sort) | comm -23 - "$tracked" | while read -r f; do
    dest="$out/files/$(basename "$copy")-${f//\//_}"
    mkdir -p "$out/files"
    mask <"$copy$f" >"$dest"
  done
done
rm -rf "$work" "$tracked"
echo "golden: $(ls "$out" | wc -l) outputs, $(ls "$out/files" 2>/dev/null | wc -l) files in $out"
