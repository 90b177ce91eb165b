"""Barriers as Python objects: Barrier (one curve with its figures) and Barriers (the list run() returns, with
to_dataframe() and plot()). The core hands every numeric figure over as a double (barriers.json writes 768.0); the
figures that count something are integers here."""

import math

import numpy as np

# The figures that count (docs/extractors.md): ranks, island numbers, numbers of points, pieces and probes. A figure
# of these names that is a whole number becomes an int; any other stays as barriers.json has it.
INTEGER_FIGURES = frozenset({"rank", "island", "pieces", "neighbour_probes", "probes_with_smaller_q",
                             "advected_points"})


def _typed(name, value):
    if (name in INTEGER_FIGURES and isinstance(value, float) and math.isfinite(value)
            and value == int(value)):
        return int(value)
    return value


class Barrier:
    """One barrier (or candidate) an extractor found.

    points      (n, 2) float array of (x, y) at t0, read-only; ``x`` and ``y`` are its columns
    kind        "hyperbolic", "elliptic" or "parabolic"
    closed      True for a closed curve (the first point is not repeated at the end)
    extractor   the extractor plugin that found it
    attributes  every other figure barriers.json records for it, typed: counts (rank, island, advected_points, ...)
                as int, flags as bool, measurements as float, labels as str; also readable as ``barrier["length"]``
                or ``barrier.length``
    """

    def __init__(self, record):
        record = dict(record)
        self.kind = record.pop("kind")
        self.closed = bool(record.pop("closed"))
        self.extractor = record.pop("extractor")
        points = np.array(record.pop("points"), dtype=float).reshape(-1, 2)
        points.flags.writeable = False
        self.points = points
        self.attributes = {name: _typed(name, value) for name, value in record.items()}

    @property
    def x(self):
        """The points' x coordinates, an (n,) array."""
        return self.points[:, 0]

    @property
    def y(self):
        """The points' y coordinates, an (n,) array."""
        return self.points[:, 1]

    def __len__(self):
        return len(self.points)

    def __getitem__(self, name):
        if name not in self.attributes:  # the figures this barrier has (extractors record different ones)
            raise KeyError(f"no figure {name!r} (this barrier's: {', '.join(self.attributes)})")
        return self.attributes[name]

    def __getattr__(self, name):
        attributes = self.__dict__.get("attributes", {})
        if name in attributes:
            return attributes[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or figure {name!r}")

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self.__dict__.get("attributes", {})))

    def to_dict(self):
        """The barrier as one flat dict: kind, extractor, closed, the number of points, and every figure."""
        return {"kind": self.kind, "extractor": self.extractor, "closed": self.closed, "n_points": len(self.points),
                **self.attributes}

    def plot(self, ax=None, **kwargs):
        """Draws the curve with matplotlib (closed curves closed) on ``ax`` (default: the current Axes) and returns
        the Axes; keyword arguments go to ``Axes.plot`` (default colour by kind)."""
        import matplotlib.pyplot as plt

        ax = plt.gca() if ax is None else ax
        points = np.vstack([self.points, self.points[:1]]) if self.closed and len(self.points) else self.points
        kwargs.setdefault("color", KIND_COLOURS.get(self.kind, "red"))
        kwargs.setdefault("linewidth", 1.2)
        ax.plot(points[:, 0], points[:, 1], **kwargs)
        return ax

    def __repr__(self):
        shape = "closed" if self.closed else "open"
        return f"<geobarrier.Barrier {self.kind} ({self.extractor}), {shape}, {len(self.points)} points>"


# Barrier colours of plot(): on viridis, red and white stand out; parabolic barriers (jet cores) in magenta.
KIND_COLOURS = {"hyperbolic": "red", "elliptic": "white", "parabolic": "magenta"}


class Barriers(list):
    """A list of Barrier (``result.barriers``, ``result.candidates``) with a table and a picture of its own."""

    def to_dataframe(self):
        """One row per barrier (pandas.DataFrame): kind, extractor, closed, n_points and every figure any barrier
        has; integer figures are integer columns (pandas' nullable ``Int64`` where some barrier lacks the figure),
        a missing figure is NaN or <NA>. Needs pandas (Debian: python3-pandas)."""
        try:
            import pandas
        except ImportError:
            raise ImportError("to_dataframe() needs pandas (Debian: apt-get install python3-pandas)") from None
        rows = [b.to_dict() for b in self]
        columns = ["kind", "extractor", "closed", "n_points"]
        for row in rows:
            columns += [name for name in row if name not in columns]
        frame = pandas.DataFrame(rows, columns=columns)
        for name in columns:
            values = [row.get(name) for row in rows]
            present = [v for v in values if v is not None]
            if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
                frame[name] = frame[name].astype("int64" if len(present) == len(values) else "Int64")
        return frame

    def plot(self, ax=None, **kwargs):
        """Draws every barrier (Barrier.plot) on ``ax`` (default: the current Axes); returns the Axes."""
        import matplotlib.pyplot as plt

        ax = plt.gca() if ax is None else ax
        for barrier in self:
            barrier.plot(ax=ax, **kwargs)
        return ax
