#!/usr/bin/env bash
# Make the grids of gridsdf.json with ysdf, into sdfs/ (git-ignored).
#
#   make_grids.sh [YSDF] [BUNNY_MESH]
#
# YSDF defaults to build/release/ysdf. The bunnies come from the Stanford bunny
# mesh (BUNNY_MESH, default ../shared/meshes/bunny.ply next to the repo) via
# OpenVDB; without it a blobby stand-in bunny is baked from ellipsoids. The
# other two shapes are baked from analytic CSG. Every grid has voxel 0.002
# and 3 voxels of padding. The .sdf grids have bounds chosen so that their
# first sample sits at a known place, which scenes put at the instance's
# origin: the vol_instances' frames in gridsdf.json rely on it. The .vdb is
# placed by its own transform (where it was baked), as Blender places it.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
ysdf="${1:-$here/../../build/release/ysdf}"
bunny_mesh="${2:-$here/../../../shared/meshes/bunny.ply}"
voxel=0.002
mkdir -p "$here/sdfs"

# Bunny: mesh units are metres, bbox x in [-0.0807, 0.0807], y in [0, 0.162],
# z in [-0.0616, 0.0616], so the lattice puts the first sample at
# (-0.088, -0.006, -0.068); the stand-in uses the same bounds.
if [ -f "$bunny_mesh" ]; then
  "$ysdf" from-mesh "$bunny_mesh" "$here/sdfs/bunny.sdf" --voxel $voxel --pad 3
else
  echo "make_grids: $bunny_mesh not found, baking a stand-in bunny" >&2
  "$ysdf" bake "$here/sdfs/bunny.sdf" --voxel $voxel --pad 3 --blend 0.02 \
    --bounds -0.082 0 -0.062 0.082 0.162 0.062 \
    --shape "ellipsoid radii=0.065,0.05,0.048 at=0.012,0.05,0" \
    --shape "sphere radius=0.032 at=-0.045,0.095,0" \
    --shape "ellipsoid radii=0.012,0.035,0.008 at=-0.05,0.125,0.016" \
    --shape "ellipsoid radii=0.012,0.035,0.008 at=-0.05,0.125,-0.016" \
    --shape "sphere radius=0.014 at=0.07,0.055,0"
fi

# Blob: a smooth union of four spheres, as skanti binary.
"$ysdf" bake "$here/sdfs/blob.sdf" --binary --voxel $voxel --pad 3 --blend 0.03 \
  --bounds -0.07 0 -0.07 0.07 0.15 0.07 \
  --shape "sphere radius=0.05 at=0,0.05,0" \
  --shape "sphere radius=0.04 at=0.03,0.1,0.01" \
  --shape "sphere radius=0.035 at=-0.03,0.095,-0.02" \
  --shape "sphere radius=0.025 at=0,0.12,0.035"

# Dice: a rounded cube with a sphere carved out, as an OpenVDB level set.
"$ysdf" bake "$here/sdfs/dice.vdb" --voxel $voxel --pad 3 --blend 0.008 \
  --bounds -0.055 0 -0.055 0.055 0.11 0.055 \
  --shape "rounded_box whd=0.055,0.055,0.055 radius=0.012 at=0,0.055,0" \
  --shape "-sphere radius=0.066 at=0,0.055,0"
