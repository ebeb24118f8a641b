#!/usr/bin/env bash
# Regenerates docs/gallery/*.png and docs/gallery.md: one 384x384 image of every shipped scene
# (scenes/*.json), rasterized from the CPU mesh with the scene's own camera.
#   scripts/gallery.sh [path/to/blobvk]     (default: build/release/apps/blobvk)
set -euo pipefail
cd "$(dirname "$0")/.."
BLOBVK="${1:-${BLOBVK:-build/release/apps/blobvk}}"
SIZE="${GALLERY_SIZE:-384x384}"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
mkdir -p docs/gallery
{
  echo "# Gallery"
  echo
  echo "Every shipped scene (\`scenes/*.json\`), rendered headless on lavapipe with"
  echo "\`blobvk render SCENE -o docs/gallery/NAME.png --size $SIZE\` (CPU mesh at the scene's grid,"
  echo "4x MSAA, the scene's camera or auto-framing). Regenerate all with \`scripts/gallery.sh\`."
  echo
  echo "| scene | image | |"
  echo "|---|---|---|"
} > docs/gallery.md
for scene in scenes/*.json; do
  name="$(basename "$scene" .json)"
  echo "gallery: $name" >&2
  if info="$("$BLOBVK" render "$scene" -o "docs/gallery/$name.png" --size "$SIZE" 2>&1)"; then
    line="$(echo "$info" | grep -m1 ': ' | sed 's/^[^:]*: //')"
    echo "| \`$name\` | ![$name](gallery/$name.png) | $line |" >> docs/gallery.md
  else
    echo "| \`$name\` | (failed) | $(echo "$info" | tail -1) |" >> docs/gallery.md
  fi
done
echo "wrote docs/gallery.md" >&2
