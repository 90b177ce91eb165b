// fields.nc: the fields on the grid G0 as a CF-1.8 NetCDF-4 file (coordinates x, y with the system's state units;
// one (y, x) variable per field with _FillValue where masked; a `mask` flag variable saying why; UDUNITS-2 unit
// strings), written atomically.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <netcdf.h>

#include <array>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <vector>

#include <cmath>
#include <fcntl.h>
#include <set>
#include <string>
#include <unistd.h>

namespace geobarrier {

namespace {

// Turns every netCDF status into an IoError naming the target file (not the temporary one) and the step.
class NcChecker {
  public:
    explicit NcChecker(const std::filesystem::path &target) : m_target(target) {}
    void operator()(int status, const std::string &what) const {
        if (status != NC_NOERR) throw IoError("'" + m_target.string() + "': " + what + ": " + nc_strerror(status));
    }

  private:
    const std::filesystem::path &m_target;
};

// Why a file cannot be created at `path`, found by creating it and writing HDF5's first few KiB (superblock and
// root group) ourselves: "No space left on device (the file system is full)", or "" when that works. NetCDF answers
// every failure of HDF5's file creation with EACCES, so a full disk read "Permission denied".
std::string creation_failure(const std::filesystem::path &path) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    int err = fd < 0 ? errno : 0;
    if (fd >= 0) {
        const std::vector<char> zeros(8192, 0);
        if (::write(fd, zeros.data(), zeros.size()) != static_cast<ssize_t>(zeros.size()) || ::fsync(fd) != 0)
            err = errno != 0 ? errno : ENOSPC; // a short write: the space ran out
        ::close(fd);
        ::unlink(path.c_str());
    }
    if (err == 0 || err == EINVAL) return ""; // EINVAL: a file system that cannot fsync, not the cause
    std::string text = std::strerror(err);
    if (err == ENOSPC) text += " (the file system is full)";
    if (err == EDQUOT) text += " (the disk quota is used up)";
    if (err == EFBIG) text += " (a file-size limit, ulimit -f)";
    return text;
}

// Closes the dataset if a step throws, so the temporary file can be removed (its handle would otherwise leak).
class NcFile {
  public:
    NcFile(const std::filesystem::path &path, const std::filesystem::path &target, const NcChecker &check) {
        const int status = nc_create(path.c_str(), NC_NETCDF4 | NC_CLOBBER, &m_id);
        if (status != NC_NOERR) {
            const std::string cause = creation_failure(path);
            if (!cause.empty()) throw IoError("'" + target.string() + "': cannot create the NetCDF-4 file: " + cause);
            check(status, "cannot create the NetCDF-4 file");
        }
        m_open = true;
    }
    ~NcFile() {
        if (m_open) nc_close(m_id);
    }
    NcFile(const NcFile &) = delete;
    NcFile &operator=(const NcFile &) = delete;

    int id() const { return m_id; }
    void close(const NcChecker &check) {
        m_open = false;
        check(nc_close(m_id), "cannot finish writing");
    }

