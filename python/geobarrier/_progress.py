"""The progress shown by run(..., progress=True): one line per stage on stderr, redrawn in place with a carriage
return, which terminals and notebooks (Jupyter's stderr stream) both honour."""

import sys
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
            if self.stage is not None:
                self.stream.write("\n")
            self.stage, self.start = stage, time.monotonic()
        fraction = done / total if total else 1.0
        filled = int(fraction * self.width + 0.5)
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = time.monotonic() - self.start
        self.stream.write(f"\r{stage:<20s}[{bar}] {100 * fraction:3.0f}%  {elapsed:.1f} s")
        self.stream.flush()

    def close(self):
        if self.stage is not None:
            self.stream.write("\n")
            self.stream.flush()
            self.stage = None
