// The manifest's "provenance" object (provenance.hpp): timestamp, host CPU and instruction set, the build's
// compiler, flags and commit (captured when CMake configured the build), SHA-256 of every plugin file, whether the
// system plugin's fused step ran, the files the extractors wrote beside the runner's own, and the size and SHA-256 of
// every output file.
#include "output/provenance.hpp"

#include <geobarrier/errors.hpp>

#include <sys/utsname.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <fstream>
#include <set>
#include <thread>

#ifndef GEOBARRIER_GIT_COMMIT
#define GEOBARRIER_GIT_COMMIT "unknown"
#endif
#ifndef GEOBARRIER_BUILD_FLAGS
#define GEOBARRIER_BUILD_FLAGS "unknown"
#endif
#ifndef GEOBARRIER_BUILD_TYPE
#define GEOBARRIER_BUILD_TYPE "unknown"
#endif

namespace geobarrier::detail {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// ---- SHA-256, FIPS 180-4 section 6.2 ----

constexpr std::array<std::uint32_t, 64> sha256_round_constants = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

class Sha256 {
  public:
    void update(const unsigned char *data, std::size_t size) {
        m_length += size;
        for (std::size_t i = 0; i < size; ++i) {
            m_block[m_used++] = data[i];
            if (m_used == 64) compress();
        }
    }
    std::string hex_digest() {
        const std::uint64_t bits = m_length * 8;
        const unsigned char one = 0x80, zero = 0;
        update(&one, 1);
        while (m_used != 56) update(&zero, 1);
        for (int shift = 56; shift >= 0; shift -= 8) {
            const unsigned char byte = static_cast<unsigned char>(bits >> shift);
            update(&byte, 1);
        }
        static const char digits[] = "0123456789abcdef";
        std::string out;
        for (std::uint32_t word : m_state)
            for (int shift = 28; shift >= 0; shift -= 4) out += digits[(word >> shift) & 0xf];
        return out;
    }

  private:
    static std::uint32_t rotate(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }
    void compress() {
        std::array<std::uint32_t, 64> w{};
        for (std::size_t t = 0; t < 16; ++t)
            w[t] = std::uint32_t(m_block[4 * t]) << 24 | std::uint32_t(m_block[4 * t + 1]) << 16 |
                   std::uint32_t(m_block[4 * t + 2]) << 8 | std::uint32_t(m_block[4 * t + 3]);
        for (std::size_t t = 16; t < 64; ++t) {
            const std::uint32_t s0 = rotate(w[t - 15], 7) ^ rotate(w[t - 15], 18) ^ (w[t - 15] >> 3);
            const std::uint32_t s1 = rotate(w[t - 2], 17) ^ rotate(w[t - 2], 19) ^ (w[t - 2] >> 10);
            w[t] = w[t - 16] + s0 + w[t - 7] + s1;
        }
        std::array<std::uint32_t, 8> v = m_state; // a b c d e f g h
        for (std::size_t t = 0; t < 64; ++t) {
            const std::uint32_t sum1 = rotate(v[4], 6) ^ rotate(v[4], 11) ^ rotate(v[4], 25);
            const std::uint32_t choose = (v[4] & v[5]) ^ (~v[4] & v[6]);
            const std::uint32_t t1 = v[7] + sum1 + choose + sha256_round_constants[t] + w[t];
            const std::uint32_t sum0 = rotate(v[0], 2) ^ rotate(v[0], 13) ^ rotate(v[0], 22);
            const std::uint32_t majority = (v[0] & v[1]) ^ (v[0] & v[2]) ^ (v[1] & v[2]);
            for (std::size_t i = 7; i > 0; --i) v[i] = v[i - 1];
            v[4] += t1;
            v[0] = t1 + sum0 + majority;
        }
        for (std::size_t i = 0; i < 8; ++i) m_state[i] += v[i];
        m_used = 0;
    }

    std::array<std::uint32_t, 8> m_state = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                            0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
    std::array<unsigned char, 64> m_block{};
    std::size_t m_used = 0;
    std::uint64_t m_length = 0;
};

// ---- the host ----

std::string utc_timestamp() {
    const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm parts{};
    gmtime_r(&now, &parts);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &parts);
    return text;
}

std::string cpu_model() {
    std::ifstream in("/proc/cpuinfo");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos)
            return line.substr(line.find_first_not_of(" \t", line.find(':') + 1));
    return "unknown";
}

// Vector instruction sets that matter to the flow-map loops: those this build was compiled for, and those the CPU
// running it has (a -march=native build moved to an older CPU would die with SIGILL before getting here).
json instruction_sets() {
    json compiled = json::array();
#if defined(__SSE2__)
    compiled.push_back("sse2");
#endif
#if defined(__AVX__)
    compiled.push_back("avx");
#endif
#if defined(__AVX2__)
    compiled.push_back("avx2");
#endif
#if defined(__FMA__)
    compiled.push_back("fma");
#endif
#if defined(__AVX512F__)
    compiled.push_back("avx512f");
#endif
#if defined(__ARM_NEON)
    compiled.push_back("neon");
#endif
    json available = json::array();
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("sse2")) available.push_back("sse2");
    if (__builtin_cpu_supports("avx")) available.push_back("avx");
    if (__builtin_cpu_supports("avx2")) available.push_back("avx2");
    if (__builtin_cpu_supports("fma")) available.push_back("fma");
    if (__builtin_cpu_supports("avx512f")) available.push_back("avx512f");
