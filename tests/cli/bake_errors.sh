# Bad input gives a clear message and exit 1, and never destroys a good file already on disk.
source "$(dirname "$0")/lib.sh"
expect_exit 1 "$PENUMBRA" bake builtin:nosuch -o "$scratch/x.pbake";  expect_output "nosuch"; expect_output "cornell"
expect_exit 1 "$PENUMBRA" bake "$scratch/missing.gltf" -o "$scratch/x.pbake"; expect_output "missing.gltf"
expect_exit 1 "$PENUMBRA" bake builtin:cornell -o "$scratch/x.pbake" --only nosuch; expect_output "nosuch"
[ -e "$scratch/x.pbake" ] && fail "a failed bake left a file behind"

expect_exit 0 "$PENUMBRA" bake builtin:cornell -o "$scratch/good.pbake" --preset draft
cp "$scratch/good.pbake" "$scratch/before.pbake"
expect_exit 1 "$PENUMBRA" bake builtin:nosuch -o "$scratch/good.pbake"
cmp "$scratch/good.pbake" "$scratch/before.pbake" || fail "a failed bake changed the previous file"

# info on damaged files: truncated, corrupted, not a bake file at all.
head -c 100 "$scratch/good.pbake" > "$scratch/short.pbake"
expect_exit 1 "$PENUMBRA" info "$scratch/short.pbake"; expect_output "short.pbake"
cp "$scratch/good.pbake" "$scratch/flip.pbake"
size=$(stat -c %s "$scratch/flip.pbake")
# Complement one byte near the end (whatever it held: 0xff is a common value there).
byte=$(od -An -tu1 -j $((size - 5)) -N1 "$scratch/flip.pbake" | tr -d ' ')
printf "\\$(printf '%03o' $((255 - byte)))" | dd of="$scratch/flip.pbake" bs=1 seek=$((size - 5)) conv=notrunc status=none
expect_exit 1 "$PENUMBRA" info "$scratch/flip.pbake"; expect_output "flip.pbake"
echo "hello" > "$scratch/text.pbake"
expect_exit 1 "$PENUMBRA" info "$scratch/text.pbake"; expect_output "text.pbake"
finish
