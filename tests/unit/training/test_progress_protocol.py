"""The progress protocol: the library's lines and stages, plain lines, silence, and the
command line's Rich display of them; and a library that imports no Rich console or bar."""

from __future__ import annotations

import io
import re
import subprocess
import sys

from rich.console import Console

from adaptsky.progress import LogLines, Reporter, Silent, WorkProgress
from adaptsky_cli.cli.progress_display import RichReporter

STAMP = r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d "


class Recorder(Reporter):
    """Every call, in order."""

    def __init__(self, live: bool = False) -> None:
        self.live, self.calls = live, []

    def print(self, text: str) -> None:
        self.calls.append(("print", text))

    def open(self, layout):
        self.calls.append(("open", layout))

    def close(self):
        self.calls.append(("close",))

    def start(self, key, total, done=0, **fields):
        self.calls.append(("start", total, done, fields))

    def advance(self, key, done, **fields):
        self.calls.append(("advance", done))

    def finish(self, key):
        self.calls.append(("finish",))


def _lines(stream: io.StringIO) -> list[str]:
    return stream.getvalue().splitlines()


def test_plain_lines_stamp_messages_and_logs_and_quiet_keeps_only_warnings_and_messages():
    for quiet in (False, True):
        stream = io.StringIO()
        reporter = LogLines(stream, quiet=quiet)
        reporter.print("warning: w")
        reporter.say("result")
        reporter.message("interrupted")
        reporter.note("run a: done")
        reporter.log("evaluating: 3 steps ...")
        lines = _lines(stream)
        expected = 2 if quiet else 5
        assert len(lines) == expected, lines
        assert lines[0] == "warning: w"
        if not quiet:
            assert lines[1] == "result"
            assert all(re.match(STAMP, line) for line in lines[2:])
        else:
            assert re.match(STAMP + "interrupted$", lines[1])


def test_silent_shows_nothing(capsys):
    reporter = Silent()
    for method in (reporter.print, reporter.say, reporter.message, reporter.note, reporter.log):
        method("x")
    assert capsys.readouterr() == ("", "")


def test_work_progress_reports_stages_and_logs_where_nothing_is_live():
    recorder = Recorder()
    work = WorkProgress(recorder, log_every_s=3600)
    with work, work.stage("oracle", 3, "layout") as tick:
        tick(1)
        tick(3)
    kinds = [call[0] for call in recorder.calls]
    assert kinds == ["open", "start", "print", "advance", "advance", "finish", "print", "close"]
    assert recorder.calls[1] == ("start", 3, 0, {"name": "oracle", "unit": "layout"})
    assert re.match(STAMP + "oracle: 3 layouts ...$", recorder.calls[2][1])
    assert re.match(STAMP + r"oracle: done in [\d.]+ s$", recorder.calls[6][1])
    live = Recorder(live=True)
    with WorkProgress(live) as work, work.stage("oracle", 3, "layout") as tick:
        tick(3)
    assert "print" not in [call[0] for call in live.calls]  # the bar shows it


def test_rich_display_on_a_terminal_draws_bars_and_unstamped_messages():
    buffer = io.StringIO()
    reporter = RichReporter(Console(file=buffer, force_terminal=True, width=100))
    with WorkProgress(reporter, log_every_s=0) as work, work.stage("oracle", 2, "layout") as tick:
        tick(1)
        reporter.message("interrupted")
    text = buffer.getvalue()
    assert "oracle" in text and "interrupted" in text and not re.search(STAMP, text)
    quiet = RichReporter(Console(file=io.StringIO(), force_terminal=True), quiet=True)
    assert not quiet.live  # quiet: no bars, and messages are stamped as in a log


def test_the_library_creates_no_rich_console_or_progress():
    code = ("import sys; import adaptsky.training.api, adaptsky.experiment.reproduce, "
            "adaptsky.experiment.sweep, adaptsky.experiment.evaluation, adaptsky.evaluation.api;"
            " print(sorted(m for m in ('rich.console', 'rich.progress', 'rich.live') "
            "if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip() == "[]"
