"""The command table: every top-level command, the ``cli/cmd_*.py`` modules that define it,
and the one line ``terrascape --help`` shows for it.

``terrascape --help`` is read from this table alone, and a command's modules are imported
only when that command runs or shows its own help: importing all of them would load numpy,
scipy, the registries and their kernels (most of a second) for a screen of text.
``tests/core/test_registries.py`` imports every ``cmd_*.py`` module and checks that the
commands they register are exactly this table, so a command missing here fails a test.

This module imports nothing (not even ``dataclasses``, which loads ``inspect``: a tenth of
the top-level help's time): the help, the documentation and the tests read it cheaply.
"""

from __future__ import annotations


class Command:
    """One top-level command: its ``cli`` modules (imported in this order) and its summary."""

    __slots__ = ("modules", "summary")

    def __init__(self, modules: tuple[str, ...], summary: str) -> None:
        self.modules = modules
        self.summary = summary

    def __repr__(self) -> str:
        return f"Command(modules={self.modules!r}, summary={self.summary!r})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Command):
            return NotImplemented
        return (self.modules, self.summary) == (other.modules, other.summary)

    def __hash__(self) -> int:
        return hash((self.modules, self.summary))


#: Command name → where it is defined; the order is the order of ``terrascape --help``.
COMMANDS: dict[str, Command] = {
    "demo": Command(("cmd_demo",),
                    "Generate, texture, shade and render terrains; write everything to OUTPUT."),
    "warm-up": Command(("cmd_warmup",),
                       "Compile the common commands' code once, in parallel, so first runs are "
                       "fast."),
    "blur": Command(("cmd_generate",),
                    "Smooth a heightmap on float heights: --sigma S or --box N."),
    "erode": Command(("cmd_erode",),
                     "Erode a heightmap; with no options, stream-power river erosion."),
    "export": Command(("cmd_export",),
                      "Export a heightmap for a game engine, GIS or the web."),
    "info": Command(("cmd_files",), "Describe a heightmap file."),
    "convert": Command(("cmd_files",),
                       "Convert a heightmap between formats by extension."),
    "mesh": Command(("cmd_mesh",),
                    "Export a terrain mesh and print its triangle count and measured maximum "
                    "error."),
    "relief": Command(("cmd_relief",),
                      "Render one relief-mapped quad seen at ANGLE and write it as a PNG."),
    "render": Command(("cmd_render",),
                      "Render a heightmap with OpenGL (headless EGL) to a PNG, a PNG sequence "
                      "or an MP4."),
    "normalmap": Command(("cmd_shade",),
                         "Write the packed normal + height texture (RGB normal, A height)."),
    "heightfromimage": Command(("cmd_shade",),
                               "Approximate a heightmap from a photo's brightness (bright = "
                               "high)."),
    "shade": Command(("cmd_shade",),
                     "Lightmap of the terrain under the sun (the daylight model by default)."),
    "view": Command(("cmd_view",),
                    "Fly over a terrain in a window (F1 or H lists every key)."),
    "bench": Command(("cmd_bench", "cmd_report"),
                     "Benchmarks: print timing tables (also `python -m terrascape.bench NAME`)."),
    "generate": Command(("cmd_generate",),
                        "Generate a heightmap with one of the generators and write it."),
    "texture": Command(("cmd_texture",),
                       "Texture synthesis: height-region textures, splat maps, built-in "
                       "materials."),
    "objects": Command(("cmd_objects",),
                       "Trees, rocks and buildings: place them on a terrain by rules, or "
                       "write the built-in models."),
    "world": Command(("cmd_world",),
                     "Worlds bigger than memory: build a recipe chunk by chunk into a zarr "
                     "store, and describe a store."),
}
