import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app


def test_relief_cli_prewarp_writes_png_and_refuses_overwrite(tmp_path):
    out = tmp_path / "pw.png"
    args = ["relief", str(out), "--technique", "prewarp", "--texture-size", "64",
            "--size", "48x32", "--angle", "50", "-q"]
    assert run_app(args) == 0
    img = np.asarray(Image.open(out))
    assert img.shape == (32, 48, 4)
    assert img[..., 3].max() == 255 and img[..., 3].min() == 0  # quad and background
    assert img[..., :3][img[..., 3] > 0].std() > 3  # shaded relief, not flat
    assert run_app(args) == 2  # exists, no --force
    assert run_app([*args, "--force"]) == 0


@pytest.mark.parametrize(
    "extra", [["--field", "bricks"], ["--angle", "89"], ["--size", "0x3"], ["--sun", "1"],
              ["--bits", "12"]]
)
def test_relief_cli_bad_input_is_exit_2(tmp_path, extra):
    out = tmp_path / "x.png"
    assert run_app(["relief", str(out), "--technique", "prewarp", "-q", *extra]) == 2
    assert not out.exists()


@pytest.mark.gl
def test_relief_cli_gpu_technique(tmp_path, gl_ctx):
    out = tmp_path / "relief.png"
    assert run_app(["relief", str(out), "--texture-size", "64", "--size", "64x48",
                    "--technique", "minmax", "-q"]) == 0
    img = np.asarray(Image.open(out))
    assert img.shape == (48, 64, 4) and img[..., :3].std() > 3
    assert run_app(["relief", str(tmp_path / "b.png"), "--technique", "bogus", "-q"]) == 2


@pytest.mark.gl
def test_relief_cli_default_is_exact_on_8_bit_fences(tmp_path, gl_ctx, capsys):
    out = tmp_path / "fences.png"
    assert run_app(["relief", str(out), "--field", "fences", "--bits", "8",
                    "--texture-size", "64", "--size", "64x48", "--angle", "70"]) == 0
    assert "minmax" in capsys.readouterr().err  # auto chose the exact tracer
    img = np.asarray(Image.open(out))
    assert img.shape == (48, 64, 4) and img[..., :3].std() > 3


@pytest.mark.gl
def test_relief_cli_leaves_the_callers_context_current(tmp_path, gl_ctx):
    """Run in-process (a notebook, a test), the command's own context must not stay current
    after it: the caller's objects, made before, would then be looked up in a released
    context."""
    from terrascape.render.context import current

    texels = bytes(range(64))
    with current(gl_ctx):
        tex = gl_ctx.texture((4, 4), 4, texels)
        try:
            assert run_app(["relief", str(tmp_path / "r.png"), "--texture-size", "32",
                            "--size", "32x24", "--technique", "minmax", "-q"]) == 0
            assert tex.read() == texels
        finally:
            tex.release()
