import pytest

from terrascape.bench.report import write_report


def test_report_writes_markdown_and_plots(tmp_path):
    path = write_report(tmp_path, quick=True, tiny=True, cases=())
    text = path.read_text()
    assert "## Machine" in text and "| cores |" in text
    # the thesis's depth analysis, measured by the library (Filipović 2008 §5.3.1)
    assert "| LIN | linear | 7 |" in text
    assert "| DIV | halve | 8 |" in text
    assert "| SQRT | sqrt | 4 |" in text
    for name in ("fractal_roughness.png", "fractal_decay_laws.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"]({name})" in text
    assert not list(tmp_path.glob(".*.part"))


def test_analyses_read_tables_and_write_plots(tmp_path):
    """Each analysis builds its plots and discussion from the numbers in the tables."""
    from terrascape.bench import BenchTable
    from terrascape.bench.report_analysis import ANALYSES

    seed = BenchTable("Janković 2010 §2.7 reproduction on the terrain mesh (x)",
                      ["texture", "technique", "ms/frame", "% drop vs texture",
                       "seed % drop (config 2)"],
                      [["a", "texture mapping", 10.0, 0.0, 0.0],
                       ["a", "parallax", 12.0, 10.0, 3.0],
                       ["a", "relief 16+8", 40.0, 70.0, 75.0],
                       ["b", "texture mapping", 10.0, 0.0, 0.0],
                       ["b", "parallax", 12.0, 20.0, 3.0],
                       ["b", "relief 16+8", 40.0, 80.0, 75.0]])
    text, images = ANALYSES["relief"]([seed], tmp_path)
    assert "parallax 15.00 %, relief mapping 75.00 %" in text  # averages of the rows
    assert images == ["relief_seed_drop.png"]
    assert (tmp_path / "relief_seed_drop.png").read_bytes()[:4] == b"\x89PNG"

    roam = BenchTable("ROAM and Turner's ROAM: per-frame update at 80,000 triangles vs map size",
                      ["algorithm", "map", "median ms", "triangles (median)"],
                      [["ROAM", "513²", 2.0, 80000], ["ROAM", "4097²", 3.0, 79990]])
    text, images = ANALYSES["lod_roam"]([roam], tmp_path)
    assert "ROAM: 1.50× from 513² to 4097²" in text
    assert images == ["roam_vs_map_size.png"]

    flight = BenchTable("LOD flight: frame rate and triangles vs map size at 80,000 triangles",
                        ["algorithm", "map", "triangles", "frames/s"],
                        [["ROAM", "513²", 80000, 20.0], ["ROAM", "1025²", 79000, 19.0]])
    text, images = ANALYSES["lod_flight"]([flight], tmp_path)
    assert "ROAM 20.0 → 19.0 frames/s (513² → 1025²)" in text


@pytest.mark.gl
def test_quick_report_runs_every_benchmark_section(tmp_path, gl_ctx):
    """The whole `bench report --quick` on this machine: every section, table and plot."""
    path = write_report(tmp_path, quick=True, tiny=True)
    text = path.read_text()
    for title in ("Relief texturing", "ROAM analysis", "Rendering", "Level of detail",
                  "Objects' shadows"):
        assert f"## {title}" in text
    for image in ("relief_quality.png", "relief_seed_drop.png", "roam_vs_map_size.png",
                  "render_modes.png", "object_shadow_cost.png"):
        assert (tmp_path / image).exists() and f"]({image})" in text
    assert "Average frame-rate drop against texture mapping" in text


def test_shadow_analysis_answers_the_thesis_from_the_tables(tmp_path):
    from terrascape.bench import BenchTable
    from terrascape.bench.report_analysis import ANALYSES

    cost = BenchTable("frame time by object shadow mode (x)",
                      ["mode", "ms/frame", "× no object shadows"],
                      [["none", 100.0, 1.0], ["cascades", 130.0, 1.3],
                       ["volumes", 290.0, 2.9]])
    agree = BenchTable("agreement with the CPU ray cast (per pixel)",
                       ["mode", "what is compared", "pixels", "agree %"],
                       [["volumes", "stencil", 1000, 99.88], ["cascades", "darker", 900, 99.82]])
    moving = BenchTable("a sun moving 1° per frame with volumes (12 frames)",
                        ["frames", "median ms", "slowest ms", "slowest × median",
                         "volume rebuild ms (median)"], [[12, 2000.0, 2200.0, 1.1, 45.4]])
    lod = BenchTable("terrain shadow volumes under LOD (x)",
                     ["casting mesh", "drawn mesh", "triangles", "terrain pixels", "shadowed %",
                      "changed vs full detail %"],
                     [["full detail", "full detail", 100, 50, 2.2, 0.0],
                      ["geomipmap 2 px", "full detail", 10, 50, 48.9, 47.8],
                      ["geomipmap 2 px", "the same LOD", 10, 50, 1.35, 1.4],
                      ["geomipmap 8 px", "full detail", 5, 50, 48.7, 47.9],
                      ["geomipmap 8 px", "the same LOD", 5, 50, 1.06, 1.8]])
    text, images = ANALYSES["shadows"]([cost, agree, moving, lod], tmp_path)
    assert images == ["object_shadow_cost.png"]
    assert (tmp_path / "object_shadow_cost.png").read_bytes()[:4] == b"\x89PNG"
    assert "marks 99.88 % of the surface pixels" in text
    assert "agree on 99.82 %" in text
    assert "volumes make the frame 2.9×" in text and "shadow maps 1.3×" in text
    assert "(45.4 ms a frame)" in text and "1.1× the median" in text
    assert "shadows 2.2 %" in text and "48.7–48.9 % are shadowed" in text
    assert "1.4–1.8 % of the pixels change" in text


def test_log_axes_label_plain_numbers_without_overlapping_minor_labels():
    # a short log range (3–40 frames/s) made matplotlib label every minor tick as 3×10⁰,
    # 4×10⁰, …, and the labels ran into each other
    from terrascape.bench.report_analysis import _plain_log_ticks, _pyplot

    plt = _pyplot()
    fig, ax = plt.subplots()
    ax.barh(["a", "b"], [3.5, 40.0])
    ax.set_xscale("log")
    ax.set_xlim(3.0, 45.0)
    _plain_log_ticks(ax.xaxis)
    fig.canvas.draw()
    major = {t.get_text() for t in ax.xaxis.get_ticklabels()}
    minor = [t.get_text() for t in ax.xaxis.get_ticklabels(minor=True) if t.get_text()]
    plt.close(fig)
    assert {"5", "10", "20"} <= major
    assert minor == []
