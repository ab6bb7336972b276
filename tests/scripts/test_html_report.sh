#!/usr/bin/env bash
# The HTML report in a real browser, the diagnosis in the CLI, the --field
# extension.  Headless Chromium loads the page offline (every host maps to
# nothing), the DOM after scripts ran is checked for the charts and their
# bars, the console for errors, and a screenshot for not being blank.
# usage: test_html_report.sh TETOPT SOURCE_DIR      exit 77: no chromium (skip)
# TETOPT_LONG_TESTS=1 also compares the mesh-wide bound with
# ../shared/tools/bound.py on hinge_raw (minutes).
set -u
T=$1; SRC=$2
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
PY=/usr/bin/python3
fail=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fail=1; fi; }

"$T" generate "$W/box.mesh" --cells 6 6 6 --jitter 0.42 --regions 2 --seed 7
"$T" improve "$W/box.mesh" -o "$W/out.mesh" --html "$W/improve.html" --field "$W/f.vtu" --report "$W/r.json" \
  > "$W/improve.txt" 2>&1; rc=$?
check "improve --html exits 0" '[ $rc -eq 0 ]'
check "improve prints the diagnosis" 'grep -q "diagnosis at α < 0.3" "$W/improve.txt"'
check "improve prints the bound" 'grep -q "bound from [0-9]* constrained triangles" "$W/improve.txt"'
"$T" quality "$W/box.mesh" --html "$W/quality.html" --threshold 0.4 --field "$W/q.vtu" > "$W/quality.txt" 2>&1; rc=$?
check "quality --html exits 0" '[ $rc -eq 0 ]'
check "quality prints diagnosis counts" 'grep -Eq "diagnosis at α < 0.4: [1-9][0-9]* tets — [0-9]+ locked by their boundary triangle, [0-9]+ locked by constrained neighbours, [0-9]+ improvable" "$W/quality.txt"'
"$T" quality "$W/box.mesh" --json > "$W/q.json"
check "quality --json carries the diagnosis" '$PY -c "
import json; q=json.load(open(\"$W/q.json\")); d=q[\"diagnosis\"]
assert d[\"below_threshold\"] == d[\"locked_by_triangle\"] + d[\"locked_by_neighbours\"] + d[\"improvable\"]
assert d[\"below_threshold\"] == q[\"alpha_below_0.3\"]
assert d[\"bound\"][\"alpha_upper_bound\"] >= q[\"alpha_worst\"]
"'
check "report JSON lists diagnosed tets with locations" '$PY -c "
import json; r=json.load(open(\"$W/r.json\")); d=r[\"diagnosis\"]
assert r[\"boundary_unchanged\"][\"ok\"] is True
assert len(d[\"tets\"]) == d[\"below_threshold\"]
for t in d[\"tets\"]: assert len(t[\"centroid\"]) == 3 and t[\"alpha\"] < d[\"threshold\"]
"'

# Self-contained: no external resource of any kind.  The 3D view's code
# (the three.js inlined as <script type="text/plain" id="tv-three-...">, and
# the module that loads it from blob: URLs) names URLs in code that never
# fetches here (three's loaders, an XHTML namespace); test_view3d.sh checks
# in the browser that the page requests nothing outside itself.
page_text() {
  $PY -c 'import re, sys
t = open(sys.argv[1], encoding="utf-8").read()
t = re.sub(r"<script type=\"(text/plain\" id=\"tv-three-[a-z]+|module)\">.*?</script>", "", t, flags=re.S)
sys.stdout.write(t.replace("http://www.w3.org/2000/svg", ""))' "$1"
}
for h in improve quality; do
  check "$h.html references nothing outside itself" \
    '! grep -Eiq "<link|<script[^>]+src|<img|@import|url\(|https?://" <(page_text "$W/$h.html")'
done

# The .vtu field file: alpha_before where the tet survived, NaN elsewhere.
# Bar titles name each 0.05-wide alpha bin by its own bounds (one decimal
# gave "0.1-0.1"), and the first one says it holds inverted and flat tets.
check "alpha bar titles: two decimals, first bin holds the inverted" \
  'grep -q "<title>before: 0.05–0.10: [0-9]*</title>" "$W/improve.html" && grep -q "<title>mesh: below 0.05 (inverted and flat tets included): [0-9]*</title>" "$W/quality.html"'
# A file name that is not UTF-8 (Latin-1 0xFF) must not make the page,
# which says charset utf-8, malformed: such bytes become U+FFFD.
cp "$W/box.mesh" "$W/bad"$'\xff'"name.mesh"
"$T" quality "$W/bad"$'\xff'"name.mesh" --html "$W/latin.html" -q > /dev/null 2>&1
check "HTML is valid UTF-8 for a non-UTF-8 file name" \
  '$PY -c "import sys; t = open(sys.argv[1], \"rb\").read().decode(\"utf-8\"); assert \"bad\ufffdname\" in t" "$W/latin.html"'
check "field file has the new arrays" '( for n in alpha alpha_before diagnosis alpha_bound kind; do grep -q "Name=\"$n\"" "$W/f.vtu" || exit 1; done )'
if $PY -c "import meshio" 2> /dev/null; then
  check "alpha_before: survivors carry the input alpha, new tets NaN" '$PY -c "
import meshio, numpy as np
def alpha(p, t):
    a,b,c,d = (p[t[:,i]] for i in range(4))
    vol = np.einsum(\"ij,ij->i\", b-a, np.cross(c-a, d-a))/6
    ar = lambda x,y,z: 0.5*np.linalg.norm(np.cross(y-x, z-x), axis=1)
    S = ar(a,b,c)+ar(a,b,d)+ar(a,c,d)+ar(b,c,d)
    L = np.max([np.linalg.norm(x-y, axis=1) for x,y in [(a,b),(a,c),(a,d),(b,c),(b,d),(c,d)]], axis=0)
    return 6*np.sqrt(6)*vol/(S*L)
i = meshio.read(\"$W/box.mesh\"); o = meshio.read(\"$W/f.vtu\")
ti = i.cells_dict[\"tetra\"]; to = o.cells_dict[\"tetra\"]
ab = o.cell_data[\"alpha_before\"][0]; af = o.cell_data[\"alpha\"][0]
key = {tuple(sorted(t)): q for t, q in zip(ti, alpha(i.points, ti))}
exp = np.array([key.get(tuple(sorted(t)), np.nan) for t in to])
assert np.isnan(ab).sum() == np.isnan(exp).sum() and np.isnan(exp).sum() > 0
m = ~np.isnan(exp)
assert np.allclose(ab[m], exp[m], rtol=1e-9, atol=1e-12)
assert np.allclose(af, alpha(o.points, to), rtol=1e-9, atol=1e-12)
"'
fi

CHROME=/usr/bin/chromium
[ -x "$CHROME" ] || { echo "skip: no $CHROME"; [ $fail -eq 0 ] && exit 77 || exit 1; }
browse() {  # browse HTML EXTRA-ARGS...: runs headless chromium offline
  local page=$1; shift
  timeout 120 "$CHROME" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync --user-data-dir="$(mktemp -d -p "$W")" \
    --host-resolver-rules="MAP * ~NOTFOUND" --enable-logging=stderr --v=0 "$@" "file://$page"
}

for h in improve quality; do
  browse "$W/$h.html" --dump-dom > "$W/$h.dom" 2> "$W/$h.log"
  check "$h: chromium loads the page" '[ -s "$W/$h.dom" ]'
  check "$h: no script or console errors" '! grep -Eq "Uncaught|SyntaxError|ReferenceError|TypeError|CONSOLE\(.*error|Failed to load" "$W/$h.log"'
  check "$h: the script ran" 'grep -q "data-report-ready=\"1\"" "$W/$h.dom"'
  if [ $h = improve ]; then series=2; else series=1; fi
  check "$h: histograms have the right bars" '$PY - "$W/$h.dom" $series <<"EOF"
import sys
from html.parser import HTMLParser
class P(HTMLParser):
    def __init__(s):
        super().__init__(); s.svg = None; s.bars = {}; s.heights = {}
    def handle_starttag(s, tag, a):
        a = dict(a)
        if tag == "svg" and "hist" in a.get("class", ""): s.svg = a["id"]; s.bars[s.svg] = 0; s.heights[s.svg] = []
        if tag == "rect" and s.svg and "bar" in a.get("class", "").split():
            s.bars[s.svg] += 1; s.heights[s.svg].append((int(a["data-count"]), float(a["height"])))
    def handle_endtag(s, tag):
        if tag == "svg": s.svg = None
p = P(); p.feed(open(sys.argv[1]).read()); k = int(sys.argv[2])
assert p.bars.get("hist-alpha") == 20 * k, p.bars
assert p.bars.get("hist-dihedral") == 36 * k, p.bars
for h in p.heights.values():   # every non-empty bin drawn, empty bins flat
    assert all((c > 0) == (y > 0) for c, y in h), h
    assert sum(c for c, _ in h) > 0
EOF'
  check "$h: tables and diagnosis are in the DOM" 'grep -q "id=\"stats\"" "$W/$h.dom" && grep -q "id=\"diagnosis\"" "$W/$h.dom" && grep -q "id=\"verdict\"" "$W/$h.dom"'
  browse "$W/$h.html" --screenshot="$W/$h.png" --window-size=1200,2000 > /dev/null 2>&1
  check "$h: screenshot is not blank" '$PY - "$W/$h.png" <<"EOF"
import sys, zlib, struct
import numpy as np
def decode(path):   # PNG (8-bit RGB/RGBA) -> (h, w, 3) array, without PIL
    b = open(path, "rb").read()
    assert b[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, hdr = 8, b"", None
    while pos < len(b):
        n, typ = struct.unpack(">I4s", b[pos:pos + 8]); data = b[pos + 8:pos + 8 + n]; pos += 12 + n
        if typ == b"IHDR": hdr = struct.unpack(">IIBBBBB", data)
        elif typ == b"IDAT": idat += data
    w, h, depth, ctype, _, _, interlace = hdr
    assert depth == 8 and ctype in (2, 6) and interlace == 0, hdr
    ch = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat); stride = w * ch
    prev = bytearray(stride); rows = []
    for y in range(h):   # undo the PNG row filters
        f = raw[y * (stride + 1)]; row = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for x in range(ch, stride): row[x] = (row[x] + row[x - ch]) & 255
        elif f == 2:
            row = bytearray((a + c) & 255 for a, c in zip(row, prev))
        elif f == 3:
            for x in range(stride): row[x] = (row[x] + ((row[x - ch] if x >= ch else 0) + prev[x]) // 2) & 255
        elif f == 4:
            for x in range(stride):
                a = row[x - ch] if x >= ch else 0; up = prev[x]; c = prev[x - ch] if x >= ch else 0
                pa, pb, pc = abs(up - c), abs(a - c), abs(a + up - 2 * c)
                row[x] = (row[x] + (a if pa <= pb and pa <= pc else (up if pb <= pc else c))) & 255
        rows.append(bytes(row)); prev = row
    return np.frombuffer(b"".join(rows), np.uint8).reshape(h, w, ch)[:, :, :3].astype(np.int32)
try:
    from PIL import Image
    px = np.asarray(Image.open(sys.argv[1]).convert("RGB")).astype(np.int32)
except ImportError:
    px = decode(sys.argv[1])
h, w = px.shape[:2]
colours = len(np.unique(px.reshape(-1, 3), axis=0))
ink = (px.sum(axis=2) < 600).mean()           # darker than near-white
blue = ((px[:, :, 2] > 150) & (px[:, :, 0] < 80)).mean()   # the bar colour
print("png %dx%d colours %d ink %.3f blue %.4f" % (w, h, colours, ink, blue))
assert w == 1200 and colours > 20 and ink > 0.01 and blue > 0.0005
EOF'
done

if [ "${TETOPT_LONG_TESTS:-0}" = 1 ] && [ -f "$SRC/../shared/meshes/hinge_raw/hinge_raw.mesh" ]; then
  M=$SRC/../shared/meshes/hinge_raw/hinge_raw.mesh
  ours=$("$T" quality "$M" --json -q | $PY -c "import json,sys; print(json.load(sys.stdin)['diagnosis']['bound']['alpha_upper_bound'])")
  ref=$($PY "$SRC/../shared/tools/bound.py" "$M" | sed -n 's/.*alpha_upper_bound=\([0-9.]*\).*/\1/p')
  check "bound agrees with bound.py on hinge_raw ($ours vs $ref)" \
    '$PY -c "import sys; a,b=$ours,$ref; sys.exit(0 if a >= b - 5e-5 and a - b < 1e-3 else 1)"'
fi
exit $fail
