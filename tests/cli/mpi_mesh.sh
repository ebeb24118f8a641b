#!/bin/sh
# mpirun -n N blobvk mesh: for 1, 2 and 4 ranks (oversubscribed, one thread each) the file is the
# one-process in-memory file byte for byte (binary PLY and OBJ), and rank 0's streamed check
# reports it watertight. Usage: mpi_mesh.sh BLOBVK MPIEXEC SCENE
set -eu
blobvk=$1 mpiexec=$2 scene=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
root=""
if [ "$(id -u)" = 0 ]; then root=--allow-run-as-root; fi
# 61 cells along z with 3-cell MPUs: 21 layers, the top one thinner than the others, more than
# a rank keeps in flight (apps/mesh_mpi.cpp).
grid="--resolution 61 --mpu 3"
for ext in ply obj; do
  "$blobvk" mesh "$scene" $grid -o "$dir/one.$ext" -q
  for n in 1 2 4; do
    "$mpiexec" $root --oversubscribe -n $n "$blobvk" mesh "$scene" $grid --threads 1 -o "$dir/r$n.$ext" >"$dir/log" 2>&1 ||
      { cat "$dir/log"; echo "mpirun -n $n failed"; exit 1; }
    cmp "$dir/one.$ext" "$dir/r$n.$ext" || { echo "$n ranks: $ext differs from one process"; exit 1; }
    grep -q "; watertight (" "$dir/log" || { cat "$dir/log"; echo "$n ranks: no watertight check line"; exit 1; }
    if [ $n -gt 1 ]; then grep -q "$n MPI ranks" "$dir/log" || { cat "$dir/log"; echo "not $n ranks"; exit 1; }; fi
  done
done
# Rank 0's share of the layers, from none to all: the same bytes whoever computes a layer.
for share in 0 0.7 1; do
  BLOBVK_MPI_ROOT_SHARE=$share "$mpiexec" $root --oversubscribe -n 2 "$blobvk" mesh "$scene" $grid --threads 1 \
    -o "$dir/s.ply" -q >"$dir/log" 2>&1 || { cat "$dir/log"; echo "share $share failed"; exit 1; }
  cmp "$dir/one.ply" "$dir/s.ply" || { echo "share $share: ply differs from one process"; exit 1; }
done
# A share that is not a number from 0 to 1 stops every rank with one line naming the variable.
if BLOBVK_MPI_ROOT_SHARE=1.5 "$mpiexec" $root --oversubscribe -n 2 "$blobvk" mesh "$scene" $grid --threads 1 \
     -o "$dir/bad.ply" -q >"$dir/log" 2>&1; then
  cat "$dir/log"; echo "share 1.5 was accepted"; exit 1
fi
grep -q "blobvk: error: BLOBVK_MPI_ROOT_SHARE: expected a number from 0 to 1, got '1.5'" "$dir/log" ||
  { cat "$dir/log"; echo "no clear line for a bad share"; exit 1; }
[ ! -e "$dir/bad.ply" ] || { echo "a bad share left a file"; exit 1; }
echo "1, 2 and 4 ranks, rank 0 shares 0 to 1: identical files"
