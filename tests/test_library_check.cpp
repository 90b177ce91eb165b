// The check of a library before it is mapped (core/src/plugins/library_check.hpp): copies of a real built plugin cut
// at many offsets (in the ELF header, in the program headers, in a loadable segment, in the section headers), patched
// to another machine or class, and files that are not libraries. Each is refused with a reason, never handed to
// dlopen (which would map a cut-off segment and die of SIGBUS on its first touch); the loader and a plugin folder
// scan refuse a damaged library with a LibraryFileError naming it.
#include "plugins/library_check.hpp"

#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <elf.h>
#include <link.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <vector>

namespace fs = std::filesystem;
using namespace geobarrier;

namespace {

const fs::path real_plugin = test::test_plugin_dir() / "geobarrier-rigid-rotation.so";

// One folder for the program's files, removed when it ends.
struct Scratch {
    fs::path dir = fs::temp_directory_path() / ("geobarrier-library-check-" + std::to_string(::getpid()));
    Scratch() {
        fs::remove_all(dir);
        fs::create_directories(dir);
    }
    ~Scratch() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

fs::path scratch() {
    static const Scratch s;
    return s.dir;
}

std::vector<char> bytes_of(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path write_bytes(const std::string &name, const std::vector<char> &bytes) {
    const fs::path file = scratch() / name;
    std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return file;
}

// The first `size` bytes of `bytes`, as a file named after the cut.
fs::path cut(const std::vector<char> &bytes, std::size_t size, const std::string &name = "cut") {
    return write_bytes(name + "-" + std::to_string(size) + ".so",
                       std::vector<char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size)));
}

ElfW(Ehdr) header_of(const std::vector<char> &bytes) {
    ElfW(Ehdr) h{};
    std::memcpy(&h, bytes.data(), sizeof h);
    return h;
}

std::vector<ElfW(Phdr)> program_headers_of(const std::vector<char> &bytes) {
    const ElfW(Ehdr) h = header_of(bytes);
    std::vector<ElfW(Phdr)> out(h.e_phnum);
    std::memcpy(out.data(), bytes.data() + h.e_phoff, out.size() * sizeof(ElfW(Phdr)));
    return out;
}

// The loadable segment that ends last in the file.
ElfW(Phdr) last_load_segment(const std::vector<char> &bytes) {
    ElfW(Phdr) last{};
    for (const ElfW(Phdr) & p : program_headers_of(bytes))
        if (p.p_type == PT_LOAD && p.p_offset + p.p_filesz >= last.p_offset + last.p_filesz) last = p;
    return last;
}

bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

} // namespace

TEST_CASE("a whole built plugin passes the check") {
    const LibraryFileCheck c = check_library_file(real_plugin);
    CHECK(c.problem == LibraryFileProblem::none);
    CHECK(c.reason.empty());
    CHECK(check_library_file(test::plugin_dir() / "geobarrier-duffing.so").problem == LibraryFileProblem::none);
}

TEST_CASE("a plugin cut short is refused at every offset: header, program headers, segments, section headers") {
    const std::vector<char> bytes = bytes_of(real_plugin);
    REQUIRE(bytes.size() > 4096);
    const ElfW(Ehdr) h = header_of(bytes);
    const ElfW(Phdr) load = last_load_segment(bytes);
    REQUIRE(load.p_filesz > 16);
    struct Cut {
        std::size_t size;
        const char *expected; // in the reason
    };
    const std::vector<Cut> cuts = {
        {40, "shorter than an ELF header"},
        {sizeof(ElfW(Ehdr)), "program header table"},
        {static_cast<std::size_t>(h.e_phoff) + sizeof(ElfW(Phdr)) + 10, "program header table"},
        {static_cast<std::size_t>(load.p_offset + load.p_filesz / 2), "loadable segment"},
        {static_cast<std::size_t>(h.e_shoff) + 3, "section header table"},
        {bytes.size() - 1, "section header table"},
    };
    for (const Cut &c : cuts) {
        CAPTURE(c.size);
        const LibraryFileCheck checked = check_library_file(cut(bytes, c.size));
        CHECK(checked.problem == LibraryFileProblem::damaged);
        CHECK(contains(checked.reason, "truncated"));
        CHECK_MESSAGE(contains(checked.reason, c.expected), checked.reason);
        CHECK(checked.reason.find('\n') == std::string::npos);
    }
    // Every cut from the ELF header's end on (1/97 of the file apart) is damaged; none passes.
    for (std::size_t size = sizeof(ElfW(Ehdr)); size < bytes.size(); size += bytes.size() / 97 + 1) {
        CAPTURE(size);
        CHECK(check_library_file(cut(bytes, size, "sweep")).problem == LibraryFileProblem::damaged);
    }
    // Shorter than the magic number, or empty: not an ELF file at all.
    CHECK(check_library_file(cut(bytes, 0)).problem == LibraryFileProblem::not_elf);
    CHECK(check_library_file(cut(bytes, 3)).problem == LibraryFileProblem::not_elf);
}