  private:
    int m_id = -1;
    bool m_open = false;
};

void put_text(int ncid, int varid, const char *name, const std::string &value, const NcChecker &check) {
    check(nc_put_att_text(ncid, varid, name, value.size(), value.c_str()),
          std::string("cannot write the attribute '") + name + "'");
}

void put_global_attributes(int ncid, const nlohmann::json &attributes, const NcChecker &check) {
    if (!attributes.is_null() && !attributes.is_object())
        throw Error("write_fields_netcdf: global attributes must be a JSON object, got " + attributes.dump());
    const nlohmann::json empty = nlohmann::json::object();
    for (const auto &item : (attributes.is_null() ? empty : attributes).items()) {
        const std::string &name = item.key();
        const nlohmann::json &value = item.value();
        const std::string what = "cannot write the global attribute '" + name + "'";
        if (value.is_string()) {
            put_text(ncid, NC_GLOBAL, name.c_str(), value.get<std::string>(), check);
        } else if (value.is_boolean()) {
            const int flag = value.get<bool>() ? 1 : 0;
            check(nc_put_att_int(ncid, NC_GLOBAL, name.c_str(), NC_INT, 1, &flag), what);
        } else if (value.is_number()) {
            const double number = value.get<double>();
            check(nc_put_att_double(ncid, NC_GLOBAL, name.c_str(), NC_DOUBLE, 1, &number), what);
        } else {
            // Nested objects, arrays and null have no netCDF attribute type; keep them readable as JSON text.
            put_text(ncid, NC_GLOBAL, name.c_str(), value.dump(), check);
        }
    }
    if (attributes.is_null() || !attributes.contains("Conventions"))
        put_text(ncid, NC_GLOBAL, "Conventions", "CF-1.8", check);
}

// The long name with what a nondimensional unit stands for, e.g. "FTLE [1/time in the model's units]".
std::string documented_long_name(const std::string &long_name, const CfUnits &units) {
    return units.meaning.empty() ? long_name : long_name + " [" + units.meaning + "]";
}

// A coordinate variable (x or y) of the initial conditions, with the system's name and unit for that component.
void put_coordinate(int ncid, int varid, std::size_t component, const StateAxes &axes, const NcChecker &check) {
    const char *const axis_letters[] = {"X", "Y"};
    const NetcdfAttributes attributes = coordinate_attributes(component, axes);
    put_text(ncid, varid, "long_name", attributes.long_name, check);
    put_text(ncid, varid, "units", attributes.units, check);
    put_text(ncid, varid, "axis", axis_letters[component], check);
}

void check_arguments(const Grid &grid, const std::vector<FieldVariable> &variables,
                     const std::vector<std::uint8_t> &mask) {
    const std::string where = "write_fields_netcdf: ";
    if (grid.nx < 2 || grid.ny < 2)
        throw Error(where + "the grid needs at least 2 x 2 points, got " + std::to_string(grid.nx) + " x " +
                    std::to_string(grid.ny));
    if (mask.size() != grid.size())
        throw Error(where + "the mask has " + std::to_string(mask.size()) + " entries, the grid " +
                    std::to_string(grid.size()) + " points");
    std::set<std::string> names{"x", "y", "mask"};
    for (const FieldVariable &variable : variables) {
        if (variable.values == nullptr) throw Error(where + "variable '" + variable.name + "' has no values");
        if (variable.values->size() != grid.size())
            throw Error(where + "variable '" + variable.name + "' has " + std::to_string(variable.values->size()) +
                        " values, the grid " + std::to_string(grid.size()) + " points");
        if (!names.insert(variable.name).second)
            throw Error(where + "the variable name '" + variable.name + "' is used twice (x, y, mask are taken)");
    }
}

} // namespace

// UDUNITS-2 (the unit library CF names) knows SI units and their products and powers ("rad", "m s-1", "1/s"). The
// plugins' units may also name the model's own scales: "time" and "length" of a nondimensional model, "state" for a
// state component. No unit system defines those, so CF's answer applies: dimensionless "1", and the meaning in words.
CfUnits cf_units(const std::string &unit) {
    if (unit.empty() || unit == "1" || unit == "-" || unit == "–") return {"1", ""};
    static const std::set<std::string> model_scales{"time", "length", "state", "model"};
    std::string word;
    for (std::size_t i = 0; i <= unit.size(); ++i) {
        const char c = i < unit.size() ? unit[i] : ' ';
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
            word += c;
            continue;
        }
        if (model_scales.count(word)) return {"1", unit + " in the model's own units"};
        word.clear();
    }
    return {unit, ""};
}

MaskAttributes mask_attributes() {
    // CF flag convention: a point's value is the OR of the bits that apply (grid.hpp MaskBits).
    return {{mask_left_bounds, mask_non_finite, mask_step_limit, mask_invalid_state, mask_degenerate, mask_unstable},
            "left_bounds non_finite step_limit invalid_state degenerate_eigenvectors unstable_step",
            "why the values at a grid point are not usable (0 = valid)"};
}

NetcdfAttributes variable_attributes(const FieldVariable &variable) {
    const CfUnits units = cf_units(variable.units);
    return {documented_long_name(variable.long_name.empty() ? variable.name : variable.long_name, units), units.units};
}

NetcdfAttributes coordinate_attributes(std::size_t component, const StateAxes &axes) {
    const char *const axis_names[] = {"x", "y"};
    const std::string state_name =
        component < axes.names.size() && !axes.names[component].empty() ? axes.names[component] : axis_names[component];
    const CfUnits units = cf_units(component < axes.units.size() ? axes.units[component] : "");
    return {documented_long_name(state_name + " of the initial condition", units), units.units};
}

