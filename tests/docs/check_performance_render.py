#!/usr/bin/env python3
"""docs/performance.md and its renderer stay in step, without measuring anything.

Renders the fixture results in tests/docs/performance_fixture/ (a trimmed run of
scripts/performance.sh: one repetition of each benchmark) over a copy of docs/performance.md and
checks that, above the hand-measured marker, the rendered page has the committed page's `##` and
`###` headings and its table columns in the same order, and that the page from the marker on is
kept byte for byte. A hand edit of the generated part that the renderer does not know (a new
section, a moved one, another column) fails here instead of being dropped by the next run.

Usage: check_performance_render.py SOURCE_DIR
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

MARKER = "<!-- Hand-measured sections:"


def generated(text):
    at = text.find(MARKER)
    if at < 0:
        sys.exit(f"no '{MARKER}' line in the page")
    return text[:at], text[at:]


def headings(text):
    return [line for line in text.splitlines() if re.match(r"#{2,3} ", line)]


def table_headers(text):
    lines = text.splitlines()
    return [line for line, below in zip(lines, lines[1:])
            if line.startswith("|") and re.fullmatch(r"\|(---\|)+", below)]


def compare(what, want, got):
    if want == got:
        return 0
    print(f"{what} differ between docs/performance.md and the rendered page:")
    for i in range(max(len(want), len(got))):
        w = want[i] if i < len(want) else "(none)"
        g = got[i] if i < len(got) else "(none)"
        if w != g:
            print(f"  #{i + 1}\n    page:     {w}\n    rendered: {g}")
    return 1


def main():
    source = sys.argv[1]
    page_path = os.path.join(source, "docs", "performance.md")
    page = open(page_path, encoding="utf-8").read()
    with tempfile.TemporaryDirectory() as docs:
        shutil.copy(page_path, os.path.join(docs, "performance.md"))
        subprocess.run([sys.executable, os.path.join(source, "scripts", "perf", "render_performance.py"),
                        os.path.join(source, "tests", "docs", "performance_fixture"), docs], check=True)
        rendered = open(os.path.join(docs, "performance.md"), encoding="utf-8").read()
    page_top, page_rest = generated(page)
    top, rest = generated(rendered)
    failures = compare("Headings", headings(page_top), headings(top))
    failures += compare("Table columns", table_headers(page_top), table_headers(top))
    if "_(not measured" in top:
        print("The fixture leaves a table unmeasured: it should hold every benchmark the page shows.")
        failures += 1
    if rest != page_rest:
        print("The hand-measured part (from the marker on) was not kept byte for byte.")
        failures += 1
    if failures:
        print("Update scripts/perf/render_performance.py to the page's structure (or the page to the "
              "renderer's), then compare a real run: see scripts/performance.sh.")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
