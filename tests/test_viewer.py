"""fuzzybrep view: the self-contained page, its payload, and the page itself in headless Chromium."""

from __future__ import annotations

import json
import os
import re
import shutil

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings

from _browser import chromium_driver
from _floor import FLOOR_PATH, floor_map, floor_poses
from _fuzzy_shapes import crisp_maps, dumbbell, thesis_map
from fuzzybrep.brep import BRepMap
from fuzzybrep.cli import main
from fuzzybrep.errors import MapFileError
from fuzzybrep.fuzzy.map import fuzzify
from fuzzybrep.fuzzy.membership import Triangular
from fuzzybrep.viewer import band_quads, html_document, payload, read_path, safe_pieces, swept_cut, write_html


def run(*argv) -> int:
    return main([str(a) for a in argv])


@pytest.fixture(scope="module")
def floor():
    return floor_map()


@pytest.fixture(scope="module")
def floor_page(floor, tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "floor.html"
    write_html(out, floor, floor_poses(), np.array(FLOOR_PATH), name="floor.json")
    return out


def embedded(html: str) -> dict:
    m = re.search(r'<script type="application/json" id="fuzzybrep-data">(.*?)</script>', html, re.S)
    return json.loads(m.group(1))


def decode(data: dict) -> dict:
    """The payload decoded as viewer.js decodes it."""
    q = data["q"]
    sizes = data["rings"]["size"]
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1]))
    x, y = np.asarray(data["x"]), np.asarray(data["y"])
    ring = np.repeat(np.arange(len(sizes)), sizes)

    def undelta(v):
        c = np.cumsum(v)
        return c - np.repeat(np.concatenate(([0], c[starts[1:] - 1])), sizes)

    return {"xy": np.column_stack((undelta(x), undelta(y))) * q, "tv": np.column_stack((data["t"], data["v"])) * q / 10,
            "ring": ring}


# ------------------------------------------------------------------------- the page, offline


def test_page_is_one_self_contained_file(floor_page):
    html = floor_page.read_text(encoding="utf-8")
    assert not re.search(r"https?://", html), "the page must not name any URL (no network here)"
    assert not re.search(r"<(link|img|iframe)\b", html, re.I)
    assert not re.search(r"<script[^>]+src=", html, re.I)
    assert not re.search(r"\b(fetch|XMLHttpRequest|import\s*\(|WebSocket)\b", html)
    assert html.count("<script") == 2 and "<canvas" in html and 'type="range"' in html


def test_payload_holds_the_map_lines_poses_and_path(floor, floor_page):
    data = embedded(floor_page.read_text(encoding="utf-8"))
    assert data["format"] == "fuzzybrep-viewer" and data["version"] == 1 and data["unit"] == "m"
    assert data["q"] == 0.001 and data["name"] == "floor.json"
    d = decode(data)
    V = np.vstack([r.vertices for r in floor.crisp.rings])
    np.testing.assert_allclose(d["xy"], V, atol=1e-9)  # the floor's vertices are on the mm grid
    TV = np.vstack([np.column_stack((ln.T, ln.V)) for ln in floor.lines])
    np.testing.assert_allclose(d["tv"], TV, atol=0.5e-4 + 1e-12)
    assert data["kind"].count("1") == 1 and len(data["kind"]) == len(V)
    assert data["fm"] == np.concatenate([r.fm for r in floor.crisp.rings]).tolist()
    assert [f["index"] for f in data["functions"]] == [1, 2]
    K = data["levels"]
    assert K % (data["slider"] - 1) == 0 and K >= 1000
    for f in data["functions"]:
        fn = floor.table[f["index"]]
        np.testing.assert_allclose(f["d_in"], fn.d_in(np.arange(K + 1) / K), atol=1e-5)
        np.testing.assert_allclose(f["d_out"], fn.d_out(np.arange(K + 1) / K), atol=1e-5)
    poses = floor_poses()
    px, py = np.cumsum(data["poses"]["x"]) * 0.001, np.cumsum(data["poses"]["y"]) * 0.001
    np.testing.assert_allclose(np.column_stack((px, py)), poses[:, :2], atol=0.5e-3 + 1e-12)
    np.testing.assert_allclose(np.asarray(data["poses"]["heading"]) / 1000, poses[:, 2], atol=0.5e-3 + 1e-12)
    np.testing.assert_allclose(np.column_stack((data["path"]["x"], data["path"]["y"])) * 0.001, FLOOR_PATH)
    assert data["stats"] == {"vertices": 27, "holes": 3, "regions": 1, "area": pytest.approx(floor.crisp_geometry.area)}


