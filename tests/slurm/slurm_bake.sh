#!/usr/bin/env bash
# scripts/slurm-bake on a single-node Slurm cluster started here (tests/slurm/local_cluster.sh):
# the courtyard in 4 shards, merged, byte-identical to a local bake; a rerun after losing a part
# bakes only that part; a submission Slurm refuses exits non-zero with Slurm's message. Skips
# (exit 77) where Slurm or root is missing. Needs PENUMBRA and SOURCE_DIR.
set -euo pipefail
: "${PENUMBRA:?}" "${SOURCE_DIR:?}"

skip() { echo "SKIPPED: $*"; exit 77; }
[ "$(id -u)" -eq 0 ] || skip "a single-node Slurm cluster needs root (slurmd runs jobs as their user)"
for tool in munged mungekey slurmctld slurmd sbatch sinfo scancel runuser; do
  command -v "$tool" >/dev/null || skip "$tool is not installed (scripts/bootstrap installs slurm-wlm and munge)"
done

dir=$(mktemp -d /tmp/penumbra-slurm.XXXXXX)
chmod 755 "$dir"  # the munge user enters it
source "$SOURCE_DIR/tests/slurm/local_cluster.sh"
cleanup() { cluster_stop "$dir/cluster"; rm -rf "$dir"; }
trap cleanup EXIT
cluster_start "$dir/cluster"
echo "cluster up: $(sinfo -h -o '%P %t %N')"

"$PENUMBRA" bake builtin:courtyard --preset draft --seed 3 -o "$dir/local.pbake" >/dev/null
bake=("$SOURCE_DIR/scripts/slurm-bake" builtin:courtyard -o "$dir/shared/level.pbake" --shards 4 --preset draft
  --seed 3 --penumbra "$PENUMBRA" --wait)
mkdir -p "$dir/shared"
"${bake[@]}" | tee "$dir/run1.txt"
grep -Eq "shards: job array [0-9]+" "$dir/run1.txt"
grep -Eq "merge: job [0-9]+ \(after job [0-9]+ succeeds" "$dir/run1.txt"
cmp "$dir/local.pbake" "$dir/shared/level.pbake"
echo "merged file byte-identical to the local bake"
for i in 0 1 2 3; do grep -q "baked shard $i/4 of builtin:courtyard" "$dir/shared/level.pbake.parts/shard_$i.log"; done

# A lost part: the rerun bakes shard 2 only; the others find their parts up to date.
rm "$dir/shared/level.pbake.parts/part_2-of-4.pbake" "$dir/shared/level.pbake"
"${bake[@]}" >/dev/null
for i in 0 1 3; do grep -q "is up to date" "$dir/shared/level.pbake.parts/shard_$i.log"; done
grep -q "baked shard 2/4" "$dir/shared/level.pbake.parts/shard_2.log"
cmp "$dir/local.pbake" "$dir/shared/level.pbake"
echo "rerun baked only the missing part"

# Slurm refuses the submission: non-zero, with Slurm's own words.
if "$SOURCE_DIR/scripts/slurm-bake" builtin:courtyard -o "$dir/x.pbake" --shards 2 --partition no-such-partition \
    --penumbra "$PENUMBRA" 2>"$dir/refused.txt"; then
  echo "FAIL: a submission to a missing partition succeeded" >&2; exit 1
fi
grep -q "sbatch refused the shards: .*[Ii]nvalid partition" "$dir/refused.txt" || { cat "$dir/refused.txt" >&2; exit 1; }

# A failing shard (an unreadable scene) cancels the merge, and --wait says so.
echo "not a glTF" > "$dir/shared/broken.gltf"
if "$SOURCE_DIR/scripts/slurm-bake" "$dir/shared/broken.gltf" -o "$dir/shared/broken.pbake" --shards 2 \
    --penumbra "$PENUMBRA" --wait >"$dir/failed.txt" 2>&1; then
  echo "FAIL: a bake whose shards fail reported success" >&2; cat "$dir/failed.txt" >&2; exit 1
fi
grep -q "did not succeed" "$dir/failed.txt" || { cat "$dir/failed.txt" >&2; exit 1; }
grep -q "penumbra: .*broken.gltf: " "$dir/failed.txt" || { cat "$dir/failed.txt" >&2; exit 1; }
[ ! -e "$dir/shared/broken.pbake" ]
echo "PASS"
