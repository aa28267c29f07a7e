from terrascape.report import write_report


def test_report_writes_markdown_and_plots(tmp_path):
    path = write_report(tmp_path, quick=True, tiny=True, cases=())
    text = path.read_text()
    assert "## Machine" in text and "| cores |" in text
    # the seed's depth analysis, measured by the library (seed 001 §5.3.1)
    assert "| LIN | linear | 7 |" in text
    assert "| DIV | halve | 8 |" in text
    assert "| SQRT | sqrt | 4 |" in text
    for name in ("fractal_roughness.png", "fractal_decay_laws.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"]({name})" in text
    assert not list(tmp_path.glob(".*.part"))
