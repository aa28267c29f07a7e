"""docs/notebook.md runs as written, and what it shows is a real picture."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

DOC = Path(__file__).resolve().parents[1] / "docs" / "notebook.md"


def _png(data: bytes) -> np.ndarray:
    assert data.startswith(b"\x89PNG\r\n\x1a\n")
    with PILImage.open(io.BytesIO(data)) as im:
        return np.asarray(im.convert("RGB"))


@pytest.mark.gl
def test_notebook_doc_runs(tmp_path, monkeypatch, gl_ctx):
    from terrascape.notebook import Image

    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    for k, block in enumerate(blocks):
        exec(compile(block, f"docs/notebook.md block {k + 1}", "exec"), ns)
    # The first cell ends with `hm`: a notebook displays it through _repr_png_.
    preview = _png(ns["hm"]._repr_png_())
    assert preview.shape == (129, 129, 3) and preview.std() > 10
    picture = ns["picture"]
    assert isinstance(picture, Image) and picture.shape == (180, 320, 4)
    np.testing.assert_array_equal(np.asarray(picture), ns["frame"])
    assert _png(picture._repr_png_()).shape == (180, 320, 3)
    shadows = _png(ns["shadows"]._repr_png_())
    assert shadows.shape == (129, 129, 3)
    np.testing.assert_allclose(shadows[..., 0], np.rint(ns["light"] * 255), atol=1)
    saved = np.asarray(PILImage.open(tmp_path / "preview.png").convert("RGB"))
    np.testing.assert_array_equal(saved, preview)
