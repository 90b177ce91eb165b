// The check of a shared library before it is mapped (library_check.hpp): plain reads of the ELF header and of the
// program and section header tables, compared with the file's size.
#include "plugins/library_check.hpp"

#include <elf.h>
#include <fcntl.h>
#include <link.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <vector>

namespace geobarrier {

namespace {

// This process's ELF class, byte order and machine: a library must match them to be mapped here.
constexpr unsigned char native_class = sizeof(void *) == 8 ? ELFCLASS64 : ELFCLASS32;
constexpr unsigned char native_data = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? ELFDATA2LSB : ELFDATA2MSB;
#if defined(__x86_64__)
constexpr int native_machine = EM_X86_64;
#elif defined(__aarch64__)
constexpr int native_machine = EM_AARCH64;
#elif defined(__i386__)
constexpr int native_machine = EM_386;
#elif defined(__arm__)
constexpr int native_machine = EM_ARM;
#elif defined(__powerpc64__)
constexpr int native_machine = EM_PPC64;
#elif defined(__riscv)
constexpr int native_machine = EM_RISCV;
#elif defined(__s390x__)
constexpr int native_machine = EM_S390;
#else
constexpr int native_machine = -1; // not checked
#endif

std::string machine_name(unsigned machine) {
    switch (machine) {
    case EM_X86_64:
        return "x86-64";
    case EM_AARCH64:
        return "AArch64";
    case EM_386:
        return "i386";
    case EM_ARM:
        return "ARM";
    case EM_PPC64:
        return "PowerPC 64";
    case EM_RISCV:
        return "RISC-V";
    case EM_S390:
        return "S/390";
    default:
        return "machine " + std::to_string(machine);
    }
}

// Closes the descriptor it holds.
struct FileDescriptor {
    int fd;
    ~FileDescriptor() {
        if (fd >= 0) ::close(fd);
    }
};

// Reads exactly `size` bytes at `offset`; false on a short read or an error (errno then tells which, 0 for short).
bool read_at(int fd, void *into, std::size_t size, std::uint64_t offset) {
    auto *bytes = static_cast<char *>(into);
    while (size > 0) {
        const ssize_t got = ::pread(fd, bytes, size, static_cast<off_t>(offset));
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) {
            if (got == 0) errno = 0;
            return false;
        }
        bytes += got;
        size -= static_cast<std::size_t>(got);
        offset += static_cast<std::uint64_t>(got);
    }
    return true;
}

// A failed read's reason: the error, or a file that shrank since its size was taken.
std::string read_error() {
    return std::string("cannot be read (") + (errno ? std::strerror(errno) : "it shrank") + ")";
}

LibraryFileCheck damaged(std::string reason) { return {LibraryFileProblem::damaged, std::move(reason)}; }

// "truncated: <what> ends at byte <end>, the file has <size> bytes" when `offset + length` passes the end of the
// file (or overflows); "" when it does not.
std::string past_the_end(const std::string &what, std::uint64_t offset, std::uint64_t length, std::uint64_t size) {
    const bool overflows = offset > UINT64_MAX - length;
    if (!overflows && offset + length <= size) return "";
    return "truncated: " + what + " ends at byte " +
           (overflows ? std::string("beyond 2^64") : std::to_string(offset + length)) + ", the file has " +
           std::to_string(size) + " bytes";
}

// The identification bytes and the header's fixed fields: this process's class, byte order, machine; a shared object.
std::string header_problem(const ElfW(Ehdr) & h) {
    if (h.e_ident[EI_CLASS] != native_class)
        return std::string("an ELF file of ") + (h.e_ident[EI_CLASS] == ELFCLASS32 ? "32-bit" : "another") +
               " class; this program is " + (native_class == ELFCLASS64 ? "64-bit" : "32-bit");
    if (h.e_ident[EI_DATA] != native_data) return "an ELF file of the other byte order than this machine's";
    if (h.e_ident[EI_VERSION] != EV_CURRENT || h.e_version != EV_CURRENT) return "an ELF file of an unknown version";
    if (native_machine >= 0 && h.e_machine != native_machine)
        return "an ELF file for " + machine_name(h.e_machine) + "; this program runs on " +
               machine_name(static_cast<unsigned>(native_machine));
    if (h.e_type != ET_DYN)
        return "an ELF file that is not a shared object (ELF type " + std::to_string(h.e_type) +
               (h.e_type == ET_EXEC  ? ", an executable"
                : h.e_type == ET_REL ? ", an object file"
                                     : "") +
               ")";
    if (h.e_phnum == 0) return "an ELF shared object without program headers";
    if (h.e_phentsize != sizeof(ElfW(Phdr)))
        return "damaged: program header entries of " + std::to_string(h.e_phentsize) + " bytes, not " +
               std::to_string(sizeof(ElfW(Phdr)));
    if ((h.e_shnum != 0 || h.e_shoff != 0) && h.e_shentsize != sizeof(ElfW(Shdr)))
        return "damaged: section header entries of " + std::to_string(h.e_shentsize) + " bytes, not " +
               std::to_string(sizeof(ElfW(Shdr)));
    return "";
}

// The program header table and every loadable (and the dynamic) segment's bytes in the file: the loader maps them.
std::string segments_problem(int fd, const ElfW(Ehdr) & h, std::uint64_t size) {
    const std::uint64_t table = std::uint64_t{h.e_phnum} * sizeof(ElfW(Phdr));
    std::string problem = past_the_end("its program header table", h.e_phoff, table, size);
    if (!problem.empty()) return problem;
    std::vector<ElfW(Phdr)> headers(h.e_phnum);
    if (!read_at(fd, headers.data(), table, h.e_phoff)) return read_error();
    for (std::size_t i = 0; i < headers.size(); ++i) {
        const ElfW(Phdr) &p = headers[i];
        if (p.p_type != PT_LOAD && p.p_type != PT_DYNAMIC) continue;
        const std::string what = std::string("its ") + (p.p_type == PT_LOAD ? "loadable" : "dynamic") + " segment " +
                                 std::to_string(i) + " (file bytes " + std::to_string(p.p_offset) + " + " +
                                 std::to_string(p.p_filesz) + ")";
        problem = past_the_end(what, p.p_offset, p.p_filesz, size);
        if (!problem.empty()) return problem;
    }
    return "";
}

// The section header table (the count in section 0 when it overflows the header's 16-bit field). The loader does not
// read it, but a file whose table is cut off was cut off, whatever else it still holds.
std::string sections_problem(int fd, const ElfW(Ehdr) & h, std::uint64_t size) {
    if (h.e_shoff == 0) return ""; // no section headers: allowed
    std::uint64_t sections = h.e_shnum;
    if (sections == 0) {
        std::string problem = past_the_end("its first section header", h.e_shoff, sizeof(ElfW(Shdr)), size);
        if (!problem.empty()) return problem;
        ElfW(Shdr) first{};
        if (!read_at(fd, &first, sizeof first, h.e_shoff)) return read_error();
        sections = first.sh_size;
    }
    if (sections > UINT64_MAX / sizeof(ElfW(Shdr))) return "damaged: " + std::to_string(sections) + " section headers";
    return past_the_end("its section header table", h.e_shoff, sections * sizeof(ElfW(Shdr)), size);
}

} // namespace

