// Replays the fuzzer's seed corpus and every input it once crashed on (tests/fuzz/regressions/, one file each, named
// after what it broke) through the same checks as the fuzzer: each must be accepted or rejected with a
// geobarrier::Error, never crash or throw anything else.
#include "descriptor_check.hpp"
#include "experiment_check.hpp"

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <sstream>

namespace fs = std::filesystem;

TEST_CASE("fuzzer regressions and seed corpus: every input is accepted or refused cleanly") {
    const geobarrier::PluginRegistry registry({geobarrier::test::plugin_dir()});
    std::size_t inputs = 0, valid = 0;
    for (const char *folder : {"tests/fuzz/regressions", "tests/fuzz/corpus", "experiments"}) {
        for (const auto &entry : fs::directory_iterator(geobarrier::test::source_dir() / folder)) {
            if (!entry.is_regular_file() || entry.path().filename() == "README.md") continue;
            std::ifstream in(entry.path(), std::ios::binary);
            std::stringstream text;
            text << in.rdbuf();
            CAPTURE(entry.path());
            bool ok = false;
            CHECK_NOTHROW(ok = geobarrier::fuzz::check_experiment_text(text.str(), registry));
            valid += ok;
            ++inputs;
        }
    }
    MESSAGE(inputs << " inputs replayed, " << valid << " of them valid experiments");
    CHECK(inputs >= 10);
    CHECK(valid >= 3); // the shipped experiments and the valid seeds
}

TEST_CASE("descriptor fuzzer: its corpus and regressions are read as they should be, never crash") {
    // Every input is decoded into a library's entry and read by the loader's reader (descriptor_check.hpp). The
    // corpus holds plugins that must be accepted (the built-ins' shapes, three plugins in one entry, dimension 64)
    // and, named refused-*, entries beyond a declared limit or with a name lacking its end, which must be refused.
    std::size_t inputs = 0;
    for (const char *folder : {"tests/fuzz/descriptor-regressions", "tests/fuzz/descriptor-corpus"}) {
        for (const auto &entry : fs::directory_iterator(geobarrier::test::source_dir() / folder)) {
            if (!entry.is_regular_file() || entry.path().extension() != ".bin") continue;
            std::ifstream in(entry.path(), std::ios::binary);
            const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            CAPTURE(entry.path());
            bool accepted = false;
            CHECK_NOTHROW(accepted = geobarrier::fuzz::check_descriptor_bytes(
                              reinterpret_cast<const std::uint8_t *>(bytes.data()), bytes.size()));
            const std::string name = entry.path().filename().string();
            if (std::string(folder).find("corpus") != std::string::npos)
                CHECK(accepted == (name.rfind("refused-", 0) != 0));
            ++inputs;
        }
    }
    CHECK(inputs >= 11);
}
