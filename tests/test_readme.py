"""The README is executable documentation: its "Command line" and "Python" sections run.

Every ``terrascape …`` line of the "Command line" block runs, in the README's order, in one
empty folder (in-process, through the same entry point as the console script); each must
exit 0 and write the files it names, and the files must read back as what the command says
(heightmaps with their world units and spacing, non-blank images, a video with its frames,
meshes with triangles). Then the "Python" block runs with ``exec`` and its results are
checked against its comments.

Sizes: the README shows sizes a user would pick; so that the test stays in seconds, every
command and the Python block go through :data:`SMALLER` first — plain text substitutions
(``--size 513`` → ``--size 129``, frame counts, image sizes) that change how much work is
done, never which options are used. Commands that cannot run here are listed in
:data:`SKIPPED` with the reason; the test fails if the README gains a command that matches
neither rule, or loses one of the skipped ones (so the list stays true).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[1] / "README.md"

#: (regular expression, replacement) applied to every README command and the Python block.
SMALLER: tuple[tuple[str, str], ...] = (
    (r"--size 513\b", "--size 129"),
    (r"--size 257\b", "--size 65"),
    (r"--size \d+x\d+", "--size 160x90"),
    (r"--hydraulic \d+", "--hydraulic 2000"),
    (r"--turntable \d+", "--turntable 3"),
    (r"--frames \d+", "--frames 3"),
    (r"diamond_square\(513\b", "diamond_square(129"),
    (r"\(1280, 720\)", "(160, 90)"),
)
#: Added to commands that render at a default size (render and relief without --size).
SMALL_IMAGE = ("render", "relief")

#: Command prefix → why the test does not run it.
SKIPPED: dict[str, str] = {
    "terrascape view": "needs a display (tests/viewer/test_view_xvfb.py drives the viewer)",
    "terrascape bench render": "a benchmark: minutes, not seconds (tests/bench covers cases)",
    "terrascape bench report": "the whole benchmark suite: tens of minutes",
}

#: Commands whose outputs are heightmap files (every other output is an image or a mesh).
HEIGHTMAP_COMMANDS = {"generate", "erode", "convert", "heightfromimage"}


def section_block(title: str, language: str) -> str:
    """The first ```language fenced block under the ``## title`` heading."""
    text = README.read_text(encoding="utf-8")
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    section = text[start: end if end >= 0 else len(text)]
    match = re.search(rf"```{language}\n(.*?)```", section, flags=re.S)
    assert match, f"no ```{language} block under '## {title}' in README.md"
    return match.group(1)


def readme_commands() -> list[str]:
    """The ``terrascape …`` lines of the Command line block, comments removed."""
    commands = []
    for line in section_block("Command line", "sh").splitlines():
        line = line.strip()
        if line.startswith("terrascape "):
            commands.append(re.split(r"\s+#", line, maxsplit=1)[0].strip())
    return commands


def smaller(text: str) -> str:
    for pattern, replacement in SMALLER:
        text = re.sub(pattern, replacement, text)
    return text


def to_argv(command: str) -> list[str]:
    argv = shlex.split(smaller(command))[1:]
    if argv[0] in SMALL_IMAGE and "--size" not in argv:
        argv += ["--size", "160x90" if argv[0] == "render" else "96x96"]
    if argv[0] == "relief":
        argv += ["--texture-size", "64"]
    return argv


def outputs(argv: list[str]) -> list[Path]:
    """The files a command says it writes: ``-o/--output``, else its last file argument."""
    name = argv[0] if argv[0] not in ("texture", "bench") else " ".join(argv[:2])
    for flag in ("-o", "--output"):
        if flag in argv:
            path = Path(argv[argv.index(flag) + 1])
            if name == "texture splat":
                stem = path.with_suffix("")
                return [Path(f"{stem}_0.png"), Path(f"{stem}_1.png"),
                        Path(f"{stem}_preview.png")]
            return [path]
    if name in ("erode", "convert"):
        return [Path(argv[2])]
    if name == "relief":
        return [Path(argv[1])]
    return []


def check_heightmap_file(path: Path, argv: list[str]) -> None:
    from terrascape.io import read_heightmap

    hm = read_heightmap(path)
    assert hm.rows > 2 and hm.cols > 2 and hm.max > hm.min, f"{path}: flat or empty"
    if "--height-scale" in argv:
        top = float(argv[argv.index("--height-scale") + 1])
        assert (hm.min, hm.max) == pytest.approx((0.0, top), abs=top * 1e-4), path
    if "--spacing" in argv:
        dx = float(argv[argv.index("--spacing") + 1])
        assert hm.spacing == pytest.approx((dx, dx)), path
    if argv[0] in ("erode", "convert"):  # keeps the source's world units and spacing
        source = read_heightmap(argv[1])
        assert hm.spacing == pytest.approx(source.spacing), path
        assert hm.max == pytest.approx(source.max, rel=0.2), path