void write_fields_netcdf(const std::filesystem::path &file, const Grid &grid,
                         const std::vector<FieldVariable> &variables, const std::vector<std::uint8_t> &mask,
                         const nlohmann::json &global_attributes, const StateAxes &axes) {
    check_arguments(grid, variables, mask);
    const NcChecker check(file);
    // One file at a time: NetCDF-C and the HDF5 under it (Debian's build) are not thread-safe, and a frames run
    // writes two frames' fields.nc from two threads (frames.cpp).
    static std::mutex netcdf_mutex;
    const std::lock_guard<std::mutex> lock(netcdf_mutex);
    write_file_atomically(file, [&](const std::filesystem::path &temp) {
        NcFile nc(temp, file, check);
        const int ncid = nc.id();

        // Row index = y (grid.hpp), so the C-order shape is (y, x), as CF readers expect.
        int dim_y = -1, dim_x = -1;
        check(nc_def_dim(ncid, "y", grid.ny, &dim_y), "cannot define the dimension y");
        check(nc_def_dim(ncid, "x", grid.nx, &dim_x), "cannot define the dimension x");
        const std::array<int, 2> dims_yx{dim_y, dim_x};

        int var_x = -1, var_y = -1;
        check(nc_def_var(ncid, "x", NC_DOUBLE, 1, &dim_x, &var_x), "cannot define the variable x");
        check(nc_def_var(ncid, "y", NC_DOUBLE, 1, &dim_y, &var_y), "cannot define the variable y");
        put_coordinate(ncid, var_x, 0, axes, check);
        put_coordinate(ncid, var_y, 1, axes, check);

        const double fill = NC_FILL_DOUBLE;
        std::vector<int> var_ids;
        for (const FieldVariable &variable : variables) {
            const std::string what = "cannot define the variable '" + variable.name + "'";
            int id = -1;
            check(nc_def_var(ncid, variable.name.c_str(), NC_DOUBLE, 2, dims_yx.data(), &id), what);
            // Not compressed: the low bits of a computed double field are noise that deflate cannot squeeze (level 1
            // with shuffle saved 20% of the size of W's FTLE at N = 1000 and took 0.12 s, 17% of the whole run).
            check(nc_def_var_fill(ncid, id, 0, &fill), what);
            const NetcdfAttributes attributes = variable_attributes(variable);
            put_text(ncid, id, "long_name", attributes.long_name, check);
            put_text(ncid, id, "units", attributes.units, check);
            var_ids.push_back(id);
        }

        int var_mask = -1;
        check(nc_def_var(ncid, "mask", NC_UBYTE, 2, dims_yx.data(), &var_mask), "cannot define the variable mask");
        check(nc_def_var_deflate(ncid, var_mask, 1, 1, 1), "cannot define the variable mask");
        const MaskAttributes mask_attrs = mask_attributes();
        check(nc_put_att_uchar(ncid, var_mask, "flag_masks", NC_UBYTE, mask_attrs.flag_masks.size(),
                               mask_attrs.flag_masks.data()),
              "cannot write the attribute 'flag_masks'");
        put_text(ncid, var_mask, "flag_meanings", mask_attrs.flag_meanings, check);
        put_text(ncid, var_mask, "long_name", mask_attrs.long_name, check);

        put_global_attributes(ncid, global_attributes, check);
        check(nc_enddef(ncid), "cannot leave define mode");

        std::vector<double> coordinate(grid.nx);
        for (std::size_t j = 0; j < grid.nx; ++j) coordinate[j] = grid.x(j);
        check(nc_put_var_double(ncid, var_x, coordinate.data()), "cannot write the variable x");
        coordinate.resize(grid.ny);
        for (std::size_t i = 0; i < grid.ny; ++i) coordinate[i] = grid.y(i);
        check(nc_put_var_double(ncid, var_y, coordinate.data()), "cannot write the variable y");

        std::vector<double> data(grid.size());
        for (std::size_t v = 0; v < variables.size(); ++v) {
            const FieldVariable &variable = variables[v];
            const std::vector<double> &values = *variable.values;
            for (std::size_t k = 0; k < data.size(); ++k) {
                const bool masked = (mask[k] & variable.masked_by) != 0 || !std::isfinite(values[k]);
                data[k] = masked ? fill : values[k];
            }
            check(nc_put_var_double(ncid, var_ids[v], data.data()),
                  "cannot write the variable '" + variable.name + "'");
        }
        check(nc_put_var_uchar(ncid, var_mask, mask.data()), "cannot write the variable mask");
        nc.close(check);
    });
}

} // namespace geobarrier
