// The replay's YAML parameter reader with fuzzed files: every outcome is a configuration that
// validates, or an error message; never an exception or a crash.
#include <cstdint>
#include <fstream>
#include <string>

#include "fuzz_input.hpp"
#include "params.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = dynamap::fuzz::scratch_path("params.yaml");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  dynamap::PipelineConfig config;
  const std::string error = dynamap::tools::apply_params_file(path, config);
  if (error.empty() && !dynamap::validate(config).ok()) __builtin_trap();
  return 0;
}
