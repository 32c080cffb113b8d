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

# -o never replaces the scene being read, nor a file that is not a .pbake without --force, and
# writes through a symbolic link (the link stays a link).
echo "my notes" > "$scratch/notes.txt"
expect_exit 1 "$PENUMBRA" bake builtin:cornell -o "$scratch/notes.txt" --preset draft; expect_output "not a .pbake"
[ "$(cat "$scratch/notes.txt")" = "my notes" ] || fail "bake overwrote a text file"
expect_exit 0 "$PENUMBRA" bake builtin:cornell -o "$scratch/notes.txt" --preset draft --force
cp "$SOURCE_DIR/tests/data/gltf/valid.gltf" "$scratch/level.gltf"
cp "$scratch/level.gltf" "$scratch/level.before"
expect_exit 1 "$PENUMBRA" bake "$scratch/level.gltf" -o "$scratch/level.gltf" --force; expect_output "is the scene being baked"
cmp "$scratch/level.gltf" "$scratch/level.before" || fail "bake overwrote its own input"
ln -s good.pbake "$scratch/link.pbake"
expect_exit 0 "$PENUMBRA" bake builtin:cornell -o "$scratch/link.pbake" --preset draft --seed 7
[ -L "$scratch/link.pbake" ] || fail "bake replaced a symbolic link by a file"
expect_exit 0 "$PENUMBRA" info "$scratch/good.pbake"

# A bake that produces nothing says so and writes nothing: CesiumMan has no probe grid; its
# skinned mesh bakes vertex AO in the bind pose.
if [ -f "$SOURCE_DIR/../shared/assets/CesiumMan.glb" ]; then
  expect_exit 1 "$PENUMBRA" bake "$SOURCE_DIR/../shared/assets/CesiumMan.glb" -o "$scratch/none.pbake" --only probe-grid
  expect_output "baked nothing"; expect_output "probe-grid bakes entities with an IrradianceProbeGrid"
  [ -e "$scratch/none.pbake" ] && fail "a bake of nothing wrote a file"
  expect_exit 0 "$PENUMBRA" bake "$SOURCE_DIR/../shared/assets/CesiumMan.glb" -o "$scratch/cm.pbake" --only vertex-ao \
    --preset draft
  expect_output "1 meshes, 3273 vertices"
else
  echo "skipped the CesiumMan checks: ../shared/assets/CesiumMan.glb is absent"
fi
# Every baker named says what it bakes and what the scene lacks (the test data, always present).
expect_exit 1 "$PENUMBRA" bake "$SOURCE_DIR/tests/data/gltf/scaled_armature.gltf" -o "$scratch/none.pbake" \
  --only probe-grid,ao-field
expect_output "probe-grid bakes entities with an IrradianceProbeGrid"; expect_output "ao-field bakes"
# ... and how a glTF declares the component.
expect_output '"components": {"IrradianceProbeGrid": {"preset": "medium"}}'
expect_output '"components": {"AOFieldCaster": {"preset": "medium"}}'
expect_exit 1 "$PENUMBRA" bake "$SOURCE_DIR/tests/data/gltf/lighting_extension.gltf" -o "$scratch/none.pbake" \
  --only pose-ao
expect_output "pose-ao bakes skinned meshes"
expect_exit 1 "$PENUMBRA" bake "$SOURCE_DIR/tests/data/gltf/valid.gltf" -o "$scratch/none.pbake" --only pose-ao
expect_output "0 skinned meshes"
# A whole bake writes what it can and says, under each module that found nothing, why.
expect_exit 0 "$PENUMBRA" bake "$SOURCE_DIR/tests/data/gltf/valid.gltf" -o "$scratch/some.pbake" --preset draft
expect_output "nothing to bake: probe-grid bakes entities with an IrradianceProbeGrid"
expect_output "nothing to bake: indirect-transport bakes a scene with an IndirectTransport"
grep -q "nothing to bake: vertex-ao" <<<"$out" && fail "vertex-ao baked the mesh but was reported empty"
# A glTF level declares its lighting components (PENUMBRA_lighting): the bake bakes them; a
# mistake in a declaration names the file, the node, the component and the field.
level="$SOURCE_DIR/tests/data/gltf/lighting_extension.gltf"
expect_exit 0 "$PENUMBRA" bake "$level" -o "$scratch/level.pbake" --only probe-grid,ao-field
expect_output "grid 8x4x8"; expect_output "falloff 1.5"
sed 's/"spacing": 1.0/"spacing": -1.0/' "$level" > "$scratch/bad_level.gltf"
expect_exit 1 "$PENUMBRA" bake "$scratch/bad_level.gltf" -o "$scratch/bad.pbake"
expect_output "bad_level.gltf: nodes\[3\] 'probes'.extensions.PENUMBRA_lighting: IrradianceProbeGrid: field 'spacing'"
expect_exit 1 "$PENUMBRA" validate "$scratch/bad_level.gltf"; expect_output "field 'spacing'"
expect_exit 0 "$PENUMBRA" validate "$level"; expect_output "2 lighting components declared"

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

