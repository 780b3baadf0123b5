#include <unistd.h>

#include <string>

#include "fuzz_input.hpp"

namespace dynamap::fuzz {

std::string scratch_path(const char* name) {
  return "/tmp/dynamap_fuzz_" + std::to_string(::getpid()) + "_" + name;
}

}  // namespace dynamap::fuzz
