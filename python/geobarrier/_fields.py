"""A run's fields as fields.nc holds them: an xarray.Dataset when xarray is installed, else a Fields object of NumPy
arrays with the same names, coordinates and attributes."""

import numpy as np

try:
    import xarray
except ImportError:  # results fall back to NumPy arrays
    xarray = None

from . import _geobarrier

# fields.nc's mask variable, from the core's one definition (geobarrier::mask_attributes, used by its NetCDF writer).
MASK_ATTRIBUTES = _geobarrier.mask_attributes()
MASK_ATTRIBUTES["flag_masks"] = np.array(MASK_ATTRIBUTES["flag_masks"], dtype=np.uint8)


class Fields:
    """The fields without xarray: ``fields.ftle`` or ``fields["ftle"]`` is an (ny, nx) array (row index = y, NaN
    where fields.nc has its fill value), ``fields.x``, ``fields.y`` the coordinates, ``fields.mask`` the mask,
    ``fields.attrs`` the global attributes, ``fields.variable_attrs[name]`` each variable's and
    ``fields.coordinate_attrs["x"]`` the coordinates'."""

    def __init__(self, x, y, variables, variable_attrs, attrs):
        self.x, self.y = x, y
        self._variables = variables
        self.variable_attrs = variable_attrs
        self.attrs = attrs

    def __getattr__(self, name):
        variables = self.__dict__.get("_variables", {})
        if name in variables:
            return variables[name]
        raise AttributeError(f"no field named {name!r} (fields: {', '.join(variables)})")

    def __getitem__(self, name):
        if name not in self._variables:
            raise KeyError(f"no field named {name!r} (fields: {', '.join(self._variables)})")
        return self._variables[name]

    def __contains__(self, name):
        return name in self._variables

    def __iter__(self):
        return iter(self._variables)

    def keys(self):
        return self._variables.keys()

    def __repr__(self):
        shape = next(iter(self._variables.values())).shape if self._variables else (len(self.y), len(self.x))
        return f"<geobarrier.Fields {shape[0]} x {shape[1]}: {', '.join(self._variables)}>"


def _global_attributes(attributes):
    # As netCDF stores them: booleans become integers; CF's Conventions is added when absent.
    out = {name: int(value) if isinstance(value, bool) else value for name, value in attributes.items()}
    out.setdefault("Conventions", "CF-1.8")
    return out


def build(native, use_xarray=True):
    """The fields of a native result (geobarrier._geobarrier.run): the values of fields.nc, NaN where it holds the
    fill value (the mask hits the variable's bits, or the value is not finite)."""
    import json

    mask = native["mask"]
    variables, variable_attrs = {}, {}
    for name, long_name, units, masked_by, values in native["fields"]:
        if mask is not None:
            values[(mask & masked_by) != 0] = np.nan
        values[~np.isfinite(values)] = np.nan
        variables[name] = values
        variable_attrs[name] = {"long_name": long_name or name, "units": units or "1"}
    if mask is not None:
        variables["mask"] = mask
        variable_attrs["mask"] = dict(MASK_ATTRIBUTES)
    attrs = _global_attributes(json.loads(native["attributes"]) or {})
    coordinates = {name: (values, {"long_name": long_name, "units": units, "axis": name.upper()})
                   for name, long_name, units, values in native["coordinates"]}
    if xarray is None or not use_xarray:
        fields = Fields(coordinates["x"][0], coordinates["y"][0], variables, variable_attrs, attrs)
        fields.coordinate_attrs = {name: a for name, (_, a) in coordinates.items()}
        return fields
    return xarray.Dataset(
        {name: (("y", "x"), values, variable_attrs[name]) for name, values in variables.items()},
        coords={name: (name, values, a) for name, (values, a) in coordinates.items()},
        attrs=attrs,
    )
