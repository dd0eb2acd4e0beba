"""Progress bars: drawn on a terminal (or when forced), absent in logs and pipes."""

from __future__ import annotations

import io
import sys

from campaign.core import progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_a_bar_and_every_item(monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    monkeypatch.delenv("CAMPAIGN_PROGRESS", raising=False)
    assert list(progress.progress([1, 2, 3], desc="verify")) == [1, 2, 3]
    assert "verify" in term.getvalue() and "/3 " in term.getvalue()


def test_a_pipe_or_log_gets_nothing(monkeypatch):
    pipe = io.StringIO()  # not a terminal, like a Snakemake job's log
    monkeypatch.setattr(sys, "stderr", pipe)
    monkeypatch.delenv("CAMPAIGN_PROGRESS", raising=False)
    assert list(progress.progress(iter(range(4)), desc="identify")) == [0, 1, 2, 3]
    assert pipe.getvalue() == ""


def test_the_environment_overrides_the_terminal(monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    assert list(progress.progress([1], desc="x")) == [1] and term.getvalue() == ""
    pipe = io.StringIO()
    monkeypatch.setattr(sys, "stderr", pipe)
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "1")
    assert list(progress.progress([1, 2], desc="forced")) == [1, 2] and "forced" in pipe.getvalue()


def test_identify_shows_progress_only_when_asked(monkeypatch, capsys, tmp_path):
    from pathlib import Path

    from campaign.cli.main import main

    trial = Path(__file__).resolve().parents[2] / "archive/reference/fixed/config1/zero/v1.500/r00.nc"
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "1")
    assert main(["identify", str(trial)]) == 0
    assert "identify" in capsys.readouterr().err
    monkeypatch.setenv("CAMPAIGN_PROGRESS", "0")
    assert main(["identify", str(trial)]) == 0
    assert capsys.readouterr().err == ""
