// Replays the fuzzer's seed corpus and every input it once crashed on (tests/fuzz/regressions/, one file each, named
// after what it broke) through the same checks as the fuzzer: each must be accepted or rejected with a
// geobarrier::Error, never crash or throw anything else.
#include "experiment_check.hpp"

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <fstream>
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
