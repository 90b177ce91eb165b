// Where, when and with what a run was made, for manifest.json's "provenance" object: enough to tell two runs'
// numbers apart after the fact (which machine and instruction set, which build and commit, which plugin files
// byte for byte, whether the plugin's fused step did the integration, which files the extractors wrote, and the size
// and SHA-256 of every output file, which a resumed sweep checks before it reuses a member).
#ifndef GEOBARRIER_PROVENANCE_HPP
#define GEOBARRIER_PROVENANCE_HPP

#include <geobarrier/experiment.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace geobarrier::detail {

// SHA-256 (FIPS 180-4) of a file's bytes as 64 lowercase hex digits, the value `sha256sum FILE` prints. Throws
// IoError when the file cannot be read.
std::string sha256_file(const std::filesystem::path &file);
std::string sha256_hex(const std::string &bytes);

// The provenance of a run, from the manifest written so far (its "plugins" and "integrator_stats") and the run's
// staging folder: `listed` are the files the runner wrote itself; anything else there was written by an extractor.
nlohmann::json run_provenance(const ResolvedExperiment &run, const nlohmann::json &manifest,
                              const std::vector<std::filesystem::path> &listed, const std::filesystem::path &staging);

} // namespace geobarrier::detail

#endif // GEOBARRIER_PROVENANCE_HPP