def test_script_end_tag_in_a_name_cannot_break_the_page(floor):
    html = html_document(payload(floor, name="</script><b>x"))
    assert html.count("</script>") == 2
    assert embedded(html)["name"] == "</script><b>x"


def test_read_path(tmp_path):
    p = tmp_path / "plan.json"
    p.write_text(json.dumps({"path": [[0, 0], [1.5, 2]], "alpha": 0.5}))
    np.testing.assert_array_equal(read_path(p), [[0, 0], [1.5, 2]])
    for text, match in (("[1, 2]", "path"), ('{"path": [[0, "a"]]}', "point 1"), ("{", "not valid JSON"),
                        ('{"path": [[0, 1], [2]]}', "point 2")):
        p.write_text(text)
        with pytest.raises(MapFileError, match=match):
            read_path(p)
    with pytest.raises(MapFileError, match="cannot read"):
        read_path(tmp_path / "none.json")


def test_view_command(floor, tmp_path, capsys):
    floor.save(tmp_path / "floor.json", poses=floor_poses())
    (tmp_path / "path.json").write_text(json.dumps({"path": FLOOR_PATH}))
    out = tmp_path / "floor.html"
    assert run("view", tmp_path / "floor.json", "--html", out, "--path", tmp_path / "path.json", "--alphas", 21) == 0
    said = capsys.readouterr().out
    assert "23 poses" in said and "a path of 4 points" in said
    data = embedded(out.read_text(encoding="utf-8"))
    assert data["slider"] == 21 and data["levels"] == 1000
    (tmp_path / "bad.json").write_text('{"route": []}')
    assert run("view", tmp_path / "floor.json", "--html", out, "--path", tmp_path / "bad.json") == 2
    assert "path" in capsys.readouterr().err


# ------------------------------------------------------------------------- what the page draws


@pytest.mark.parametrize("alpha", [0.0, 0.3, 0.8])
def test_swept_cut_is_the_alpha_cut(floor, alpha):
    """The page draws crisp ∓ the band hulls (thesis) or the safe sweep's pieces; that is the
    proper polygon (docs/fuzzy.md), and the safe cut's positive-winding union (Clipper), here
    checked against GEOS's union of the pieces."""
    sided = fuzzify(BRepMap.from_shapely(dumbbell(0.3)), Triangular(tme_in=0.1, tme_out=0.3))
    for fz in (floor, fuzzify(BRepMap.from_shapely(dumbbell(0.3)), tme=0.2), sided):
        for method in ("safe", "thesis"):
            cut = fz.alpha_cut(alpha, method)
            inner, outer = swept_cut(fz, alpha, method)
            band = cut.outer.area - cut.inner.area
            assert shapely.symmetric_difference(inner, cut.inner).area <= 1e-6 * band
            assert shapely.symmetric_difference(outer, cut.outer).area <= 1e-6 * band


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(crisp_maps())
def test_swept_cut_is_the_alpha_cut_on_random_maps(crisp):
    fz = fuzzify(crisp, tme=0.3)
    for alpha in (0.0, 0.5):
        for method in ("safe", "thesis"):
            cut = fz.alpha_cut(alpha, method)
            inner, outer = swept_cut(fz, alpha, method)
            band = max(cut.outer.area - cut.inner.area, 1e-12)
            assert shapely.symmetric_difference(inner, cut.inner).area <= 1e-5 * band
            assert shapely.symmetric_difference(outer, cut.outer).area <= 1e-5 * band


# ------------------------------------------------------------------------- in Chromium


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    driver = chromium_driver(tmp_path_factory.mktemp("chromium-profile"))
    yield driver
    driver.quit()


def open_page(browser, path):
    from selenium.webdriver.support.ui import WebDriverWait

    browser.get(path.as_uri())
    WebDriverWait(browser, 20).until(lambda d: d.execute_script("return !!window.fuzzybrepViewer"))
    browser.execute_script("return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")


def canvas_pixels(browser) -> str:
    return browser.execute_script("return document.getElementById('map').toDataURL('image/png')")


def keep_screenshot(browser, path, name):
    """Save the screenshot beside the test's files, and also in $FUZZYBREP_SCREENSHOTS if set."""
    assert browser.save_screenshot(str(path))
    assert path.stat().st_size > 10_000
    keep = os.environ.get("FUZZYBREP_SCREENSHOTS")
    if keep:
        os.makedirs(keep, exist_ok=True)
        shutil.copy(path, os.path.join(keep, name))


