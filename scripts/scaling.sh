#!/usr/bin/env bash
# Mrays/s against the number of spheres (or triangles), lancer and Embree on the same rays.
#
#   scripts/scaling.sh [--triangles] [--incoherent] [--million] [--sizes "N ..."] [--repeat R]
#                      [--out DIR] [--lancer PATH] [--readme]
#
# For N in 4 64 1024 16384 65536 (and 1048576 with --million): `lancer generate --spheres N
# --seed 1` (spheres in a box on a ground plane, the same file on any machine), then
# `lancer bench SCENE --mode primary --width W --threads 1 --peer embree --json --repeat R`,
# W the widest width this CPU runs. --triangles: a tessellated sphere of at least N triangles
# on the ground plane instead (`lancer generate --spheres 0 --mesh-triangles N`), N in 1024
# 16384 65536 (and 1048576 with --million); Embree traces them as its native triangles.
# --incoherent: also the two incoherent ray kinds, `bench --mode ao,diffuse` (4 cosine-weighted
# rays from each camera hit; ambient occlusion to 5% of the scene's extent, diffuse closest
# hits), lancer through the library API and its kernels alone beside Embree's best, lancer's
# rate over Embree's per round (median, range): a second table, and both kinds in the figure.
# --readme copies the figure and table into docs/.
# Writes DIR/scaling.csv, DIR/scaling.md and the log-log figure DIR/scaling.{png,svg} (default
# DIR: out/scaling, out/scaling-triangles with --triangles), and prints the table and the
# ratios (lancer / Embree, build time / Embree's, time per ray of the largest size over the
# smallest, and at 65536 over 1024 side by side in one bench run).
# Needs jq and python3.
set -euo pipefail

# cd prints the directory when CDPATH is set (and the path relative): keep it out of $root.
root="$(cd -- "$(dirname -- "$0")/.." >/dev/null && pwd)"
lancer="$root/build/lancer"
out=""
repeat=5
readme=0
kind=spheres
sizes=()
million=0
incoherent=0
while [ $# -gt 0 ]; do
  case "$1" in
    --triangles) kind=triangles ;;
    --million) million=1 ;;
    --sizes) read -r -a sizes <<<"$2"; shift ;;
    --repeat) repeat="$2"; shift ;;
    --out) out="$2"; shift ;;
    --lancer) lancer="$2"; shift ;;
    --readme) readme=1 ;;
    --incoherent) incoherent=1 ;;
    -h|--help) sed -n 2,22p "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "scaling.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
