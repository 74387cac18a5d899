"""Conventions every command follows: --version, -q/-v on logging, TQDM_DISABLE, NO_COLOR, --overwrite."""

from __future__ import annotations

import io
import logging

import pytest

from scenarios.cli import main
from scenarios.runner import VERSION


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"mocap-bench {VERSION}"


def test_quiet_and_verbose_set_the_logging_level(tmp_path):
    main(["-q", "export", str(tmp_path / "none"), "--format", "csv", "--out", str(tmp_path / "x.csv")])
    assert logging.getLogger().level == logging.WARNING
    main(["-v", "export", str(tmp_path / "none"), "--format", "csv", "--out", str(tmp_path / "x.csv")])
    assert logging.getLogger().level == logging.DEBUG
    with pytest.raises(SystemExit):
        main(["-q", "-v", "--version"])  # mutually exclusive


@pytest.mark.parametrize("how", ["quiet", "env"])
def test_progress_bars_can_be_hidden(tmp_path, capsys, monkeypatch, how):
    monkeypatch.delenv("TQDM_DISABLE", raising=False)
    argv = ["simulate", "single", "--duration", "1", "--out", str(tmp_path / "r")]
    if how == "quiet":
        argv = ["-q", *argv]
    else:
        monkeypatch.setenv("TQDM_DISABLE", "1")
    assert main(argv) == 0
    assert "simulate single" not in capsys.readouterr().err  # the bar's description
    import os

    assert os.environ.get("TQDM_DISABLE") == (None if how == "quiet" else "1")  # restored after -q


def test_progress_bar_shown_by_default(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("TQDM_DISABLE", raising=False)
    assert main(["simulate", "single", "--duration", "1", "--out", str(tmp_path / "r")]) == 0
    assert "simulate single" in capsys.readouterr().err


@pytest.mark.parametrize("no_color, coloured", [(None, True), ("1", False)])
def test_error_colour_honours_no_color(tmp_path, monkeypatch, no_color, coloured):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    if no_color is None:
        monkeypatch.delenv("NO_COLOR", raising=False)
    else:
        monkeypatch.setenv("NO_COLOR", no_color)
    assert main(["export", str(tmp_path / "none"), "--format", "csv", "--out", str(tmp_path / "x.csv")]) == 2
    text = terminal.getvalue()
    assert "mocap-bench export: error:" in text and ("\033[31m" in text) is coloured


def test_no_overwrite_without_the_flag(tmp_path, capsys):
    out = tmp_path / "c.toml"
    out.write_text("keep")
    assert main(["calibrate", str(tmp_path), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err and out.read_text() == "keep"
    assert main(["calibrate", str(tmp_path), "--out", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