@pytest.mark.browser
def test_slider_redraws_the_alpha_cut(browser, floor_page, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    open_page(browser, floor_page)
    assert browser.execute_script("return window.fuzzybrepViewer.alpha") == 0.5
    keep_screenshot(browser, tmp_path / "floor.png", "floor.png")
    before = canvas_pixels(browser)
    redraws = browser.execute_script("return window.fuzzybrepViewer.redraws")
    slider = browser.find_element(By.ID, "alpha")
    slider.send_keys(*[Keys.ARROW_LEFT] * 30)  # real key presses: α 0.5 → 0.2
    browser.execute_script("return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    assert browser.find_element(By.ID, "alpha-value").text == "0.20"
    assert browser.execute_script("return window.fuzzybrepViewer.alpha") == pytest.approx(0.2)
    assert browser.execute_script("return window.fuzzybrepViewer.redraws") > redraws
    after = canvas_pixels(browser)
    assert after != before, "moving the slider must change the drawing"
    # a script move of the slider (an input event), to α = 1: the band vanishes, another drawing
    browser.execute_script("const s = document.getElementById('alpha'); s.value = 1;"
                           "s.dispatchEvent(new Event('input'));"
                           "return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    assert canvas_pixels(browser) not in (before, after)
    keep_screenshot(browser, tmp_path / "floor-alpha1.png", "floor-alpha1.png")


@pytest.mark.browser
def test_scale_bar_is_a_round_length_of_the_map_at_the_zoom(browser, floor_page, tmp_path):
    open_page(browser, floor_page)
    bar = browser.execute_script("return window.fuzzybrepViewer.scaleBar")
    width = browser.execute_script("return document.getElementById('map').clientWidth")
    # a round length near a fifth of the view (1, 2 or 5 × 10^k), drawn at the map's scale
    assert bar["length"] in (1.0, 2.0, 5.0) and bar["pixels"] == pytest.approx(bar["length"] * bar["scale"])
    assert width / 12 < bar["pixels"] <= width / 5 + 1e-9
    # its pixels are dark on the canvas: the bar is drawn where it says
    dark = browser.execute_script(
        "const b = window.fuzzybrepViewer.scaleBar, c = document.getElementById('map').getContext('2d');"
        "const r = devicePixelRatio, d = c.getImageData(Math.round((b.x + b.pixels / 4) * r), Math.round((b.y - 2) * r), 1, 4 * r).data;"
        "let m = 765; for (let i = 0; i < d.length; i += 4) m = Math.min(m, d[i] + d[i + 1] + d[i + 2]); return m;")
    keep_screenshot(browser, tmp_path / "floor-scalebar.png", "floor-scalebar.png")
    assert dark < 450  # antialiased: grey, not the white box (765)
    # zoomed in 10 times: a length a tenth as long, as many pixels again within the same bounds
    browser.execute_script("const v = window.fuzzybrepViewer; v.zoom(10); v.draw();")
    zoomed = browser.execute_script("return window.fuzzybrepViewer.scaleBar")
    assert zoomed["length"] == pytest.approx(bar["length"] / 10)
    assert width / 12 < zoomed["pixels"] <= width / 5 + 1e-9
    keep_screenshot(browser, tmp_path / "floor-zoomed.png", "floor-zoomed.png")


@pytest.mark.browser
def test_status_line_shows_mu_under_the_cursor(browser, floor, floor_page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    open_page(browser, floor_page)
    canvas = browser.find_element(By.ID, "map")
    size = canvas.size
    status = browser.find_element(By.ID, "status")
    # a vertex of the crisp boundary (the desk's corner), and a point deep in free space
    for (x, y), lo, hi in (((0.8, 0.8), 0.9, 1.0), ((3.0, 1.0), 0.0, 0.0)):
        sx, sy = browser.execute_script(f"return window.fuzzybrepViewer.toScreen({x}, {y})")
        ActionChains(browser).move_to_element_with_offset(
            canvas, int(round(sx - size["width"] / 2)), int(round(sy - size["height"] / 2))).perform()
        text = status.text
        m = re.search(r"μ = ([0-9.]+) \(safe\) · exact μ = ([0-9.]+)", text)
        assert m, text
        mu, exact = float(m.group(1)), float(m.group(2))
        assert 0.0 <= mu <= 1.0 and 0.0 <= exact <= 1.0
        assert lo <= mu <= hi and lo <= exact <= hi, text
        assert re.search(r"x \d+\.\d{3}, y \d+\.\d{3} m", text)


@pytest.mark.browser
def test_drag_pans_wheel_zooms_double_click_fits(browser, floor_page):
    import time

    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    open_page(browser, floor_page)
    canvas = browser.find_element(By.ID, "map")
    where = "return window.fuzzybrepViewer.toScreen(5, 2)"
    x0, y0 = browser.execute_script(where)
    redraws = browser.execute_script("return window.fuzzybrepViewer.redraws")
    ActionChains(browser).move_to_element(canvas).click_and_hold().move_by_offset(40, 25).release().perform()
    x1, y1 = browser.execute_script(where)
    assert (x1 - x0, y1 - y0) == pytest.approx((40, 25), abs=1)
    browser.execute_script("const c = document.getElementById('map'), r = c.getBoundingClientRect();"
                           "c.dispatchEvent(new WheelEvent('wheel', {clientX: r.left + 300, clientY: r.top + 200,"
                           "deltaY: -300, bubbles: true, cancelable: true}))")
    x2, y2 = browser.execute_script(where)
    assert abs(x2 - 300) > 1.5 * abs(x1 - 300)  # zoomed in about (300, 200)
    time.sleep(0.4)  # the view rests: drawn afresh
    assert browser.execute_script("return window.fuzzybrepViewer.redraws") > redraws
    ActionChains(browser).double_click(canvas).perform()
    assert browser.execute_script(where) == pytest.approx([x0, y0], abs=0.5)


@pytest.mark.browser
def test_page_mu_is_the_map_mu(browser, floor, floor_page):
    """The page's μ (its own method's, the safe sweep's, and exact) against FuzzyBRepMap.membership
    at points near the walls."""
    open_page(browser, floor_page)
    rng = np.random.default_rng(7)
    V = np.vstack([r.vertices for r in floor.crisp.rings])
    pts = np.vstack([V[rng.integers(len(V), size=300)] + rng.uniform(-0.3, 0.3, (300, 2)),
                     rng.uniform([-0.5, -0.5], [10.5, 6.5], (200, 2))])
    got = np.array(browser.execute_script(
        "return arguments[0].map(([x, y]) => { const m = window.fuzzybrepViewer.muAt(x, y); "
        "return [m.mu, m.exact]; })", pts.tolist()))
    sweep, exact = floor.membership(pts, "safe"), floor.membership(pts, "exact")
    assert (sweep > 0).sum() > 150 and (exact > 0).sum() > 150
    # T and V travel at 0.1 mm: μ agrees to a few 1e-4 (a thousand samples of d(α) do the rest)
    np.testing.assert_allclose(got[:, 1], exact, atol=2e-3)
    np.testing.assert_allclose(got[:, 0], sweep, atol=2e-3)


def two_rooms():
    """Two pieces of explored space (two regions), one with a hole, in metres."""
    room = shapely.Polygon([(0, 0), (3, 0), (3, 2), (0, 2)], [[(1, 0.5), (1, 1.2), (2, 1.2), (2, 0.5)]])
    g = shapely.MultiPolygon([room, shapely.Polygon([(4, 0), (6, 0), (5, 1.5)])])
    return fuzzify(BRepMap.from_shapely(g), tme=0.25)


@pytest.mark.browser
@pytest.mark.parametrize("make, scale", [(two_rooms, 1.0), (lambda: fuzzify(thesis_map()), 1000.0)],
                         ids=["two-regions", "thesis-mm-clockwise"])
def test_page_mu_on_other_maps(browser, tmp_path, make, scale):
    fz = make()
    rng = np.random.default_rng(3)
    V = np.vstack([r.vertices for r in fz.crisp.rings])
    pts = V[rng.integers(len(V), size=200)] + rng.uniform(-0.3, 0.3, (200, 2)) * scale
    for method in ("safe", "thesis"):
        write_html(tmp_path / "map.html", fz, method=method)
        open_page(browser, tmp_path / "map.html")
        got = np.array(browser.execute_script(
            "return arguments[0].map(([x, y]) => { const m = window.fuzzybrepViewer.muAt(x, y); "
            "return [m.mu, m.exact]; })", pts.tolist()))
        mu, exact = fz.membership(pts, method), fz.membership(pts, "exact")
        assert (mu > 0).sum() > 80
        np.testing.assert_allclose(got[:, 1], exact, atol=5e-3)
        np.testing.assert_allclose(got[:, 0], mu, atol=5e-3)


@pytest.mark.browser
def test_page_band_hulls_are_the_map_bands(browser, floor, floor_page, tmp_path):
    write_html(tmp_path / "thesis.html", floor, method="thesis")
    open_page(browser, tmp_path / "thesis.html")
    for alpha in (0.0, 0.35):
        h = browser.execute_script(f"return window.fuzzybrepViewer.hulls({alpha})")
        free, obstacle = band_quads(floor, alpha)
        for js, py in ((h["free"], free), (h["obstacle"], obstacle)):
            page = shapely.union_all([shapely.Polygon(np.reshape(c, (-1, 2))) for c in js])
            ref = shapely.union_all(shapely.convex_hull(shapely.multipoints(py)))
            # the page's offsets are good to 0.1 mm (T and V are sent at that step)
            assert shapely.symmetric_difference(page, ref).area <= 1e-4 * ref.length
            # counter-clockwise, so that one nonzero fill paints their union
            assert all(shapely.Polygon(np.reshape(c, (-1, 2))).exterior.is_ccw for c in js)


@pytest.mark.browser
def test_page_pieces_are_the_safe_sweeps(browser, floor, floor_page):
    open_page(browser, floor_page)
    assert browser.execute_script("return window.fuzzybrepViewer.method") == "safe"
    for alpha in (0.0, 0.35):
        h = browser.execute_script(f"return window.fuzzybrepViewer.hulls({alpha})")
        free, obstacle = safe_pieces(floor, alpha)
        for js, py in ((h["free"], free), (h["obstacle"], obstacle)):
            assert len(js) == len(py)
            page = shapely.union_all([shapely.Polygon(np.reshape(c, (-1, 2))) for c in js])
            ref = shapely.union_all([shapely.Polygon(c) for c in py])
            # the page's offsets are good to 0.1 mm (T and V are sent at that step)
            assert shapely.symmetric_difference(page, ref).area <= 1e-4 * ref.length
            # counter-clockwise, so that one nonzero fill paints their union
            assert all(shapely.Polygon(np.reshape(c, (-1, 2))).exterior.is_ccw for c in js)


@pytest.mark.browser
@pytest.mark.reallog
def test_intel_page_in_chromium(browser, built_map, tmp_path):
    path, fuzzy = built_map("intel")
    assert run("view", path, "--html", tmp_path / "intel.html") == 0
    size = (tmp_path / "intel.html").stat().st_size
    assert size < 1_500_000  # about 0.5 MB for 22 705 vertices and 910 poses
    open_page(browser, tmp_path / "intel.html")
    keep_screenshot(browser, tmp_path / "intel.png", "intel.png")
    before = canvas_pixels(browser)
    browser.execute_script("window.fuzzybrepViewer.setAlpha(0.1);"
                           "return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    assert canvas_pixels(browser) != before
    mu = browser.execute_script("const v = window.fuzzybrepViewer; const [x, y] = arguments[0];"
                                "return v.muAt(x, y).mu", fuzzy.crisp.principal.vertices[0].tolist())
    assert 0.99 <= mu <= 1.0


def rounded_away_map():
    """A room with two holes whose principal ring has a 1.13 mm diagonal edge (kept: at least
    ``brep.min_edge``) whose ends round to the same millimetre on the page (issue 36)."""
    room = [(0, 0), (4.9996, -0.0004), (5.0004, 0.0004), (10, 0), (10, 10), (0, 10)]
    holes = [[(2, 2), (2, 4), (4, 4), (4, 2)], [(6, 6), (6, 8), (8, 8), (8, 6)]]
    return fuzzify(BRepMap.from_shapely(shapely.Polygon(room, holes)), tme=0.3)


def test_page_data_of_a_rounded_away_edge():
    """What Python gives the page: the edge is there, and its two ends are one point in quanta."""
    fz = rounded_away_map()
    assert fz.crisp.n_vertices == 14
    d = payload(fz)
    assert d["q"] == 0.001 and 0 in d["x"][1:6]  # the edge's end is a zero step from its start
    assert all(np.isfinite(d["t"])) and all(np.isfinite(d["v"]))


@pytest.mark.browser
@pytest.mark.parametrize("method", ["safe", "thesis"])
def test_band_drawn_past_an_edge_rounded_away(browser, tmp_path, method):
    """Before, the safe sweep's corner after the edge was NaN, and Chromium dropped the band's
    path from there on, silently: no band round either hole. Pixels where the page's μ ≥ 0.1 at
    α = 0.05 are painted neither free nor outside."""
    fz = rounded_away_map()
    write_html(tmp_path / "map.html", fz, method=method)
    open_page(browser, tmp_path / "map.html")
    h = browser.execute_script("return window.fuzzybrepViewer.hulls(0.05)")
    assert all(np.isfinite(c).all() for c in h["free"] + h["obstacle"])
    browser.execute_script("window.fuzzybrepViewer.setAlpha(0.05);"
                           "return new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    xs = np.linspace(1.5, 8.5, 57)
    pts = [(x, y) for x in xs for y in xs]
    got = browser.execute_script("""
        const v = window.fuzzybrepViewer, c = document.getElementById('map'), g = c.getContext('2d');
        const k = c.width / c.clientWidth;
        return arguments[0].map(([x, y]) => {
          const [sx, sy] = v.toScreen(x, y), p = g.getImageData(Math.round(sx * k), Math.round(sy * k), 1, 1).data;
          return [v.muAt(x, y).mu, p[0], p[1], p[2]];
        });""", pts)
    got = np.array(got)
    banded = got[got[:, 0] >= 0.1]
    assert len(banded) > 100
    rgb = banded[:, 1:].astype(int)
    free_or_outside = (rgb == [255, 255, 255]).all(axis=1) | (rgb == [0xd5, 0xd8, 0xdc]).all(axis=1)
    assert free_or_outside.mean() < 0.02


#: a file name and a unit an attacker would choose (issue 19): markup, a slot of the page's template,
#: a comment opener that swallowed the viewer's own script, a script end tag
HOSTILE_NAME = "x<img src=x onerror=\"window.pwned=1\">{{DATA}}<script>{{TITLE}}.json"  # no "/" in a name
HOSTILE_UNIT = "<!--<script></script><img src=x onerror=\"window.pwned=1\">'&amp;\u2028"


def hostile_map(tmp_path):
    """The 4 × 4 square saved under HOSTILE_NAME with HOSTILE_UNIT as its unit; its path."""
    m = tmp_path / HOSTILE_NAME
    fuzzify(BRepMap.from_shapely(shapely.box(0, 0, 4, 4), HOSTILE_UNIT), tme=0.1).save(m, poses=[[1, 1, 0, 0]])
    return m


def test_hostile_name_and_unit_are_text_in_the_page(tmp_path):
    # before: {{TITLE}} was filled first and {{DATA}} after it everywhere, so the name's "{{DATA}}"
    # pasted the map's data, name and unit raw into the page: an <img onerror> element
    m, out = hostile_map(tmp_path), tmp_path / "v.html"
    assert main(["view", str(m), "--html", str(out)]) == 0
    html = out.read_text(encoding="utf-8")
    assert html.count("<script") == 2 and html.count("</script>") == 2 and "<img" not in html and "<!--" not in html
    data = embedded(html)
    assert data["name"] == HOSTILE_NAME and data["unit"] == HOSTILE_UNIT


@pytest.mark.browser
def test_hostile_name_and_unit_run_no_script_and_show_as_text(browser, tmp_path):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    m, out = hostile_map(tmp_path), tmp_path / "v.html"
    assert main(["view", str(m), "--html", str(out)]) == 0
    open_page(browser, out)  # waits for the viewer's own script: a swallowed script never gets there
    assert browser.execute_script("return window.pwned === undefined && document.images.length === 0")
    assert browser.execute_script("return document.scripts.length") == 2
    title = f"fuzzy B-rep map — {HOSTILE_NAME}"
    assert browser.title == title and browser.find_element(By.ID, "title").text == title
    canvas = browser.find_element(By.ID, "map")
    size = canvas.size
    sx, sy = browser.execute_script("return window.fuzzybrepViewer.toScreen(2, 2)")
    ActionChains(browser).move_to_element_with_offset(
        canvas, int(round(sx - size["width"] / 2)), int(round(sy - size["height"] / 2))).perform()
    status = browser.execute_script("return document.getElementById('status').textContent")
    assert re.search(r"x 2\.0\d\d, y 2\.0\d\d ", status) and f" {HOSTILE_UNIT} · μ = 0.000" in status, status
