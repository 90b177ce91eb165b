// The program under mpirun (loopback, this machine only): ranks share the flow map's tiles and rank 0 writes the
// outputs, which must be the single process's bit for bit; a sweep's members are shared by the ranks. Built only
// with MPI (GEOBARRIER_MPI and MPI found).
#include <doctest/doctest.h>
#include <netcdf.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using nlohmann::json;
extern char **environ;

namespace {

// Runs a command (argv[0] a path); returns its exit code, with its output in `log`.
int run(const std::vector<std::string> &command, const fs::path &log) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::vector<std::string> args = command;
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    REQUIRE(posix_spawn(&pid, args[0].c_str(), &actions, nullptr, argv.data(), environ) == 0);
    posix_spawn_file_actions_destroy(&actions);
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// mpirun for this machine only: we may run as root (containers), more ranks than cores, and no single-copy
// mechanism between ranks (containers often forbid the ptrace it needs).
std::vector<std::string> mpirun(int ranks) {
    return {GEOBARRIER_MPIEXEC,
            "--allow-run-as-root",
            "--oversubscribe",
            "--mca",
            "btl_vader_single_copy_mechanism",
            "none",
            "-np",
            std::to_string(ranks)};
}

struct Variable {
    std::string name;
    nc_type type;
    std::vector<unsigned char> bytes;
};

// Every variable of a NetCDF file, as raw bytes.
std::vector<Variable> variables(const fs::path &file) {
    int ncid = -1, count = 0;
    REQUIRE(nc_open(file.c_str(), NC_NOWRITE, &ncid) == NC_NOERR);
    REQUIRE(nc_inq_nvars(ncid, &count) == NC_NOERR);
    std::vector<Variable> out;
    for (int id = 0; id < count; ++id) {
        char name[NC_MAX_NAME + 1];
        nc_type type;
        int ndims = 0, dims[NC_MAX_VAR_DIMS];
        REQUIRE(nc_inq_var(ncid, id, name, &type, &ndims, dims, nullptr) == NC_NOERR);
        std::size_t n = 1, size = 0;
        for (int d = 0; d < ndims; ++d) {
            std::size_t len = 0;
            nc_inq_dimlen(ncid, dims[d], &len);
            n *= len;
        }
        REQUIRE(nc_inq_type(ncid, type, nullptr, &size) == NC_NOERR);
        Variable v{name, type, std::vector<unsigned char>(n * size)};
        REQUIRE(nc_get_var(ncid, id, v.bytes.data()) == NC_NOERR);
        out.push_back(std::move(v));
    }
    nc_close(ncid);
    return out;
}

json stats_without_time(const fs::path &manifest) {
    json stats = json::parse(geobarrier::test::read_text(manifest))["integrator_stats"];
    stats.erase("wall_seconds");
    return stats;
}

} // namespace

TEST_CASE("mpirun -np 2 and -np 3 (oversubscribed): the fields of the single process, bit for bit") {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-mpi-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    // Points leaving the box stop there (their exit times must travel too); the last tile has fewer rows than the
    // others.
    std::ofstream(dir / "exp.json") << R"({
        "system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine", "params": {"amplitude": 0.1}},
        "grid": {"x": [-1.6, 1.6], "y": [-1.1, 1.1], "n": [64, 45]}, "time": {"t0": 0, "t1": 12},
        "bounds": {"x": [-1.7, 1.7], "y": [-1.5, 1.5]},
        "products": ["ftle", "eigenvalues", "eigenvectors", "flow_map"], "output": {"plots": false}})";
    const std::string program = geobarrier::test::geobarrier_program().string(), exp = (dir / "exp.json").string();
    REQUIRE(run({program, "run", exp, "--out", (dir / "single").string(), "--threads", "2", "--quiet"},
                dir / "single.log") == 0);
    const auto reference = variables(dir / "single" / "fields.nc");
    REQUIRE(reference.size() >= 10); // x, y, 7 fields and flow_x, flow_y, exit_time, mask
    const json reference_stats = stats_without_time(dir / "single" / "manifest.json");
    CHECK(reference_stats["exited"].get<int>() > 0);

    for (const int ranks : {2, 3}) {
        CAPTURE(ranks);
        const fs::path out = dir / ("np" + std::to_string(ranks));
        auto command = mpirun(ranks);
        for (const std::string &a : {program, std::string("run"), exp, std::string("--out"), out.string(),
                                     std::string("--threads"), std::string("1"), std::string("--quiet")})
            command.push_back(a);
        const int code = run(command, dir / "mpi.log");
        CAPTURE(geobarrier::test::read_text(dir / "mpi.log"));
        REQUIRE(code == 0);
        const auto fields = variables(out / "fields.nc");
        REQUIRE(fields.size() == reference.size());
        for (std::size_t k = 0; k < fields.size(); ++k) {
            CAPTURE(fields[k].name);
            CHECK(fields[k].name == reference[k].name);
            CHECK(fields[k].bytes == reference[k].bytes);
        }
        // Every batch integrated exactly once: the step counts add up to the single process's.
        CHECK(stats_without_time(out / "manifest.json") == reference_stats);
        const json manifest = json::parse(geobarrier::test::read_text(out / "manifest.json"));
        CHECK(manifest["mpi_ranks"] == ranks);
        CHECK(manifest["tiles"]["count"].get<int>() >= 2 * ranks); // several tiles per rank, for the queue to balance
        // Only rank 0 wrote: one staging folder, published; nothing else in the folder.
        std::size_t entries = 0;
        for ([[maybe_unused]] const auto &e : fs::directory_iterator(out)) ++entries;
        CHECK(entries == 2); // fields.nc, manifest.json
    }
    fs::remove_all(dir);
}

