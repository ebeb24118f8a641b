#!/usr/bin/env bash
# Rewrites the project's own includes from "<room>/file.h" to "blobvk/<room>/file.h", the path
# they have once installed (include/blobvk/<room>/), so installed headers resolve among
# themselves without a bare mesh/ or vk/ on a consumer's include path. The source tree resolves
# the new paths through the committed links include/blobvk/<room> -> ../../<room>, which this
# script also creates for any room folder that lacks one (a room added by another branch).
#
# Mechanical and idempotent: only #include lines whose "<room>/<path>" names an existing file of
# that room's folder are changed (so tests' own "fem/..." helpers are not), and a line already
# reading "blobvk/<room>/..." is left alone. Run from anywhere in the checkout, e.g. after
# merging branches that still use the old form:  scripts/dev/rename_includes.sh
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
python3 - <<'PY'
import os, re, subprocess
rooms = [r for r in ("blobtree", "mesh", "cpu_simd", "vk", "fem", "cutting", "shaders", "surgery") if os.path.isdir(r)]
pattern = re.compile(r'^(\s*#\s*include\s*)([<"])(' + "|".join(rooms) + r')/([^">]+)([">])', re.M)
files = subprocess.run(["git", "ls-files", "-z", "--", "*.h", "*.hpp", "*.cpp", "*.cc", "*.in"],
                       check=True, capture_output=True, text=True).stdout.split("\0")
os.makedirs("include/blobvk", exist_ok=True)
for room in rooms:
    link = os.path.join("include/blobvk", room)
    if not os.path.islink(link):
        os.symlink(os.path.join("../..", room), link)
        print(f"rename_includes: added {link} -> ../../{room}")
changed = 0
for path in filter(None, files):
    if not os.path.isfile(path) or os.path.islink(path):
        continue
    with open(path, encoding="utf-8") as f:
        text = f.read()
    def fix(m):
        room, rest = m.group(3), m.group(4)
        if not os.path.isfile(os.path.join(room, rest)):
            return m.group(0)
        return f'{m.group(1)}{m.group(2)}blobvk/{room}/{rest}{m.group(5)}'
    new = pattern.sub(fix, text)
    if new != text:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)
        changed += 1
print(f"rename_includes: {changed} file(s) changed")
PY
