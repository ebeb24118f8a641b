#!/usr/bin/env bash
# Regenerates docs/gallery/*.png, docs/gallery.md and docs/gallery/manifest.json: one image of
# every shipped scene (scenes/*.json), rasterized from the CPU mesh with the scene's own camera,
# and for scenes with a blade (a surgical procedure) the last frame of `blobvk cut`.
# The manifest records each scene's and image's SHA-256; the test docs.gallery_is_current fails
# when a scene changes and its images are not regenerated.
#   scripts/gallery.sh [path/to/blobvk]     (default: build/release/apps/blobvk)
set -euo pipefail
cd "$(dirname "$0")/.."
BLOBVK="${1:-${BLOBVK:-build/release/apps/blobvk}}"
SIZE="${GALLERY_SIZE:-384x384}"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
mkdir -p docs/gallery
rm -f docs/gallery/*.png
rows="$(mktemp)"
trap 'rm -f "$rows"' EXIT
for scene in scenes/*.json; do
  name="$(basename "$scene" .json)"
  echo "gallery: $name" >&2
  if ! info="$("$BLOBVK" render "$scene" -o "docs/gallery/$name.png" --size "$SIZE" 2>&1)"; then
    echo "gallery: $name failed: $(echo "$info" | tail -1)" >&2
    exit 1
  fi
  # The caption is render's summary, "docs/gallery/NAME.png: 384x384, mesh, cpu backend, ...",
  # picked by its form: progress lines ("render: polygonizing ...") also hold ': '.
  summary="docs/gallery/$name.png: "
  line="$(printf '%s\n' "$info" | awk -v p="$summary" 'index($0, p) == 1 { print substr($0, length(p) + 1); exit }')"
  if [ -z "$line" ]; then
    echo "gallery: $name: no '$summary...' line in the output of blobvk render" >&2
    exit 1
  fi
  cut_line="-"
  if python3 -c 'import json,sys; sys.exit(0 if json.load(open(sys.argv[1])).get("simulation", {}).get("blade") else 1)' "$scene"; then
    echo "gallery: $name (blobvk cut)" >&2
    work="$(mktemp -d)"
    if ! cut_info="$("$BLOBVK" cut "$scene" -o "$work" --image-size "${SIZE%%x*}" 2>&1)"; then
      echo "gallery: $name cut failed: $(echo "$cut_info" | tail -1)" >&2
      exit 1
    fi
    last="$(ls "$work"/frame_*.png | tail -1)"
    cp "$last" "docs/gallery/${name}_cut.png"
    # "80 steps, 17 frames (PLY + PNG) in DIR; T ms/step; max tool force F N; N tets, M nodes; stats in F"
    cut_line="$(echo "$cut_info" | grep -m1 -E '^[0-9]+ steps, [0-9]+ frames ' |
      sed -e 's/ (PLY + PNG) in [^;]*;/;/' -e 's/ [0-9.]* ms\/step;//' -e 's/; stats in .*$//')"
    rm -rf "$work"
  fi
  printf '%s\t%s\t%s\t%s\n' "$name" "$(sha256sum "$scene" | cut -d' ' -f1)" "$line" "$cut_line" >>"$rows"
done
python3 - "$rows" "$SIZE" <<'PY'
import hashlib, json, os, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1]) if l.strip()]
size = sys.argv[2]
sha = lambda p: hashlib.sha256(open(p, "rb").read()).hexdigest()
manifest = {"scenes": {}}
for n, scene_sha, _, cut in rows:
    images = {f"{n}.png": sha(f"docs/gallery/{n}.png")}
    if cut != "-":
        images[f"{n}_cut.png"] = sha(f"docs/gallery/{n}_cut.png")
    manifest["scenes"][n] = {"scene_sha256": scene_sha, "images": images}
with open("docs/gallery/manifest.json", "w") as f:
    json.dump(manifest, f, indent=2, sort_keys=True)
    f.write("\n")
with open("docs/gallery.md", "w") as f:
    f.write("# Gallery\n\n")
    f.write("Every shipped scene (`scenes/*.json`), rendered headless on lavapipe with\n"
            f"`blobvk render SCENE -o docs/gallery/NAME.png --size {size}` (CPU mesh at the scene's grid,\n"
            "4x MSAA, the scene's camera or auto-framing). Scenes with a blade are surgical procedures:\n"
            "the second image is the last frame of `blobvk cut SCENE` (the soft body after the cut, with\n"
            "its lift and tools). `scripts/gallery.sh` regenerates the page, the images and\n"
            "`gallery/manifest.json`; the test `docs.gallery_is_current` fails when a scene changed and\n"
            "its images did not.\n\n")
    f.write("| scene | model | procedure (`blobvk cut`, last frame) |\n|---|---|---|\n")
    for n, _, line, cut in rows:
        proc = f"![{n} after the cut](gallery/{n}_cut.png)<br>{cut}" if cut != "-" else ""
        f.write(f"| `{n}` | ![{n}](gallery/{n}.png)<br>{line} | {proc} |\n")
PY
echo "wrote docs/gallery.md and docs/gallery/manifest.json" >&2
