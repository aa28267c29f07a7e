"""``terrascape export web``: the page renders the terrain in headless Chromium (software GL),
from file:// and from a static server; the canvas colours match terrascape's baked texture."""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import subprocess
import threading

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.export.glb import bake_texture

IN_CI = os.environ.get("CI", "").lower() in {"1", "true", "yes"}
SKY = np.array([0xA9, 0xC8, 0xE8])


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    if IN_CI:
        pytest.fail("CI must run the browser test: apt-get install -y chromium")
    pytest.skip("chromium is not installed")


def _screenshot(url: str, tmp_path, name: str) -> np.ndarray:
    out = tmp_path / f"{name}.png"
    profile = tmp_path / f"profile-{name}"
    cmd = [_chromium(), "--headless", "--no-sandbox", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--disable-gpu-sandbox",
           "--disable-background-networking", "--disable-component-update", "--no-first-run",
           f"--user-data-dir={profile}", "--window-size=640,480",
           "--virtual-time-budget=20000", f"--screenshot={out}", url]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert out.exists(), done.stderr[-2000:]
    return np.asarray(Image.open(out).convert("RGB")).astype(np.float64)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    rng = np.random.default_rng(21)
    h = ndimage.gaussian_filter(rng.standard_normal((150, 200)), 8) * 1500 + 300
    hm = Heightmap(h.astype(np.float32), (20.0, 20.0))
    root = tmp_path_factory.mktemp("web")
    np.save(root / "t.npy", hm.heights)
    assert run_app(["export", "web", str(root / "t.npy"), "-o", str(root / "site"),
                    "--spacing", "20", "-q"]) == 0
    return root / "site", hm


def _terrain_pixels(img: np.ndarray) -> np.ndarray:
    body = img[:-30]  # the info line at the bottom
    sky = np.abs(body - SKY).max(axis=2) <= 6
    return body[~sky]


def test_page_is_self_contained(site, gltf_validator):
    folder, _ = site
    issues = gltf_validator(folder / "t.glb")
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    html = (folder / "index.html").read_text()
    assert "src=" not in html.split("<body>")[1].replace("img src", "")  # nothing fetched
    assert (folder / "t.glb").read_bytes()[:4] == b"glTF"
    assert "MIT License" in (folder / "THREE_LICENSE.txt").read_text()
    # the page's three.js decodes meshopt-compressed geometry (the screenshots below show it)
    import pygltflib

    doc = pygltflib.GLTF2.load(folder / "t.glb")
    assert set(doc.extensionsRequired) == {"EXT_meshopt_compression", "KHR_mesh_quantization"}
    assert "setMeshoptDecoder(MeshoptDecoder)" in html
    assert "meshoptimizer library and is distributed under the terms of MIT License" in html


def test_top_view_from_file_matches_the_baked_texture(site, tmp_path):
    folder, hm = site
    img = _screenshot((folder / "index.html").as_uri() + "#top", tmp_path, "top")
    terrain = _terrain_pixels(img)
    assert len(terrain) > 0.5 * img[:-30].shape[0] * img.shape[1]  # the map fills the view
    texture = bake_texture(hm).reshape(-1, 3).astype(np.float64)
    np.testing.assert_allclose(terrain.mean(axis=0), texture.mean(axis=0), atol=12)
    np.testing.assert_allclose(terrain.std(axis=0), texture.std(axis=0), rtol=0.35)


def test_default_view_over_http_shows_terrain_and_sky(site, tmp_path):
    folder, _ = site
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        img = _screenshot(f"http://127.0.0.1:{server.server_port}/index.html", tmp_path, "http")
    finally:
        server.shutdown()
        server.server_close()
    terrain = _terrain_pixels(img)
    share = len(terrain) / (img[:-30].shape[0] * img.shape[1])
    assert 0.15 < share < 0.9  # an oblique view: terrain and sky
    assert np.abs(img[5, 5] - SKY).max() <= 6  # sky in the top corner