TEST_CASE("mpirun -np 2 geobarrier sweep: the ranks share the members, rank 0 writes one summary") {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-mpi-sweep-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const json sweep = json::parse(R"({"base": {"system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-1, 1], "y": [-1, 1], "n": [21, 21]}, "time": {"t0": 0, "t1": 6},
        "products": ["ftle"], "output": {"plots": false}},
        "parameters": [{"path": "/forcing/params/amplitude", "values": [0, 0.05, 0.1, 0.15, 0.2]}],
        "figures": ["ftle_max"], "plot": false})");
    std::ofstream(dir / "sweep.json") << sweep.dump();
    auto command = mpirun(2);
    for (const std::string &a :
         {geobarrier::test::geobarrier_program().string(), std::string("sweep"), (dir / "sweep.json").string(),
          std::string("--out"), (dir / "out").string(), std::string("--threads"), std::string("1")})
        command.push_back(a);
    const int code = run(command, dir / "mpi.log");
    const std::string log = geobarrier::test::read_text(dir / "mpi.log");
    CAPTURE(log);
    REQUIRE(code == 0);
    std::size_t rows = 0;
    std::ifstream csv(dir / "out" / "summary.csv");
    for (std::string line; std::getline(csv, line);) {
        if (rows++ == 0) continue;
        CHECK(line.find(",done,") != std::string::npos);
    }
    CHECK(rows == 6);
    for (int k = 0; k < 5; ++k) CHECK(fs::exists(dir / "out" / ("member-00" + std::to_string(k)) / "manifest.json"));
    // One report, from rank 0.
    std::size_t reports = 0;
    for (std::size_t at = log.find("swept 5 members"); at != std::string::npos;
         at = log.find("swept 5 members", at + 1))
        ++reports;
    CHECK(reports == 1);
    fs::remove_all(dir);
}

TEST_CASE("mpirun -np 2 geobarrier run into a folder another writer holds: refused by rank 0, every rank ends") {
    // The other writer is this test, holding the folder's lock as a run would (docs/robustness.md).
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-mpi-busy-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir / "out");
    std::ofstream(dir / "exp.json") << R"({
        "system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-1.6, 1.6], "y": [-1.1, 1.1], "n": [16, 12]}, "time": {"t0": 0, "t1": 2},
        "products": ["ftle"]})";
    const int fd = ::open((dir / "out" / ".geobarrier-lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    REQUIRE(fd >= 0);
    REQUIRE(::flock(fd, LOCK_EX | LOCK_NB) == 0);
    const std::string holder = "geobarrier run (pid " + std::to_string(::getpid()) + ")\n";
    REQUIRE(::write(fd, holder.data(), holder.size()) == static_cast<ssize_t>(holder.size()));
    std::vector<std::string> command = mpirun(2);
    for (const std::string &a : {geobarrier::test::geobarrier_program().string(), std::string("run"),
                                 (dir / "exp.json").string(), std::string("--out"), (dir / "out").string()})
        command.push_back(a);
    const int code = run(command, dir / "busy.log"); // MPI_Abort(2) on rank 0 ends rank 1, which waits for tiles
    CHECK(code != 0);
    std::ifstream in(dir / "busy.log");
    std::stringstream log;
    log << in.rdbuf();
    CHECK(log.str().find("geobarrier: error: " + (dir / "out").string() + ": another geobarrier run (pid " +
                         std::to_string(::getpid()) + ") is writing into this output folder") != std::string::npos);
    ::close(fd);
    std::vector<std::string> left;
    for (const auto &e : fs::directory_iterator(dir / "out")) left.push_back(e.path().filename().string());
    CHECK(left == std::vector<std::string>{".geobarrier-lock"}); // ours; nothing of the refused run
    fs::remove_all(dir);
}