TEST_CASE("a library whose headers are whole but whose segment is cut off is refused") {
    // Without its section headers (the loader needs none), the file can end inside a loadable segment with every
    // header intact: only the segments' own file ranges show the cut.
    std::vector<char> bytes = bytes_of(real_plugin);
    ElfW(Ehdr) h = header_of(bytes);
    h.e_shoff = 0;
    h.e_shnum = 0;
    h.e_shstrndx = SHN_UNDEF;
    std::memcpy(bytes.data(), &h, sizeof h);
    const ElfW(Phdr) load = last_load_segment(bytes);
    bytes.resize(static_cast<std::size_t>(load.p_offset + load.p_filesz));
    const fs::path whole = write_bytes("no-sections.so", bytes);
    CHECK(check_library_file(whole).problem == LibraryFileProblem::none);

    for (const std::size_t size :
         {static_cast<std::size_t>(load.p_offset + load.p_filesz - 1), static_cast<std::size_t>(load.p_offset + 1)}) {
        CAPTURE(size);
        const LibraryFileCheck c = check_library_file(cut(bytes, size, "no-sections"));
        CHECK(c.problem == LibraryFileProblem::damaged);
        CHECK_MESSAGE(contains(c.reason, "loadable segment"), c.reason);
    }
    const std::size_t in_headers = static_cast<std::size_t>(h.e_phoff) + 2 * sizeof(ElfW(Phdr)) + 7;
    const LibraryFileCheck c = check_library_file(cut(bytes, in_headers, "no-sections"));
    CHECK(c.problem == LibraryFileProblem::damaged);
    CHECK_MESSAGE(contains(c.reason, "program header table"), c.reason);
}

TEST_CASE("another machine's, another class's, or a non-shared ELF file is refused") {
    const std::vector<char> bytes = bytes_of(real_plugin);
    const auto patched = [&](const std::string &name, auto change) {
        std::vector<char> copy = bytes;
        ElfW(Ehdr) h = header_of(copy);
        change(h);
        std::memcpy(copy.data(), &h, sizeof h);
        return check_library_file(write_bytes(name, copy));
    };
    const LibraryFileCheck machine =
        patched("machine.so", [](ElfW(Ehdr) & h) { h.e_machine = h.e_machine == EM_AARCH64 ? EM_X86_64 : EM_AARCH64; });
    CHECK(machine.problem == LibraryFileProblem::damaged);
    CHECK(contains(machine.reason, "this program runs on"));
    const LibraryFileCheck klass = patched("class.so", [](ElfW(Ehdr) & h) {
        h.e_ident[EI_CLASS] = h.e_ident[EI_CLASS] == ELFCLASS64 ? ELFCLASS32 : ELFCLASS64;
    });
    CHECK(klass.problem == LibraryFileProblem::damaged);
    CHECK(contains(klass.reason, "class"));
    const LibraryFileCheck type = patched("exec.so", [](ElfW(Ehdr) & h) { h.e_type = ET_EXEC; });
    CHECK(type.problem == LibraryFileProblem::damaged);
    CHECK(contains(type.reason, "not a shared object"));
    const LibraryFileCheck far = patched("far.so", [](ElfW(Ehdr) & h) { h.e_phoff = UINT64_MAX - 8; });
    CHECK(far.problem == LibraryFileProblem::damaged);
    CHECK(contains(far.reason, "beyond 2^64"));
}

TEST_CASE("a file that is not ELF, a folder and an unreadable file") {
    const fs::path text = write_bytes("text.so", {'h', 'e', 'l', 'l', 'o', '\n'});
    const LibraryFileCheck t = check_library_file(text);
    CHECK(t.problem == LibraryFileProblem::not_elf);
    CHECK(contains(t.reason, "not an ELF file"));
    CHECK(check_library_file(test::test_plugin_dir() / "not-a-plugin.so").problem == LibraryFileProblem::not_elf);

    const fs::path folder = scratch() / "folder.so";
    fs::create_directories(folder);
    const LibraryFileCheck f = check_library_file(folder);
    CHECK(f.problem == LibraryFileProblem::damaged);
    CHECK(contains(f.reason, "not a regular file"));
    const LibraryFileCheck missing = check_library_file(scratch() / "missing.so");
    CHECK(missing.problem == LibraryFileProblem::damaged);
    CHECK(contains(missing.reason, "cannot be opened"));

    if (::geteuid() != 0) { // root reads any file
        const fs::path locked = write_bytes("locked.so", bytes_of(real_plugin));
        fs::permissions(locked, fs::perms::none);
        const LibraryFileCheck l = check_library_file(locked);
        CHECK(l.problem == LibraryFileProblem::damaged);
        CHECK(contains(l.reason, "Permission denied"));
    }
}

TEST_CASE("the loader and a plugin folder refuse a damaged library, naming it; a non-library is only skipped") {
    const std::vector<char> bytes = bytes_of(real_plugin);
    const fs::path folder = scratch() / "folder-with-a-cut-library";
    fs::create_directories(folder);
    const fs::path damaged = folder / "geobarrier-rigid-rotation.so";
    std::ofstream(damaged, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));

    std::string message;
    try {
        load_plugin_library(damaged);
    } catch (const LibraryFileError &e) {
        message = e.what();
    }
    CHECK(contains(message, damaged.string() + ": not a loadable shared library (truncated"));
    message.clear();
    try {
        const PluginRegistry registry({folder, test::plugin_dir()});
    } catch (const LibraryFileError &e) {
        message = e.what();
    }
    CHECK(contains(message, damaged.string()));
    // Named by path in an experiment: a ConfigError at the JSON path (exit 2 as well).
    const PluginRegistry builtin({test::plugin_dir()});
    CHECK_THROWS_AS(builtin.find(PluginKind::system, damaged.string(), "/system/plugin"), ConfigError);

    // A file that is not ELF at all stays what it was: skipped with a warning.
    fs::remove(damaged);
    std::ofstream(folder / "notes.so") << "not a library\n";
    const PluginRegistry registry({folder, test::plugin_dir()});
    REQUIRE(registry.warnings().size() == 1);
    CHECK(contains(registry.warnings()[0], "notes.so: not a loadable shared library (not an ELF file"));
}
