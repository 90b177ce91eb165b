// libFuzzer target for the plugin descriptor reader (see descriptor_check.hpp for how an input becomes a library's
// entry and what is checked). Built by scripts/fuzz descriptor with clang and -fsanitize=fuzzer,address,undefined.
#include "descriptor_check.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size) {
    geobarrier::fuzz::check_descriptor_bytes(data, size);
    return 0;
}