#endif
    return {{"compiled_for", compiled}, {"cpu_has", available}};
}

json host() {
    utsname names{};
    std::string system = "unknown", machine = "unknown", node = "unknown";
    if (::uname(&names) == 0) {
        system = std::string(names.sysname) + " " + names.release;
        machine = names.machine;
        node = names.nodename;
    }
    return {{"name", node},
            {"os", system},
            {"architecture", machine},
            {"cpu", cpu_model()},
            {"hardware_threads", std::thread::hardware_concurrency()},
            {"instruction_sets", instruction_sets()}};
}

json build() {
#if defined(__clang__)
    const std::string compiler = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
    const std::string compiler = std::string("gcc ") + __VERSION__;
#else
    const std::string compiler = "unknown";
#endif
    return {{"version", GEOBARRIER_VERSION},
            {"commit", GEOBARRIER_GIT_COMMIT},
            {"build_type", GEOBARRIER_BUILD_TYPE},
            {"compiler", compiler},
            {"flags", GEOBARRIER_BUILD_FLAGS}};
}

// Whether the system plugin's fused step (ABI 1.2 advance) integrated the grid: it can only for fixed lockstep
// steps of rk4 or dop853 with "fused" on, and a plugin may still decline; the engine counts the batches it took.
json fused_step(const ResolvedExperiment &run, const json &manifest) {
    const json stats = manifest.value("integrator_stats", json::object());
    const std::uint64_t fused = stats.value("fused_batches", std::uint64_t{0});
    const std::uint64_t batches = stats.value("batches", std::uint64_t{0});
    return {{"plugin_has_one", run.system.has_advance()},
            {"requested", run.experiment.integrator.fused},
            {"batches", fused},
            {"of_batches", batches},
            {"ran", fused > 0}};
}

json plugin_hashes(const json &plugins) {
    json out = json::array();
    std::set<std::string> seen;
    for (const json &p : plugins) {
        const std::string file = p.value("file", "");
        if (file.empty() || !seen.insert(file).second) continue;
        json entry = {{"file", file}};
        try {
            entry["sha256"] = sha256_file(file);
        } catch (const IoError &e) {
            entry["sha256"] = nullptr;
            entry["error"] = e.what();
        }
        out.push_back(entry);
    }
    return out;
}

// Files in the staging folder the runner did not list itself: the extractors write their pictures and tables there.
json extractor_files(const std::vector<fs::path> &listed, const fs::path &staging) {
    std::set<std::string> known{"manifest.json"};
    for (const fs::path &f : listed) known.insert(f.filename().string());
    std::set<std::string> others;
    std::error_code ec;
    for (const auto &entry : fs::directory_iterator(staging, ec)) {
        const std::string name = entry.path().filename().string();
        if (!known.count(name)) others.insert(name);
    }
    return json(std::vector<std::string>(others.begin(), others.end()));
}

// Every regular file of the run in its staging folder (the runner's and the extractors'), with its size and SHA-256:
// what a resumed sweep checks before it reuses a finished member (a file deleted, cut short or changed since).
json output_files(const std::vector<fs::path> &listed, const json &extractor_names, const fs::path &staging) {
    std::set<std::string> names;
    for (const fs::path &f : listed) names.insert(f.filename().string());
    for (const json &name : extractor_names)
        if (name.is_string()) names.insert(name.get<std::string>());
    names.erase("manifest.json");
    json out = json::array();
    for (const std::string &name : names) {
        const fs::path file = staging / name;
        std::error_code ec;
        if (!fs::is_regular_file(file, ec)) continue;
        const std::uintmax_t bytes = fs::file_size(file, ec);
        if (ec) continue;
        out.push_back({{"file", name}, {"bytes", bytes}, {"sha256", sha256_file(file)}});
    }
    return out;
}

} // namespace

std::string sha256_hex(const std::string &bytes) {
    Sha256 hash;
    hash.update(reinterpret_cast<const unsigned char *>(bytes.data()), bytes.size());
    return hash.hex_digest();
}

std::string sha256_file(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file.string() + ": cannot open the file to hash it");
    Sha256 hash;
    std::array<char, 1 << 16> buffer;
    while (in) {
        in.read(buffer.data(), buffer.size());
        hash.update(reinterpret_cast<const unsigned char *>(buffer.data()), static_cast<std::size_t>(in.gcount()));
    }
    if (in.bad()) throw IoError(file.string() + ": cannot read the file to hash it");
    return hash.hex_digest();
}

json run_provenance(const ResolvedExperiment &run, const json &manifest, const std::vector<fs::path> &listed,
                    const fs::path &staging) {
    const json extractors = extractor_files(listed, staging);
    return {{"created", utc_timestamp()},
            {"host", host()},
            {"build", build()},
            {"plugin_files", plugin_hashes(manifest.value("plugins", json::array()))},
            {"fused_step", fused_step(run, manifest)},
            {"extractor_files", extractors},
            {"output_files", output_files(listed, extractors, staging)}};
}

} // namespace geobarrier::detail
