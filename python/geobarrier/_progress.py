"""The progress shown by run(..., progress=True). In a Jupyter notebook: a live bar per stage, tqdm's notebook bar
(an ipywidgets widget) where tqdm and ipywidgets 7 or newer are installed, else tqdm's text bar on stderr (rate and
time left; Debian 12's ipywidgets 6 speaks a widget protocol that today's Jupyter front-ends and nbclient no longer
read). Elsewhere, and in a notebook without tqdm: one text line per stage on stderr (ProgressLine), redrawn in place
with a carriage return, which terminals and Jupyter's stderr stream both honour.

The core calls progress(stage, done, total) from its worker threads (with the GIL, one call at a time). Each call is
run in the context (contextvars) of the thread that started the run, so that what it draws in a notebook is the
output of the cell that called run()."""

import contextvars
import sys
import threading
import time


class ProgressLine:
    """Called as progress(stage, done, total) from the running computation; draws
    "flow map            [#########.....................]  31%  2.0 s"."""

    width = 30

    def __init__(self, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.stage = None
        self.start = time.monotonic()

    def __call__(self, stage, done, total):
        if stage != self.stage:
            self.close(completed=True)
            self.stage, self.start = stage, time.monotonic()
        self._draw(done, total)

    def _draw(self, done, total):
        self.done, self.total = done, total
        stage = self.stage
        fraction = done / total if total else 1.0
        filled = int(fraction * self.width + 0.5)
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = time.monotonic() - self.start
        self._write(f"\r{stage:<20s}[{bar}] {100 * fraction:3.0f}%  {elapsed:.1f} s")

    def _write(self, text):
        # A progress line must not stop the run it shows: without a stream (sys.stderr is None under pythonw and in
        # some services) or with one that fails (closed, a full disk), the line is not drawn.
        if self.stream is None:
            return
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError, AttributeError):
            self.stream = None

    def close(self, completed=False):
        """Ends the line of the stage in progress; ``completed``: the stage finished (a later stage began, or the
        run returned), so the line is redrawn at 100% first (an extractor reports only its start)."""
        if self.stage is not None:
            if completed and self.done != self.total:
                self._draw(self.total or 1, self.total or 1)
            self._write("\n")
            self.stage = None


class ProgressBar:
    """Called as progress(stage, done, total): one tqdm bar per stage, ``tqdm_class`` (tqdm.notebook.tqdm in a
    notebook: a live ipywidgets bar). A stage that reports no total (0) is shown done. A stage is complete when
    the next one begins or the run returns (close(completed=True)): its bar is filled then (an extractor reports
    only its start). A run that stopped early (Ctrl-C, an error) leaves the bar of its stage short of its total,
    which the notebook bar shows in red."""

    def __init__(self, tqdm_class):
        self.tqdm_class = tqdm_class
        self.stage = None
        self.bar = None

    def __call__(self, stage, done, total):
        if stage != self.stage:
            self.close(completed=True)
            self.stage = stage
            self.bar = self.tqdm_class(total=max(total, 1), desc=stage, unit="pt" if stage == "flow map" else "it",
                                       leave=True, dynamic_ncols=True)
        if not total:
            done, total = 1, 1
        if self.bar.total != total:
            self.bar.total = total
        if done >= self.bar.n:
            self.bar.update(done - self.bar.n)  # tqdm redraws at most every 0.1 s, with its rate and time left
        else:
            self.bar.n = done
            self.bar.refresh()

    def close(self, completed=False):
        """Closes the bar of the stage in progress, filled first when ``completed``."""
        if self.bar is not None:
            if completed and self.bar.n != self.bar.total:
                self.bar.n = self.bar.total
                self.bar.refresh()
            self.bar.close()
        self.bar, self.stage = None, None


def in_notebook():
    """True inside a Jupyter kernel (an IPython shell of an IPKernelApp), as tqdm.auto decides."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
        return shell is not None and "IPKernelApp" in shell.config
    except Exception:  # an IPython too old or too odd to tell: plain text
        return False


def notebook_tqdm():
    """The tqdm bar class for a notebook: tqdm.notebook's widget bar with ipywidgets 7 or newer, else tqdm's text
    bar (on stderr); None without tqdm."""
    try:
        from tqdm import tqdm as text_bar
    except ImportError:
        return None
    try:
        import ipywidgets
        from tqdm.notebook import tqdm as widget_bar
    except ImportError:
        return text_bar
    return widget_bar if int(ipywidgets.__version__.split(".")[0]) >= 7 else text_bar


def default_progress():
    """What progress=True draws: a tqdm bar in a Jupyter kernel (notebook_tqdm), else the text line on stderr."""
    if in_notebook():
        tqdm = notebook_tqdm()
        if tqdm is not None:
            return ProgressBar(tqdm)
    return ProgressLine()


class InContext:
    """Wraps a progress callback so that every call runs in the contextvars context of the thread that made it
    (the run's caller): the core's worker threads have none of their own. A context can be entered by one thread at
    a time, and two worker threads' calls can overlap (the callback may release the GIL while it writes), so the
    calls take turns: without the lock the second raised "cannot enter context: ... is already entered"."""

    def __init__(self, callback):
        self.callback = callback
        self.context = contextvars.copy_context()
        self.lock = threading.Lock()

    def __call__(self, stage, done, total):
        with self.lock:
            return self.context.run(self.callback, stage, done, total)