LibraryFileCheck check_library_file(const std::filesystem::path &file) {
    // O_NONBLOCK: a FIFO named like a library must not block the open; it is then refused as not a regular file.
    const FileDescriptor f{::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK)};
    if (f.fd < 0) return damaged("cannot be opened (" + std::string(std::strerror(errno)) + ")");
    struct stat st {};
    if (::fstat(f.fd, &st) != 0) return damaged("cannot be examined (" + std::string(std::strerror(errno)) + ")");
    if (!S_ISREG(st.st_mode)) return damaged("not a regular file");
    const auto size = static_cast<std::uint64_t>(st.st_size);

    unsigned char magic[SELFMAG] = {};
    if (size < SELFMAG) return {LibraryFileProblem::not_elf, "not an ELF file: " + std::to_string(size) + " bytes"};
    if (!read_at(f.fd, magic, SELFMAG, 0)) return damaged(read_error());
    if (std::memcmp(magic, ELFMAG, SELFMAG) != 0)
        return {LibraryFileProblem::not_elf, "not an ELF file (no ELF magic number)"};

    ElfW(Ehdr) header{};
    if (size < sizeof header)
        return damaged("truncated: " + std::to_string(size) + " bytes, shorter than an ELF header (" +
                       std::to_string(sizeof header) + " bytes)");
    if (!read_at(f.fd, &header, sizeof header, 0)) return damaged(read_error());
    std::string problem = header_problem(header);
    if (!problem.empty()) return damaged(problem);
    problem = segments_problem(f.fd, header, size);
    if (problem.empty()) problem = sections_problem(f.fd, header, size);
    if (!problem.empty()) return damaged(problem);
    return {};
}

} // namespace geobarrier
