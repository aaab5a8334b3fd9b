#!/usr/bin/env bash
# lancer across MPI ranks (docs/mpi.md): `mpirun -np 2` and `-np 4` (oversubscribed) renders byte
# for byte equal to the single-process render on every scene in scenes/, in exact and double
# precision; and a bad scene, an unwritable output, ranks asked different things (MPMD), an error
# on one rank only and a killed rank each end the job with one message, no output file and no
# hang. Skipped, saying so, when lancer was built without MPI.
#
#   .ci/mpi.sh [build dir, default build]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
lancer="$build/lancer"
[ -x "$lancer" ] || { echo "mpi: $lancer not built" >&2; exit 1; }
if ! grep -q "^LANCER_HAVE_MPI:INTERNAL=ON" "$build/CMakeCache.txt" 2>/dev/null; then
  echo "mpi: SKIPPED: $build was built without MPI (apt-get install libopenmpi-dev openmpi-bin; cmake -DLANCER_MPI=ON)"
  exit 0
fi
command -v mpirun >/dev/null || { echo "mpi: SKIPPED: mpirun not on PATH (apt-get install openmpi-bin)"; exit 0; }

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# -q: mpirun's own banners off, so lancer's line is the message. Root needs the flag.
mpirun=(mpirun -q --oversubscribe)
[ "$(id -u)" -eq 0 ] && mpirun+=(--allow-run-as-root)
run() { timeout --kill-after=10 120 "${mpirun[@]}" "$@"; }

status=0
fail() { echo "mpi: FAIL: $*"; status=1; }

