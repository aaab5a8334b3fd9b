#!/usr/bin/env bash
# README.md's commands, as a reader runs them after scripts/setup.sh: every line of every ```sh
# block, in order, each must exit 0. They run in a scratch copy of the tree (the files git
# tracks, as they are in the working tree) whose build/ is a link to BUILD_DIR, already built, so
# that nothing is rebuilt and out/ and the generated scenes stay out of the checkout.
#
#   .ci/readme.sh [BUILD_DIR] [--list]      (default BUILD_DIR: build; --list prints, runs nothing)
#
# A block right after the line `<!-- readme-check: not run: REASON -->` is listed with its reason
# and not run: the setup and test commands themselves (this stage runs inside the second) and the
# plain CMake build (a full build from nothing, what setup.sh already did). Each command has
# LANCER_README_BUDGET seconds (default 300), the whole stage LANCER_README_TOTAL (default 900):
# a command that runs longer fails the stage, so a README command never grows unbounded unseen.
# The commands run with CDPATH=. exported, as some users' shells have it.
set -euo pipefail
# cd prints the directory when CDPATH is set (and the path relative): keep it out of $root.
root="$(cd -- "$(dirname -- "$0")/.." >/dev/null && pwd)"
build="build" list=0
for a in "$@"; do
  case "$a" in
    --list) list=1 ;;
    *) build="$a" ;;
  esac
done
budget="${LANCER_README_BUDGET:-300}"
total_budget="${LANCER_README_TOTAL:-900}"

# Blocks as records: "run<TAB>command" or "skip<TAB>reason<TAB>first line", backslash-continued
# lines joined, comments and blank lines dropped.
mapfile -t records < <(awk '
  /^<!-- readme-check: not run: / {
    reason = $0; sub(/^<!-- readme-check: not run: /, "", reason); sub(/ *-->$/, "", reason); next }
  /^```sh *$/ { inblock = 1; skip = (reason != ""); next }
  /^```/ && inblock { inblock = 0; reason = ""; next }
  inblock {
    line = $0
    if (cont != "") { line = cont " " line; cont = "" }
    if (line ~ /\\$/) { sub(/\\$/, "", line); cont = line; next }
    if (line ~ /^[ \t]*(#|$)/) next
    if (skip) print "skip\t" reason "\t" line; else print "run\t" line
  }
  { if (!inblock && $0 !~ /^[ \t]*$/) reason = "" }
' "$root/README.md")

if [ "$list" -eq 1 ]; then
  printf '%s\n' "${records[@]}"
  exit 0
fi
[ -x "$root/$build/lancer" ] || [ -x "$build/lancer" ] ||
  { echo "readme: no lancer in $build (run scripts/setup.sh first)" >&2; exit 2; }
build_abs="$(cd -- "$root" >/dev/null && cd -- "$build" >/dev/null && pwd)"

scratch="$(mktemp -d "${TMPDIR:-/tmp}/lancer-readme.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT
# The tracked and new files as they are now (a file deleted but not yet committed left out);
# outside a git checkout (git archive's tree in scripts/clean-root-check.sh) all but build
# directories and out/.
if git -C "$root" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  (cd "$root" && git ls-files -z --cached --others --exclude-standard |
    while IFS= read -r -d '' f; do [ -e "$f" ] && printf '%s\0' "$f"; done |
    tar --null -T - -cf -) | tar -xf - -C "$scratch"
else
  (cd "$root" && tar --exclude='./build*' --exclude=./out -cf - .) | tar -xf - -C "$scratch"
fi
rm -rf "$scratch/build"
ln -s "$build_abs" "$scratch/build"

start=$(date +%s) ran=0
for rec in "${records[@]}"; do
  kind="${rec%%$'\t'*}" rest="${rec#*$'\t'}"
  if [ "$kind" = skip ]; then
    echo "readme: not run (${rest%%$'\t'*}): ${rest#*$'\t'}"
    continue
  fi
  t0=$(date +%s%N)
  status=0
  # CDPATH set as some users' shells have it: a script that captures `cd`'s output then got
  # the directory twice (measure.sh: "no lancer at ...").
  (cd "$scratch" && CDPATH=. timeout --kill-after=10 "$budget" bash -o pipefail -c "$rest") \
    >"$scratch/.readme-out" 2>&1 || status=$?
  ms=$((($(date +%s%N) - t0) / 1000000))
  if [ "$status" -ne 0 ]; then
    tail -n 30 "$scratch/.readme-out" >&2
    [ "$status" -eq 124 ] && echo "readme: over its ${budget} s budget: $rest" >&2
    echo "readme: FAILED (exit $status after $((ms / 1000)) s): $rest" >&2
    exit 1
  fi
  printf 'readme: %4d.%d s  %s\n' $((ms / 1000)) $((ms % 1000 / 100)) "$rest"
  ran=$((ran + 1))
  if [ $(($(date +%s) - start)) -gt "$total_budget" ]; then
    echo "readme: the README's commands took over ${total_budget} s (LANCER_README_TOTAL)" >&2
    exit 1
  fi
done
echo "readme: all $ran commands of README.md's sh blocks ran (exit 0) in $(($(date +%s) - start)) s"
