#!/usr/bin/env python3
"""index.html as a browser shows it: `red compare` writes the report, headless Chromium
renders it to a PNG and dumps its DOM, and this checks that the page has no error text,
that the timeline's SVG is in the rendered DOM with every unit box, and that the
screenshot is not blank and shows the timeline's boxes (pixels of the first operation's
colour). Standard library only: the PNG is decoded here (zlib + the PNG row filters).

The layout at 1400 px wide: a copy of the page with a small script that measures every
element's box (getBoundingClientRect) against the panel it sits in (its figure, section,
table, list item or the page), run by Chromium's --dump-dom: nothing may stick out of its
panel (the timeline drawings scroll inside their own frame, which must fit), and the page
must not scroll sideways. Then `red report` redraws the page from the saved files and the
same checks hold; every policy that missed has its worst miss drawn on the default page.

usage: screenshot_test.py RED SCENARIO OUT_PNG
Chromium: $RED_CHROMIUM, else `chromium` on PATH (scripts/deps.sh installs it).
"""

import html
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

# The first operation's colour in the timeline (src/report/timeline.cpp, kOpColors[0]).
FIRST_OP_RGB = (0x7F, 0xB2, 0xE5)


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def chromium_command():
    exe = os.environ.get("RED_CHROMIUM") or shutil.which("chromium")
    if not exe:
        fail("chromium not found (install it with scripts/deps.sh, or set RED_CHROMIUM)")
    profile = tempfile.mkdtemp(prefix="red_chromium_")
    return [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
            "--no-first-run", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", "--disable-dev-shm-usage", "--hide-scrollbars",
            "--user-data-dir=" + profile], profile


def decode_png(path):
    """(width, height, rows of RGB tuples) of an 8-bit RGB or RGBA PNG."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail(path + " is not a PNG")
    pos, idat, width, height, depth, ctype = 8, b"", 0, 0, 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, ctype = struct.unpack(">IIBB", body[:10])
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if depth != 8 or ctype not in (2, 6):
        fail("unexpected PNG format: bit depth %d, colour type %d" % (depth, ctype))
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        base = y * (stride + 1)
        ftype, line = raw[base], bytearray(raw[base + 1:base + 1 + stride])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 0xFF
            elif ftype == 2:
                line[i] = (line[i] + b) & 0xFF
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 0xFF
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 0xFF
        rows.append(line)
        prev = line
    return width, height, bpp, rows


LAYOUT_SCRIPT = """<script>
(function () {
  var bad = [];
  var panels = "figure,section,table,li,dd,dt,p,h1,h2,caption,.timeline";
  var els = document.body.querySelectorAll("*");
  for (var i = 0; i < els.length; i++) {
    var el = els[i];
    if (el.tagName === "SCRIPT" || el.closest("svg")) continue;
    var inner = el.parentElement && el.parentElement.closest(".timeline");
    if (inner) continue;  // scrolls inside the timeline's frame
    var r = el.getBoundingClientRect();
    if (r.width === 0 && r.height === 0) continue;
    var panel = (el.parentElement && el.parentElement.closest(panels)) || document.body;
    var p = panel.getBoundingClientRect();
    if (r.left < p.left - 1 || r.right > p.right + 1)
      bad.push(el.tagName.toLowerCase() + (el.id ? "#" + el.id : "") + " [" +
               Math.round(r.left) + "," + Math.round(r.right) + "] out of " +
               panel.tagName.toLowerCase() + " [" + Math.round(p.left) + "," +
               Math.round(p.right) + "]: " + (el.textContent || "").slice(0, 60));
  }
  var out = document.createElement("pre");
  out.id = "layout-result";
  out.textContent = "LAY" + "OUT: " + JSON.stringify({
    width: window.innerWidth,
    scroll: document.documentElement.scrollWidth,
    checked: els.length,
    bad: bad}) + " :END";
  document.body.appendChild(out);
})();
</script>
"""


def check_layout(index):
    """Elements' boxes at 1400 px: nothing out of its panel, no sideways scrolling."""
    with open(index, encoding="utf-8") as f:
        page = f.read()
    probe = os.path.join(os.path.dirname(index), "layout_probe.html")
    with open(probe, "w", encoding="utf-8") as f:
        f.write(page.replace("</body>", LAYOUT_SCRIPT + "</body>"))
    cmd, profile = chromium_command()
    r = subprocess.run(cmd + ["--window-size=1400,2400", "--dump-dom", "file://" + probe],
                       capture_output=True, text=True, timeout=300)
    shutil.rmtree(profile, ignore_errors=True)
    os.remove(probe)
    m = re.search(r"LAYOUT: (\{.*?\}) :END", r.stdout, re.S)
    if r.returncode != 0 or not m:
        fail("the layout probe gave nothing (chromium exited %d): %s"
             % (r.returncode, r.stderr[-2000:]))
    result = json.loads(html.unescape(m.group(1)))
    if result["width"] != 1400:
        fail("the probe ran %d px wide, not 1400" % result["width"])
    if result["checked"] < 50:
        fail("the probe checked only %d elements" % result["checked"])
    if result["bad"]:
        fail("%d element(s) out of their panel at 1400 px:\n  %s"
             % (len(result["bad"]), "\n  ".join(result["bad"][:20])))
    if result["scroll"] > result["width"]:
        fail("the page scrolls sideways at 1400 px: %d px wide" % result["scroll"])
    return result["checked"]


