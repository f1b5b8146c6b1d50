"""The SVG picture looks the same in librsvg (rsvg-convert) and in Chromium: real stroke widths (no
CSS non-scaling-stroke, which librsvg ignores: it drew every line 1 m wide), a legend, a scale bar.

Set FUZZYBREP_SCREENSHOTS=DIR to keep the renderings."""

from __future__ import annotations

import os
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from _browser import chromium_driver
from _floor import floor_map
from fuzzybrep.cli import main
from fuzzybrep.formats.svg import scale_bar_length

SVG = "{http://www.w3.org/2000/svg}"
OBSTACLE = np.array([0x1F, 0x3A, 0x5F])
SUPPORT = np.array([0xF6, 0xD4, 0x9A])


def run(*argv) -> int:
    return main([str(a) for a in argv])


def rgb(path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int16)


def share(img, colour, tol=40) -> float:
    return float((np.abs(img - colour).sum(axis=2) < tol).mean())


def keep(path):
    d = os.environ.get("FUZZYBREP_SCREENSHOTS")
    if d:
        os.makedirs(d, exist_ok=True)
        shutil.copy(path, os.path.join(d, path.name))


def rsvg(svg, png):
    exe = shutil.which("rsvg-convert")
    if not exe:
        pytest.skip("rsvg-convert not found (Debian: apt-get install librsvg2-bin)")
    subprocess.run([exe, str(svg), "-o", str(png)], check=True, timeout=120)
    keep(png)
    return rgb(png)


def chromium(svg, png, tmp_path, size):
    driver = chromium_driver(tmp_path / "profile")
    try:
        w, h = size
        driver.set_window_size(w + 40, h + 200)
        # an HTML page holding only the picture at its own size, no margin
        page = tmp_path / "page.html"
        page.write_text(f'<!DOCTYPE html><html><body style="margin:0"><img id="p" src="{svg.as_uri()}" '
                        f'width="{w}" height="{h}"></body></html>')
        driver.get(page.as_uri())
        driver.execute_script("return new Promise(r => { const i = document.getElementById('p');"
                              "if (i.complete) r(); else i.onload = r; })")
        el = driver.find_element("id", "p")
        assert el.screenshot(str(png))
    finally:
        driver.quit()
    keep(png)
    return rgb(png)


def picture(tmp_path, fz, name="floor"):
    path = tmp_path / f"{name}.json"
    fz.save(path)
    svg = tmp_path / f"{name}.svg"
    assert run("export", path, "--svg", svg) == 0
    root = ET.parse(svg).getroot()
    return svg, (int(root.get("width")), int(root.get("height"))), root


def test_svg_has_real_widths_a_legend_and_a_scale_bar(tmp_path):
    fz = floor_map()
    svg, (w, h), root = picture(tmp_path, fz)
    text = svg.read_text()
    assert "non-scaling-stroke" not in text
    vx, vy, vw, vh = map(float, root.get("viewBox").split())
    # a pixel of the nominal width is vw / w map units: the crisp stroke 1.2 px
    import re

    crisp = float(re.search(r"\.crisp\{fill:none;stroke-width:([0-9.e-]+)\}", text).group(1))
    assert crisp == pytest.approx(1.2 * vw / w, rel=1e-3)
    legend = next(g for g in root.iter(f"{SVG}g") if g.get("id") == "legend")
    labels = [t.text for t in legend.iter(f"{SVG}text")]
    assert "support band (α = 0)" in labels and "frontier edge" in labels and "2 m" in labels
    bar = next(p for p in legend.iter(f"{SVG}path") if p.get("class") == "scale-bar")
    assert float(bar.get("data-length")) == 2.0 == scale_bar_length(vw)
    # 2 m long: the bar's pixels times the legend group's scale (map units a pixel)
    scale = float(re.search(r"scale\(([0-9.e-]+)\)", legend.get("transform")).group(1))
    xs = [float(v) for v in re.findall(r"[MH]([0-9.e-]+)", bar.get("d"))]
    assert (max(xs) - min(xs)) * scale == pytest.approx(2.0, abs=1e-6)
    assert [scale_bar_length(x) for x in (7.0, 37.0, 260.0, 0.04)] == [1.0, 5.0, 50.0, 0.005]


@pytest.mark.browser
def test_librsvg_and_chromium_draw_the_same_picture(tmp_path):
    fz = floor_map()
    svg, size, _ = picture(tmp_path, fz)
    a = rsvg(svg, tmp_path / "floor-rsvg.png")
    b = chromium(svg, tmp_path / "floor-chromium.png", tmp_path, size)
    assert a.shape == b.shape == (size[1], size[0], 3)
    # lines a pixel or so wide: the dark edge colour covers a few per cent, in both (librsvg, with
    # non-scaling-stroke ignored, drew strokes 1 map unit wide: over half of the picture)
    for img in (a, b):
        assert 0.002 < share(img, OBSTACLE) < 0.05
        assert share(img, SUPPORT) > 0.03  # the support band shaded
        assert share(img[-64:], SUPPORT) > 0.001  # and its swatch in the legend
    # the two renderings agree but for antialiasing and the fonts
    differ = (np.abs(a - b).sum(axis=2) > 90).mean()
    assert differ < 0.03, differ


@pytest.mark.browser
@pytest.mark.reallog
def test_intel_svg_in_both_renderers(built_map, tmp_path):
    path, fz = built_map("intel")
    svg = tmp_path / "intel.svg"
    assert run("export", path, "--svg", svg) == 0
    root = ET.parse(svg).getroot()
    size = (int(root.get("width")), int(root.get("height")))
    a = rsvg(svg, tmp_path / "intel-rsvg.png")
    b = chromium(svg, tmp_path / "intel-chromium.png", tmp_path, size)
    for img in (a, b):
        assert 0.01 < share(img, OBSTACLE) < 0.2
    assert (np.abs(a - b).sum(axis=2) > 90).mean() < 0.05
