#!/usr/bin/env bash
# The sample games as a studio would build them and as a player would see them: installs the SDK
# into a scratch prefix, builds samples/ against it with find_package(penumbra), then plays each
# game headless on the Vulkan device (lavapipe without a GPU) with the validation layer, and
# checks its per-frame report:
#   courtyard_walk  the player moves; the crate it walks into moves, and its contact shadow with
#                   it (the AO beside where the crate stood falls below a quarter, the AO beside
#                   where it is stays); the player's pose-AO changes as it walks; the probe grid
#                   lights the player.
#   lantern_maze    the lantern stays in the player's hand; the bounce light on the watched wall
#                   rises at least tenfold from the start to where the lantern comes nearest.
# The courtyard's player is ../shared/assets/CesiumMan.glb when present (else the built-in walker,
# and the test says so). Bad input is checked too: a missing character file fails naming it.
set -euo pipefail
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cmake --install "$BUILD_DIR" --prefix "$scratch/prefix" > "$scratch/install.log"
cmake -S "$SOURCE_DIR/samples" -B "$scratch/build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$scratch/prefix" > "$scratch/configure.log" || { cat "$scratch/configure.log"; exit 1; }
cmake --build "$scratch/build" -j 2 > "$scratch/build.log" || { cat "$scratch/build.log"; exit 1; }

fail() { echo "FAIL: $*"; exit 1; }
# value REPORT FRAME KEY: the KEY=value of frame FRAME's line.
value() { awk -v f="frame=$2" -v k="$3" '$1 == f { for (i = 2; i <= NF; ++i) { split($i, a, "="); if (a[1] == k) print a[2] } }' "$1"; }
# check "EXPRESSION" "what it means": an awk condition over numbers.
check() { awk "BEGIN { exit !($1) }" || fail "$2 ($1)"; echo "ok: $2 ($1)"; }

character=()
cesium="$SOURCE_DIR/../shared/assets/CesiumMan.glb"
if [ -f "$cesium" ]; then
  character=(--character "$cesium")
else
  echo "note: $cesium is absent; the courtyard runs with the built-in walker"
fi

# --- courtyard_walk ---
"$scratch/build/courtyard_walk" "${character[@]}" --headless --validation --autoplay --frames 100 --width 320 \
  --height 180 --screenshot "$scratch/courtyard.png" --report "$scratch/courtyard.txt" | grep -v "^  baking:"
test -s "$scratch/courtyard.png" || fail "courtyard_walk wrote no screenshot"
r=$scratch/courtyard.txt
check "$(value $r 0 player_z) - $(value $r 99 player_z) > 3" "the player walked north"
check "$(value $r 0 crate_z) - $(value $r 99 crate_z) > 2" "the crate it walked into moved"
check "$(value $r 0 ao_crate_start) > 0.2" "the crate's contact shadow darkens the ground beside it"
check "$(value $r 99 ao_crate_start) < 0.25 * $(value $r 0 ao_crate_start)" "the shadow left where the crate stood"
check "$(value $r 99 ao_crate_now) > 0.95 * $(value $r 0 ao_crate_start)" "the shadow is beside the crate where it is"
lo=$(awk '{ for (i = 2; i <= NF; ++i) { split($i, a, "="); if (a[1] == "pose_ao_mean") print a[2] } }' $r | sort -g | head -1)
hi=$(awk '{ for (i = 2; i <= NF; ++i) { split($i, a, "="); if (a[1] == "pose_ao_mean") print a[2] } }' $r | sort -g | tail -1)
check "$hi - $lo > 0.005" "the player's pose-AO changes with its pose"
check "$(value $r 50 probe_irradiance) > 0" "the probe grid lights the player"

# --- lantern_maze ---
"$scratch/build/lantern_maze" --headless --validation --autoplay --frames 300 --width 320 --height 180 \
  --screenshot "$scratch/maze.png" --report "$scratch/maze.txt" | grep -v "^  baking:"
test -s "$scratch/maze.png" || fail "lantern_maze wrote no screenshot"
r=$scratch/maze.txt
far=$(awk '{ split($6, d, "="); split($8, e, "="); print d[2], e[2] }' $r | head -1)
near=$(awk '{ split($6, d, "="); split($8, e, "="); print d[2], e[2] }' $r | sort -g | head -1)
check "$(cut -d' ' -f1 <<<"$near") < 2.5" "the lantern comes within 2.5 m of the watched wall"
check "$(cut -d' ' -f2 <<<"$near") > 10 * $(cut -d' ' -f2 <<<"$far")" "the wall's bounce light rose as the lantern approached"
awk '{ split($2, px, "="); split($3, pz, "="); split($4, lx, "="); split($5, lz, "=");
       if ((px[2] - lx[2])^2 + (pz[2] - lz[2])^2 > 0.36) { print "frame", NR - 1, "lantern off the hand"; exit 1 } }' $r \
  || fail "the lantern left the player's hand"
echo "ok: the lantern stays within 0.6 m of the player"

# --- bad input ---
if "$scratch/build/courtyard_walk" --character "$scratch/missing.glb" --headless --frames 1 > "$scratch/bad.log" 2>&1; then
  fail "courtyard_walk accepted a missing character file"
fi
grep -q "missing.glb" "$scratch/bad.log" || { cat "$scratch/bad.log"; fail "the error does not name the missing file"; }
echo "ok: a missing character file fails naming it: $(head -1 "$scratch/bad.log")"
