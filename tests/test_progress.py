"""The progress bar: drawn on a terminal only, complete at the end."""
import io

from pysim.cli.progress import Progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_draws_on_a_terminal_and_ends_the_line():
    stream = Terminal()
    with Progress(4, "sweeping", stream=stream) as progress:
        for _ in range(4):
            progress.update()
    text = stream.getvalue()
    assert text.endswith("\n") and "sweeping" in text
    assert text.rstrip("\n").split("\r")[-1].count("#") == Progress.WIDTH
    assert "100%" in text


def test_progress_is_silent_when_not_on_a_terminal():
    stream = io.StringIO()
    with Progress(3, "x", stream=stream) as progress:
        progress.update(3, label="done")
    assert stream.getvalue() == ""
    assert progress.done == 3 and progress.label == "done"
