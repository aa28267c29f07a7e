"""Plots and discussion paragraphs for the benchmark sections of ``terrascape bench report``.

Each ``analyse_<case>`` function takes the :class:`~terrascape.bench.BenchTable` list that
benchmark case produced in this run and the output folder, writes its PNG plots and returns
``(markdown, image names)``. Every number in the discussion is read from those tables; the
theses' figures they are compared with are quoted as such (Janković 2010 §2.7, Filipović 2008 §5.3).
Tables are found by title prefix and columns by name, so a case that grew or lost a table
still gets whatever analysis its tables support.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path

from terrascape.bench import BenchTable

# Janković 2010 §2.7, test configuration 2: average FPS drop against texture mapping.
SEED_PARALLAX_DROP = 14.06
SEED_RELIEF_DROP = 69.75
# Janković 2010 §2.7, test 4 (configuration 2), frames per second.
SEED_TEST4_FPS = {
    "texture": 824, "parallax": 716, "relief": 55, "lod1": 5, "lod3": 62, "lod5": 170,
}  # fmt: skip


# --- helpers ---------------------------------------------------------------------------------
def find_table(tables: Sequence[BenchTable], prefix: str) -> BenchTable | None:
    """The first table whose title starts with ``prefix`` (case-insensitive)."""
    prefix = prefix.lower()
    return next((t for t in tables if t.title.lower().startswith(prefix)), None)


def column_index(table: BenchTable, name: str) -> int:
    """Index of column ``name``, or of the first column starting with it ("triangles"
    finds "triangles (mean)"); raises KeyError with the available columns."""
    if name in table.columns:
        return table.columns.index(name)
    for i, col in enumerate(table.columns):
        if col.startswith(name):
            return i
    raise KeyError(f"{table.title!r} has no column {name!r}: {table.columns}")


def column(table: BenchTable, name: str) -> list:
    """Values of column ``name`` (see :func:`column_index`)."""
    i = column_index(table, name)
    return [row[i] for row in table.rows]


def as_number(value) -> float:
    """A float from a cell: numbers as they are, '4097²' → 4097, '-' or '' → NaN."""
    if isinstance(value, int | float):
        return float(value)
    match = re.search(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", str(value))
    return float(match.group()) if match else math.nan


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_log_ticks(axis) -> None:
    """Label a log axis at 1, 2, 5 × 10^k in plain numbers, minor ticks unlabelled.

    Matplotlib's default labels the minor ticks of a short log range as 3×10⁰, 4×10⁰, …,
    which run into each other on a narrow plot.
    """
    from matplotlib import ticker

    axis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda v, _pos: f"{v:g}"))
    axis.set_minor_formatter(ticker.NullFormatter())


def save_figure(fig, out: Path, name: str) -> str:
    """Save atomically (temp file + rename) and close; returns ``name``."""
    plt = _pyplot()
    tmp = out / f".{name}.part"
    fig.savefig(tmp, dpi=80, format="png")
    plt.close(fig)
    os.replace(tmp, out / name)
    return name


def _fmt(v: float, digits: int = 3) -> str:
    return f"{v:.{digits}g}"


Analysis = tuple[str, list[str]]


def plot_per_algorithm_vs_size(table: BenchTable, out: Path, name: str,
                               panels: Sequence[tuple[str, str, bool]]) -> dict:
    """One panel per ``(column, y label, log y)``: that column against the map side, a line per
    algorithm. Returns ``{algorithm: {side: value of the first column}}``."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4), squeeze=False)
    first: dict[str, dict[float, float]] = {}
    for algo in dict.fromkeys(column(table, "algorithm")):
        rows = [r for r in table.rows if r[0] == algo]
        sizes = [as_number(r[column_index(table, "map")]) for r in rows]
        for k, (ax, (col, _, _)) in enumerate(zip(axes[0], panels, strict=True)):
            values = [as_number(r[column_index(table, col)]) for r in rows]
            ax.plot(sizes, values, marker="o", label=algo)
            if k == 0:
                first[algo] = dict(zip(sizes, values, strict=True))
    for ax, (_, label, log_y) in zip(axes[0], panels, strict=True):
        ax.set_xscale("log", base=2)
        if log_y:
            ax.set_yscale("log")
        ax.set_xlabel("heightmap side (samples)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    save_figure(fig, out, name)
    return first


# --- relief texturing (Janković 2010 §2.7) ---
def analyse_relief(tables: Sequence[BenchTable], out: Path) -> Analysis:
    md: list[str] = []
    images: list[str] = []
    plt = _pyplot()
    quality = find_table(tables, "Relief quality")
    if quality is not None and quality.rows:
        fields = sorted(set(column(quality, "field")))
        techniques = list(dict.fromkeys(column(quality, "technique")))
        fig, axes = plt.subplots(1, len(fields), figsize=(6 * len(fields), 4.5), squeeze=False)
        for ax, fld in zip(axes[0], fields, strict=True):
            for tech in techniques:
                pts = sorted(
                    (as_number(r[quality.columns.index("angle°")]),
                     as_number(r[quality.columns.index("p95 err (texel)")]))
                    for r in quality.rows
                    if r[quality.columns.index("field")] == fld
                    and r[quality.columns.index("technique")] == tech
                )
                if pts:
                    xs, ys = zip(*pts, strict=True)
                    ax.plot(xs, [max(y, 1e-5) for y in ys], marker="o", label=tech)
            ax.set_yscale("log")
            ax.set_xlabel("view angle from the normal (°)")
            ax.set_ylabel("95th-percentile UV error (texels)")
            ax.set_title(f"{fld} field")
            ax.grid(True, which="both", alpha=0.3)
        axes[0][-1].legend(fontsize=7, loc="best")
        images.append(save_figure(fig, out, "relief_quality.png"))
        md.append("![relief quality vs view angle](relief_quality.png)\n")

        def rows_of(tech_prefix: str):
            ti = quality.columns.index("technique")
            return [r for r in quality.rows if str(r[ti]).startswith(tech_prefix)]

        p95 = quality.columns.index("p95 err (texel)")
        ratio = quality.columns.index("× relief 16+8")
        relief = rows_of("relief 16+8")
        exact = rows_of("min/max exact")
        cone = rows_of("cone step")
        parallax = rows_of("parallax")
        text = []
        if relief:
            worst = max(relief, key=lambda r: as_number(r[p95]))
            text.append(
                f"Relief mapping 16+8 reaches a worst 95th-percentile error of "
                f"{_fmt(as_number(worst[p95]))} texels ({worst[0]} field, {worst[1]}°)"
            )
        if exact:
            worst_e = max(as_number(r[p95]) for r in exact)
            slow_e = max(as_number(r[ratio]) for r in exact)
            text.append(
                f"the min/max-mip tracer stays exact (worst p95 {_fmt(worst_e)} texels) at up "
                f"to {_fmt(slow_e)}× the time of relief 16+8"
            )
        if cone and exact:
            beats = sum(
                as_number(e[p95]) <= as_number(c[p95])
                and as_number(e[ratio]) <= as_number(c[ratio])
                for e, c in zip(exact, cone, strict=False)
            )
            text.append(f"it beats cone step mapping on both error and time in {beats} of "
                        f"{min(len(exact), len(cone))} cells")
        if parallax:
            worst_p = max(as_number(r[p95]) for r in parallax
                          if r[quality.columns.index("technique")] == "parallax")
            text.append(
                f"plain parallax, a single fetch, is off by up to {_fmt(worst_p)} texels at "
                "the 95th percentile — the thesis's remark that its texture \"deforms\" up close "
                "and at low angles, quantified"
            )
        if text:
            md.append("Discussion: " + "; ".join(text) + ".\n")

    seed = find_table(tables, "Janković 2010 §2.7 reproduction")
    if seed is not None and seed.rows:
        tech_i = seed.columns.index("technique")
        drop_i = seed.columns.index("% drop vs texture")
        tex_i = seed.columns.index("texture")
        par = [as_number(r[drop_i]) for r in seed.rows if r[tech_i] == "parallax"]
        rel = [as_number(r[drop_i]) for r in seed.rows if str(r[tech_i]).startswith("relief")]
        textures = list(dict.fromkeys(r[tex_i] for r in seed.rows))
        if par and rel:
            fig, ax = plt.subplots(figsize=(7, 4))
            x = range(len(textures))
            ax.bar([i - 0.2 for i in x], par[: len(textures)], width=0.4, label="parallax")
            ax.bar([i + 0.2 for i in x], rel[: len(textures)], width=0.4, label="relief 16+8")
            ax.axhline(SEED_PARALLAX_DROP, color="C0", ls="--", lw=1,
                       label=f"seed average, parallax {SEED_PARALLAX_DROP} %")
            ax.axhline(SEED_RELIEF_DROP, color="C1", ls="--", lw=1,
                       label=f"seed average, relief {SEED_RELIEF_DROP} %")
            ax.set_xticks(list(x), textures, fontsize=8)
            ax.set_ylabel("frame-rate drop vs texture mapping (%)")
            ax.set_ylim(0, 100)
            ax.legend(fontsize=7)
            images.append(save_figure(fig, out, "relief_seed_drop.png"))
            md.append("![frame-rate drop vs texture mapping](relief_seed_drop.png)\n")
            avg_p, avg_r = sum(par) / len(par), sum(rel) / len(rel)
            md.append(
                f"Average frame-rate drop against texture mapping over the three textures: "
                f"parallax {avg_p:.2f} %, relief mapping {avg_r:.2f} % (Janković 2010: "
                f"{SEED_PARALLAX_DROP} % and {SEED_RELIEF_DROP} %). "
                + ("Relief mapping costs about what it cost the thesis; "
                   if abs(avg_r - SEED_RELIEF_DROP) < 10 else
                   "Relief mapping costs more than it cost the thesis; "
                   if avg_r > SEED_RELIEF_DROP else
                   "Relief mapping costs less than it cost the thesis; ")
                + ("parallax costs far more here than on the thesis's GPU, because llvmpipe "
                   "shades fragments on the CPU, where one more dependent texture fetch per "
                   "pixel is a large share of a cheap frame.\n"
                   if avg_p > 2 * SEED_PARALLAX_DROP else
                   "parallax stays cheap, as in the thesis.\n")
            )
    return "\n".join(md), images


# --- ROAM and Turner's ROAM, update only (Filipović 2008 §5.3, figures 27–29) ---
def analyse_lod_roam(tables: Sequence[BenchTable], out: Path) -> Analysis:
    md: list[str] = []
    images: list[str] = []
    plt = _pyplot()
    by_size = find_table(tables, "ROAM and Turner's ROAM: per-frame update")
    by_target = find_table(tables, "ROAM and Turner's ROAM: update time")
    if by_size is not None and by_size.rows:
        series = plot_per_algorithm_vs_size(
            by_size, out, "roam_vs_map_size.png",
            [("median ms", "LOD update, median ms/frame", False),
             ("triangles (median)", "triangles (median)", False)])
        images.append("roam_vs_map_size.png")
        md.append("![ROAM update time and triangles vs map size](roam_vs_map_size.png)\n")
        ratios = []
        for algo, pts in series.items():
            if 513 in pts and len(pts) > 1:
                big = max(pts)
                if big > 513:
                    ratios.append(f"{algo}: {pts[big] / pts[513]:.2f}× from 513² to {int(big)}²")
        if ratios:
            md.append(
                "Discussion: at a fixed 80,000-triangle target the update time changes "
                "little with the map (" + "; ".join(ratios) + "), the thesis's finding that map "
                "size does not drive ROAM's cost; the small 257² map cannot supply 80,000 "
                "visible triangles, the thesis's own exception.\n"
            )
    if by_target is not None and by_target.rows:
        fig, ax = plt.subplots(figsize=(6, 4))
        targets = [as_number(v) for v in column(by_target, "target")]
        for name in ("Turner", "ROAM"):
            col = f"{name} fps (LOD only)"
            if col in by_target.columns:
                ax.plot(targets, [as_number(v) for v in column(by_target, col)], marker="o",
                        label=name)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("triangle target")
        ax.set_ylabel("LOD-only frames/s (1000 / update ms)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        images.append(save_figure(fig, out, "roam_vs_target.png"))
        md.append("![LOD-only frame rate vs triangle target](roam_vs_target.png)\n")
    return "\n".join(md), images


# --- the whole-frame LOD flight (helper case lod_flight) -----------------------------------
def analyse_lod_flight(tables: Sequence[BenchTable], out: Path) -> Analysis:
    md: list[str] = []
    images: list[str] = []
    plt = _pyplot()
    by_size = find_table(tables, "LOD flight: frame rate and triangles vs map size")
    by_target = find_table(tables, "LOD flight: frame rate vs triangle target")
    if by_size is not None and by_size.rows:
        fps_at = plot_per_algorithm_vs_size(
            by_size, out, "lod_flight_vs_map_size.png",
            [("frames/s", "frames/s (LOD + draw)", False),
             ("triangles", "triangles drawn (mean)", True)])
        images.append("lod_flight_vs_map_size.png")
        md.append("![frame rate and triangles vs map size](lod_flight_vs_map_size.png)\n")
        parts = []
        for algo, pts in fps_at.items():
            finite = {k: v for k, v in pts.items() if not math.isnan(v)}
            if len(finite) > 1 and 513 in finite:
                big = max(finite)
                parts.append(f"{algo} {finite[513]:.1f} → {finite[big]:.1f} frames/s "
                             f"(513² → {int(big)}²)")
        if parts:
            md.append(
                "Discussion (Filipović 2008, figure 27–28): with the triangle count held near "
                "80,000, the whole frame rate is " + "; ".join(parts) + ". The thesis found "
                "frame rate independent of map size for ROAM; a full-resolution row, where "
                "present, shows what the LOD saves.\n"
            )
    if by_target is not None and by_target.rows:
        fig, ax = plt.subplots(figsize=(6, 4))
        fps_cols = [c for c in by_target.columns if c.endswith("frames/s")]
        tri_cols = [c for c in by_target.columns if c.endswith("triangles")]
        for fc, tc in zip(fps_cols, tri_cols, strict=False):
            xs = [as_number(v) for v in column(by_target, tc)]
            ys = [as_number(v) for v in column(by_target, fc)]
            ax.plot(xs, ys, marker="o", label=fc.replace(" frames/s", ""))
        ax.set_xscale("log")
        ax.set_xlabel("triangles drawn")
        ax.set_ylabel("frames/s (LOD + draw)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        images.append(save_figure(fig, out, "lod_flight_vs_target.png"))
        md.append("![frame rate vs triangles](lod_flight_vs_target.png)\n")
        if fps_cols:
            first, last = by_target.rows[0], by_target.rows[-1]
            i = by_target.columns.index(fps_cols[0])
            md.append(
                f"Discussion (Filipović 2008, figure 29): frame rate falls from "
                f"{_fmt(as_number(first[i]))} to {_fmt(as_number(last[i]))} frames/s "
                f"({fps_cols[0].replace(' frames/s', '')}) as the target grows from "
                f"{first[0]} to {last[0]} triangles — every extra triangle costs CPU work "
                "(here the rasteriser is on the CPU too), as the thesis observed.\n"
            )
    return "\n".join(md), images


# --- Janković 2010 test 4: relief-mapped texture terrain vs polygons (helper case) ---------------
def analyse_terrain_vs_relief(tables: Sequence[BenchTable], out: Path) -> Analysis:
    md: list[str] = []
    images: list[str] = []
    speed = [t for t in tables if t.rows and "frames/s" in t.columns and "method" in t.columns]
    if not speed:
        return "", images
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(speed), figsize=(6 * len(speed), 4), squeeze=False)
    slowest: list[bool] = []
    for ax, table in zip(axes[0], speed, strict=True):
        methods = [str(v) for v in column(table, "method")]
        fps = [as_number(v) for v in column(table, "frames/s")]
        ax.barh(methods, fps)
        ax.set_xscale("log")
        _plain_log_ticks(ax.xaxis)
        ax.set_xlabel("frames/s (log)")
        ax.invert_yaxis()
        ax.tick_params(axis="y", labelsize=7)
        ax.grid(True, axis="x", which="both", alpha=0.3)
        short = table.title.split(":")[0].split(",", 1)[-1].strip()
        ax.set_title(short, fontsize=9)
        lookup = dict(zip(methods, fps, strict=True))

        def first(pred, lookup=lookup):
            return next((v for k, v in lookup.items() if pred(k.lower())), None)

        texture = first(lambda k: k.startswith("texture"))
        relief = first(lambda k: k.startswith("relief"))
        parallax = first(lambda k: k.startswith("parallax"))
        full = first(lambda k: "full" in k)
        if texture and relief and full:
            slowest.append(full <= min(lookup.values()) * 1.05)
            md.append(
                f"Discussion ({short}): relief mapping on a flat quad runs at {_fmt(relief)} "
                f"frames/s ({relief / texture:.2f}× texture mapping's {_fmt(texture)}; "
                f"parallax {_fmt(parallax or math.nan)}), the full-resolution polygons at "
                f"{_fmt(full)}. Janković 2010, test 4: texture {SEED_TEST4_FPS['texture']}, "
                f"parallax {SEED_TEST4_FPS['parallax']}, relief {SEED_TEST4_FPS['relief']}, "
                f"polygons at 1 / 3 / 5 LOD levels {SEED_TEST4_FPS['lod1']} / "
                f"{SEED_TEST4_FPS['lod3']} / {SEED_TEST4_FPS['lod5']} frames/s.\n"
            )
    fig.tight_layout()
    images.append(save_figure(fig, out, "terrain_vs_relief.png"))
    md.insert(0, "![texture-based vs polygonal terrain](terrain_vs_relief.png)\n")
    if slowest and all(slowest):
        md.append(
            "As in the seed, polygons at full resolution are the slowest option in every "
            "case and level of detail recovers the frame rate; unlike the thesis's GPU, "
            "llvmpipe shades fragments on the CPU, so relief mapping loses less against "
            "texture mapping here. The quality table says what each shortcut costs in the "
            "image.\n"
        )
    return "\n".join(md), images


# --- rendering modes ------------------------------------------------------------------------
def analyse_render(tables: Sequence[BenchTable], out: Path) -> Analysis:
    table = find_table(tables, "render:")
    if table is None or not table.rows:
        return "", []
    plt = _pyplot()
    names = [str(v) for v in column(table, "technique")]
    ms = [as_number(v) for v in column(table, "ms/frame (median)")]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.bar(names, ms)
    ax.set_ylabel("ms/frame (median)")
    ax.grid(True, axis="y", alpha=0.3)
    image = save_figure(fig, out, "render_modes.png")
    worst = max(zip(ms, names, strict=True))
    text = (f"![ms per frame per texturing mode](render_modes.png)\n\nDiscussion: plain texturing "
            f"runs at {1000 / ms[0]:.1f} frames/s; the most expensive mode, {worst[1]}, takes "
            f"{worst[0] / ms[0]:.2f}× its time. On llvmpipe the full-resolution mesh's "
            "sub-pixel triangles, not texturing, set the cost: the renderer leaves out those "
            "that cover no pixel centre and shades the expensive modes once per pixel "
            "(deferred), so the modes stay close to each other.\n")
    return text, [image]


# --- object shadows (Filipović 2008 §3.2.1) -------------------------------------------------
def analyse_shadows(tables: Sequence[BenchTable], out: Path) -> Analysis:
    """The thesis's three claims about stencil shadow volumes, answered from the run's
    tables: exact, fast on graphics hardware with a moving light, and not for terrain under
    level of detail."""
    cost = find_table(tables, "frame time by object shadow mode")
    agree = find_table(tables, "agreement with the CPU ray cast")
    moving = find_table(tables, "a sun moving")
    lod = find_table(tables, "terrain shadow volumes under LOD")
    md: list[str] = []
    images: list[str] = []
    if cost is not None and cost.rows:
        plt = _pyplot()
        modes = [str(v) for v in column(cost, "mode")]
        ratio = [as_number(v) for v in column(cost, "× no object shadows")]
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.barh(modes, ratio)
        ax.set_xlabel("frame time × the frame without object shadows")
        ax.invert_yaxis()
        ax.grid(True, axis="x", alpha=0.3)
        fig.tight_layout()  # the long mode names would be cut off at the left edge
        images.append(save_figure(fig, out, "object_shadow_cost.png"))
        md.append("![frame cost per object shadow mode](object_shadow_cost.png)\n")
    parts: list[str] = []
    if agree is not None:
        vol = agree.value("volumes", "agree %")
        casc = agree.value("cascades", "agree %")
        if vol is not None and casc is not None:
            parts.append(
                f"*Exact.* The thesis calls the volumes exact. Their stencil count marks "
                f"{_fmt(vol, 4)} % of the surface pixels as the CPU ray cast toward the sun "
                f"does (the rest are one-pixel edges and depth-buffer rounding); the cascaded "
                f"shadow maps agree on {_fmt(casc, 4)} % away from the shadows' edges, losing "
                "the thin shadows a cascade texel cannot resolve.")
    if cost is not None:
        vol_cost = cost.value("volumes", "× no object shadows")
        casc_cost = cost.value("cascades", "× no object shadows")
        if vol_cost is not None and casc_cost is not None:
            parts.append(
                f"*Fast on graphics hardware.* On this CPU rasteriser the volumes make the "
                f"frame {_fmt(vol_cost)}× the frame without object shadows, the shadow maps "
                f"{_fmt(casc_cost)}×: the volumes' cost is fill (every volume rasterised on "
                "both sides into the stencil, the shadowed surfaces drawn again), which a GPU "
                "has and llvmpipe does not, so the shadow maps are the default here and the "
                "volumes the exact reference.")
    if moving is not None and moving.rows:
        slow = as_number(column(moving, "slowest × median")[0])
        rebuild = as_number(column(moving, "volume rebuild ms")[0])
        parts.append(
            f"*No special code, and the light can move.* With the sun moving 1° a frame every "
            f"volume is rebuilt from the objects' silhouettes ({_fmt(rebuild)} ms a frame) "
            f"and the slowest frame takes {_fmt(slow)}× the median: day and night need no "
            "precomputation, as the thesis says.")
    if lod is not None and lod.rows:
        full = next((r for r in lod.rows if r[0] == "full detail"), None)
        own = [r for r in lod.rows if r[1] == "the same LOD"]
        cross = [r for r in lod.rows if r[0] != "full detail" and r[1] == "full detail"]
        si, ci = column_index(lod, "shadowed %"), column_index(lod, "changed vs full detail %")
        if full is not None and own and cross:
            lo_cross = min(as_number(r[si]) for r in cross)
            hi_cross = max(as_number(r[si]) for r in cross)
            parts.append(
                f"*Not with level of detail.* Terrain casting its own volumes at full detail "
                f"shadows {_fmt(as_number(full[si]))} % of the terrain's pixels. Cast from a "
                f"geomipmapped mesh onto the full-detail surface, {_fmt(lo_cross)}–"
                f"{_fmt(hi_cross)} % are shadowed: the coarse "
                "mesh's volumes start below the real surface and cover it. Cast and drawn from "
                f"the same LOD mesh, {_fmt(min(as_number(r[ci]) for r in own))}–"
                f"{_fmt(max(as_number(r[ci]) for r in own))} % of the pixels change against "
                "full detail, a large share of the shadowed area, because the vertices LOD "
                "removes take their shadows with them. The thesis is right: volumes suit "
                "objects and a terrain without LOD; the terrain's own shadows come from the "
                "ray-cast shadow map.")
    if parts:
        md.append("Discussion (Filipović 2008 §3.2.1):\n\n" + "\n\n".join(parts) + "\n")
    return "\n".join(md), images


ANALYSES: dict[str, Callable[[Sequence[BenchTable], Path], Analysis]] = {
    "relief": analyse_relief,
    "lod_roam": analyse_lod_roam,
    "lod_flight": analyse_lod_flight,
    "terrain_vs_relief": analyse_terrain_vs_relief,
    "render": analyse_render,
    "shadows": analyse_shadows,
}

__all__ = ["ANALYSES", "as_number", "column", "column_index", "find_table", "save_figure"]