if [ ${#sizes[@]} -eq 0 ]; then
  if [ "$kind" = triangles ]; then sizes=(1024 16384 65536); else sizes=(4 64 1024 16384 65536); fi
  [ "$million" -eq 1 ] && sizes+=(1048576)
fi
[ -n "$out" ] || { [ "$kind" = triangles ] && out="$root/out/scaling-triangles" || out="$root/out/scaling"; }
# What a size means: the generator's option and the table's words.
if [ "$kind" = triangles ]; then
  what="triangles" scene_words="a tessellated sphere on a ground plane, 600x400"
else
  what="spheres" scene_words="random cloud on a ground plane, 600x400"
fi
command -v jq >/dev/null || { echo "scaling.sh: needs jq (scripts/deps.sh installs it)" >&2; exit 2; }
[ -x "$lancer" ] || {
  echo "scaling.sh: no lancer at $lancer: run scripts/setup.sh (it builds build/lancer), or pass --lancer PATH" >&2
  exit 2
}
mkdir -p "$out"
# The widest packet width this CPU runs (16 with AVX-512, 8 with AVX2, else 4): what render picks.
width="$("$lancer" render "$root/scenes/lorenzi-diffuse.json" --resolution 8x8 --precision exact \
  -o "$out/width-probe.png" --json | jq .width)"
rm -f "$out/width-probe.png"

cpu="$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')"
# VMs often give a bare "AMD EPYC": the family and model tell the core (25/17: Zen 4; 26: Zen 5).
cpu="$cpu (family $(awk -F'\t*: ' '$1 == "cpu family" {print $2; exit}' /proc/cpuinfo), model $(awk -F'\t*: ' '$1 == "model" {print $2; exit}' /proc/cpuinfo))"
csv="$out/scaling.csv"
md="$out/scaling.md"
echo "$what,path,mrays_per_s,embree_mrays_per_s,embree_config,embree_build_s,structure,build_s,bytes_per_object" >"$csv"
{
  echo "Primary rays, 1 thread, $cpu, medians of $repeat (scripts/scaling.sh):"
  echo
  echo "| $what | lancer path | lancer Mrays/s | Embree Mrays/s | Embree configuration | Embree build s | structure | build s | bytes/${what%s} |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
} >"$md"

# Every scene made before any timing: just after `generate` wrote and freed a million spheres'
# 100 MB, the next process's first build (lancer's) took 0.31 s instead of 0.21 on a VM, while
# the system caught up (a sync alone did not help, seconds later it was gone).
for n in "${sizes[@]}"; do
  if [ "$kind" = triangles ]; then
    "$lancer" generate --spheres 0 --mesh-triangles "$n" --seed 1 -o "$out/$what-$n.json" >/dev/null
  else
    "$lancer" generate --spheres "$n" --seed 1 -o "$out/$what-$n.json" >/dev/null
  fi
done
sync
sleep 5
for n in "${sizes[@]}"; do
  scene="$out/$what-$n.json"
  json="$out/bench-$n.json"
  "$lancer" bench "$scene" --mode primary --width "$width" --threads 1 --peer embree --json \
    --repeat "$repeat" >"$json"
  # One row per lancer configuration; Embree's best row (and its setup, when the bench names it).
  # Triangles: the count the mesh has (at least n), and the shapes' own hierarchy.
  rows="$(jq -c --arg n "$n" --arg kind "$kind" '
    def num(x): if x == null then "" else (x * 1000 | round / 1000 | tostring) end;
    def sec(x): if x == null then "" else (x * 100000 | round / 100000 | tostring) end;
    .peer_build_seconds as $pb
    | (.results | map(select(.engine == "embree")) | max_by(.mrays_per_s)) as $e
    | (if $kind == "triangles" then (.structure.shapes // {}) | {kind: "shapes", objects:
         .primitives, bytes, build_seconds} else (.structure // {}) end) as $s
    | .results[] | select(.engine != "embree")
    | [(if $kind == "triangles" then ($s.objects // $n | tostring) else $n end),
       "\(.precision) w\(.width) \(.isa)", num(.mrays_per_s), num($e.mrays_per_s),
       ($e.config // ""), sec($e.build_seconds // $pb),
       ($s.kind // ""), sec($s.build_seconds),
       (if $s.bytes != null and ($s.objects // 0) > 0 then num($s.bytes / $s.objects) else "" end)]
    ' "$json")"
  jq -r '@csv' <<<"$rows" >>"$csv"
  jq -r '"| " + join(" | ") + " |"' <<<"$rows" >>"$md"
done
# Issue 12's ratios, from this run's rows: lancer / Embree per size, and the time per ray of
# the largest size against the smallest (the rows are one per size: one lancer configuration).
python3 - "$csv" "$what" >>"$md" <<'PY'
import csv, sys
what = sys.argv[2]
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["mrays_per_s"]]
if rows:
    print()
    for r in rows:
        e = r["embree_mrays_per_s"]
        b, eb = r["build_s"], r["embree_build_s"]
        print(f"- {r[what]} {what}: lancer / Embree {float(r['mrays_per_s']) / float(e):.2f}x"
              if e else f"- {r[what]} {what}: no Embree figure", end="")
        print(f"; build {float(b) / float(eb):.2f}x Embree's" if b and eb and float(b) > 0 else "")
    by_n = {int(r[what]): r for r in rows}
    # Issue 12's pair when the run has it, else the smallest and largest sizes.
    lo, hi = (by_n[1024], by_n[65536]) if 1024 in by_n and 65536 in by_n else (
        by_n[min(by_n)], by_n[max(by_n)])
    if lo is not hi:
        ratio = float(lo["mrays_per_s"]) / float(hi["mrays_per_s"])
        print(f"- time per ray at {hi[what]} {what} / at {lo[what]} (the rows above: "
              f"separate runs): {ratio:.2f}x")
PY
# Time per ray at 65536 spheres (triangles) over 1024, measured side by side: the two sizes' runs above
# are minutes apart, and this VM's speed moves in between, so the ratio of their rows spreads
# widely. Here both scenes in one bench run (3 x repeat rounds, each scene's run right after
# the other's in every round) and the median of the rounds' ratios (bench's side_by_side).
if [ -f "$out/$what-1024.json" ] && [ -f "$out/$what-65536.json" ] &&
  [[ " ${sizes[*]} " == *" 1024 "* && " ${sizes[*]} " == *" 65536 "* ]]; then
  "$lancer" bench "$out/$what-1024.json" "$out/$what-65536.json" --mode primary \
    --width "$width" --threads 1 --json --repeat $((3 * repeat)) >"$out/side-by-side.json"
  jq -r --arg what "$what" '.side_by_side[] | select(.engine == "lancer") |
    "- time per ray at 65536 \($what) / at 1024, side by side in one run (\(.ratios | length) rounds): " +
    "median \(.time_per_ray_ratio * 100 | round / 100)x " +
    "(\(.ratio_min * 100 | round / 100)x to \(.ratio_max * 100 | round / 100)x)"' \
    "$out/side-by-side.json" >>"$md"
fi
# The incoherent kinds: one bench run per size, lancer's widest width, then a table of the
# per-round ratios (the rounds interleave lancer's rows and Embree's, seconds apart).
inc="$out/incoherent.csv"
if [ "$incoherent" -eq 1 ]; then
  for n in "${sizes[@]}"; do
    "$lancer" bench "$out/$what-$n.json" --mode ao,diffuse --width "$width" --threads 1 \
      --peer embree --json --repeat "$repeat" >"$out/rays-$n.json"
  done
  python3 - "$out" "$what" "$inc" "${sizes[@]}" >>"$md" <<'PY'
import csv, json, statistics, sys
out, what, inc, sizes = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
def rate_ratios(a, b):  # a's rate over b's, per round (same rays: b's seconds over a's)
    return [sb / sa for sa, sb in zip(a["samples_seconds"], b["samples_seconds"])]
rows = []
for n in sizes:
    res = json.load(open(f"{out}/rays-{n}.json"))["results"]
    for mode in ("ao", "diffuse"):
        api = [r for r in res if r["mode"] == mode and r["engine"] == "lancer" and not r.get("config")]
        ker = [r for r in res if r["mode"] == mode and r["engine"] == "lancer" and r.get("config")]
        emb = [r for r in res if r["mode"] == mode and r["engine"] == "embree"]
        if not (api and emb):
            continue
        a, e = api[0], max(emb, key=lambda r: r["mrays_per_s"])
        k = ker[0] if ker else None
        ra = rate_ratios(a, e)
        rk = rate_ratios(k, e) if k else []
        rows.append({what: n, "kind": mode, "path": f"{a['precision']} w{a['width']} {a['isa']}",
                     "api_mrays_per_s": round(a["mrays_per_s"], 3),
                     "kernels_mrays_per_s": round(k["mrays_per_s"], 3) if k else "",
                     "embree_mrays_per_s": round(e["mrays_per_s"], 3),
                     "embree_config": e.get("config", ""),
                     "api_over_embree": round(statistics.median(ra), 3),
                     "api_over_embree_min": round(min(ra), 3), "api_over_embree_max": round(max(ra), 3),
                     "kernels_over_embree": round(statistics.median(rk), 3) if rk else ""})
with open(inc, "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0].keys()) if rows else [what])
    w.writeheader()
    w.writerows(rows)
print()
print("Incoherent rays (4 cosine-weighted rays per camera hit; ao: occlusion to 5% of the extent, "
      "diffuse: closest hit), lancer through the library API and its kernels alone, Embree's best "
      "setup per kind; lancer / Embree per round, median (min..max):")
print()
print(f"| {what} | ray kind | lancer path | lancer API Mrays/s | lancer kernels Mrays/s | Embree Mrays/s "
      "| Embree configuration | API / Embree | kernels / Embree |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for r in rows:
    print(f"| {r[what]} | {r['kind']} | {r['path']} | {r['api_mrays_per_s']} | {r['kernels_mrays_per_s']} "
          f"| {r['embree_mrays_per_s']} | {r['embree_config']} | {r['api_over_embree']}x "
          f"({r['api_over_embree_min']}..{r['api_over_embree_max']}) | {r['kernels_over_embree']}x |")
PY
fi
# The figure: Mrays/s against spheres (triangles), log-log, lancer and Embree's best as series
# (with --incoherent, each ray kind's too).
long="$out/scaling-long.csv"
{
  echo "$what,engine,mrays_per_s"
  python3 - "$csv" "$what" "$inc" "$incoherent" <<'PY'
import csv, sys
what = sys.argv[2]
kinds = sys.argv[4] == "1"
primary = " primary" if kinds else ""
for r in csv.DictReader(open(sys.argv[1])):
    if r["mrays_per_s"]:
        print(f"{r[what]},lancer {r['path']}{primary},{r['mrays_per_s']}")
    if r["embree_mrays_per_s"]:
        print(f"{r[what]},Embree best setup{primary},{r['embree_mrays_per_s']}")
if kinds:
    for r in csv.DictReader(open(sys.argv[3])):
        print(f"{r[what]},lancer {r['path']} {r['kind']} (API),{r['api_mrays_per_s']}")
        print(f"{r[what]},Embree best setup {r['kind']},{r['embree_mrays_per_s']}")
PY
} >"$long"
title="Primary rays"
[ "$incoherent" -eq 1 ] && title="Primary, AO, diffuse rays"
for ext in png svg; do
  "$lancer" plot "$long" -o "$out/scaling.$ext" --x "$what" --y mrays_per_s --group engine \
    --log xy --title "$title, 1 thread ($cpu)" \
    --x-label "$what ($scene_words)" \
    --y-label "Mrays/s (median of $repeat)" >/dev/null
done
if [ "$readme" -eq 1 ]; then
  mkdir -p "$root/docs/images"
  # Spheres keep their historic names; triangles get their own.
  name=scaling
  [ "$kind" = triangles ] && name=scaling-triangles
  cp "$out/scaling.png" "$root/docs/images/$name.png"
  cp "$out/scaling.svg" "$root/docs/images/$name.svg"
  cp "$md" "$root/docs/$name-table.md"
  echo "scaling.sh: copied the figure to docs/images/$name.{png,svg} and the table to docs/$name-table.md"
fi
cat "$md"
echo "scaling.sh: wrote $csv, $md and $out/scaling.{png,svg}"
