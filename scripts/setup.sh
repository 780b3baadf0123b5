#!/usr/bin/env bash
# Installs the Debian packages dynamap's build, tests, cross build, benchmarks and tools need.
# Skips what is already installed; says what it does. Safe to run repeatedly.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config   # toolchain
  git clang-format                               # sources list and format check
  libeigen3-dev                                  # core (header-only)
  googletest libgtest-dev                        # tests; /usr/src/googletest for the cross build
  libbenchmark-dev                               # host benchmarks
  g++-aarch64-linux-gnu qemu-user                # Jetson cross build, tests under qemu-aarch64
  libboost-dev liboctomap-dev                    # benchmark peers (boost::lockfree, OctoMap)
  libpng-dev libcairo2-dev libyaml-cpp-dev       # tools: PNG depth, pictures, YAML parameters
  libzstd-dev liblz4-dev                         # tools: ROS 2 bags (MCAP chunk compression)
  clang libclang-rt-14-dev                       # fuzz preset: libFuzzer, ASan, UBSan
  clang-tidy                                     # static checks of library and tools (run_tests.sh)
)

# Node.js and npm for the independent MCAP check (ctest node_check): Debian's, unless a node is
# already on the PATH.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  PACKAGES+=(nodejs npm)
fi

# The npm packages of tools/node_check (package-lock.json), into its node_modules.
node_packages() {
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/tools/node_check"
  if [ -d "$dir/node_modules/@mcap/core" ] && [ -d "$dir/node_modules/@foxglove/rosmsg2-serialization" ] \
     && [ -d "$dir/node_modules/@foxglove/rosmsg" ] && [ -d "$dir/node_modules/fzstd" ]; then
    echo "setup: the npm packages of tools/node_check are already installed."
    return 0
  fi
  echo "setup: installing the npm packages of tools/node_check (npm ci)"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} required Debian packages are already installed."
  node_packages
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "setup: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "setup: installing ${#missing[@]} missing Debian package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
node_packages
echo "setup: done."