# validate checks without baking: a good bake and glTF pass, damaged ones fail naming the file and
# the element, anything else is a usage error.
expect_exit 0 "$PENUMBRA" validate "$scratch/good.pbake"; expect_output "valid .pbake"
expect_exit 1 "$PENUMBRA" validate "$scratch/flip.pbake"; expect_output "flip.pbake"
expect_exit 0 "$PENUMBRA" validate "$SOURCE_DIR/tests/data/gltf/valid.glb"; expect_output "valid glTF"
expect_exit 1 "$PENUMBRA" validate "$SOURCE_DIR/tests/data/gltf/short_buffer.gltf"; expect_output "bufferViews\[2\]"
expect_exit 2 "$PENUMBRA" validate "$scratch/notes.txt"; expect_output "validate reads"
# --quiet hides the SDK's warnings (the degenerate triangles dropped), --verbose keeps them.
expect_exit 0 "$PENUMBRA" validate "$SOURCE_DIR/tests/data/gltf/degenerate.gltf"
expect_output "penumbra: warning: .*degenerate"
expect_exit 0 "$PENUMBRA" validate "$SOURCE_DIR/tests/data/gltf/degenerate.gltf" --quiet
grep -q "penumbra: warning" <<<"$out" && fail "--quiet still printed a warning: $out"
expect_exit 0 "$PENUMBRA" --verbose validate "$SOURCE_DIR/tests/data/gltf/degenerate.gltf"
expect_output "penumbra: warning: .*degenerate"
# A character without clips bakes its pose-AO over its joints' roles; --poses adds an animation
# file's clips retargeted by joint name (a node the character lacks is named, not fatal), and a
# file that drives nothing of the scene is refused by name.
armature="$SOURCE_DIR/tests/data/gltf/scaled_armature.gltf"
expect_exit 0 "$PENUMBRA" bake "$armature" -o "$scratch/roles.pbake" --only pose-ao --preset draft
expect_output "pose space from the joints' roles: 2 of 2 joints move"
expect_exit 0 "$PENUMBRA" bake "$armature" -o "$scratch/wave.pbake" --only pose-ao --preset draft \
  --poses "$SOURCE_DIR/tests/data/gltf/scaled_armature_wave.gltf"
expect_output "1 clips, 1 channels retargeted"; expect_output "dropped ('rig:prop')"
expect_output "pose space from the clips: 1 of 2 joints move, the widest 0.9 rad"
expect_exit 1 "$PENUMBRA" bake builtin:cornell -o "$scratch/x.pbake" --poses "$SOURCE_DIR/tests/data/gltf/scaled_armature_wave.gltf"
expect_output "no animation channel drives a node of the scene"; expect_output "'rig:head'"
expect_exit 2 "$PENUMBRA" bake "$armature" -o "$scratch/x.pbake" --poses; expect_output "--poses needs a value"
# Joint limits by name, declared in the glTF lighting extension: applied, and a name that matches
# no joint is named.
expect_exit 0 "$PENUMBRA" bake "$SOURCE_DIR/tests/data/gltf/scaled_armature_limits.gltf" -o "$scratch/limits.pbake" \
  --only pose-ao
expect_output "joint_limits 'tail' match no joint"; expect_output "the widest 1.6 rad"
finish
