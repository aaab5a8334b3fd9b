#!/usr/bin/env bash
# The figures of README's "Measured" section, from one run on this machine:
#
#   scripts/measure.sh [--repeat R] [--out DIR] [--lancer PATH]
#
# 1. `bench scenes/lorenzi-reflections.json`: every width this CPU runs, 1 and 2 threads,
#    primary and full, beside Embree's best setup, with the single-thread peak (--peak);
# 2. exact against fast at the widest width (full renders);
# 3. `profile` of the same scene at the widest width: where the time goes;
# 4. a glass scene (scenes/lorenzi-glass.json): Mrays/s per width, the speedup of the widest
#    over the reference, lane occupancy per stage.
# Writes DIR/measured.md (default out/measured) and the JSON it was made from, and prints it.
# Needs jq. Medians of R runs (default 7), configurations interleaved within each bench call.
set -euo pipefail

# cd prints the directory when CDPATH is set (and the path relative): keep it out of $root.
root="$(cd -- "$(dirname -- "$0")/.." >/dev/null && pwd)"
lancer="$root/build/lancer"
out="$root/out/measured"
repeat=7
while [ $# -gt 0 ]; do
  case "$1" in
    --repeat) repeat="$2"; shift ;;
    --out) out="$2"; shift ;;
    --lancer) lancer="$2"; shift ;;
    -h|--help) sed -n 2,13p "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "measure.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
command -v jq >/dev/null || { echo "measure.sh: needs jq (scripts/deps.sh installs it)" >&2; exit 2; }
[ -x "$lancer" ] || {
  echo "measure.sh: no lancer at $lancer: run scripts/setup.sh (it builds build/lancer), or pass --lancer PATH" >&2
  exit 2
}
mkdir -p "$out"
scene="$root/scenes/lorenzi-reflections.json"
glass="$root/scenes/lorenzi-glass.json"
cpu="$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')"
# VMs often give a bare "AMD EPYC": the family and model tell the core (25/17: Zen 4; 26: Zen 5).
cpu="$cpu (family $(awk -F'\t*: ' '$1 == "cpu family" {print $2; exit}' /proc/cpuinfo), model $(awk -F'\t*: ' '$1 == "model" {print $2; exit}' /proc/cpuinfo))"
commit="$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)"

"$lancer" bench "$scene" --width all --threads 1,2 --mode primary,full --repeat "$repeat" \
  --peer embree --peak --json >"$out/bench.json"
"$lancer" bench "$scene" --width all --precision exact,fast --mode full --repeat "$repeat" \
  --json >"$out/fast.json"
"$lancer" profile "$scene" --json >"$out/profile.json"
"$lancer" bench "$glass" --width all --mode full --repeat "$repeat" --json >"$out/glass.json"
"$lancer" profile "$glass" --json >"$out/glass-profile.json"

md="$out/measured.md"
{
  echo "One run of \`scripts/measure.sh --repeat $repeat\` on $cpu, $(nproc) cores, commit $commit"
  echo "($(date -u +%Y-%m-%d)); exact precision unless said, medians of $repeat runs (spread: min..max)."
  echo
  echo "\`lancer bench scenes/lorenzi-reflections.json --width all --threads 1,2 --peer embree --peak\`:"
  echo
  echo "| mode | width | ISA | Mrays/s, 1 thread (min..max) | vs reference | % of peak | 2 threads | Embree best setup, same rays, 1 thread (full: tracing only, no shading) |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
  jq -r '
    def r(x): (x * 10 | round / 10 | tostring);
    .results as $all
    | ($all | map(select(.engine == "embree"))) as $em
    | ($all | map(select(.engine == "lancer" and .threads == 1))) as $one
    | $one | sort_by(.mode, -.width)[]
    | . as $row
    | ($one | map(select(.mode == $row.mode and .width == 1))[0].mrays_per_s) as $ref
    | ($all | map(select(.engine == "lancer" and .threads == 2 and .mode == $row.mode
                         and .width == $row.width))[0]) as $two
    | ($em | map(select(.threads == 1 and .mode == $row.mode)) | max_by(.mrays_per_s)) as $e
    | "| \(.mode) | \(.width) | \(.isa) | \(r(.mrays_per_s)) (\(r(.rays / .seconds_max / 1e6))..\(r(.rays / .seconds_min / 1e6))) | \(r(.mrays_per_s / $ref))x | \(if .peak_fraction then (.peak_fraction * 100 | round | tostring) + "%" else "-" end) | \(if $two then r($two.mrays_per_s) + " (" + (($two.mrays_per_s / .mrays_per_s) * 100 | round / 100 | tostring) + "x)" else "-" end) | \(if $e then r($e.mrays_per_s) + " (" + ($e.config // "") + ")" else "-" end) |"
  ' "$out/bench.json"
  echo
  echo "Fast against exact, full render, 1 thread:"
  echo
  jq -r '
    def r(x): (x * 100 | round / 100 | tostring);
    .results | group_by(.width) | reverse[] | (map(select(.precision == "exact"))[0]) as $e
    | (map(select(.precision == "fast"))[0]) as $f | select($e != null and $f != null)
    | "- width \($e.width) (\($e.isa)): exact \($e.mrays_per_s | . * 10 | round / 10) Mrays/s, fast \($f.mrays_per_s | . * 10 | round / 10), fast/exact \(r($f.mrays_per_s / $e.mrays_per_s))x"
  ' "$out/fast.json"
  echo
  echo "Where the time goes (\`lancer profile\`, width $(jq .width "$out/profile.json"), $(jq -r .isa "$out/profile.json")):"
  jq -r '(.stages | map(.seconds) | add) as $t
    | [.stages | sort_by(-.seconds)[] | "\(.name) \(.seconds / $t * 100 | round)%"] | join(", ")' \
    "$out/profile.json"
  echo
  echo "A glass scene, \`scenes/lorenzi-glass.json\` (reflection, refraction, shadows through glass), full render, 1 thread:"
  echo
  echo "| width | ISA | Mrays/s (min..max) | vs reference |"
  echo "| --- | --- | --- | --- |"
  jq -r '
    def r(x): (x * 10 | round / 10 | tostring);
    .results as $all | ($all | map(select(.width == 1))[0].mrays_per_s) as $ref
    | $all | sort_by(-.width)[]
    | "| \(.width) | \(.isa) | \(r(.mrays_per_s)) (\(r(.rays / .seconds_max / 1e6))..\(r(.rays / .seconds_min / 1e6))) | \(r(.mrays_per_s / $ref))x |"
  ' "$out/glass.json"
  echo
  echo "Its lane occupancy per stage (\`lancer profile\`, width $(jq .width "$out/glass-profile.json")):"
  jq -r '[.stages[] | select(.lane_occupancy != null)
          | "\(.name) \(.lane_occupancy * 1000 | round / 10)%"] | join(", ")' "$out/glass-profile.json"
} >"$md"
cat "$md"
echo "measure.sh: wrote $md"
