#!/usr/bin/env bash
# Record the outputs of `photostereo normals` and `run` on a few cases into $1 (a dir).
# Usage: scripts/bitcheck.sh OUT_DIR [BIN]   (from the repository root; BIN default
# target/release/photostereo). The inputs are rendered once into $BITCHECK_DATA
# (default /tmp/bitcheck-data); ../shared/data must exist. Compare two recordings with
# scripts/bitcheck_compare.py A B. Used for issue 25 item 3 (outputs bit-identical).
set -euo pipefail
out="$1"; bin="$(realpath "${2:-target/release/photostereo}")"
data="${BITCHECK_DATA:-/tmp/bitcheck-data}"; sh="$(realpath ../shared/data)"
mkdir -p "$out"
if [ ! -d "$data" ]; then
  mkdir -p "$data"
  $bin -q synth --shape blob --material plastic --bits 8 --exposure peak --calib-sphere 100 --seed 5 -o $data/plastic8
  $bin -q synth --shape blob --material metal --bits 8 --exposure peak --calib-sphere 100 --seed 5 -o $data/metal8
  $bin -q synth --shape blob --material lambertian --size 128 --noise 0.01 -o $data/lamb
  $bin -q synth --shape blob --material plastic --albedo-texture --size 128 --noise 0.005 --calib-sphere 50 -o $data/tex
  $bin -q calibrate $data/plastic8/sphere -o $data/plastic8.lut
  $bin -q calibrate $data/metal8/sphere -o $data/metal8.lut
  $bin -q calibrate $data/tex/sphere -o $data/tex.lut
  $bin -q calibrate $sh/calib_roughplastic -o $data/rough.lut
  $bin -q calibrate $sh/calib_diffuse -o $data/diffuse.lut
fi
n() { local name="$1"; shift; $bin -q normals "$@" -o "$out/$name"; }
r() { local name="$1"; shift; $bin -q run "$@" -o "$out/$name"; }
n plastic8 $data/plastic8 --lut $data/plastic8.lut
n plastic8_nosp $data/plastic8 --lut $data/plastic8.lut --no-spatial
n metal8 $data/metal8 --lut $data/metal8.lut
n metal8_nocontour $data/metal8 --lut $data/metal8.lut --no-contour
n lamb $data/lamb --lambertian
n lamb_nosp $data/lamb --lambertian --no-spatial
n lamb_plain $data/lamb --lambertian --plain
n tex_norm $data/tex --lut $data/tex.lut --normalize
n tex_nosplit $data/tex --lut $data/tex.lut --normalize --no-split
n tex_split $data/tex --lut $data/tex.lut --split-specular
n tex_nearest $data/tex --lut $data/tex.lut --lookup nearest
n rough $sh/target_roughplastic --lut $data/rough.lut
n rough_mix $sh/target_roughplastic --lut $data/rough.lut --lut $data/diffuse.lut
n diffuse $sh/target_diffuse --lut $data/diffuse.lut
r run_plastic8 $data/plastic8 --sphere $data/plastic8/sphere
r run_lamb $data/lamb --lambertian
r run_lamb_nosp $data/lamb --lambertian --no-spatial
r run_rough $sh/target_roughplastic --sphere $sh/calib_roughplastic
r run_rough_lut $sh/target_roughplastic --lut $data/rough.lut --no-spatial
r run_tex_norm $data/tex --lut $data/tex.lut --normalize
# whole-stack path of run (a non-linear response is not read by bands)
r run_plastic8_srgb $data/plastic8 --sphere $data/plastic8/sphere --response srgb
r run_lamb_srgb $data/lamb --lambertian --response srgb
r run_lamb_srgb_nosp $data/lamb --lambertian --response srgb --no-spatial
r run_tex_srgb $data/tex --lut $data/tex.lut --normalize --response srgb
$bin -q demo --size 96 -o "$out/demo"
echo done
