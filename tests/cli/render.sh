# penumbra render writes a PNG/EXR of the right size, times frames, and fails clearly on bad input.
source "$(dirname "$0")/lib.sh"
expect_exit 0 "$PENUMBRA" bake builtin:cornell -o "$scratch/c.pbake" --preset draft
expect_exit 0 "$PENUMBRA" render builtin:cornell --bake "$scratch/c.pbake" -o "$scratch/c.png" --width 96 --height 64
[ -s "$scratch/c.png" ] || fail "no PNG written"
# PNG header: width and height are the big-endian words at bytes 16..23.
size=$(od -An -tu1 -j16 -N8 "$scratch/c.png" | tr -s ' ')
[ "$size" = " 0 0 0 96 0 0 0 64" ] || fail "PNG size is '$size', expected 96x64"
expect_exit 0 "$PENUMBRA" render builtin:cornell --bake "$scratch/c.pbake" -o "$scratch/c.exr" --width 32 --height 24 --view indirect --frames 3
expect_output "median"; expect_output "p95"
expect_exit 0 "$PENUMBRA" render builtin:courtyard -o "$scratch/a.png" --width 32 --height 24 --frames 2 --animate \
  --shadow-taps 1 --ambient-step 1
expect_output "2 animated frames"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --shadow-taps 3; expect_output "1, 4 or 16"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --ambient-step 4; expect_output "1 or 2"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --animate; expect_output "--frames"
head -c 4 "$scratch/c.exr" | od -An -tx1 | grep -q "76 2f 31 01" || fail "not an OpenEXR file"
expect_exit 1 "$PENUMBRA" render builtin:nosuch -o "$scratch/x.png"; expect_output "nosuch"
[ -e "$scratch/x.png" ] && fail "a failed render left a file behind"
expect_exit 1 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --camera nope; expect_output "nope"; expect_output "cameras:"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.bmp"; expect_output ".png"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --view shiny; expect_output "albedo"
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/x.png" --width 0
expect_exit 1 "$PENUMBRA" render builtin:cornell --bake "$scratch/missing.pbake" -o "$scratch/x.png"; expect_output "missing.pbake"
# The AO passes: a courtyard bake with AO fields and pose-AO darkens the ao view, and --time moves
# the walker (its pose-AO with it).
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/y.pbake" --preset draft --only ao-field,pose-ao
for t in 0 0.4; do
  expect_exit 0 "$PENUMBRA" render builtin:courtyard --bake "$scratch/y.pbake" -o "$scratch/y$t.png" --view ao \
    --width 64 --height 48 --time "$t"
done
expect_exit 0 "$PENUMBRA" render builtin:courtyard -o "$scratch/plain.png" --view ao --width 64 --height 48
cmp -s "$scratch/y0.png" "$scratch/plain.png" && fail "the AO-field and pose-AO bake did not change the ao view"
cmp -s "$scratch/y0.png" "$scratch/y0.4.png" && fail "--time 0.4 rendered the same ao view as --time 0"
# A character exported alone (an armature scaled by 0.01, no lights, no camera) is framed by its
# skinned vertices and lit by the default light, which the tool announces; a black image fails.
armature="$SOURCE_DIR/tests/data/gltf/scaled_armature.gltf"
expect_exit 0 "$PENUMBRA" render "$armature" -o "$scratch/arm.png" --width 64 --height 48
expect_output "no lights"; expect_output "default light"
covered=$(grep -o '[0-9.]*% of the pixels not black' <<<"$out" | cut -d% -f1)
awk -v c="${covered:-0}" 'BEGIN { exit !(c > 10) }' || fail "the character covers ${covered:-no}% of the image, expected > 10%"
expect_exit 1 "$PENUMBRA" render "$armature" -o "$scratch/dark.png" --width 64 --height 48 --exposure 1e-9
expect_output "the image is black"
# --sky puts an equirectangular OpenEXR map behind and onto any scene (here an offline render of the
# Cornell box serves as one): the bake under it differs from the bake under the courtyard's uniform
# sky, and the render shows it; a missing map or a stray --sky-scale are refused.
expect_exit 0 "$PENUMBRA" render builtin:cornell --offline mc --spp 1 --width 32 --height 16 -o "$scratch/sky.exr"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard --only probe-grid --preset draft --sky "$scratch/sky.exr" --sky-scale 4 \
  -o "$scratch/mapped.pbake"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard --only probe-grid --preset draft -o "$scratch/uniform.pbake"
cmp -s "$scratch/mapped.pbake" "$scratch/uniform.pbake" && fail "the sky map did not change the probe bake"
expect_exit 0 "$PENUMBRA" render builtin:courtyard --bake "$scratch/mapped.pbake" --sky "$scratch/sky.exr" \
  --sky-scale 4 -o "$scratch/mapped.png" --width 48 --height 32
expect_exit 0 "$PENUMBRA" render builtin:courtyard --bake "$scratch/uniform.pbake" -o "$scratch/uniform.png" \
  --width 48 --height 32
cmp -s "$scratch/mapped.png" "$scratch/uniform.png" && fail "the sky map did not change the image"
expect_exit 1 "$PENUMBRA" render builtin:cornell --sky "$scratch/nosky.exr" -o "$scratch/x.png"
expect_output "--sky"; expect_output "nosky.exr"
expect_exit 2 "$PENUMBRA" render builtin:cornell --sky-scale 2 -o "$scratch/x.png"; expect_output "give --sky"
expect_exit 2 "$PENUMBRA" bake builtin:cornell --sky "$scratch/sky.exr" --sky-scale -1 -o "$scratch/x.pbake"
expect_output "--sky-scale"
# An ambient view of an unbaked scene is black too, and says to bake.
expect_exit 1 "$PENUMBRA" render builtin:cornell -o "$scratch/dark.png" --width 32 --height 24 --view irradiance
expect_output "--bake"
finish