def check_misses_drawn(out, source):
    """Every policy that missed has its worst miss drawn, with a missed job in view."""
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    drawn = 0
    for p in summary["policies"]:
        if p["missed"] == 0:
            continue
        title = "Timeline of %s: 2 s around its worst miss" % p["name"]
        if title not in source:
            fail("no drawing of %s's worst miss on the default page" % p["name"])
        svg = os.path.join(out, "plots", "timeline_worst_%s.svg" % p["name"])
        with open(svg, encoding="utf-8") as f:
            text = f.read()
        if not re.search(r'data-outcome="(missed|dropped|skipped|failed)"', text):
            fail("%s shows no missed job" % svg)
        drawn += 1
    return drawn


def main():
    if len(sys.argv) != 4:
        fail("usage: screenshot_test.py RED SCENARIO OUT_PNG")
    red, scenario, shot = sys.argv[1:]
    work = tempfile.mkdtemp(prefix="red_screenshot_")
    out = os.path.join(work, "report")
    r = subprocess.run([red, "compare", scenario, "--policies", "edf,fifo,red", "--out", out],
                       capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        fail("red compare exited %d: %s" % (r.returncode, r.stderr))
    index = os.path.join(out, "index.html")
    with open(index, encoding="utf-8") as f:
        source = f.read()
    units = source.count('<g class="unit"')
    if units == 0:
        fail("index.html has no timeline unit boxes")
    url = "file://" + os.path.abspath(index)

    # The DOM after rendering: no error text, the timeline's SVG with all its boxes.
    cmd, profile = chromium_command()
    r = subprocess.run(cmd + ["--dump-dom", url], capture_output=True, text=True, timeout=300)
    shutil.rmtree(profile, ignore_errors=True)
    if r.returncode != 0 or not r.stdout.strip():
        fail("chromium --dump-dom exited %d: %s" % (r.returncode, r.stderr[-2000:]))
    dom = r.stdout
    text = re.sub(r"<[^>]*>", " ", dom).lower()
    for bad in ("error", "parsererror", "not found", "cannot"):
        if bad in text:
            at = text.find(bad)
            fail("the page shows %r: ...%s..." % (bad, text[max(0, at - 80):at + 80]))
    if dom.count('class="red-timeline"') < 1:
        fail("no timeline SVG in the rendered DOM")
    if dom.count('<g class="unit"') != units:
        fail("the rendered DOM has %d unit boxes, index.html %d"
             % (dom.count('<g class="unit"'), units))

    # The standalone SVG files are well-formed XML (a browser shows a parser error
    # otherwise) and hold the same boxes as the page.
    svg_units = 0
    for name in sorted(os.listdir(os.path.join(out, "plots"))):
        if not (name.startswith("timeline") and name.endswith(".svg")):
            continue
        cmd, profile = chromium_command()
        r = subprocess.run(cmd + ["--dump-dom", "file://" + os.path.join(out, "plots", name)],
                           capture_output=True, text=True, timeout=300)
        shutil.rmtree(profile, ignore_errors=True)
        if r.returncode != 0 or "parsererror" in r.stdout or "error on line" in r.stdout:
            fail("plots/%s does not render as SVG: %s" % (name, (r.stdout + r.stderr)[-2000:]))
        svg_units += r.stdout.count('<g class="unit"')
    if svg_units != units:
        fail("plots/timeline*.svg have %d unit boxes, index.html %d" % (svg_units, units))

    # The screenshot: not blank, the timeline's boxes visible.
    if os.path.exists(shot):
        os.remove(shot)
    cmd, profile = chromium_command()
    r = subprocess.run(cmd + ["--screenshot=" + shot, "--window-size=1400,2400", url],
                       capture_output=True, text=True, timeout=300)
    shutil.rmtree(profile, ignore_errors=True)
    if r.returncode != 0 or not os.path.exists(shot) or os.path.getsize(shot) == 0:
        fail("no screenshot (chromium exited %d): %s" % (r.returncode, r.stderr[-2000:]))
    width, height, bpp, rows = decode_png(shot)
    if (width, height) != (1400, 2400):
        fail("screenshot is %dx%d, not 1400x2400" % (width, height))
    colours, box_pixels = set(), 0
    for line in rows:
        for x in range(0, width * bpp, bpp):
            px = (line[x], line[x + 1], line[x + 2])
            colours.add(px)
            if px == FIRST_OP_RGB:
                box_pixels += 1
    if len(colours) < 16:
        fail("screenshot is (nearly) blank: %d colours" % len(colours))
    if box_pixels < 2000:
        fail("the timeline's boxes are not visible: %d pixels of the first operation's colour"
             % box_pixels)
    checked = check_layout(index)
    missed = check_misses_drawn(out, source)
    if missed == 0:
        fail("no policy missed: the scenario does not exercise the worst-miss drawings")

    # The page redrawn from the saved files, with one phase's timeline: the same checks.
    r = subprocess.run([red, "report", out, "--phase", "1"], capture_output=True, text=True,
                       timeout=300)
    if r.returncode != 0:
        fail("red report exited %d: %s" % (r.returncode, r.stderr))
    check_layout(index)
    shutil.rmtree(work, ignore_errors=True)
    print("ok: %d unit boxes in the DOM, screenshot %s with %d colours, %d box pixels; "
          "%d elements on the page at 1400 px, none out of its panel; %d policies' worst misses drawn"
          % (units, shot, len(colours), box_pixels, checked, missed))


if __name__ == "__main__":
    main()
