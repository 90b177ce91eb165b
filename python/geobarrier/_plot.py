"""plot(): a field with barriers over it, drawn with matplotlib from an xarray Dataset or a Fields object alike."""

import itertools

import numpy as np


def _field(fields, variable):
    """(x, y, values (ny, nx), attrs) of one variable of an xarray Dataset or a geobarrier.Fields."""
    if hasattr(fields, "data_vars"):  # xarray.Dataset
        if variable not in fields.data_vars:
            raise KeyError(f"no field named {variable!r} (fields: {', '.join(fields.data_vars)})")
        data = fields[variable]
        return np.asarray(fields["x"]), np.asarray(fields["y"]), np.asarray(data), dict(data.attrs)
    if not (hasattr(fields, "variable_attrs") and hasattr(fields, "keys")):  # not a geobarrier.Fields either
        from ._arrays import not_fields_message
        raise TypeError(not_fields_message(fields))
    if variable not in fields:
        raise KeyError(f"no field named {variable!r} (fields: {', '.join(fields)})")
    return np.asarray(fields.x), np.asarray(fields.y), np.asarray(fields[variable]), fields.variable_attrs[variable]


def _label(attrs, variable):
    name = attrs.get("long_name") or variable
    if len(name) > 40:  # a long_name with its formula (the FTLE's): the words before it
        words = name.split()
        short = list(itertools.takewhile(lambda w: "(" not in w and "[" not in w, words))
        name = " ".join(short) or name
    units = attrs.get("units")
    return f"{name} [{units}]" if units and units != "1" else name


def plot(fields, barriers=(), *, variable="ftle", ax=None, candidates=(), colorbar=True, cmap="viridis",
         aspect="equal", barrier_kwargs=None, **kwargs):
    """Draws one field (default "ftle") of ``fields`` (a run's xarray Dataset or geobarrier.Fields) as a pcolormesh
    in the (x, y) plane, with ``barriers`` over it (Barrier.plot: colour by kind) and ``candidates`` dashed in grey;
    masked points (NaN) stay blank. Returns the matplotlib Axes (a new figure's when ``ax`` is None).

    aspect          the Axes' aspect ("equal": one unit of x as long as one of y; "auto" fills the Axes)
    colorbar        draw a colour bar labelled with the field's long_name and units
    barrier_kwargs  keyword arguments for every barrier's Axes.plot (e.g. {"color": "k"})
    kwargs          go to Axes.pcolormesh (vmin, vmax, norm, ...)
    """
    import matplotlib.pyplot as plt

    x, y, values, attrs = _field(fields, variable)
    if ax is None:
        _, ax = plt.subplots(constrained_layout=True)
    mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(values), cmap=cmap, shading="nearest", **kwargs)
    if colorbar:
        ax.figure.colorbar(mesh, ax=ax, label=_label(attrs, variable))
    for barrier in barriers:
        barrier.plot(ax=ax, **(barrier_kwargs or {}))
    for candidate in candidates:
        candidate.plot(ax=ax, **{"color": "0.6", "linestyle": "--", "linewidth": 0.8, **(barrier_kwargs or {})})
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_aspect(aspect)
    return ax
