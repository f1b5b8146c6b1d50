"""A progress bar for the long commands: named steps on standard error, as ``build`` shows its own.

Shown only where standard error is a terminal and the command was not told --quiet, so that a
log or a pipe gets the command's output and nothing else.
"""

from __future__ import annotations

from contextlib import contextmanager


@contextmanager
def steps(total: int, quiet: bool = False):
    """A bar over ``total`` steps; yields ``step(description)``, which finishes the step before (if
    any) and names the next, so that the bar says what the command is doing while it does it."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True, quiet=quiet)
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True, disable=quiet or not console.is_terminal) as bar:
        task = bar.add_task("", total=total)
        started = [False]

        def step(description: str) -> None:
            if started[0]:
                bar.advance(task)
            started[0] = True
            bar.update(task, description=description)

        yield step
        bar.update(task, completed=total)