def check_image_file(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        pixels = np.asarray(im.convert("RGBA"))
    assert pixels[..., :3].std() > 1.0, f"{path} is blank"
    return pixels


def check_export_folder(path: Path, argv: list[str]) -> None:
    """An export's folder: its import notes, and what each destination's importer reads."""
    assert path.is_dir(), f"{' '.join(argv)} did not write the folder {path}"
    if argv[1] != "web":  # a page to open, not an import
        notes = list(path.glob("*_import.txt"))
        assert notes and notes[0].read_text().strip(), f"{path}: no import settings"
    wanted = {"unity": "*.raw", "unreal": "*.png", "godot": "*.exr", "blender": "*.glb",
              "cesium": "layer.json", "terrain_rgb": "*/*/*.png", "web": "index.html"}[argv[1]]
    assert list(path.glob(wanted)), f"{path}: no {wanted}"


def check_output(path: Path, argv: list[str]) -> None:
    if argv[0] == "export":
        check_export_folder(path, argv)
        return
    assert path.is_file() and path.stat().st_size > 0, f"{' '.join(argv)} did not write {path}"
    suffix = path.suffix.lower()
    if argv[0] in HEIGHTMAP_COMMANDS:
        check_heightmap_file(path, argv)
    elif suffix == ".png":
        pixels = check_image_file(path)
        if argv[:2] == ["texture", "splat"]:
            assert (pixels[..., 3] == 255).all(), f"{path}: splat images must be opaque"
    elif suffix == ".mp4":
        import imageio.v3 as iio

        frames = iio.imread(path, plugin="pyav" if _has_pyav() else None, index=None)
        count = argv[argv.index("--turntable" if "--turntable" in argv else "--frames") + 1]
        assert len(frames) == int(count)
        assert frames.std() > 1.0
    elif suffix == ".glb" and "--compress" in argv:
        import pygltflib  # trimesh has no meshopt decoder; tests/export decodes these files

        doc = pygltflib.GLTF2.load(path)
        assert "EXT_meshopt_compression" in (doc.extensionsRequired or [])
        assert doc.accessors[doc.meshes[0].primitives[0].indices].count > 300
    elif suffix == ".json":
        import json

        listing = json.loads(path.read_text())
        assert listing["count"] == len(listing["instances"]) > 10
        assert all(r["mesh"] in listing["meshes"] for r in listing["instances"])
    elif suffix == ".glb":
        import trimesh

        mesh = trimesh.load(path, force="mesh")
        assert len(mesh.faces) > 100 and mesh.bounds[1][1] > mesh.bounds[0][1]
    elif suffix == ".obj":
        lines = path.read_text().splitlines()
        assert sum(ln.startswith("f ") for ln in lines) > 100
    else:
        pytest.fail(f"no read-back check for {path}")


def _has_pyav() -> bool:
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True


def test_readme_lists_the_skipped_commands():
    commands = readme_commands()
    assert len(commands) >= 15
    for prefix in SKIPPED:
        assert any(c.startswith(prefix) for c in commands), f"README no longer has {prefix!r}"


@pytest.mark.gl
def test_readme_commands_run_in_order(tmp_path, monkeypatch, capsys, gl_ctx):
    from terrascape.cli import run_app

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    ran = 0
    for command in readme_commands():
        if any(command.startswith(prefix) for prefix in SKIPPED):
            continue
        argv = to_argv(command)
        code = run_app(argv)
        captured = capsys.readouterr()
        assert code == 0, f"{' '.join(argv)} exited {code}:\n{captured.err}"
        assert "under the ground" not in captured.err, captured.err
        assert "Traceback" not in captured.err
        for path in outputs(argv):
            check_output(path, argv)
        if argv[0] == "info":
            assert "dx=4" in captured.out and "0 … 300" in captured.out, captured.out
        ran += 1
    assert ran >= 15


@pytest.mark.gl
def test_readme_python_block_runs(gl_ctx):
    code = smaller(section_block("Python", "python"))
    namespace: dict = {}
    exec(compile(code, "README.md (Python)", "exec"), namespace)
    hm, light, image = namespace["hm"], namespace["light"], namespace["image"]
    assert (hm.min, hm.max) == pytest.approx((0.0, 180.0))
    assert light.dtype == np.float32 and light.shape == hm.shape
    assert 0.0 <= light.min() < light.max() <= 1.0
    assert image.dtype == np.uint8 and image.shape == (90, 160, 4)
    assert image[..., :3].std() > 1.0
    triangles = namespace["triangles"]
    assert triangles.ndim == 2 and triangles.shape[1] == 3
    assert 0 < len(triangles) <= 80_000
    assert triangles.max() < hm.rows * hm.cols
