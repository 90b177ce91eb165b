// A shared library checked before the dynamic loader maps it (private to the core; plugin.cpp and the equations cache
// call it, the tests of the tree include it). dlopen maps a library's segments as the program headers describe them
// and trusts the file to hold them: a library cut short (a copy interrupted, a full disk, a truncated download) is
// mapped beyond its end, and the first touch of a missing page kills the process with SIGBUS, no message. The check
// reads the ELF header and the program and section header tables with plain reads and refuses such a file with a
// reason, so that it never reaches dlopen.
#ifndef GEOBARRIER_PLUGINS_LIBRARY_CHECK_HPP
#define GEOBARRIER_PLUGINS_LIBRARY_CHECK_HPP

#include <filesystem>
#include <string>

namespace geobarrier {

// What the check found. `not_elf`: no ELF magic at all (a text file, a script); the loader refuses it harmlessly, and
// a plugin folder scan skips it with a warning. `damaged`: the file cannot be read, or claims to be an ELF library but
// is not one this process can map safely (truncated, another machine's or class, not a shared object): refused as
// bad input wherever it is found.
enum class LibraryFileProblem { none, not_elf, damaged };

struct LibraryFileCheck {
    LibraryFileProblem problem = LibraryFileProblem::none;
    std::string reason; // "" when problem is none; else one line without the file's name, e.g. "truncated: ..."
};

// Checks `file` without mapping it: a regular, readable file; an ELF header of this process's class, byte order and
// machine, of a shared object; a program header table, every PT_LOAD segment's file range and the section header
// table within the file's size. Never throws for a bad file (only std::bad_alloc).
LibraryFileCheck check_library_file(const std::filesystem::path &file);

} // namespace geobarrier

#endif // GEOBARRIER_PLUGINS_LIBRARY_CHECK_HPP
