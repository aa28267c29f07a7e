from terrascape.cli.app import run_app


def test_help_exits_zero(capsys):
    assert run_app(["--help"]) == 0
    assert "terrascape" in capsys.readouterr().out


def test_unknown_option_is_usage_error():
    assert run_app(["--no-such-option"]) == 2


def test_unknown_benchmark_is_usage_error():
    assert run_app(["bench", "no-such-bench"]) == 2
