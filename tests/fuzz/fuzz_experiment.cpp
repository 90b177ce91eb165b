// libFuzzer target for the experiment parser and validator (see experiment_check.hpp for what is checked). Built by
// scripts/fuzz with clang and -fsanitize=fuzzer,address,undefined; run for a bounded time by scripts/test --all.
#include "experiment_check.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size) {
    // The built-in plugins' schemas, loaded once: GEOBARRIER_FUZZ_PLUGIN_DIR (scripts/fuzz points it at the main
    // build's plugins), else where this build puts them.
    static const geobarrier::PluginRegistry registry({[] {
        const char *dir = std::getenv("GEOBARRIER_FUZZ_PLUGIN_DIR");
        return std::filesystem::path(dir && *dir ? dir : GEOBARRIER_PLUGIN_DIR);
    }()});
    geobarrier::fuzz::check_experiment_text(std::string(reinterpret_cast<const char *>(data), size), registry);
    return 0;
}
