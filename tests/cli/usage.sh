# The tool's usage contract: --help, exit codes 0/1/2, clear messages.
source "$(dirname "$0")/lib.sh"
expect_exit 0 "$PENUMBRA" --help;              expect_output "penumbra bake\|bake SCENE"
expect_exit 2 "$PENUMBRA";                     expect_output "usage"
expect_exit 2 "$PENUMBRA" frobnicate;          expect_output "unknown command 'frobnicate'"
expect_exit 2 "$PENUMBRA" bake builtin:cornell; expect_output "needs -o"
expect_exit 2 "$PENUMBRA" bake builtin:cornell -o "$scratch/a.pbake" --threads lots; expect_output "non-negative integer"
expect_exit 2 "$PENUMBRA" bake builtin:cornell -o "$scratch/a.pbake" --preset ultra; expect_output "ultra"
expect_exit 2 "$PENUMBRA" bake builtin:cornell --estimate --shard 0/2; expect_output "leave out --shard"
# An estimate writes nothing and names each baker; one of a scene with nothing to bake fails.
expect_exit 0 "$PENUMBRA" bake builtin:cornell --estimate --preset draft --only vertex-ao,probe-grid
expect_output "estimate of baking builtin:cornell"; expect_output "probe-grid"; expect_output "elements run"
expect_exit 1 "$PENUMBRA" bake builtin:furnace --estimate --preset draft --only pose-ao; expect_output "nothing to bake"
# An option a command does not know is named, whatever the command (and nothing is written).
expect_exit 2 "$PENUMBRA" render builtin:cornell -o "$scratch/u.png" --size 480x360; expect_output "render: unknown option --size"
[ -e "$scratch/u.png" ] && fail "a render with an unknown option wrote a file"
expect_exit 2 "$PENUMBRA" bake builtin:cornell -o "$scratch/u.pbake" --fast; expect_output "bake: unknown option --fast"
expect_exit 2 "$PENUMBRA" info "$scratch/u.pbake" -v;  expect_output "info: unknown option -v"
expect_exit 2 "$PENUMBRA" bench ecs --fast;            expect_output "bench: unknown option --fast"
expect_exit 2 "$PENUMBRA" compare a.exr b.exr --ssim;  expect_output "compare: unknown option --ssim"
expect_exit 2 "$PENUMBRA" merge a b -o "$scratch/m.pbake" --quick; expect_output "merge: unknown option --quick"
expect_exit 2 "$PENUMBRA" validate x.glb --strict;     expect_output "validate: unknown option --strict"
expect_exit 2 "$PENUMBRA" bench;               expect_output "one benchmark name"
expect_exit 2 "$PENUMBRA" bench nosuch;        expect_output "no benchmark named 'nosuch'"
expect_exit 0 "$PENUMBRA" bench --list;        expect_output "ecs"; expect_output "rays"; expect_output "probe-grid"; expect_output "ao-field"
expect_exit 0 "$PENUMBRA" bake --list;         expect_output "vertex-ao"; expect_output "probe-grid"; expect_output "ao-field"
finish