# 1. Byte-identical renders. Small frames, supersampled once so sub-samples cross tile borders
# too; PFM keeps every float bit. Threads 1 per rank: the machine has 2 cores.
for scene in scenes/*.json; do
  name=$(basename "$scene" .json)
  for precision in exact double; do
    args=(--resolution 83x61 --precision "$precision" --threads 1)
    "$lancer" render "$scene" -o "$out/$name-1.pfm" "${args[@]}" >/dev/null
    for np in 2 4; do
      run -np $np "$lancer" render "$scene" -o "$out/$name-$np.pfm" "${args[@]}" >/dev/null ||
        { fail "$scene $precision -np $np exited $?"; continue; }
      cmp -s "$out/$name-1.pfm" "$out/$name-$np.pfm" ||
        fail "$scene $precision: -np $np differs from the single-process render"
    done
  done
done
# The PNG path too (rank 0 writes through the same atomic writer).
"$lancer" render scenes/lorenzi-reflections.json -o "$out/r1.png" --resolution 64x48 >/dev/null
run -np 3 "$lancer" render scenes/lorenzi-reflections.json -o "$out/r3.png" --resolution 64x48 >/dev/null
cmp -s "$out/r1.png" "$out/r3.png" || fail "PNG at -np 3 differs"
# Ranks on different CPUs (LANCER_MAX_WIDTH=8 makes rank 1 an AVX2 machine; Open MPI's MPMD
# syntax): auto width is the narrowest rank's widest, so even fast mode, whose bits depend on
# the width, gives the single-process width-8 file; exact gives the widest single-process file.
mixed() { run -np 1 "$lancer" "$@" : -np 1 -x LANCER_MAX_WIDTH=8 "$lancer" "$@"; }
small=(--resolution 90x70 --threads 1)
if [ "$(LANCER_MAX_WIDTH=16 "$lancer" validate scenes/lorenzi-diffuse.json | grep -c '^ *16 ')" -gt 0 ]; then
  "$lancer" render scenes/lorenzi-reflections.json -o "$out/f8.pfm" --precision fast --width 8 "${small[@]}" >/dev/null
  mixed render scenes/lorenzi-reflections.json -o "$out/fm.pfm" --precision fast "${small[@]}" >/dev/null
  cmp -s "$out/f8.pfm" "$out/fm.pfm" || fail "mixed CPUs: fast mode differs from the width-8 render"
  "$lancer" render scenes/lorenzi-reflections.json -o "$out/e1.pfm" --precision exact "${small[@]}" >/dev/null
  mixed render scenes/lorenzi-reflections.json -o "$out/em.pfm" --precision exact "${small[@]}" >/dev/null
  cmp -s "$out/e1.pfm" "$out/em.pfm" || fail "mixed CPUs: exact differs from the single-process render"
else
  echo "mpi: this CPU lacks width 16: the mixed-CPU case is not run"
fi
[ $status -eq 0 ] && echo "mpi: -np 2 and -np 4 byte-identical to the single-process render on every scene, exact and double; mixed-CPU ranks agree on the width"

# 2. Failures: exit status, exactly one stderr line, no output file, within the timeout.
expect_failure() {  # name, expected status, expected text, then the command
  local name=$1 want=$2 text=$3; shift 3
  local rc=0
  "$@" >"$out/stdout" 2>"$out/stderr" || rc=$?
  [ "$rc" -eq 124 ] || [ "$rc" -eq 137 -a "$want" != 137 ] && { fail "$name: hung (status $rc)"; return; }
  [ "$rc" -eq "$want" ] || fail "$name: status $rc, expected $want"
  local lines; lines=$(wc -l <"$out/stderr")
  [ "$lines" -eq 1 ] || { fail "$name: $lines lines on stderr, expected 1"; cat "$out/stderr"; }
  grep -q -- "$text" "$out/stderr" || { fail "$name: stderr lacks '$text'"; cat "$out/stderr"; }
  [ -z "$(ls -A "$out/dir")" ] || { fail "$name: left files: $(ls -A "$out/dir")"; rm -f "$out/dir"/*; }
}
mkdir -p "$out/dir"
printf '{"camera": {"resolution": [8, 8]}, "objects": [{"type": "sphere", "radius": -1}]}' >"$out/bad.json"
expect_failure "bad scene" 2 "bad.json" run -np 4 "$lancer" render "$out/bad.json" -o "$out/dir/x.png"
expect_failure "unwritable output" 2 "no-such-folder" \
  run -np 4 "$lancer" render scenes/lorenzi-diffuse.json -o "$out/dir/no-such-folder/x.png"
expect_failure "bad width" 2 "--width" \
  run -np 2 "$lancer" render scenes/lorenzi-diffuse.json -o "$out/dir/x.png" --width 3
expect_failure "bad resolution" 2 "--resolution" \
  run -np 2 "$lancer" render scenes/lorenzi-diffuse.json -o "$out/dir/x.png" --resolution 0x9
# Commands that are not distributed are refused once, not run once per rank.
expect_failure "validate under mpirun" 2 "validate: runs in one process" \
  run -np 2 "$lancer" validate scenes/lorenzi-diffuse.json
expect_failure "generate under mpirun" 2 "only render and bench are distributed" \
  run -np 2 "$lancer" generate --spheres 8 -o "$out/dir/g.json"
# A width one rank's CPU lacks: that rank's message, naming it.
[ "$(LANCER_MAX_WIDTH=16 "$lancer" validate scenes/lorenzi-diffuse.json | grep -c '^ *16 ')" -gt 0 ] &&
  expect_failure "width a rank lacks" 2 "rank 1: --width: width 16" \
    mixed render scenes/lorenzi-diffuse.json -o "$out/dir/x.png" --width 16

# Ranks asked different things (Open MPI's MPMD syntax gives each its own command line): they
# must not gather frames of different shapes (rank 0 crashed with "malloc(): corrupted top
# size"), wait for rows a rank never renders (a hang), or mix two scenes into one image.
d=scenes/lorenzi-diffuse.json
expect_failure "ranks disagree on the image size" 2 "rank 1: the ranks disagree on the image size" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" --resolution 30x20 : \
  -np 2 "$lancer" render $d -o "$out/dir/x.png"
expect_failure "a 1x1 rank" 2 "1 x 1 here, 30 x 20 on rank 0" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" --resolution 30x20 : \
  -np 2 "$lancer" render $d -o "$out/dir/x.png" --resolution 1x1
sed 's/"radius": 2}/"radius": 2.5}/' $d >"$out/stale.json"
cmp -s $d "$out/stale.json" && fail "stale scene: the edit changed nothing"
expect_failure "a stale scene on one rank" 2 "rank 1: the ranks disagree on the scene file's bytes" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" render "$out/stale.json" -o "$out/dir/x.png"
expect_failure "ranks disagree on --precision" 2 "rank 1: the ranks disagree on --precision" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" render $d -o "$out/dir/x.png" --precision double
expect_failure "ranks disagree on --supersample" 2 "rank 2: the ranks disagree on the sub-samples" \
  run -np 2 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" render $d -o "$out/dir/x.png" --supersample 2
expect_failure "render and bench" 2 "rank 1: the ranks disagree on the command" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" bench $d --repeat 1
expect_failure "bench ranks disagree on --repeat" 2 "rank 1: the ranks disagree on bench's" \
  run -np 1 "$lancer" bench $d --repeat 1 --resolution 8x8 : -np 1 "$lancer" bench $d --repeat 2 --resolution 8x8
# An error on one rank only (an environment variable or option only it was given) reaches every
# rank: one line, status 2, no hang; the same error on every rank is said once.
expect_failure "LANCER_MAX_WIDTH=zz on rank 1" 2 "rank 1: LANCER_MAX_WIDTH: must be" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 -x LANCER_MAX_WIDTH=zz "$lancer" render $d -o "$out/dir/x.png"
expect_failure "LANCER_MAX_WIDTH=zz on every rank" 2 "^lancer: LANCER_MAX_WIDTH: must be" \
  run -np 3 -x LANCER_MAX_WIDTH=zz "$lancer" render $d -o "$out/dir/x.png"
expect_failure "LANCER_MAX_WIDTH=zz on a bench rank" 2 "rank 1: LANCER_MAX_WIDTH: must be" \
  run -np 1 "$lancer" bench $d --repeat 1 : -np 1 -x LANCER_MAX_WIDTH=zz "$lancer" bench $d --repeat 1
expect_failure "an unknown option on rank 1" 2 "rank 1: The following argument was not expected: --bogus" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" render $d -o "$out/dir/x.png" --bogus
expect_failure "a bad --width on rank 0 only" 2 "^lancer: --width: must be auto" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" --width 3 : -np 2 "$lancer" render $d -o "$out/dir/x.png"
expect_failure "validate beside render" 2 "rank 1: validate: runs in one process" \
  run -np 1 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" validate $d
expect_failure "an unknown command on rank 2" 2 "rank 2: unknown command 'rendr'" \
  run -np 2 "$lancer" render $d -o "$out/dir/x.png" : -np 1 "$lancer" rendr $d
# --json: one JSON object on stdout, from rank 0 alone, with the ranks' figures.
rc=0
run -np 2 "$lancer" render $d -o "$out/j.png" --resolution 40x30 --json >"$out/stdout" 2>"$out/stderr" || rc=$?
[ $rc -eq 0 ] || fail "--json under mpirun: status $rc"
[ "$(head -c1 "$out/stdout")" = "{" ] && [ "$(grep -c '^{' "$out/stdout")" -eq 1 ] &&
  grep -q '"ranks": 2' "$out/stdout" && grep -q '"resolution": \[' "$out/stdout" ||
  { fail "--json under mpirun: not one JSON object with the ranks"; head -5 "$out/stdout"; }
[ ! -s "$out/stderr" ] || { fail "--json under mpirun: stderr not empty"; cat "$out/stderr"; }

# A killed rank: SIGKILL rank 1 mid-render; mpirun ends the job (SIGTERM to the others), rank 0
# says so in one line and writes no file.
# Long enough that rank 1 dies mid-render: about 14 s in one process on a fast core (AMD Zen 5;
# scenes/many-spheres.json at 2400x1800, 8x8 samples had finished within the second before the
# kill there), 20000 reflective spheres, 3x3 samples.
"$lancer" generate --spheres 20000 --reflect 0.5 --seed 3 -o "$out/killed.json" >/dev/null
big=(--resolution 2400x1800 --supersample 3 --threads 1)
timeout --kill-after=10 120 "${mpirun[@]}" -np 3 "$lancer" render "$out/killed.json" \
  -o "$out/dir/killed.png" "${big[@]}" >"$out/stdout" 2>"$out/stderr" &
job=$!
victim=""
for _ in $(seq 100); do  # find rank 1 among mpirun's children once it runs
  for pid in $(pgrep -P "$(pgrep -P $job mpirun || echo $job)" lancer 2>/dev/null); do
    tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qx OMPI_COMM_WORLD_RANK=1 && victim=$pid
  done
  [ -n "$victim" ] && break
  sleep 0.1
done
if [ -z "$victim" ]; then
  fail "killed rank: rank 1 never appeared"
else
  sleep 1
  kill -KILL "$victim"
  rc=0; wait $job || rc=$?
  [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] || fail "killed rank: status $rc (0 = finished anyway, 124 = hung)"
  [ "$(wc -l <"$out/stderr")" -eq 1 ] && grep -q "MPI job was ended" "$out/stderr" ||
    { fail "killed rank: expected one line saying the job was ended, got:"; cat "$out/stderr"; }
  [ -z "$(ls -A "$out/dir")" ] || fail "killed rank: left files: $(ls -A "$out/dir")"
fi
[ $status -eq 0 ] && echo "mpi: bad scene, unwritable output, bad width or resolution, commands that are not distributed, a width one rank lacks, ranks asked different things, an error on one rank, a killed rank: each ends the job with one message, no file, no hang; --json prints one object"
exit $status
